/* volume_mip.h — a brick volume at half the resolution: each voxel the mean of 2x2x2.
 *
 * Why: rays that light a grid of records (shgrid's records, constellation's cached shadows)
 * need the density only as finely as the records resolve it. On a volume whose grid is
 * capped at 64 or 128 cells, a volume with 8x the voxels gives cells of twice the voxels,
 * and rays stepping a voxel take twice the samples from a grid 8x the size (issue 31, item
 * 4: shgrid 5.6x, constellation 3.9x the time). A level of this pyramid matched to the
 * cells brings the rays' samples back to the cells' count (src/method/density_levels.h).
 *
 * Layout: coarse voxel I holds the mean of fine voxels 2I and 2I+1 on each axis, so its
 * centre sits at fine index 2I + 1/2 and index_to_world is the fine one times that map.
 * A box filter keeps each slab's integral of the field (the optical depth a ray through
 * it sees) up to the trilinear reconstruction's own smoothing. The origin and the brick
 * box follow vsd/volume.h's coverage rule (a margin cell below the data). */
#ifndef VSD_VOLUME_MIP_H
#define VSD_VOLUME_MIP_H
#include "vsd/volume.h"

/* *out: a new volume (free with vsd_volume_destroy) at half src's resolution; an empty src
 * gives an empty volume. Its grid_name and file are src's. */
vsd_status vsd_volume_mip_half(const vsd_volume *src, vsd_volume **out, char *err, size_t errlen);

/* How much of src a level `levels_between` halvings coarser loses: over a fixed seventh of
 * src's stored voxels, the sum of (src - the coarse level's trilinear field at the voxel's
 * point)^2 over the sum of src^2 (0 for an empty src). The data's own detail decides it: a
 * volume upsampled from a coarser grid loses almost nothing at the next level (cloud256
 * upsampled x2: 0.0014), one at its native resolution loses its finest wisps (cloud256
 * 0.009, smoke128 0.043, the Houdini smoke 0.089). */
double vsd_volume_mip_loss(const vsd_volume *src, const vsd_volume *coarse, int levels_between);

#endif
