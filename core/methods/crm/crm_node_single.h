/* crm_node_single.h — single scattering on crm's node grid from the medium itself: the
 * option `single: "grid"` (default), beside the paper's RBF-centre form ("sh").
 *
 * Why: the paper computes J_ss at the RBF centres and interpolates it with the RBF weights
 * (eq. 7). A view ray sees mostly the first optical depth of the smoke, where J_ss falls
 * steeply inward, but the centres sit in the bulk, so the interpolated J_ss is too dark
 * there: VolumeDir 18% dark on smoke128 at density 20 (docs/methods/crm.md), with the
 * transmittance exact (`direct`) or not. Here every node inside the medium gets its own
 * J_ss: the transmittance toward M HEALPix directions is marched through the node grid's
 * cell-mean extinction (one node per step; marching the voxels instead moved VolumeDir on
 * smoke128 from 5.2% to 4.6% at 4x the time, so the node grid it is), and L_in tau is projected on order-n SH and
 * convolved with HG as in eq. 11 (crm_single_directions.h's engine). This is the "lighting cache"
 * variant issue 13 part 7 asks for, built on crm's own grid; the RBFs then serve the
 * view's density (D~ + R) and the multiple scattering. */
#ifndef VSD_CRM_NODE_SINGLE_H
#define VSD_CRM_NODE_SINGLE_H
#include <stdint.h>
#include "vsd/status.h"
#include "crm_phase.h"

/* The transmittance half, kept between lighting changes: the optical depth of the node
 * grid's density (unscaled, world units) from every node with density toward `directions`
 * world directions (the sky's HEALPix directions, or the extracted lights' of
 * crm_lights.h). It depends on the grid, the volume's transform and the directions only,
 * so an environment, albedo or phase edit reuses the sky's; a density-scale edit reuses it too, except
 * that the marches stop where the light is gone (optical depth 7 at the scale they ran
 * for), so a smaller scale than that marches again. */
typedef struct vsd_crm_node_depths {
    int32_t res[3];
    double to_node[9];
    int directions;
    double *dirs;           /* [3 * directions] world unit directions */
    float scale;            /* the density scale the marches stopped for */
    size_t count;           /* nodes with density */
    int32_t *which;         /* [count] their indices */
    float *od;              /* [count * directions] */
} vsd_crm_node_depths;

/* res: the node grid; to_node: world direction to node-grid displacement per world unit
 * (the volume's world-to-index matrix over the node spacing, row-major); density: per node,
 * unscaled; scale: sigma_t per unit density (world units); dirs: `directions` world unit
 * directions; threads: CPU threads (0 = all).
 * Keeps what `c` holds when it is valid for these (same grid shape, transform, directions
 * and a scale >= the one it ran for; the caller frees it when the density changes), else
 * marches; *marched says which. */
vsd_status vsd_crm_node_depths_update(vsd_crm_node_depths *c, const int32_t res[3], const double to_node[9],
                                      const float *density, float scale, const double *dirs, int directions, int threads,
                                      int *marched, char *err, size_t errlen);
void vsd_crm_node_depths_free(vsd_crm_node_depths *c);

/* The HEALPix directions of `directions` pixels (RING order), malloc'd: NULL when out of
 * memory or not 12 nside^2. */
double *vsd_crm_healpix_directions(int directions);

/* Writes the single-scattering part of every node with density and its CRM_NODE_SINGLE bit
 * (cleared elsewhere), for extinction sigma_t = scale * density; c's directions are the
 * HEALPix ones. env_sh: 3 * order^2; sky: NULL, or the map per HEALPix pixel of the
 * depths' directions (vsd_crm_single_from_depths). */
vsd_status vsd_crm_node_single(const vsd_crm_node_depths *c, float scale, const double albedo[3],
                               const vsd_crm_phase *phase, int order,
                               const double *env_sh, const float *sky, int threads, float *nodes, uint8_t *valid,
                               char *err, size_t errlen);

#endif
