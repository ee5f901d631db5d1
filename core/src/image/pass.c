/* Render pass names and channel letters, exactly as Blender names them, because Blender's
 * compositor matches passes of a multilayer EXR by "<layer>.<Pass>.<chan>". */
#include "src/image/imageio_internal.h"
#include <stdio.h>
#include <string.h>

static const char *const pass_names[VSD_PASS_COUNT] = {
    "Combined", "VolumeDir", "VolumeInd", "Emit", "Transmittance", "Depth"
};

const char *vsd_pass_name(vsd_pass p)
{
    return (unsigned)p < VSD_PASS_COUNT ? pass_names[p] : "";
}

const char *vsd_pass_chan_ids(vsd_pass p)
{
    if (p == VSD_PASS_COMBINED)
        return "RGBA";
    if (p == VSD_PASS_DEPTH)
        return "Z";
    return (unsigned)p < VSD_PASS_COUNT ? "RGB" : "";
}

int vsd_pass_channels(vsd_pass p)
{
    return (int)strlen(vsd_pass_chan_ids(p));
}

/* Exact, case-sensitive: the names are Blender's and a near miss is a typo to report. */
vsd_pass vsd_pass_from_name(const char *name)
{
    for (int p = 0; name && p < VSD_PASS_COUNT; p++)
        if (strcmp(name, pass_names[p]) == 0)
            return (vsd_pass)p;
    return VSD_PASS_COUNT;
}

int vsd_pass_name_problem(const char *name, char *why, size_t whylen)
{
    if (!name || !name[0])
        snprintf(why, whylen, "empty name");
    else if (strlen(name) > VSD_PASS_NAME_MAX)
        snprintf(why, whylen, "longer than %d characters (Blender's limit)", VSD_PASS_NAME_MAX);
    else if (strchr(name, '.'))
        snprintf(why, whylen, "\"%s\" contains '.' (the EXR layer.pass.channel separator)", name);
    else
        return 0;
    return 1;
}

int vsd_pass_names_clash(const char *const names[], unsigned mask, int *p, int *q)
{
    for (int i = 0; i < VSD_PASS_COUNT; i++)
        for (int j = i + 1; j < VSD_PASS_COUNT; j++)
            if ((mask & VSD_PASS_BIT(i)) && (mask & VSD_PASS_BIT(j)) && strcmp(names[i], names[j]) == 0) {
                *p = i;
                *q = j;
                return 1;
            }
    return 0;
}
