/* crm_single.h — single scattering at the RBF centres in spherical harmonics (Zhou et al.
 * 2008, §5.3 and the appendix): per centre c_l the SH of the transmittance
 *     tau(c_l, w_i) = exp(-sigma * sum_h w_h T_h(c_l, w_i)),
 * with T_h the optical depth of B_h along the ray from c_l outwards along w_i (the path the
 * light arriving FROM w_i has crossed), then J_ss = albedo * ((L_in x tau) * HG).
 *
 * Direction conventions (all directions unit vectors in voxel index space, which the
 * renderer maps to world space with the volume's transform):
 *   L_in(w_i)  radiance arriving at the medium FROM direction w_i (it propagates along -w_i);
 *              this is what vsd_sh_project_env returns for an environment map.
 *   J_ss(w_o)  radiance scattered at c_l INTO direction w_o, w_o pointing from c_l towards
 *              the viewer (the propagation direction). A camera ray with direction d (eye
 *              into the scene) therefore reads J_ss(-d).
 *   HG         p(cos) normalised to 1 over the sphere with cos = (-w_i) . w_o, the cosine
 *              between the propagation directions (core/kernel/kernel_phase.h, Cycles, pbrt):
 *              g > 0 sends the light on, towards w_o = -w_i.
 * so J_ss(c, w_o) = albedo * integral L_in(w_i) tau(c, w_i) p((-w_i) . w_o) dw_i. For a
 * constant L_in = L and sigma = 0 it is albedo * L for every g; the paper's Omega/4pi
 * prefactor belongs to its 4pi-normalised phase function and is absorbed in p here.
 *
 * Units: sigma is the extinction per voxel length per unit density, so the optical depth of
 * a path is sigma times the integral of D~ along it in voxels (crm_rbf.h's units). */
#ifndef VSD_CRM_SINGLE_H
#define VSD_CRM_SINGLE_H
#include <stddef.h>
#include "vsd/sh.h"
#include "vsd/status.h"
#include "crm_rbf.h"

/* ---- optical-depth table of a unit-radius RBF (§5.3) --------------------------------- */

/* The table variable theta of a point at distance d (in units of the RBF radius r) from
 * the RBF centre, with the paper's formula scaled to the 3r support:
 *     theta = asin(3/d)            for d > 3 (half-angle of the cone the support subtends)
 *           = acos(d/3) + pi/2     for d <= 3 (inside the support),
 * monotonic from theta = 0 (d = infinity) through pi/2 (d = 3) to pi (d = 0). */
double vsd_crm_od_theta(double d_over_r);
/* Inverse of vsd_crm_od_theta: d / r for theta in [0, pi] (infinity at theta = 0). */
double vsd_crm_od_distance(double theta);

/* ZH of the optical depth T_u(w) of the unit RBF exp(-|x|^2) (cut at |x| = 3) along the
 * ray from a point at distance d from its centre outwards along w, about the axis pointing
 * from the point to the RBF centre (+Z): zh[l] is the coefficient of y_l0, l < order.
 * Computed directly (analytic erf line integrals, Gauss-Legendre in cos), no table. */
void vsd_crm_od_zh_exact(int order, double d_over_r, double *zh);

typedef struct vsd_crm_od_table {
    int order;                  /* SH order n (bands 0..n-1), 1..VSD_SH_MAX_ORDER */
    int angles;                 /* entries; entry k is at theta_k = pi k / (angles - 1) */
    double *zh;                 /* [angles * order]: vsd_crm_od_zh_exact at theta_k */
    double *zh_far;             /* [angles * order]: zh / sin^2(theta_k), the form that is
                                 * interpolated outside the support (see the lookup) */
    vsd_sh_tensor *tensor;      /* triple product tensor of this order */
    vsd_sh_exp_table *exp;      /* SH exponentiation of this order */
} vsd_crm_od_table;

/* Build the table: `angles` (the paper uses 256; 16..65536) uniform samples of theta in
 * [0, pi], plus the order's triple-product tensor and exp* table so a single-scattering
 * pass allocates nothing. */
vsd_status vsd_crm_od_table_create(int order, int angles, vsd_crm_od_table **out, char *err, size_t errlen);
void vsd_crm_od_table_destroy(vsd_crm_od_table *t);
/* ZH (table->order entries) of T_u at distance d_over_r, from the two entries around its
 * theta. Inside the support (theta >= pi/2) linearly in theta; outside, T_u's ZH falls as
 * 1/d^2 = sin^2(theta)/9 (the whole Gaussian seen from afar), which a straight line in
 * theta follows badly near theta = 0, so zh / sin^2(theta) is interpolated instead (and
 * held constant below the first non-zero entry, d beyond ~240 radii at 256 entries). */
void vsd_crm_od_lookup(const vsd_crm_od_table *t, double d_over_r, double *zh);

/* ---- single scattering at the centres (eq. 10-11) ------------------------------------- */

/* For every centre c_l of `rbfs`:
 *   od    = sum_h w_h r_h rot(T_u(theta_lh), axis c_l -> c_h)  (the own RBF, d = 0, is the
 *           isotropic half line integral w_l r_l sqrt(pi)/2 erf(3))
 *   tau   = exp*(-sigma od)
 *   J_ss  = albedo_c * parity((L_in,c x tau) * HG_g)   per channel c,
 * where parity flips the odd bands (the convolution returns the function of -w_o, see the
 * conventions above). Pairs whose contribution to sigma * od is below 1e-10 in SH norm
 * (far, light or zero-weight RBFs) are skipped; every other pair counts, since even a far
 * RBF blocks its small cone of directions completely.
 *   rbfs              centres, radii > 0, finite weights (negative weights are accepted;
 *                     exp* was fitted to blockers, so they are less accurate)
 *   sigma_per_voxel   >= 0, finite
 *   albedo[3]         each in [0, 1] (the scene's range: > 1 would create energy)
 *   g                 HG anisotropy in (-1, 1)
 *   order             == table->order
 *   env_sh            3 * order^2 (R, G, B) SH of L_in
 *   j_ss              out: count * 3 * order^2, centre-major then channel then coefficient
 *   transmittance_sh  optional out (NULL to skip): count * order^2, tau per centre
 * Cost O(count^2): each unordered pair shares one SH basis evaluation; runs on up to 8
 * threads (the online CPUs, one per 32 centres), with a count * order^2 double accumulator
 * per thread (VSD_ERR_NOMEM if it cannot be allocated). Accuracy is that of
 * order-n SH and of exp* (vsd/sh.h; measured in tests/test_crm_single.c); exp* clamps its
 * table at |f^| = 32, so very dense RBF sets (optical depth vectors beyond that) are
 * approximated with the clamped coefficients. */
vsd_status vsd_crm_single_scatter(const vsd_crm_rbfs *rbfs, double sigma_per_voxel, const double albedo[3],
                                  double g, int order, const double *env_sh, const vsd_crm_od_table *table,
                                  double *j_ss, double *transmittance_sh, char *err, size_t errlen);

/* rgb[c] = sum_i sh[c * order^2 + i] y_i(dir) for a unit direction dir (for J_ss: w_o,
 * pointing towards the viewer). */
void vsd_crm_eval_sh_rgb(int order, const double *sh, const double dir[3], double rgb[3]);

#endif
