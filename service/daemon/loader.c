/* Which loader runs: the isolated child by default, in-process for debugging
 * (--loader inprocess). The choice is the daemon's, made once at start. */
#include "loader.h"

int vsdd_load_volume(const char *src, const char *path, const char *grid, int grid_index, vsd_volume **out,
                     vsdd_err *e)
{
    if (g_daemon.cfg.loader == VSDD_LOADER_INPROCESS)
        return vsdd_decode_volume(src, path, grid, grid_index, g_daemon.cfg.max_voxels, out, e);
    return vsdd_isolated_volume(src, path, grid, grid_index, out, e);
}

int vsdd_load_env(const char *src, const char *path, const char *conversion, vsd_env **out, vsdd_err *e)
{
    if (g_daemon.cfg.loader == VSDD_LOADER_INPROCESS)
        return vsdd_decode_env(src, path, conversion, g_daemon.cfg.max_pixels, out, e);
    return vsdd_isolated_env(src, path, conversion, out, e);
}
