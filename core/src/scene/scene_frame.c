/* Frame-number patterns in file names ("smoke_####.vdb"), Blender's convention. */
#include "vsd/scene.h"

#include <stdio.h>
#include <string.h>

/* Like Blender, only the file name (after the last '/') is searched: a '#' in a folder
 * name is part of the name. Unlike Blender, which silently uses the last run, two runs in
 * the file name are an error: which one is the frame number would be a guess.
 * Frames are printed with printf's "%0*d", the way Blender's Mantaflow caches
 * (Python zfill) name their files: 7 -> "0007", -3 -> "-003", 12345 -> "12345". */
vsd_status vsd_frame_path(const char *pattern, int frame, char *out, size_t outlen,
                          char *err, size_t errlen)
{
    if (!pattern || !out || !outlen)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "vsd_frame_path: invalid arguments");
    const char *slash = strrchr(pattern, '/');
    const char *name = slash ? slash + 1 : pattern;
    const char *run = strchr(name, '#');
    size_t plen = strlen(pattern);
    size_t head = run ? (size_t)(run - pattern) : plen;
    size_t width = run ? strspn(run, "#") : 0;
    if (run && strchr(run + width, '#'))
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "\"%s\": more than one run of '#' in the file name (one frame number allowed)",
                        pattern);

    int dlen = 0;
    if (run) {
        /* The run may be any length; snprintf says how long the number comes out. */
        dlen = snprintf(NULL, 0, "%0*d", (int)width, frame);
        if (dlen < 0)
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "\"%s\": bad frame number width", pattern);
    }
    size_t need = head + (size_t)dlen + (plen - head - width) + 1;
    if (need > outlen) {
        out[0] = '\0';
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "\"%s\" at frame %d: path too long (%zu bytes needed, buffer holds %zu)",
                        pattern, frame, need, outlen);
    }
    memcpy(out, pattern, head);
    if (run)
        snprintf(out + head, (size_t)dlen + 1, "%0*d", (int)width, frame);
    memcpy(out + head + dlen, pattern + head + width, plen - head - width + 1);
    return VSD_OK;
}
