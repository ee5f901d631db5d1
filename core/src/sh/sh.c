/* Real spherical harmonics for shgrid and crm (vsd/sh.h): basis, projections (HEALPix
 * samples through chealpix, product quadrature, environment maps), rotation, zonal
 * harmonics, HG convolution, the triple-product tensor and SH exponentiation. */
#include "vsd/sh.h"
#include <chealpix.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* Same recurrence as the kernel's vsd_sh_eval_f (kernel/kernel_sh.h), in double: the
 * basis is polynomial in (x, y, z) via sin^m e^{im phi} = (x + iy)^m. */
void vsd_sh_eval(int order, const double d[3], double *y)
{
    double cm = 1.0, sm = 0.0, qmm = 1.0;
    int m, l, k;
    for (m = 0; m < order; m++) {
        double qlm2 = 0.0, qlm1 = qmm, fr = 1.0;
        for (k = 2; k <= 2 * m; k++) fr /= (double)k;
        for (l = m; l < order; l++) {
            double q, kn;
            if (l == m) q = qmm;
            else if (l == m + 1) q = d[2] * (double)(2 * m + 1) * qmm;
            else q = ((double)(2 * l - 1) * d[2] * qlm1 - (double)(l + m - 1) * qlm2) / (double)(l - m);
            if (l > m) fr *= (double)(l - m) / (double)(l + m);
            kn = sqrt((double)(2 * l + 1) / (4.0 * PI) * fr);
            if (m == 0) {
                y[l * (l + 1)] = kn * q;
            } else {
                y[l * (l + 1) + m] = 1.41421356237309504880 * kn * q * cm;
                y[l * (l + 1) - m] = 1.41421356237309504880 * kn * q * sm;
            }
            if (l > m) { qlm2 = qlm1; qlm1 = q; }
        }
        {
            double c = cm * d[0] - sm * d[1], s = cm * d[1] + sm * d[0];
            cm = c; sm = s;
        }
        qmm *= -(double)(2 * m + 1);
    }
}

long vsd_sh_healpix_nside(long count)
{
    long n;
    if (count < 12 || count % 12) return 0;
    for (n = 1; 12 * n * n <= count; n++)
        if (12 * n * n == count) return n;
    return 0;
}

vsd_status vsd_sh_healpix_dirs(long nside, double *dirs, char *err, size_t errlen)
{
    long i, count;
    if (nside < 1 || nside > 8192) return vsd_fail(VSD_ERR_INVALID, err, errlen, "HEALPix nside %ld out of range 1..8192", nside);
    count = nside2npix(nside);
    for (i = 0; i < count; i++) {
        double theta, phi;
        pix2ang_ring(nside, i, &theta, &phi);
        dirs[3 * i + 0] = sin(theta) * cos(phi);
        dirs[3 * i + 1] = sin(theta) * sin(phi);
        dirs[3 * i + 2] = cos(theta);
    }
    return VSD_OK;
}

/* Newton on the Legendre recurrence from Chebyshev starting points (Numerical Recipes'
 * gauleg): a handful of iterations reach double precision for the n <= a few hundred used
 * here. */
void vsd_sh_gauss_legendre(int n, double *x, double *w)
{
    int i, j, it;
    for (i = 0; i < (n + 1) / 2; i++) {
        double z = cos(PI * (i + 0.75) / (n + 0.5)), pp = 1.0;
        for (it = 0; it < 100; it++) {
            double p1 = 1.0, p2 = 0.0, z1;
            for (j = 1; j <= n; j++) {
                double p3 = p2;
                p2 = p1;
                p1 = ((2.0 * j - 1.0) * z * p2 - (j - 1.0) * p3) / j;
            }
            pp = n * (z * p1 - p2) / (z * z - 1.0);
            z1 = z;
            z = z1 - p1 / pp;
            if (fabs(z - z1) < 1e-15) break;
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = w[n - 1 - i] = 2.0 / ((1.0 - z * z) * pp * pp);
    }
}

void vsd_sh_project_samples(int order, long count, const double *dirs, const double *values,
                            int channels, double *coef)
{
    int n2 = order * order, c, i;
    long j;
    double y[VSD_SH_MAX_COEFFS], w = 4.0 * PI / (double)count;
    memset(coef, 0, sizeof(double) * (size_t)(n2 * channels));
    for (j = 0; j < count; j++) {
        vsd_sh_eval(order, dirs + 3 * j, y);
        for (c = 0; c < channels; c++) {
            double v = values[j * channels + c] * w;
            for (i = 0; i < n2; i++) coef[c * n2 + i] += v * y[i];
        }
    }
}

/* Walk the product rule's nodes: cb(direction, weight). */
static void product_rule(int quad_n, void (*cb)(const double d[3], double w, void *u), void *u)
{
    double *x = malloc(sizeof(double) * 2 * (size_t)quad_n), *wz = x + quad_n;
    int i, k, np = 2 * quad_n;
    if (!x) return;
    vsd_sh_gauss_legendre(quad_n, x, wz);
    for (i = 0; i < quad_n; i++) {
        double st = sqrt(fmax(0.0, 1.0 - x[i] * x[i]));
        for (k = 0; k < np; k++) {
            double phi = 2.0 * PI * ((double)k + 0.5) / (double)np, d[3];
            d[0] = st * cos(phi);
            d[1] = st * sin(phi);
            d[2] = x[i];
            cb(d, wz[i] * 2.0 * PI / (double)np, u);
        }
    }
    free(x);
}

typedef struct fn_ctx { int order; vsd_sh_fn f; void *user; double *coef; } fn_ctx;

static void fn_node(const double d[3], double w, void *u)
{
    fn_ctx *c = u;
    double y[VSD_SH_MAX_COEFFS], v = c->f(d, c->user) * w;
    int i;
    vsd_sh_eval(c->order, d, y);
    for (i = 0; i < c->order * c->order; i++) c->coef[i] += v * y[i];
}

void vsd_sh_project_fn(int order, int quad_n, vsd_sh_fn f, void *user, double *coef)
{
    fn_ctx c;
    c.order = order; c.f = f; c.user = user; c.coef = coef;
    memset(coef, 0, sizeof(double) * (size_t)(order * order));
    product_rule(quad_n, fn_node, &c);
}

vsd_status vsd_sh_project_env(int order, const vsd_env *env, double strength, double rotation_z,
                              double *coef, char *err, size_t errlen)
{
    int n2 = order * order, row, col, i, c;
    double cr = cos(rotation_z), sr = sin(rotation_z);
    double *rowsum = calloc((size_t)(3 * n2), sizeof(double));
    if (!rowsum) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for the SH environment projection");
    memset(coef, 0, sizeof(double) * (size_t)(3 * n2));
    for (row = 0; row < env->height; row++) {
        double th0 = PI * row / env->height, th1 = PI * (row + 1) / env->height, thc = 0.5 * (th0 + th1);
        double domega = vsd_env_texel_solid_angle(env->width, env->height, row) * strength;
        double st = sin(thc), ct = cos(thc);
        /* accumulate a row separately: rows are summed in double over ~1000 texels each, so
         * a bright sun does not swamp the small terms of other rows */
        memset(rowsum, 0, sizeof(double) * (size_t)(3 * n2));
        for (col = 0; col < env->width; col++) {
            const float *p = env->rgb + 3 * ((size_t)row * env->width + col);
            double u = (col + 0.5) / env->width, phi = (0.5 - u) * 2.0 * PI;
            double tx = st * cos(phi), ty = st * sin(phi), d[3], y[VSD_SH_MAX_COEFFS];
            if (p[0] == 0.0f && p[1] == 0.0f && p[2] == 0.0f) continue;
            /* texture = Rz(rotation) world, so world = Rz(-rotation) texture (kernel_env.h) */
            d[0] = cr * tx + sr * ty;
            d[1] = -sr * tx + cr * ty;
            d[2] = ct;
            vsd_sh_eval(order, d, y);
            for (c = 0; c < 3; c++)
                for (i = 0; i < n2; i++) rowsum[c * n2 + i] += (double)p[c] * y[i];
        }
        for (i = 0; i < 3 * n2; i++) coef[i] += rowsum[i] * domega;
    }
    free(rowsum);
    return VSD_OK;
}

double vsd_sh_reconstruct(int order, const double *coef, const double d[3])
{
    double y[VSD_SH_MAX_COEFFS], s = 0.0;
    int i;
    vsd_sh_eval(order, d, y);
    for (i = 0; i < order * order; i++) s += coef[i] * y[i];
    return s;
}

void vsd_sh_band_energy(int order, const double *coef, double *energy)
{
    int l, m;
    for (l = 0; l < order; l++) {
        energy[l] = 0.0;
        for (m = -l; m <= l; m++) energy[l] += coef[l * (l + 1) + m] * coef[l * (l + 1) + m];
    }
}

/* Offset of band l's (2l+1)^2 block in vsd_sh_rotation.m. */
static int band_offset(int l)
{
    int k, o = 0;
    for (k = 0; k < l; k++) o += (2 * k + 1) * (2 * k + 1);
    return o;
}

typedef struct rot_ctx { vsd_sh_rotation *r; const double *R; } rot_ctx;

static void rot_node(const double t[3], double w, void *u)
{
    rot_ctx *c = u;
    const double *R = c->R;
    double rt[3], yt[VSD_SH_MAX_COEFFS], yr[VSD_SH_MAX_COEFFS];
    int l, a, b, order = c->r->order;
    rt[0] = R[0] * t[0] + R[1] * t[1] + R[2] * t[2];
    rt[1] = R[3] * t[0] + R[4] * t[1] + R[5] * t[2];
    rt[2] = R[6] * t[0] + R[7] * t[1] + R[8] * t[2];
    vsd_sh_eval(order, t, yt);
    vsd_sh_eval(order, rt, yr);
    for (l = 0; l < order; l++) {
        int n = 2 * l + 1, base = l * l;
        double *blk = c->r->m + band_offset(l);
        for (a = 0; a < n; a++)
            for (b = 0; b < n; b++) blk[a * n + b] += w * yr[base + a] * yt[base + b];
    }
}

void vsd_sh_rotation_init(vsd_sh_rotation *r, int order, const double R[9])
{
    rot_ctx c;
    memset(r, 0, sizeof *r);
    r->order = order;
    c.r = r;
    c.R = R;
    /* integrand degree 2(order-1) in (x,y,z): order nodes in z and 2 order azimuths suffice */
    product_rule(order + 1, rot_node, &c);
}

void vsd_sh_rotate(const vsd_sh_rotation *r, const double *in, double *out)
{
    int l, a, b;
    for (l = 0; l < r->order; l++) {
        int n = 2 * l + 1, base = l * l;
        const double *blk = r->m + band_offset(l);
        for (a = 0; a < n; a++) {
            double s = 0.0;
            for (b = 0; b < n; b++) s += blk[a * n + b] * in[base + b];
            out[base + a] = s;
        }
    }
}

void vsd_sh_zh_rotate(int order, const double *zh, const double axis[3], double *out)
{
    double y[VSD_SH_MAX_COEFFS];
    int l, m;
    vsd_sh_eval(order, axis, y);
    for (l = 0; l < order; l++) {
        double s = sqrt(4.0 * PI / (2 * l + 1)) * zh[l];
        for (m = -l; m <= l; m++) out[l * (l + 1) + m] = s * y[l * (l + 1) + m];
    }
}

void vsd_sh_zh_project(int order, int quad_n, double (*k)(double z, void *user), void *user, double *zh)
{
    double *x = malloc(sizeof(double) * 2 * (size_t)quad_n), *w = x + quad_n;
    int i, l;
    for (l = 0; l < order; l++) zh[l] = 0.0;
    if (!x) return;
    vsd_sh_gauss_legendre(quad_n, x, w);
    for (i = 0; i < quad_n; i++) {
        double d[3] = {sqrt(fmax(0.0, 1.0 - x[i] * x[i])), 0.0, x[i]}, y[VSD_SH_MAX_COEFFS];
        double v = k(x[i], user) * w[i] * 2.0 * PI;
        vsd_sh_eval(order, d, y);
        for (l = 0; l < order; l++) zh[l] += v * y[l * (l + 1)];
    }
    free(x);
}

void vsd_sh_hg_zh(int order, double g, double *zh)
{
    double gl = 1.0;
    int l;
    for (l = 0; l < order; l++) {
        zh[l] = sqrt((2 * l + 1) / (4.0 * PI)) * gl;
        gl *= g;
    }
}

void vsd_sh_convolve_zh(int order, const double *f, const double *zh, double *out)
{
    int l, m;
    for (l = 0; l < order; l++) {
        double s = sqrt(4.0 * PI / (2 * l + 1)) * zh[l];
        for (m = -l; m <= l; m++) out[l * (l + 1) + m] = s * f[l * (l + 1) + m];
    }
}

/* ---- triple product ---- */

typedef struct tensor_ctx { int order; double *dense; } tensor_ctx;

static void tensor_node(const double d[3], double w, void *u)
{
    tensor_ctx *c = u;
    int n2 = c->order * c->order, i, j, k;
    double y[VSD_SH_MAX_COEFFS];
    vsd_sh_eval(c->order, d, y);
    for (i = 0; i < n2; i++)
        for (j = i; j < n2; j++) {
            double yij = w * y[i] * y[j];
            for (k = j; k < n2; k++) c->dense[((size_t)i * n2 + j) * n2 + k] += yij * y[k];
        }
}

vsd_status vsd_sh_tensor_create(int order, vsd_sh_tensor **out, char *err, size_t errlen)
{
    int n2 = order * order, i, j, k;
    vsd_sh_tensor *t;
    tensor_ctx c;
    long cap = 0, n = 0;
    *out = NULL;
    if (order < 1 || order > VSD_SH_MAX_ORDER)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "SH order %d out of range 1..%d", order, VSD_SH_MAX_ORDER);
    c.order = order;
    c.dense = calloc((size_t)n2 * n2 * n2, sizeof(double));
    t = calloc(1, sizeof *t);
    if (!c.dense || !t) goto nomem;
    /* y_i y_j y_k has degree 3(order-1): ceil((3(order-1)+1)/2) Gauss nodes in z are exact */
    product_rule((3 * (order - 1)) / 2 + 2, tensor_node, &c);
    for (i = 0; i < n2; i++)
        for (j = i; j < n2; j++)
            for (k = j; k < n2; k++)
                if (fabs(c.dense[((size_t)i * n2 + j) * n2 + k]) > 1e-12) cap += 6;
    t->order = order;
    t->ijk = malloc(sizeof(unsigned short) * 3 * (size_t)(cap ? cap : 1));
    t->value = malloc(sizeof(double) * (size_t)(cap ? cap : 1));
    if (!t->ijk || !t->value) goto nomem;
    /* store every distinct permutation of each symmetric entry, so applying the tensor is
     * one flat loop with no symmetry bookkeeping */
    for (i = 0; i < n2; i++)
        for (j = i; j < n2; j++)
            for (k = j; k < n2; k++) {
                double v = c.dense[((size_t)i * n2 + j) * n2 + k];
                int p[6][3] = {{i, j, k}, {i, k, j}, {j, i, k}, {j, k, i}, {k, i, j}, {k, j, i}};
                int a, b;
                if (fabs(v) <= 1e-12) continue;
                for (a = 0; a < 6; a++) {
                    int dup = 0;
                    for (b = 0; b < a; b++)
                        if (p[a][0] == p[b][0] && p[a][1] == p[b][1] && p[a][2] == p[b][2]) dup = 1;
                    if (dup) continue;
                    t->ijk[3 * n] = (unsigned short)p[a][0];
                    t->ijk[3 * n + 1] = (unsigned short)p[a][1];
                    t->ijk[3 * n + 2] = (unsigned short)p[a][2];
                    t->value[n++] = v;
                }
            }
    t->count = n;
    free(c.dense);
    *out = t;
    return VSD_OK;
nomem:
    free(c.dense);
    vsd_sh_tensor_destroy(t);
    return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for the SH triple-product tensor (order %d)", order);
}

void vsd_sh_tensor_destroy(vsd_sh_tensor *t)
{
    if (!t) return;
    free(t->ijk);
    free(t->value);
    free(t);
}

void vsd_sh_triple(const vsd_sh_tensor *t, const double *f, const double *g, double *out)
{
    long n;
    memset(out, 0, sizeof(double) * (size_t)(t->order * t->order));
    for (n = 0; n < t->count; n++) {
        const unsigned short *p = t->ijk + 3 * n;
        out[p[0]] += t->value[n] * f[p[1]] * g[p[2]];
    }
}

/* ---- exponentiation ---- */

#define EXP_TABLE_SIZE 256
#define EXP_TABLE_MAX 32.0
#define EXP_SHAPES 35
#define EXP_QUAD 96

/* exp* of a zonal vector (zh as coefficients of y_l0) by Gauss-Legendre in z: exp of a
 * zonal function is zonal, so a 1D rule gives the full projection. */
static void zonal_exp(int order, const double *zh, const double *w, int nq,
                      const double *yz /* [nq * order] y_l0(x_q) */, double *out)
{
    int q, l;
    for (l = 0; l < order; l++) out[l] = 0.0;
    for (q = 0; q < nq; q++) {
        double f = 0.0, e;
        for (l = 0; l < order; l++) f += zh[l] * yz[q * order + l];
        e = exp(f) * w[q] * 2.0 * PI;
        for (l = 0; l < order; l++) out[l] += e * yz[q * order + l];
    }
}

vsd_status vsd_sh_exp_table_create(int order, vsd_sh_exp_table **out, char *err, size_t errlen)
{
    vsd_sh_exp_table *t;
    double x[EXP_QUAD], w[EXP_QUAD], yz[EXP_QUAD * VSD_SH_MAX_ORDER];
    double shape[EXP_SHAPES][VSD_SH_MAX_ORDER];
    int s, q, l, k;
    *out = NULL;
    if (order < 1 || order > VSD_SH_MAX_ORDER)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "SH order %d out of range 1..%d", order, VSD_SH_MAX_ORDER);
    t = calloc(1, sizeof *t);
    if (t) {
        t->a = malloc(sizeof(double) * EXP_TABLE_SIZE);
        t->b = malloc(sizeof(double) * EXP_TABLE_SIZE);
    }
    if (!t || !t->a || !t->b) {
        vsd_sh_exp_table_destroy(t);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for the SH exponentiation table");
    }
    t->order = order;
    t->count = EXP_TABLE_SIZE;
    t->max_magnitude = EXP_TABLE_MAX;
    vsd_sh_gauss_legendre(EXP_QUAD, x, w);
    for (q = 0; q < EXP_QUAD; q++) {
        double d[3] = {sqrt(fmax(0.0, 1.0 - x[q] * x[q])), 0.0, x[q]}, y[VSD_SH_MAX_COEFFS];
        vsd_sh_eval(order, d, y);
        for (l = 0; l < order; l++) yz[q * order + l] = y[l * (l + 1)];
    }
    /* training shapes: caps of depth -1 and half-angle alpha about +Z, projected, DC
     * removed (exp* factors the DC out exactly), normalised to unit magnitude */
    for (s = 0; s < EXP_SHAPES; s++) {
        double alpha = (5.0 + 85.0 * s / (EXP_SHAPES - 1)) * PI / 180.0, ca = cos(alpha), norm = 0.0;
        for (l = 0; l < order; l++) shape[s][l] = 0.0;
        for (q = 0; q < EXP_QUAD; q++) {
            /* integrate the cap exactly on its own Gauss rule over z in [cos alpha, 1] */
            double zq = ca + (x[q] + 1.0) * 0.5 * (1.0 - ca), wq = w[q] * 0.5 * (1.0 - ca);
            double d[3] = {sqrt(fmax(0.0, 1.0 - zq * zq)), 0.0, zq}, y[VSD_SH_MAX_COEFFS];
            vsd_sh_eval(order, d, y);
            for (l = 0; l < order; l++) shape[s][l] -= wq * 2.0 * PI * y[l * (l + 1)];
        }
        shape[s][0] = 0.0;
        for (l = 1; l < order; l++) norm += shape[s][l] * shape[s][l];
        norm = sqrt(norm);
        for (l = 1; l < order; l++) shape[s][l] = norm > 0 ? shape[s][l] / norm : 0.0;
    }
    for (k = 0; k < EXP_TABLE_SIZE; k++) {
        double r = EXP_TABLE_MAX * k / (EXP_TABLE_SIZE - 1), sa = 0.0, sb = 0.0, sw = 0.0;
        if (k == 0 || order == 1) {
            /* exp*(f) = f_0 term only at |f^| = 0 (and always at order 1): a = 1; b is the
             * first-order slope, exp(f) ~ 1 + f */
            t->a[k] = 1.0;
            t->b[k] = 1.0;
            continue;
        }
        /* weighted least squares over the training set, min sum_s ||e_s - a 1 - b f_s||^2 /
         * ||e_s||^2 (relative errors, so the shapes whose exp is largest do not dominate):
         * f_s is orthogonal to 1 and |f_s| = r, so a = sum w e_s0 / (sqrt(4pi) sum w) and
         * b = sum w (e_s . f_s) / (r^2 sum w) */
        for (s = 0; s < EXP_SHAPES; s++) {
            double f[VSD_SH_MAX_ORDER], e[VSD_SH_MAX_ORDER], dot = 0.0, en = 0.0, ws;
            for (l = 0; l < order; l++) f[l] = r * shape[s][l];
            zonal_exp(order, f, w, EXP_QUAD, yz, e);
            for (l = 0; l < order; l++) en += e[l] * e[l];
            for (l = 1; l < order; l++) dot += e[l] * f[l];
            ws = 1.0 / en;
            sa += ws * e[0];
            sb += ws * dot;
            sw += ws;
        }
        t->a[k] = sa / sw / sqrt(4.0 * PI);
        t->b[k] = sb / sw / (r * r);
    }
    *out = t;
    return VSD_OK;
}

void vsd_sh_exp_table_destroy(vsd_sh_exp_table *t)
{
    if (!t) return;
    free(t->a);
    free(t->b);
    free(t);
}

void vsd_sh_exp(const vsd_sh_exp_table *t, const double *f, double *out)
{
    int n2 = t->order * t->order, i, k;
    double mag = 0.0, pos, fr, a, b, scale;
    for (i = 1; i < n2; i++) mag += f[i] * f[i];
    mag = sqrt(mag);
    pos = mag / t->max_magnitude * (t->count - 1);
    if (pos >= t->count - 1) { k = t->count - 2; fr = 1.0; }
    else { k = (int)pos; fr = pos - k; }
    a = t->a[k] + (t->a[k + 1] - t->a[k]) * fr;
    b = t->b[k] + (t->b[k + 1] - t->b[k]) * fr;
    scale = exp(f[0] / sqrt(4.0 * PI));
    out[0] = scale * a * sqrt(4.0 * PI);
    for (i = 1; i < n2; i++) out[i] = scale * b * f[i];
}

typedef struct exp_ctx { int order; const double *f; } exp_ctx;

static double exp_fn(const double d[3], void *u)
{
    exp_ctx *c = u;
    return exp(vsd_sh_reconstruct(c->order, c->f, d));
}

void vsd_sh_exp_reference(int order, const double *f, int quad_n, double *out)
{
    exp_ctx c;
    c.order = order;
    c.f = f;
    vsd_sh_project_fn(order, quad_n, exp_fn, &c, out);
}
