/* The one decoding path for volumes and maps, run in the loader child (isolated) or on a
 * worker thread (--loader inprocess): the voxel limit is checked from the file's metadata
 * before any voxel is read; errors name the client's source, not the daemon's private
 * blob file. */
#define _GNU_SOURCE
#include "loader.h"
#include "vsd/vdbio.h"
#include <stdio.h>
#include <string.h>

int vsdd_decode_volume(const char *src, const char *path, const char *grid, int grid_index, uint64_t max_voxels,
                       vsd_volume **out, vsdd_err *e)
{
    char err[1024];
    vsd_grid_info info;
    vsd_grid_select sel;
    vsd_status st;
    *out = NULL;
    sel.name = grid;
    sel.index = grid_index;
    /* the voxel count the file states, for the grid the load would pick, before loading it */
    st = vsd_vdb_select_info(path, sel, &info, err, sizeof err);
    if (!st && info.active_voxels > max_voxels)
        return vsdd_fail(e, VSD_E_LIMIT, "grid '%s' has %llu active voxels, more than the daemon's limit %llu (--max-voxels)",
                         info.name, (unsigned long long)info.active_voxels, (unsigned long long)max_voxels);
    if (!st) st = vsd_vdb_load(path, sel, out, err, sizeof err);
    if (!st) return 0;
    /* name the blob, not the daemon's private file */
    if (strncmp(src, "blob:", 5) == 0) {
        size_t pl = strlen(path);
        char *p = strstr(err, path);
        return vsdd_fail(e, VSD_E_INPUT, "%s: %s", src, p ? p + pl + (p[pl] == ':' ? 2 : 0) : err);
    }
    return vsdd_fail(e, VSD_E_INPUT, "%s", err);
}

int vsdd_decode_env(const char *src, const char *path, const char *conversion, uint64_t max_pixels, vsd_env **out,
                    vsdd_err *e)
{
    char err[1024];
    vsd_status st = vsd_env_load(path, conversion[0] ? conversion : NULL, out, err, sizeof err);
    if (st) {
        *out = NULL;
        return vsdd_fail(e, VSD_E_INPUT, "%s: %s", src, err);
    }
    if ((uint64_t)(*out)->width * (uint64_t)(*out)->height > max_pixels * 4) {
        vsdd_fail(e, VSD_E_LIMIT, "environment map %dx%d is larger than the daemon allows", (*out)->width,
                  (*out)->height);
        vsd_env_destroy(*out);
        *out = NULL;
        return -1;
    }
    return 0;
}
