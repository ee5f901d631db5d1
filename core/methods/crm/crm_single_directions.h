/* crm_single_directions.h — single scattering with the transmittance taken direction by
 * direction instead of through SH exponentiation: the engine of `single: "grid"`
 * (crm_node_single.h), beside the paper's ZH table + exp* at the RBF centres (crm_single.h,
 * `single: "sh"`).
 *
 * Why: exp* (vsd/sh.h) is accurate while the optical-depth SH vector is small; inside our
 * smoke (smoke128 at density 20: optical depths of tens) it is off by tens of percent, and
 * single scattering came out 30% dark against the reference (docs/methods/crm.md). Here, for
 * each point and each of M HEALPix directions w, tau(w) = exp(-optical depth toward w), and
 * L_in(w) tau(w) is projected onto order-n SH with weight 4pi/M, then convolved with HG as in
 * the paper (eq. 11). L_in is the environment's own order-n SH (the paper's lighting),
 * unclamped (so the band-limited map keeps its mean), or the map per HEALPix pixel. Runs on
 * `threads` CPU threads (0 = all; the CPU backend's pool). Layouts as vsd_crm_single_scatter.
 * (The same at the RBF centres with the RBFs' analytic optical depth was the option
 * `single: "direct"`; it lost to the node grid, docs/methods/crm.md.) */
#ifndef VSD_CRM_SINGLE_DIRECTIONS_H
#define VSD_CRM_SINGLE_DIRECTIONS_H
#include "vsd/status.h"
#include "crm_phase.h"
#include "crm_rbf.h"

/* optical_depth(user, p, w) is the optical depth (sigma included) from point p toward unit
 * direction w. */
typedef double (*vsd_crm_depth_fn)(const void *user, const double p[3], const double w[3]);
/* The two halves of it, for callers that keep the transmittance between lighting changes
 * (crm_node_single.h): od[p * directions + d], the optical depth from point p toward
 * direction d of dirs (unit, 3 doubles each: the HEALPix directions in RING order for the
 * sky, crm_lights.h's for the extracted lights) as optical_depth gives it; then the
 * projection of L_in exp(-scale od) with the phase (crm_phase.h: HG, or delta-M's scaled
 * phase) and the albedo, for any scale of the extinction. */
vsd_status vsd_crm_optical_depths(int count, const double *points, vsd_crm_depth_fn optical_depth, const void *user,
                                  const double *dirs, int directions, int threads, float *od, char *err, size_t errlen);
/* sky: NULL = L_in from env_sh (the map's order-`order` SH, the paper's); else the map
 * averaged over each of the `directions` HEALPix pixels (src/lighting/env_healpix.h, 4
 * floats each), so a lamp or a small sun is shadowed where it is, not as its SH blur. */
vsd_status vsd_crm_single_from_depths(int count, const float *od, float scale, const double albedo[3],
                                      const vsd_crm_phase *phase, int order, const double *env_sh, const float *sky, int directions, int threads,
                                      double *j_ss, char *err, size_t errlen);

#endif
