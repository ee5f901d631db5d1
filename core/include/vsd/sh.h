/* vsd/sh.h — real spherical harmonics (SH), shared by the `shgrid` and `crm` methods.
 *
 * Convention (Zhou et al. 2008, appendix; Sloan's PRT): real, orthonormal over the unit
 * sphere, Condon-Shortley phase; coefficient i = l(l+1)+m; an order-n vector has n^2
 * coefficients (bands l = 0..n-1). y0 = sqrt(1/4pi), y1 = -sqrt(3/4pi) y,
 * y2 = sqrt(3/4pi) z, y3 = -sqrt(3/4pi) x, with (x, y, z) the world direction (Z up).
 * Orders 1..VSD_SH_MAX_ORDER (8) are supported. Vectors are double arrays of n^2 entries;
 * RGB vectors are three such arrays back to back (R coefficients, then G, then B).
 *
 * Ownership: vsd_sh_tensor and vsd_sh_exp_table are created by their _create function and
 * freed by their _destroy function; everything else writes into caller-owned arrays and
 * allocates nothing (except vsd_sh_project_env and the _create functions, which return
 * VSD_ERR_NOMEM on failure). Functions are thread-safe on distinct outputs. */
#ifndef VSD_SH_H
#define VSD_SH_H
#include <stddef.h>
#include "vsd/status.h"
#include "vsd/env.h"
#ifdef __cplusplus
extern "C" {
#endif

#define VSD_SH_MAX_ORDER 8
#define VSD_SH_MAX_COEFFS (VSD_SH_MAX_ORDER * VSD_SH_MAX_ORDER)

static inline int vsd_sh_count(int order) { return order * order; }
static inline int vsd_sh_index(int l, int m) { return l * (l + 1) + m; }

/* Basis at unit direction d: y[0 .. order^2). */
void vsd_sh_eval(int order, const double d[3], double *y);

/* ---- Directions and quadrature ------------------------------------------------------ */

/* nside when count = 12 nside^2 (a HEALPix pixel count), else 0. */
long vsd_sh_healpix_nside(long count);
/* Centres of the 12 nside^2 HEALPix pixels (RING order, chealpix's pix2ang_ring) as unit
 * vectors, 3 doubles each. Every pixel has solid angle 4pi / count. */
vsd_status vsd_sh_healpix_dirs(long nside, double *dirs, char *err, size_t errlen);

/* Gauss-Legendre nodes and weights on [-1, 1] (n points, exact to degree 2n-1). */
void vsd_sh_gauss_legendre(int n, double *x, double *w);

/* ---- Projection ---------------------------------------------------------------------- */

/* Projection from samples of equal solid angle (e.g. HEALPix centres):
 * coef[c*n^2 + i] = 4pi/count * sum_j values[j*channels + c] y_i(dirs_j). */
void vsd_sh_project_samples(int order, long count, const double *dirs, const double *values,
                            int channels, double *coef);

typedef double (*vsd_sh_fn)(const double d[3], void *user);
/* Projection of f by a product rule: Gauss-Legendre in z (quad_n nodes) x 2 quad_n uniform
 * azimuths. Exact for band-limited f of band < quad_n (it integrates every polynomial in
 * (x, y, z) of degree < 2 quad_n - order); used as the numerical reference in tests. */
void vsd_sh_project_fn(int order, int quad_n, vsd_sh_fn f, void *user, double *coef);

/* Projection of the environment map, every texel weighted by its solid angle
 * (2pi/W)(cos theta_top - cos theta_bottom), in world space: texel directions are taken
 * through the Cycles mapping with rotation_z (vsd/env.h), radiance times strength.
 * coef: 3 * order^2 (R, G, B). */
vsd_status vsd_sh_project_env(int order, const vsd_env *env, double strength, double rotation_z,
                              double *coef, char *err, size_t errlen);

/* Reconstruction sum_i coef_i y_i(d). */
double vsd_sh_reconstruct(int order, const double *coef, const double d[3]);

/* Band energies e_l = sum_m coef_lm^2 (rotation invariant), l = 0..order-1. */
void vsd_sh_band_energy(int order, const double *coef, double *energy);

/* ---- Rotation ------------------------------------------------------------------------ */

/* Block-diagonal rotation matrix of SH coefficients for the 3x3 rotation R (row-major):
 * rotating f gives g(s) = f(R^T s), i.e. features of f at direction t move to R t. */
typedef struct vsd_sh_rotation {
    int order;
    double m[1 + 9 + 25 + 49 + 81 + 121 + 169 + 225];   /* band blocks (2l+1)^2, row-major */
} vsd_sh_rotation;

/* Built by exact quadrature, M_l[m][m'] = integral y_lm(R t) y_lm'(t) dt: band l is a
 * polynomial of degree 2l, so a Gauss-Legendre rule of `order` nodes in z times 2 order
 * azimuths integrates it exactly (to rounding). */
void vsd_sh_rotation_init(vsd_sh_rotation *r, int order, const double R[9]);
/* out = M in (in and out may not alias). */
void vsd_sh_rotate(const vsd_sh_rotation *r, const double *in, double *out);

/* Zonal harmonics (circularly symmetric about +Z): zh[l] is the coefficient of y_l0.
 * Rotating one to axis a is cheap: f_lm = sqrt(4pi/(2l+1)) zh_l y_lm(a). */
void vsd_sh_zh_rotate(int order, const double *zh, const double axis[3], double *out);
/* ZH coefficients of a circularly symmetric function k(cos theta) about +Z (by
 * Gauss-Legendre in cos theta with quad_n nodes). */
void vsd_sh_zh_project(int order, int quad_n, double (*k)(double z, void *user), void *user, double *zh);

/* ---- Convolution ----------------------------------------------------------------------- */

/* ZH of the Henyey-Greenstein phase p(cos) with anisotropy g: zh_l = sqrt((2l+1)/4pi) g^l
 * (HG's Legendre moments are g^l). */
void vsd_sh_hg_zh(int order, double g, double *zh);
/* Convolution with a circularly symmetric kernel given by its ZH coefficients
 * (Sloan et al. 2005): out_lm = sqrt(4pi/(2l+1)) zh_l f_lm. With the HG ZH,
 * out(d) = integral p(d . w) f(w) dw: the radiance scattered toward a viewer looking
 * along d (propagation -d) from light arriving from directions w. in may alias out. */
void vsd_sh_convolve_zh(int order, const double *f, const double *zh, double *out);

/* ---- Triple product ------------------------------------------------------------------- */

/* The sparse tensor Gamma_ijk = integral y_i y_j y_k (Zhou et al. appendix), computed once
 * per order by exact quadrature; entries below 1e-12 are dropped (they are zero by the
 * selection rules). */
typedef struct vsd_sh_tensor {
    int order;
    long count;
    unsigned short *ijk;   /* [count * 3] */
    double *value;         /* [count] */
} vsd_sh_tensor;

vsd_status vsd_sh_tensor_create(int order, vsd_sh_tensor **out, char *err, size_t errlen);
void vsd_sh_tensor_destroy(vsd_sh_tensor *t);
/* (f * g)_i = sum_jk Gamma_ijk f_j g_k: the order-n projection of the product of the two
 * reconstructions. out may not alias f or g. */
void vsd_sh_triple(const vsd_sh_tensor *t, const double *f, const double *g, double *out);

/* ---- Exponentiation ------------------------------------------------------------------- */

/* exp*(f) = order-n projection of exp(reconstruction of f). Ren et al. 2006's optimal
 * linear approximation, as in Zhou et al.'s appendix:
 *   exp*(f) ~ exp(f_0 / sqrt(4pi)) (a(|f^|) 1 + b(|f^|) f^),  f^ = (0, f_1, ..., f_{n^2-1}),
 *   1 = (sqrt(4pi), 0, ...).
 * a, b are tabulated per order over |f^| in [0, max_magnitude] (256 entries, linear
 * interpolation, clamped beyond). Each entry is the least-squares fit (closed form: the
 * fit is linear in a and b) to the exact exp* of a training set of negative log-visibility
 * vectors of the kind the methods exponentiate (optical depths): order-n projections of
 * circular caps of half-angle 5..90 degrees (blockers: a cap, not a hole), scaled to that magnitude. Errors are
 * measured in tests/test_sh.c and documented in docs/methods/shgrid.md. */
typedef struct vsd_sh_exp_table {
    int order;
    int count;
    double max_magnitude;
    double *a, *b;         /* [count] */
} vsd_sh_exp_table;

vsd_status vsd_sh_exp_table_create(int order, vsd_sh_exp_table **out, char *err, size_t errlen);
void vsd_sh_exp_table_destroy(vsd_sh_exp_table *t);
void vsd_sh_exp(const vsd_sh_exp_table *t, const double *f, double *out);
/* Reference exp* by numerical projection (vsd_sh_project_fn with quad_n nodes). */
void vsd_sh_exp_reference(int order, const double *f, int quad_n, double *out);

#ifdef __cplusplus
}
#endif
#endif
