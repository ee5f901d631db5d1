/* The one place that decides which OpenColorIO config vsd uses (preview PNG and environment
 * colour spaces alike), in the order docs/architecture.md §6 gives: $OCIO, Blender's config,
 * none. Where the chosen config lacks a colour space (or there is none), an environment map's
 * conversion falls back to vsd's built-in config of Blender's linear spaces (env.c). */
#define _POSIX_C_SOURCE 200809L
#include "src/image/imageio_internal.h"
#include <errno.h>
#include <glob.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Debian's blender package installs the unversioned path; upstream builds and other
 * distributions use a version folder, hence the pattern. */
static const char *const default_candidates[] = {
    "/usr/share/blender/datafiles/colormanagement/config.ocio",
    "/usr/share/blender/*/datafiles/colormanagement/config.ocio",
    NULL
};
const char *const *vsd_ocio_blender_candidates = default_candidates;

const char *vsd_ocio_origin_str(vsd_ocio_origin o)
{
    switch (o) {
    case VSD_OCIO_ENV: return "$OCIO";
    case VSD_OCIO_BLENDER: return "Blender's";
    case VSD_OCIO_NONE: break;
    }
    return "none";
}

/* First readable file matching `pattern`; glob sorts, and the last match of a versioned
 * pattern is the newest Blender, whose config is a superset of older ones. */
static int find_readable(const char *pattern, char *path, size_t pathlen)
{
    glob_t g;
    int found = 0;
    if (glob(pattern, 0, NULL, &g) == 0) {
        for (size_t i = g.gl_pathc; i-- > 0 && !found;) {
            if (access(g.gl_pathv[i], R_OK) == 0 && strlen(g.gl_pathv[i]) < pathlen) {
                snprintf(path, pathlen, "%s", g.gl_pathv[i]);
                found = 1;
            }
        }
    }
    globfree(&g);
    return found;
}

vsd_status vsd_ocio_choose_config(char *path, size_t pathlen, vsd_ocio_origin *origin,
                                  char *err, size_t errlen)
{
    path[0] = '\0';
    *origin = VSD_OCIO_NONE;
    const char *env = getenv("OCIO");
    if (env && *env) {
        if (access(env, R_OK) != 0)
            return vsd_fail(VSD_ERR_IO, err, errlen,
                            "$OCIO names the OpenColorIO config '%s', which cannot be read: %s",
                            env, strerror(errno));
        if (strlen(env) >= pathlen)
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "$OCIO path too long");
        snprintf(path, pathlen, "%s", env);
        *origin = VSD_OCIO_ENV;
        return VSD_OK;
    }
    for (int i = 0; vsd_ocio_blender_candidates && vsd_ocio_blender_candidates[i]; i++) {
        if (find_readable(vsd_ocio_blender_candidates[i], path, pathlen)) {
            *origin = VSD_OCIO_BLENDER;
            return VSD_OK;
        }
    }
    return VSD_OK;
}
