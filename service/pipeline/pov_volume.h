/* pov_volume.h — one frame's vsd volumes as a POV-Ray include: per volume, hollow unit
 * boxes holding media whose density is a df3 file, placed where vsd renders the grid.
 *
 * Physics (docs/povray.md). vsd: sigma_t = medium.density * grid, sigma_s = albedo *
 * sigma_t, sigma_a = (1 - albedo) * sigma_t, emitted radiance per unit length
 * emission_color * emission_strength * emission grid, all per world unit. A df3 voxel
 * holds grid / max, so the coefficients written are the per-unit values at the grid's
 * maximum; POV-Ray multiplies them by the df3 density. Media coefficients are per world
 * unit in POV-Ray too, and the axis swap keeps lengths: no other scale. */
#ifndef VSD_PIPELINE_POV_VOLUME_H
#define VSD_PIPELINE_POV_VOLUME_H
#include <stdio.h>
#include "vsd/scene.h"
#include "vsd/volume.h"
#include "df3.h"

/* Row-major 4x4 (column vectors): the df3's unit box -> POV-Ray world, through vsd's
 * index space, the grid's index_to_world, volume.matrix and the axis swap. */
void vsd_pov_box_matrix(const vsd_df3 *d, const vsd_volume *grid, const double object_matrix[16], double out[16]);

/* A default for POV-Ray's media samples: one per voxel along the df3 box's diagonal
 * (clamped to 16..1000), so the adaptive method 3 sees every voxel a ray crosses. */
int vsd_pov_default_samples(const vsd_df3 *density);

/* One volume of a frame as the .inc shows it: scene->volumes[index] (its medium and
 * volume.matrix), its grids and their df3 files. density_df3 / emission_df3 are the file
 * names as POV-Ray will open them (relative to where it runs); emission may be NULL (no
 * emission media). The grids give the transforms; only the df3's size, index_min, scale
 * and negative are read (its data may already be freed). */
typedef struct vsd_pov_volume_part {
    int index;                        /* in scene->volumes[] */
    const vsd_scene_volume *volume;
    const vsd_df3 *density;
    const vsd_volume *density_grid;
    const char *density_df3;
    const vsd_df3 *emission;
    const vsd_volume *emission_grid;
    const char *emission_df3;
} vsd_pov_volume_part;

/* The frame's .inc declaring `vsd_volume`: one union holding, for every part in order, a
 * hollow box with that volume's density media (its own coefficients and box matrix) and,
 * with emission, a second box with its emission media. With more than one part each
 * volume's boxes are headed by a comment naming volumes[i], its VDB file and the frame it
 * reads (vsd_scene_volume_frame); one part writes what a one-volume scene always wrote.
 * vsd_media_samples defaults to the largest of the parts' vsd_pov_default_samples. Every
 * box after the first gets a container grown by k half voxels (at least k * 0.002 world
 * units), k its place in the .inc: POV-Ray drops one medium of coinciding containers. */
void vsd_pov_write_volumes(FILE *f, int frame, const vsd_pov_volume_part *parts, int count);

#endif
