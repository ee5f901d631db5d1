/* pov_volume.h — one frame's vsd volume as a POV-Ray include: hollow unit boxes holding
 * media whose density is a df3 file, placed where vsd renders the grid.
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

/* The frame's .inc declaring `vsd_volume`. density_df3 / emission_df3 are the file names
 * as POV-Ray will open them (relative to where it runs); emission may be NULL (no
 * emission media). The grids give the transforms. */
void vsd_pov_write_volume(FILE *f, const vsd_scene *scene, int frame, const vsd_df3 *density,
                          const vsd_volume *density_grid, const char *density_df3, const vsd_df3 *emission,
                          const vsd_volume *emission_grid, const char *emission_df3);

#endif
