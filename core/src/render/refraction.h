/* refraction.h — the refractive-index field of a frame (issue 14, `medium.ior`): n = 1
 * outside the medium and `ior` inside it, where inside is where the density is above 0.
 * Built on a grid over the density's box in its index space (cells of k voxels, k chosen
 * so that no axis exceeds `max_cells`), with a margin of 3 sigma + 1 cells:
 *   occupancy  the fraction of k^3 samples of the density in the cell that are > 0;
 *   n          1 + (ior - 1) occupancy, smoothed by a Gaussian of `smooth` cells (the
 *              paper, after Ihrke et al.: the gradient of a step would refract rays at one
 *              cell and not at its neighbours);
 *   grad n     central differences of the smoothed n, carried into world space by the
 *              transpose of the grid's world-to-grid map.
 * The kernel view is kernel/kernel_refract.h's vsd_krefract; the integrator step is half a
 * cell's smallest world edge. */
#ifndef VSD_REFRACTION_H
#define VSD_REFRACTION_H
#include "kernel/kernel_refract.h"
#include "vsd/status.h"

typedef struct vsd_refraction_field {
    vsd_krefract k;          /* k.ng owned here */
    float n_max;
} vsd_refraction_field;

vsd_status vsd_refraction_build(const vsd_kvolume *density, float ior, float smooth, int max_cells,
                                vsd_refraction_field *out, char *err, size_t errlen);
void vsd_refraction_free(vsd_refraction_field *f);

#endif
