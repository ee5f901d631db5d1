/* The path policy: a client names blobs it uploaded, or, only when the daemon was started
 * with --allow-path, regular files under those folders (after resolving links, so a
 * symlink cannot lead outside). */
#define _GNU_SOURCE
#include "policy.h"
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int vsdd_path_allowed(const vsdd_config *cfg, const char *path, char *resolved, size_t len)
{
    char real[PATH_MAX];
    int i;
    if (!realpath(path, real)) return -1;
    for (i = 0; i < cfg->allow_count; i++) {
        const char *dir = cfg->allow[i];
        size_t n = strlen(dir);
        if (strncmp(real, dir, n) == 0 && (real[n] == '/' || (n == 1 && dir[0] == '/'))) {
            struct stat st;
            if (stat(real, &st) != 0 || !S_ISREG(st.st_mode)) return -1;
            if (strlen(real) >= len) return -1;
            snprintf(resolved, len, "%s", real);
            return 0;
        }
    }
    return -1;
}

int vsdd_resolve_source(const vsdd_config *cfg, const char *field, const char *file, int frame, char *src, size_t len,
                        vsdd_err *e)
{
    char path[VSD_PATH_LEN], err[512];
    if (strncmp(file, "blob:", 5) == 0) {
        if (vsd_hash_kind_of(file + 5) == VSD_HASH_NONE)
            return vsdd_fail(e, VSD_E_BAD_HASH, "%s: \"%.200s\": a blob name is blob:<32 or 64 lowercase hex digits>",
                             field, file);
        snprintf(src, len, "%s", file);
        return 0;
    }
    if (vsd_frame_path(file, frame, path, sizeof path, err, sizeof err))
        return vsdd_fail(e, VSD_E_INVALID_SCENE, "%s: %s", field, err);
    if (!cfg->allow_count)
        return vsdd_fail(e, VSD_E_PATH_DENIED,
                         "%s: this daemon takes blob:<hash> names only (start it with --allow-path DIR "
                         "to allow server-side files)", field);
    if (vsdd_path_allowed(cfg, path, src, len))
        return vsdd_fail(e, VSD_E_PATH_DENIED, "%s: \"%.300s\" is missing or outside the folders allowed by --allow-path",
                         field, path);
    return 0;
}
