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

/* Where n comes from: the constant medium.ior inside the density's support; a grid of n
 * (volume.ior_grid; 0 = background, n = 1 there; below 1 is an error); or Blender's
 * normalised temperature (medium.ior_from = "temperature"): T = 293 K + 1000 K t, and the
 * Gladstone-Dale law n - 1 = (n0 - 1) T0 / T with n0 - 1 = 2.9e-4 at T0 = 293 K, taken
 * relative to the ambient air so that n = 1 at 293 K (only grad n bends rays; a jump to
 * vacuum at the grid's edge would bend them there). */
enum { VSD_IOR_CONSTANT = 0, VSD_IOR_GRID = 1, VSD_IOR_TEMPERATURE = 2 };

/* density: the frame's density (its support and box for VSD_IOR_CONSTANT); source, name:
 * the n or temperature grid and its name (for errors), NULL for VSD_IOR_CONSTANT; ior:
 * the constant's value. */
vsd_status vsd_refraction_build(const vsd_kvolume *density, const vsd_kvolume *source, const char *name, int mode,
                                float ior, float smooth, int max_cells, vsd_refraction_field *out, char *err,
                                size_t errlen);
void vsd_refraction_free(vsd_refraction_field *f);

/* The field a frame's scene asks for (an empty one, k.ng NULL, when n = 1 everywhere, and
 * in a part's context): the refracting volume's (vsd_scene_refracting_volume; at most one,
 * vsd_method_check_volumes) medium.ior over its density, or its grid of volume.ior_grid /
 * medium.ior_from (ctx->volume_ior); both at once is an error that names them. What
 * `reference` and `lbl` call in their frame stage. */
struct vsd_frame_ctx;
vsd_status vsd_refraction_for_frame(const struct vsd_frame_ctx *ctx, vsd_refraction_field *out, char *err,
                                    size_t errlen);

#endif
