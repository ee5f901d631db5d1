/* crm_fit.h — §5.1 of Zhou et al. 2008: approximating a density grid D by a sum of Gaussian
 * RBFs D~ = sum_l w_l exp(-(|x - c_l| / r_l)^2) (crm_rbf.h) with bounded L-BFGS (NLopt),
 * teleportation on the first frame and delete / minimise / insert on coherent frames.
 *
 * Units: centres and radii in voxel index space (voxel (i,j,k) sits at (i+.5, j+.5, k+.5)),
 * weights in density units. Option fractions are of the largest grid dimension (radii) and
 * of the grid's maximum density (weights), as in the paper. */
#ifndef VSD_CRM_FIT_H
#define VSD_CRM_FIT_H
#include <stddef.h>
#include "vsd/status.h"
#include "crm_rbf.h"

typedef struct vsd_crm_fit_options {
    int rbf_count;          /* RBFs of the first frame (default 800; the paper uses 1000) */
    float radius_min;       /* radius bounds, fractions of the largest grid dimension */
    float radius_max;       /*   (paper: 0.015 .. 0.09) */
    float weight_min;       /* weight bounds, fractions of the grid's maximum density */
    float weight_max;       /*   (paper: 0.01 .. 1.0) */
    int teleport_every;     /* first frame: teleport every this many iterations (20); 0 = only
                             * at convergence */
    int max_iterations;     /* bound on the L-BFGS iterations of the whole fit */
    int delete_per_frame;   /* coherent frames: RBFs deleted before minimising (3) */
    int insert_max;         /* coherent frames: at most this many RBFs inserted (8) */
    float error_ratio;      /* coherent frames: insert while rel_error / first > this (1.1) */
    int fit_stride;         /* objective samples every s-th voxel per axis; 0 = auto */
    unsigned seed;          /* initial placement and random teleports; same seed, same fit */
} vsd_crm_fit_options;

typedef struct vsd_crm_fit_stats {
    int iterations;   /* evaluations that lowered the objective: the minimiser's accepted steps */
    int evaluations;  /* objective + gradient evaluations (0 when the fit came from the cache) */
    int teleports, deleted, inserted, rbf_count;
    double rel_error; /* sum (D - D~)^2 / sum D^2 on the full grid (D~ as vsd_crm_rasterise) */
    double seconds;
} vsd_crm_fit_stats;

void vsd_crm_fit_defaults(vsd_crm_fit_options *o);

/* VSD_ERR_INVALID naming the first field out of its range. */
vsd_status vsd_crm_fit_options_check(const vsd_crm_fit_options *o, char *err, size_t errlen);

/* The stride fit_stride resolves to for a grid (fit_stride itself when > 0). */
int vsd_crm_fit_stride(const vsd_crm_dense *d, const vsd_crm_fit_options *o);

/* Fit D. previous == NULL (or with 0 RBFs: smoke appearing after empty frames): a first
 * frame, with teleports; the caller keeps its rel_error as first_rel_error for the frames
 * after it. Otherwise a coherent frame starting from `previous`. `out` is overwritten (its old
 * arrays are not freed) and owned by the caller: vsd_crm_rbfs_free. An all-zero (or nowhere
 * positive) grid gives 0 RBFs and VSD_OK. A NaN/Inf voxel is VSD_ERR_INVALID naming it.
 * `stats` may be NULL. */
vsd_status vsd_crm_fit(const vsd_crm_dense *d, const vsd_crm_fit_options *o,
                       const vsd_crm_rbfs *previous, double first_rel_error, vsd_crm_rbfs *out,
                       vsd_crm_fit_stats *stats, char *err, size_t errlen);

/* The fit's objective: sum over the voxels (i,j,k) with i,j,k = s/2 (mod s) of
 * (D - sum_l w_l Bs_l)^2, where Bs = exp(-q) - exp(-9) for q = |x-c|^2/r^2 < 9, else 0: the
 * renderer's kernel shifted down by its value at the 3r cut-off (< 1.3e-4 w), so the
 * objective is continuous in the parameters — L-BFGS's line search and finite differences
 * need that, and the shift is far below the fit error. grad (or NULL) receives 5*count
 * partial derivatives, per RBF in the order c0, c1, c2, r, w. Returns -1 on a bad argument
 * or when out of memory. */
double vsd_crm_fit_objective(const vsd_crm_dense *d, int stride, const vsd_crm_rbfs *r,
                             double *grad);

/* D~ on the full nx*ny*nz grid (layout as vsd_crm_dense), evaluated with vsd_crm_rbf_eval
 * exactly as the renderer does, so D - D~ is the residual the renderer must add back. */
void vsd_crm_rasterise(const vsd_crm_rbfs *r, int nx, int ny, int nz, float *out);

/* sum (D - D~)^2 / sum D^2 on the full grid (0 for an all-zero grid); -1 when out of memory. */
double vsd_crm_rel_error(const vsd_crm_dense *d, const vsd_crm_rbfs *r);

/* Frees r's array and leaves it empty. NULL-safe. */
void vsd_crm_rbfs_free(vsd_crm_rbfs *r);

#endif
