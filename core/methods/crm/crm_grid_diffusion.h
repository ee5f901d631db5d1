/* crm_grid_diffusion.h — multiple scattering by diffusion on crm's node grid, with a vacuum
 * boundary: the option `multiple: "grid"` (default), beside the paper's system at the RBF
 * centres (crm_diffusion.h, `multiple: "rbf"`).
 *
 * Why: eq. 13 collocated at the RBF centres has no boundary condition (the diffusion
 * coefficient 1/(3 sigma_tr D~) grows without bound where D~ falls), so nothing makes light
 * leave the medium; on our fitted smoke its converged solution is unphysical (bright and
 * dark blobs, VolumeInd 260% from the reference at 493 CG iterations) and the early-stopped
 * one (the paper's 20-40 iterations) depends on the iteration count (VolumeInd 6x too dark
 * at 40, measured on smoke128, docs/methods/crm.md). Here the same diffusion equation,
 *     -div(kappa grad phi) + sigma_a phi = sigma_s phi_ri,   kappa = 1 / (3 sigma_t'),
 * sigma_t' = sigma_t (1 - albedo g) (the reduced extinction), is solved by finite volumes on
 * the node grid, where phi is the fluence of scattered light and phi_ri the fluence of the
 * reduced incident light (4 pi times the band-0 part of L_in tau, read from J_ss's band 0).
 * A face between a medium node and an empty one (density below VSD_CRM_GRID_EMPTY of the
 * largest) carries Marshak's vacuum condition: the flux to a zero fluence extrapolated
 * 2 kappa beyond the face, kappa / (h/2 + 2 kappa) per unit area and fluence.
 * The result is the radiance of light scattered at least once, L(w) = phi/4pi +
 * 3/(4pi) F.w with F = -kappa grad phi; what scatters it once more toward the viewer is
 * J_ms(w_o) = albedo (phi/4pi + g 3/(4pi) F.w_o), stored as order-2 SH in the nodes.
 * The system is symmetric positive definite: Jacobi-preconditioned CG, vector algebra
 * through OpenBLAS, warm-started from the previous solve. */
#ifndef VSD_CRM_GRID_DIFFUSION_H
#define VSD_CRM_GRID_DIFFUSION_H
#include <stdint.h>
#include "vsd/status.h"

#define VSD_CRM_GRID_EMPTY 1e-4

typedef struct vsd_crm_grid_diffusion_stats {
    int iterations;         /* CG iterations (most over the channels solved) */
    int systems;            /* 1 when the albedo is grey, else 3 */
    double residual;        /* final relative residual (largest over the systems) */
    double seconds;
} vsd_crm_grid_diffusion_stats;

/* res: nodes per axis; h: world distance between nodes; sigma_t: per node (world units,
 * density times the medium's density scale, averaged over the node's cell); nodes,
 * valid: crm_source_grid's arrays, whose single-scattering band 0 is the source and whose
 * multiple-scattering part (and CRM_NODE_MULTIPLE bit: the medium's nodes) is overwritten; phi: 3 per node, in: warm start (zeros for
 * none), out: the fluence per channel. tol: relative residual; max_iter bounds the CG. */
vsd_status vsd_crm_grid_diffusion(const int32_t res[3], double h, const float *sigma_t, const double albedo[3],
                                  double g, float *nodes, uint8_t *valid, double *phi, double tol, int max_iter,
                                  vsd_crm_grid_diffusion_stats *stats, char *err, size_t errlen);

#endif
