/* The in-memory result of vsd_exr_read (read by exr_read.cpp): lookup and release. Plain
 * malloc'd memory, so C callers free it without crossing into C++. */
#include "vsd/image.h"
#include <stdlib.h>
#include <string.h>

const float *vsd_exr_channel(const vsd_exr_image *img, const char *name)
{
    for (int i = 0; img && name && i < img->channel_count; i++)
        if (img->channel_names[i] && strcmp(img->channel_names[i], name) == 0)
            return img->channels[i];
    return NULL;
}

void vsd_exr_image_destroy(vsd_exr_image *img)
{
    if (!img)
        return;
    for (int i = 0; i < img->channel_count; i++) {
        if (img->channel_names)
            free(img->channel_names[i]);
        if (img->channels)
            free(img->channels[i]);
    }
    free(img->channel_names);
    free(img->channels);
    free(img);
}
