/* density_levels.h — the densities that the rays lighting a grid of records read: each
 * volume at the coarsest half-resolution level (src/volume/volume_mip.h) whose voxel still
 * fits in the records' cell and that keeps the detail the data holds.
 *
 * Why: shgrid's records and constellation's cached shadows are interpolated between cells
 * of a grid capped at 64 (shgrid) or 128 (constellation) cells; their rays need the
 * density no finer than those cells resolve it. Stepping the source voxels instead, a
 * volume with 8x the voxels took 5.6x (shgrid) and 3.9x (constellation) the cold frame's
 * time (issue 31, item 4; bench/README.md "8x the voxels"): twice the samples per ray,
 * each from a grid 8x the size. With the level matched to the cells the samples per cell
 * stay what the method was designed for, whatever the source resolution.
 *
 * Rule (level option -1, "auto"): volume i reads level L, the largest such that
 *  - 2^L voxels are no longer than the cell's smallest world extent (its thinnest slab), and
 *  - the level keeps what the data holds: its trilinear field reproduces the source voxels
 *    within VSD_DENSITY_MAX_LOSS (relative squared error, vsd_volume_mip_loss; 5% RMS).
 * The second condition is what the images asked for. Level 1 on cells of about 2 voxels
 * blurs real detail at the scale of the cells, and clouds under a sun show it: shgrid's
 * VolumeDir on cloud256 35.7 -> 37.8%, cloud128_interior 5.2 -> 7.5% (160x90 against 1024
 * spp), while smoke under a forest map did not mind (smoke128 3.35 -> 3.31%). A volume stored
 * finer than its detail (cloud256 upsampled x2: loss 0.0014 at level 1, against cloud256's
 * own 0.009) loses nothing there: shgrid 35.8 -> 36.3%, constellation 16.1 -> 15.9%, at a
 * quarter and a third of the time. So the project's volumes keep their source voxels and
 * their images; oversampled ones are read at the detail they hold.
 * Where some volume reads a level above 0 the rays step the cell's thinnest extent (`step`:
 * one to two voxels of that level, once per cell crossed), so their samples follow the cells
 * and not the voxels; where every volume reads its source voxels the methods keep their own
 * step (a voxel). With a fixed level the rays step a voxel of it. */
#ifndef VSD_DENSITY_LEVELS_H
#define VSD_DENSITY_LEVELS_H
#include "src/method/method.h"
#include "src/grids/record_grid.h"

#define VSD_DENSITY_MAX_LEVEL 4
#define VSD_DENSITY_MAX_LOSS 0.0025

/* The methods' option (shgrid's record_density, constellation's shadow_density): "auto"
 * (the rule above) or "full" (the source voxels), in this order. */
enum { VSD_DENSITY_AUTO = 0, VSD_DENSITY_FULL = 1 };
extern const char *const vsd_density_choice_names[];

typedef struct vsd_density_levels {
    vsd_volume *mip[VSD_KMAX_VOLUMES][VSD_DENSITY_MAX_LEVEL];   /* [i][L - 1]: level L of volume i */
    int level[VSD_KMAX_VOLUMES];                                 /* the level volume i's rays read */
    int count;                                                   /* volumes */
    float step;                                                  /* the rays' step (world), 0 = the method's */
    double seconds;                                              /* wall time of the build */
} vsd_density_levels;

/* Build the levels of every volume of ctx (its kd.volumes, or kd.density alone) for cells
 * of smallest world extent cell_world; level_option -1 = the rule above, k >= 0 = level k
 * for every volume (clamped to VSD_DENSITY_MAX_LEVEL). Frees what d held before. */
vsd_status vsd_density_levels_build(vsd_density_levels *d, const vsd_frame_ctx *ctx, double cell_world,
                                    int level_option, char *err, size_t errlen);
/* The same for the cells of record grid g, with the option's choice (VSD_DENSITY_AUTO /
 * FULL); nothing for an empty grid. */
vsd_status vsd_density_levels_for_grid(vsd_density_levels *d, const vsd_frame_ctx *ctx, const vsd_record_grid *g,
                                       int choice, char *err, size_t errlen);
/* 1 when some volume reads a level above 0. */
int vsd_density_levels_any(const vsd_density_levels *d);
/* *out = *kd with each volume's density (kd->density and kd->volumes[i].density) at its
 * level; objects: caller storage for VSD_KMAX_VOLUMES entries that out->volumes points to. */
void vsd_density_levels_kd(const vsd_density_levels *d, const vsd_kernel_data *kd, vsd_kernel_data *out,
                           vsd_kobject *objects);
void vsd_density_levels_free(vsd_density_levels *d);

#endif
