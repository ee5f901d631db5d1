/* The names of the EXR compressions vsd writes (vsd/image.h): the scene file's
 * output.compression choices and the writer's enum in one table. */
#include "vsd/image.h"
#include <string.h>

const char *const vsd_exr_compression_names[VSD_EXR_COMPRESSION_COUNT + 1] = {
    [VSD_EXR_ZIP] = "zip", [VSD_EXR_NONE] = "none", [VSD_EXR_RLE] = "rle", [VSD_EXR_COMPRESSION_COUNT] = NULL};

const char *vsd_exr_compression_name(vsd_exr_compression c)
{
    return (unsigned)c < VSD_EXR_COMPRESSION_COUNT ? vsd_exr_compression_names[c] : "?";
}

vsd_exr_compression vsd_exr_compression_from_name(const char *name)
{
    int c;
    for (c = 0; c < VSD_EXR_COMPRESSION_COUNT; c++)
        if (name && strcmp(name, vsd_exr_compression_names[c]) == 0) return (vsd_exr_compression)c;
    return VSD_EXR_COMPRESSION_COUNT;
}
