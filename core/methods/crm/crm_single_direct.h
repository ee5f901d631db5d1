/* crm_single_direct.h — single scattering at the RBF centres with the transmittance taken
 * direction by direction instead of through SH exponentiation: the option
 * `single: "direct"` beside the paper's ZH table + exp* (crm_single.h, `single: "sh"`).
 *
 * Why: exp* (vsd/sh.h) is accurate while the optical-depth SH vector is small; inside our
 * smoke (smoke128 at density 20: optical depths of tens) it is off by tens of percent, and
 * single scattering came out 30% dark against the reference (docs/methods/crm.md). Here,
 * for each centre c and each of M HEALPix directions w, the optical depth of the RBF model
 * along the ray from c toward w is summed analytically,
 *     T_h = w_h exp(-d_perp^2 / r_h^2) r_h sqrt(pi)/2 (1 + erf(t_c / r_h))
 * (t_c the distance along the ray to the foot of c_h, d_perp its distance from the ray; RBFs
 * whose 3r support the ray misses are skipped), tau = exp(-sigma sum T_h), and
 * L_in(w) tau(w) is projected onto order-n SH with weight 4pi/M, then convolved with HG as
 * in the paper (eq. 11). L_in is the environment's own order-n SH (the paper's lighting),
 * unclamped (so the band-limited map keeps its mean). Cost O(count^2 M), on `threads` CPU
 * threads (0 = all; the CPU backend's pool). Same layouts and conventions as
 * vsd_crm_single_scatter. */
#ifndef VSD_CRM_SINGLE_DIRECT_H
#define VSD_CRM_SINGLE_DIRECT_H
#include "vsd/status.h"
#include "crm_rbf.h"

/* sigma: sigma_t per unit density (world units); w2i: the volume's world-to-index matrix
 * (linear part, row-major), which carries world directions into the RBFs' index space. */
vsd_status vsd_crm_single_scatter_direct(const vsd_crm_rbfs *rbfs, double sigma, const double w2i[9],
                                         const double albedo[3], double g, int order, const double *env_sh,
                                         int directions, int threads, double *j_ss, char *err, size_t errlen);

/* The same at any points: optical_depth(user, p, w) is the optical depth (sigma included)
 * from point p toward unit direction w; j_ss: count * 3 * order^2. Used by the RBF form
 * above and by the node-grid single scattering (`single: "grid"`, crm.c). */
typedef double (*vsd_crm_depth_fn)(const void *user, const double p[3], const double w[3]);
/* The two halves of it, for callers that keep the transmittance between lighting changes
 * (crm_node_single.h): od[p * directions + d], the optical depth from point p toward
 * HEALPix direction d (RING order) as optical_depth gives it; then the projection of
 * L_in exp(-scale od) with HG and the albedo, for any scale of the extinction. */
vsd_status vsd_crm_optical_depths(int count, const double *points, vsd_crm_depth_fn optical_depth, const void *user,
                                  int directions, int threads, float *od, char *err, size_t errlen);
/* sky: NULL = L_in from env_sh (the map's order-`order` SH, the paper's); else the map
 * averaged over each of the `directions` HEALPix pixels (src/lighting/env_healpix.h, 4
 * floats each), so a lamp or a small sun is shadowed where it is, not as its SH blur. */
vsd_status vsd_crm_single_from_depths(int count, const float *od, float scale, const double albedo[3], double g,
                                      int order, const double *env_sh, const float *sky, int directions, int threads,
                                      double *j_ss, char *err, size_t errlen);

vsd_status vsd_crm_single_scatter_points(int count, const double *points, vsd_crm_depth_fn optical_depth,
                                         const void *user, const double albedo[3], double g, int order,
                                         const double *env_sh, int directions, int threads, double *j_ss,
                                         char *err, size_t errlen);

#endif
