/* crm_diffusion.h — multiple scattering at the RBF centres by the diffusion approximation
 * (Zhou et al. 2008, §3 eq. 5-6 after Stam 1995, §5.4 eq. 12-13; plain text in
 * ../shared/papers/001_…txt), solved as A^T A x = A^T b by CG (crm_cg.h).
 *
 * Conventions (the same as crm_single.h, whose J_ss this consumes):
 *   lengths are voxels (voxel index space, crm_rbf.h); sigma = sigma_per_voxel is the
 *   extinction per voxel per unit density, so the extinction coefficient is sigma D~(x);
 *   per channel: albedo a, sigma_a = (1 - a) sigma, sigma_tr = (1 - a g) sigma (the paper's
 *   (1 - a mu/3) sigma_t with mu = 3 g, HG's first moment in its 4pi normalisation);
 *   directions w are PROPAGATION directions (J(w_o): radiance scattered into w_o, towards the
 *   viewer); the HG phase p is normalised to 1 over the sphere, so J_ss and J_ms both carry
 *   the albedo (J_ss = a int p L_d, J_ms = a int p L_m; eq. 3-4 with the 4pi absorbed in p).
 *
 * Physics, derived from the radiative transfer equation of the media radiance L_m,
 *   w . grad L_m = -sigma D L_m + sigma D (J_ss + J_ms),
 * with the two-term expansions L_m = L0 + L1 . w and J_ss = J0 + J1 . w, where
 * L0 = (1/4pi) int L_m, L1 = (3/4pi) int L_m w (the paper's definitions):
 *   zeroth moment   (1/3) div L1 = -sigma_a D L0 + sigma D J0
 *   first moment    grad L0 = -sigma_tr D L1 + sigma D J1
 *   =>  L1 = 3 kappa (-grad L0 + sigma D J1),          kappa = 1 / (3 sigma_tr D)     (eq. 6')
 *       div(kappa grad L0) - sigma_a D L0 + sigma D J0 - (sigma / (3 sigma_tr)) div J1 = 0   (eq. 5')
 * (kappa sigma D = sigma / (3 sigma_tr) is constant, so it leaves the divergence.)
 * This differs from the paper's printed eq. 5-6 in two places, both checked against the exact
 * infinite-medium solution (tests/test_crm_diffusion.c): a uniform source J_ss = J0 + J1 . w
 * in an infinite homogeneous medium has L_l = J_l / (1 - a g^l) per band, so
 * L0 = J0 / (1 - a) and L1 = J1 / (1 - a g); eq. 5'-6' give exactly that. The paper's
 *   - S = sigma_t a D J0 counts the albedo twice (J_ss already has it): L0 = a J0 / (1 - a);
 *   - kappa(...) in eq. 6 and (sigma_t / sigma_tr) div J1 in S are a factor 3 off for L1 as
 *     the Taylor coefficient (they hold for L1 := flux / 4pi): L1 = J1 / (3 (1 - a g)).
 *
 * Discretisation (eq. 12-13): L0(x) = N(x) / D~(x), N = sum_l w_l B_l(x) u_l, with unknowns
 * u_l = L0(c_l); J0, J1 are interpolated the same way (eq. 7). Substituting gives, at each
 * centre x = c_h (row h; D = D~, all B_l, D~ and derivatives cut off beyond 3 r_l together):
 *   A_hl = w_l { [D^2 lap B_l - 3 D grad D . grad B_l + (3 |grad D|^2 - D lap D) B_l] / (3 sigma_tr D^4)
 *                - sigma_a B_l }
 *   b_h  = -sigma sum_l w_l { B_l J0_l - (D grad B_l - B_l grad D) . J1_l / (3 sigma_tr D^2) }
 * with B = exp(-q), q = |x - c|^2 / r^2, grad B = -2 (x - c) / r^2 B, lap B = (4 q - 6) / r^2 B.
 * A differs per channel only through sigma_tr and sigma_a: channels with equal albedo share
 * one system (solved with k right-hand sides together).
 * Property of this formulation (not of the physics of a finite cloud): there is no vacuum
 * boundary condition (kappa -> infinity where D~ -> 0), so an isotropic J_ss with the same
 * value J0 at every centre gives exactly the constant u = J0 / (1 - a) for ANY RBF set
 * (eq. 12 reproduces constants, so the diffusion term vanishes); light leaves the smoke in
 * this model only through the spatial variation of J_ss.
 *
 * Solve: rows of A and b are scaled to unit 2-norm and columns of A to unit 2-norm (the
 * unknowns are rescaled back) before CG; for square non-singular A this leaves the solution
 * unchanged and makes CG's iteration count depend much less on the spread of radii and
 * densities. The warm start is rescaled too.
 *
 * Nothing keeps L0 >= 0: on ill-posed sets (see the defaults below) iterates can go negative
 * at some centres; a caller that needs non-negative light must clamp.
 *
 * Output: L1(c_h) is eq. 6' evaluated with eq. 12 (the paper: "substituting Eq. (12) into
 * Eq. (6)"): L1 = (sigma/sigma_tr) J1(c_h) - grad L0(c_h) / (sigma_tr D~(c_h)),
 * grad L0 = (grad N - L0 grad D~) / D~, J1(c_h) interpolated by eq. 7. Then
 * L_m's order-2 SH from (u_h, L1) and J_ms = a (L_m * HG_g): J_ms_lm = a g^l L_m_lm.
 *
 * Order-2 SH <-> Taylor (vsd/sh.h: real, orthonormal, Condon-Shortley, index l(l+1)+m):
 *   y0 = Y00 = 1 / (2 sqrt(pi)),  y1 = -C1 y,  y2 = C1 z,  y3 = -C1 x,  C1 = sqrt(3 / (4 pi)),
 *   f(w) = t0 + t1 . w   <=>   f0 = t0 / Y00,  f1 = -t1_y / C1,  f2 = t1_z / C1,  f3 = -t1_x / C1,
 *                              t0 = Y00 f0,    t1 = C1 (-f3, -f1, f2).
 * (Exact both ways: an order-2 projection is the two-term expansion, t0 = (1/4pi) int f,
 * t1 = (3/4pi) int f w.) */
#ifndef VSD_CRM_DIFFUSION_H
#define VSD_CRM_DIFFUSION_H
#include <stddef.h>
#include "vsd/status.h"
#include "crm_rbf.h"

/* Defaults: the paper's practice ("20-40 iterations are usually sufficient for a visually
 * plausible result", §5.4) rather than convergence. On overlapping smoke-like RBF sets the
 * collocation system of eq. 13 is very ill-conditioned (measured cond(A) 7e6 at 400 and 4e8
 * at 1000 random RBFs) and its exact solution is unphysical (L0 from -24 to 79 where the local
 * equilibrium J0 / (1 - a) spans 0.4..3.9), so CG stopped early acts as the regulariser:
 * 20-300 iterations from zero stay near the plausible range, thousands drift towards the
 * exact solution. Well-posed sets (tests: lattices, a single RBF, uniform sources) converge
 * to tight tolerances with vsd_crm_diffusion_solve_ex. */
#define VSD_CRM_DIFFUSION_TOL 1e-4
#define VSD_CRM_DIFFUSION_MAX_ITER 40
/* The dense solve keeps three n x n double matrices (n = 4096: 400 MB); more is refused
 * with VSD_ERR_NOMEM. The paper uses 300-1200 RBFs. */
#define VSD_CRM_DIFFUSION_MAX_RBFS 4096

typedef struct vsd_crm_diffusion_stats {
    int iterations;             /* CG iterations, the most over the systems solved */
    int channel_iterations[3];  /* CG iterations of the system that solved each channel */
    int systems;                /* distinct systems (1 when the three albedos are equal) */
    double residual;            /* largest CG stopping measure (crm_cg.h) of the scaled systems */
    double seconds;             /* wall time of the whole call */
    double assembly_seconds;    /* building A (all systems, with the scaling) and b */
} vsd_crm_diffusion_stats;

/* Multiple scattering at the RBF centres, default tol and iteration bound.
 *   rbfs             centres finite, r > 0, w > 0 (D~ divides), count 0..VSD_CRM_DIFFUSION_MAX_RBFS
 *   sigma_per_voxel  > 0, finite
 *   albedo[3]        each in [0, 1): at 1 nothing is absorbed and, without a vacuum boundary
 *                    (see above), the diffusion system is singular
 *   g                HG anisotropy in (-1, 1)
 *   j_ss_order2      count * 3 * 4: order-2 SH of J_ss(c_l, w_o) per centre, then channel
 *                    (crm_single.h's layout and direction convention)
 *   l_m0             count * 3 (centre-major, then channel) or NULL. In: the warm start u
 *                    (e.g. the previous frame's); out: u = L0(c_l). NULL: cold start (zeros)
 *                    and u is not returned.
 *   j_ms_order2      out: count * 3 * 4, J_ms's order-2 SH in j_ss's layout and convention
 *   stats            out, may be NULL
 * Errors: VSD_ERR_INVALID naming the bad input (or a CG breakdown), VSD_ERR_NOMEM.
 * Reaching the iteration bound is not an error: stats->residual says how far it got. */
vsd_status vsd_crm_diffusion_solve(const vsd_crm_rbfs *rbfs, double sigma_per_voxel, const double albedo[3],
                                   double g, const double *j_ss_order2, double *l_m0, double *j_ms_order2,
                                   vsd_crm_diffusion_stats *stats, char *err, size_t errlen);

/* The same with an explicit CG tolerance (>= 0) and iteration bound (>= 0). */
vsd_status vsd_crm_diffusion_solve_ex(const vsd_crm_rbfs *rbfs, double sigma_per_voxel, const double albedo[3],
                                      double g, const double *j_ss_order2, double *l_m0, double *j_ms_order2,
                                      double tol, int max_iter, vsd_crm_diffusion_stats *stats,
                                      char *err, size_t errlen);

/* The unscaled system of one channel (for tests and diagnostics): A (count * count, row-major)
 * and b (count) as in the header comment, for albedo `albedo` and J_ss channel `channel`
 * (0..2) of j_ss_order2. Same validation as the solve. */
vsd_status vsd_crm_diffusion_assemble(const vsd_crm_rbfs *rbfs, double sigma_per_voxel, double albedo, double g,
                                      const double *j_ss_order2, int channel, double *A, double *b,
                                      char *err, size_t errlen);

/* Order-2 SH (4 coefficients) <-> two-term Taylor expansion t0 + t1 . w (formulas above). */
void vsd_crm_sh2_to_taylor(const double sh[4], double *t0, double t1[3]);
void vsd_crm_taylor_to_sh2(double t0, const double t1[3], double sh[4]);

#endif
