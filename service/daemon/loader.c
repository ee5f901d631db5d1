/* Which loader runs: the isolated child by default, in-process for debugging
 * (--loader inprocess). The choice is the daemon's configuration's, read per decode; the
 * zygote the isolated loader talks to is loader_isolated.c's. */
#include "loader.h"
#include <stdlib.h>

struct vsdd_loader {
    const vsdd_config *cfg;        /* the daemon's, read-only: mode and limits */
    vsdd_zygote *zygote;
};

vsdd_loader *vsdd_loader_new(const vsdd_config *cfg)
{
    vsdd_loader *l = calloc(1, sizeof *l);
    if (!l) return NULL;
    l->cfg = cfg;
    l->zygote = vsdd_zygote_new(cfg);
    if (!l->zygote) {
        free(l);
        return NULL;
    }
    return l;
}

void vsdd_loader_shutdown(vsdd_loader *l) { vsdd_zygote_stop(l->zygote); }

void vsdd_loader_free(vsdd_loader *l)
{
    if (!l) return;
    vsdd_zygote_free(l->zygote);
    free(l);
}

int vsdd_load_volume(vsdd_loader *l, const char *src, const char *path, const char *grid, int grid_index,
                     vsd_volume **out, vsdd_err *e)
{
    if (l->cfg->loader == VSDD_LOADER_INPROCESS)
        return vsdd_decode_volume(src, path, grid, grid_index, l->cfg->max_voxels, out, e);
    return vsdd_isolated_volume(l->zygote, src, path, grid, grid_index, out, e);
}

int vsdd_load_env(vsdd_loader *l, const char *src, const char *path, const char *conversion, vsd_env **out,
                  vsdd_err *e)
{
    if (l->cfg->loader == VSDD_LOADER_INPROCESS)
        return vsdd_decode_env(src, path, conversion, l->cfg->max_pixels, out, e);
    return vsdd_isolated_env(l->zygote, src, path, conversion, out, e);
}
