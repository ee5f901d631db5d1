/* The densities at the records' resolution (density_levels.h). */
#include "density_levels.h"
#include "src/volume/volume_mip.h"
#include "vsd/clock.h"
#include <math.h>
#include <string.h>

const char *const vsd_density_choice_names[] = {"auto", "full", NULL};

void vsd_density_levels_free(vsd_density_levels *d)
{
    int i, l;
    for (i = 0; i < VSD_KMAX_VOLUMES; i++)
        for (l = 0; l < VSD_DENSITY_MAX_LEVEL; l++) vsd_volume_destroy(d->mip[i][l]);
    memset(d, 0, sizeof *d);
}

/* The auto level of a volume whose smallest voxel is `voxel` (world) for cells whose
 * thinnest slab is cell_world. */
static int auto_level(double voxel, double cell_world)
{
    int l = 0;
    if (!(voxel > 0) || !isfinite(cell_world)) return 0;
    /* (the 1e-6: a cell of exactly 2 voxels, as constellation's default, reads level 1) */
    while (l < VSD_DENSITY_MAX_LEVEL && voxel * (double)(2 << l) <= cell_world * (1 + 1e-6)) l++;
    return l;
}

vsd_status vsd_density_levels_build(vsd_density_levels *d, const vsd_frame_ctx *ctx, double cell_world,
                                    int level_option, char *err, size_t errlen)
{
    const int n = ctx->kd.volume_count > 1 ? ctx->kd.volume_count : 1;
    const double t0 = vsd_clock_seconds();
    int i, l;
    vsd_density_levels_free(d);
    d->count = n;
    for (i = 0; i < n; i++) {
        const vsd_kvolume *kv = n > 1 ? &ctx->kd.volumes[i].density : &ctx->kd.density;
        const vsd_volume *src = n > 1 ? ctx->volume_density[i] : ctx->density;
        int want = level_option >= 0 ? level_option : auto_level(2.0 * kv->step, cell_world);
        if (want > VSD_DENSITY_MAX_LEVEL) want = VSD_DENSITY_MAX_LEVEL;
        if (!src || kv->dims[0] == 0) want = 0;
        for (l = 1; l <= want; l++) {
            vsd_status st = vsd_volume_mip_half(l == 1 ? src : d->mip[i][l - 2], &d->mip[i][l - 1], err, errlen);
            if (st) {
                vsd_density_levels_free(d);
                return st;
            }
            /* auto: only a level that keeps what the data holds (density_levels.h) */
            if (level_option < 0 && vsd_volume_mip_loss(src, d->mip[i][l - 1], l) > VSD_DENSITY_MAX_LOSS) {
                vsd_volume_destroy(d->mip[i][l - 1]);
                d->mip[i][l - 1] = NULL;
                break;
            }
        }
        d->level[i] = l - 1;   /* the last level kept (the loop ends past `want` or at a loss) */
        if (d->level[i] > 0 && level_option < 0) d->step = (float)cell_world;
    }
    d->seconds = vsd_clock_seconds() - t0;
    return VSD_OK;
}

vsd_status vsd_density_levels_for_grid(vsd_density_levels *d, const vsd_frame_ctx *ctx, const vsd_record_grid *g,
                                       int choice, char *err, size_t errlen)
{
    vsd_density_levels_free(d);
    if (g->count == 0) return VSD_OK;
    return vsd_density_levels_build(d, ctx, vsd_record_grid_cell_world(g), choice == VSD_DENSITY_FULL ? 0 : -1, err,
                                    errlen);
}

int vsd_density_levels_any(const vsd_density_levels *d)
{
    int i;
    for (i = 0; i < d->count; i++)
        if (d->level[i] > 0) return 1;
    return 0;
}

/* kv at volume i's level: the same scale; index I of level L is index 2I + 1/2 of level
 * L - 1, so each level's world_to_index is the previous one's halved, less 1/4. */
static vsd_kvolume at_level(const vsd_density_levels *d, int i, vsd_kvolume kv)
{
    int l, a, c;
    for (l = 1; l <= d->level[i]; l++) {
        const vsd_volume *m = d->mip[i][l - 1];
        for (a = 0; a < 3; a++) {
            for (c = 0; c < 4; c++) kv.world_to_index.m[4 * a + c] *= 0.5f;
            kv.world_to_index.m[4 * a + 3] -= 0.25f;
            kv.origin[a] = m->origin[a];
            kv.dims[a] = m->brick_dims[a];
        }
        kv.brick_slots = m->brick_slots;
        kv.voxels = m->voxels;
        kv.brick_max = m->brick_max;
        kv.step *= 2.0f;
    }
    return kv;
}

void vsd_density_levels_kd(const vsd_density_levels *d, const vsd_kernel_data *kd, vsd_kernel_data *out,
                           vsd_kobject *objects)
{
    int i;
    *out = *kd;
    if (d->count <= 1 || kd->volume_count <= 1) {
        out->density = at_level(d, 0, kd->density);
        return;
    }
    for (i = 0; i < kd->volume_count && i < d->count; i++) {
        objects[i] = kd->volumes[i];
        objects[i].density = at_level(d, i, kd->volumes[i].density);
        /* volume 0 of the context (a part's own volume) is one of them */
        if (kd->density.brick_slots == kd->volumes[i].density.brick_slots) out->density = objects[i].density;
    }
    out->volumes = objects;
}
