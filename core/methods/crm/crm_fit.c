/* crm_fit.c — the RBF approximation of a density grid (Zhou et al. 2008, §5.1).
 *
 * The objective sum (D - D~)^2 is evaluated on a lattice of samples (every s-th voxel per
 * axis) and each RBF only touches the samples of its 3r support, using that a Gaussian is a
 * product of three 1-D Gaussians: per RBF the exponentials are computed once per axis, and a
 * sample costs one multiply-add (value) or a few (gradient). The minimiser works on scaled
 * variables (centres and radii in voxels, weights in units of the grid's maximum density,
 * objective divided by sum D^2) so that all of them are O(1..100) and NLopt's tolerances
 * mean the same for every grid. */
#include "crm_fit.h"
#include "src/common/clock.h"
#include <float.h>
#include <limits.h>
#include <math.h>
#include <nlopt.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* exp(-9): the kernel's value at the 3r cut-off; the fit's kernel is shifted down by it. */
#define CUT_Q 9.0
#define CUT_E 1.2340980408667956e-4
#define MAX_RBFS 1000000
#define MAX_VOXELS ((size_t)1 << 31)
/* A stop is "a lower objective" only when it is lower by this relative amount, so rounding
 * noise cannot keep the teleport loop going. */
#define IMPROVE_REL 1e-5
/* NLopt's convergence test on the (scaled) objective. */
#define FTOL_REL 1e-5
/* Periodic teleports stop when a chunk of iterations lowers the objective by less. */
#define EARLY_GAIN 0.02

void vsd_crm_fit_defaults(vsd_crm_fit_options *o)
{
    memset(o, 0, sizeof *o);
    o->rbf_count = 800;
    o->radius_min = 0.015f;
    o->radius_max = 0.09f;
    o->weight_min = 0.01f;
    o->weight_max = 1.0f;
    o->teleport_every = 20;
    o->max_iterations = 3000;
    o->delete_per_frame = 3;
    o->insert_max = 8;
    o->error_ratio = 1.1f;
    o->fit_stride = 0;
    o->seed = 1;
}

vsd_status vsd_crm_fit_options_check(const vsd_crm_fit_options *o, char *err, size_t errlen)
{
    if (!o)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "no crm fit options given");
    /* !(lo <= v && v <= hi) also rejects NaN. */
#define RANGE_I(f, lo, hi) if (!(o->f >= (lo) && o->f <= (hi))) \
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit option " #f " = %d is outside [%d, %d]", \
                        o->f, (int)(lo), (int)(hi))
#define RANGE_F(f, lo, hi) if (!(o->f >= (lo) && o->f <= (hi))) \
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit option " #f " = %g is outside [%g, %g]", \
                        (double)o->f, (double)(lo), (double)(hi))
    RANGE_I(rbf_count, 1, MAX_RBFS);
    RANGE_F(radius_min, 1e-4f, 1.0f);
    RANGE_F(radius_max, o->radius_min, 1.0f);
    RANGE_F(weight_min, 0.0f, 1.0f);
    RANGE_F(weight_max, (o->weight_min > 1e-6f ? o->weight_min : 1e-6f), 100.0f);
    RANGE_I(teleport_every, 0, 1000000);
    RANGE_I(max_iterations, 1, 100000000);
    RANGE_I(delete_per_frame, 0, MAX_RBFS);
    RANGE_I(insert_max, 0, MAX_RBFS);
    RANGE_F(error_ratio, 1.0f, 1000.0f);
    RANGE_I(fit_stride, 0, 64);
#undef RANGE_I
#undef RANGE_F
    return VSD_OK;
}

void vsd_crm_rbfs_free(vsd_crm_rbfs *r)
{
    if (!r) return;
    free(r->rbf);
    r->rbf = NULL;
    r->count = 0;
}

static int max_dim(const vsd_crm_dense *d)
{
    int m = d->nx > d->ny ? d->nx : d->ny;
    return m > d->nz ? m : d->nz;
}

int vsd_crm_fit_stride(const vsd_crm_dense *d, const vsd_crm_fit_options *o)
{
    if (o && o->fit_stride > 0) return o->fit_stride;
    if (!d) return 1;
    /* About 48 samples along the largest axis: a 128^3 frame is fitted on 43^3 samples
     * (every 3rd voxel), which keeps a 800-RBF first frame near 10 s of one core, and a
     * Gaussian of the smallest paper radius (0.015 * 128 = 1.9 voxels) still covers
     * several samples (it reaches 3r = 5.8 voxels). Measured on a noisy 128^3 field, the
     * full-grid error at stride 3 was within 6% of stride 2's at 3x less time. */
    int s = (int)lround(max_dim(d) / 48.0);
    return s < 1 ? 1 : s;
}

/* ---------------------------------------------------------------- the sample lattice */

typedef struct samples {
    int s, o[3], m[3];  /* stride, first voxel, count per axis */
    size_t n;           /* m0 * m1 * m2 */
    float *d, *dt, *res;/* D, D~ and R = D - D~ at the samples */
    double sum_d2;
    float *q[3], *e[3], *dx[3]; /* per-axis scratch of one RBF's box */
} samples;

static void samples_free(samples *S)
{
    free(S->d);
    free(S->dt);
    free(S->res);
    for (int a = 0; a < 3; a++) {
        free(S->q[a]);
        free(S->e[a]);
        free(S->dx[a]);
    }
    memset(S, 0, sizeof *S);
}

static int samples_init(samples *S, const vsd_crm_dense *d, int s)
{
    const int n3[3] = {d->nx, d->ny, d->nz};
    memset(S, 0, sizeof *S);
    S->s = s;
    for (int a = 0; a < 3; a++) {
        /* s/2 centres the lattice; an axis shorter than that gets its middle voxel. */
        S->o[a] = s / 2 < n3[a] ? s / 2 : (n3[a] - 1) / 2;
        S->m[a] = (n3[a] - S->o[a] + s - 1) / s;
    }
    S->n = (size_t)S->m[0] * S->m[1] * S->m[2];
    S->d = malloc(sizeof(float) * S->n);
    S->dt = malloc(sizeof(float) * S->n);
    S->res = malloc(sizeof(float) * S->n);
    for (int a = 0; a < 3; a++) {
        S->q[a] = malloc(sizeof(float) * S->m[a]);
        S->e[a] = malloc(sizeof(float) * S->m[a]);
        S->dx[a] = malloc(sizeof(float) * S->m[a]);
        if (!S->q[a] || !S->e[a] || !S->dx[a]) break;
    }
    if (!S->d || !S->dt || !S->res || !S->q[2] || !S->e[2] || !S->dx[2]) {
        samples_free(S);
        return -1;
    }
    double sum = 0.0;
    size_t p = 0;
    for (int k = 0; k < S->m[2]; k++)
        for (int j = 0; j < S->m[1]; j++) {
            const float *row = d->d + (size_t)d->nx *
                (size_t)(S->o[1] + s * j + (size_t)d->ny * (size_t)(S->o[2] + s * k));
            for (int i = 0; i < S->m[0]; i++, p++) {
                float v = row[S->o[0] + s * i];
                S->d[p] = v;
                sum += (double)v * v;
            }
        }
    S->sum_d2 = sum;
    return 0;
}

/* Sample index -> the centre of its voxel in index space. */
static void sample_pos(const samples *S, size_t p, double x[3])
{
    size_t i = p % S->m[0], j = (p / S->m[0]) % S->m[1], k = p / ((size_t)S->m[0] * S->m[1]);
    x[0] = S->o[0] + (double)S->s * i + 0.5;
    x[1] = S->o[1] + (double)S->s * j + 0.5;
    x[2] = S->o[2] + (double)S->s * k + 0.5;
}

/* Sample indices t with |o + s t + .5 - c| <= h on axis a, clamped to the lattice. */
static void axis_range(const samples *S, int a, double c, double h, int *lo, int *hi)
{
    double l = ceil((c - h - 0.5 - S->o[a]) / S->s), u = floor((c + h - 0.5 - S->o[a]) / S->s);
    if (l < 0) l = 0;
    if (u > S->m[a] - 1) u = S->m[a] - 1;
    if (!(l <= u)) { *lo = 0; *hi = -1; return; } /* also NaN */
    *lo = (int)l;
    *hi = (int)u;
}

/* One RBF's support box and its per-axis q = (x-c)^2/r^2, exp(-q) and x - c.
 * Returns 0 when the box holds no sample. */
static int rbf_box(samples *S, const double *p, int lo[3], int hi[3])
{
    double r = p[3], h = sqrt(CUT_Q) * r;
    for (int a = 0; a < 3; a++) {
        axis_range(S, a, p[a], h, &lo[a], &hi[a]);
        if (lo[a] > hi[a]) return 0;
        for (int t = lo[a]; t <= hi[a]; t++) {
            double dx = S->o[a] + (double)S->s * t + 0.5 - p[a], q = dx * dx / (r * r);
            S->dx[a][t - lo[a]] = (float)dx;
            S->q[a][t - lo[a]] = (float)q;
            S->e[a][t - lo[a]] = (float)exp(-q);
        }
    }
    return 1;
}

/* The two inner loops of the objective, over one row of an RBF's box. They hold nearly
 * all of the fit's time, so with GCC/Clang they use 4-wide vector extensions: -O2 does not
 * vectorise float reductions by itself (it may not reassociate the sums). */
#if defined(__GNUC__)
typedef float v4f __attribute__((vector_size(16)));
typedef int v4i __attribute__((vector_size(16)));
#define HAVE_V4 1
#endif

/* row[i] += w * max(0, ex[i] * eyz - e^-9): the shifted, cut-off kernel. */
static void add_row(float *restrict row, const float *restrict ex, int len, float eyz, float w)
{
    int i = 0;
#ifdef HAVE_V4
    const v4f zero = {0, 0, 0, 0};
    for (; i + 4 <= len; i += 4) {
        v4f e, r;
        memcpy(&e, ex + i, sizeof e);
        memcpy(&r, row + i, sizeof r);
        v4f b = e * eyz - (float)CUT_E;
        b = (v4f)((v4i)b & (b > zero));
        r += w * b;
        memcpy(row + i, &r, sizeof r);
    }
#endif
    for (; i < len; i++) {
        float b = ex[i] * eyz - (float)CUT_E;
        row[i] += w * (b > 0.0f ? b : 0.0f);
    }
}

/* Over the samples of a row inside the support (e = ex * eyz > e^-9; outside the kernel
 * is 0 and so are its derivatives): a[0] = sum R e, a[1] = sum R e dx, a[2] = sum R e dx^2,
 * a[3] = sum R (e - e^-9). In float: a row is at most ~70 samples; callers sum in double. */
static void row_sums(const float *restrict res, const float *restrict ex, const float *restrict dxv,
                     int len, float eyz, float a[4])
{
    float a0 = 0, ax = 0, axx = 0, aw = 0;
    int i = 0;
#ifdef HAVE_V4
    const v4f cut = {(float)CUT_E, (float)CUT_E, (float)CUT_E, (float)CUT_E};
    v4f A0 = {0, 0, 0, 0}, AX = A0, AXX = A0, AW = A0;
    for (; i + 4 <= len; i += 4) {
        v4f e, r, d;
        memcpy(&e, ex + i, sizeof e);
        memcpy(&r, res + i, sizeof r);
        memcpy(&d, dxv + i, sizeof d);
        e *= eyz;
        v4i in = e > cut;
        v4f re = (v4f)((v4i)(r * e) & in);
        A0 += re;
        AX += re * d;
        AXX += re * d * d;
        AW += (v4f)((v4i)(r * (e - cut)) & in);
    }
    a0 = (A0[0] + A0[1]) + (A0[2] + A0[3]);
    ax = (AX[0] + AX[1]) + (AX[2] + AX[3]);
    axx = (AXX[0] + AXX[1]) + (AXX[2] + AXX[3]);
    aw = (AW[0] + AW[1]) + (AW[2] + AW[3]);
#endif
    for (; i < len; i++) {
        float e = ex[i] * eyz;
        if (!(e > (float)CUT_E)) continue;
        float re = res[i] * e, d = dxv[i];
        a0 += re;
        ax += re * d;
        axx += re * d * d;
        aw += res[i] * (e - (float)CUT_E);
    }
    a[0] = a0, a[1] = ax, a[2] = axx, a[3] = aw;
}

/* D~ at the samples (shifted kernel), R = D - D~, returns sum R^2. x holds per RBF
 * c0, c1, c2, r, w / wscale. The shifted kernel exp(-q) - exp(-9) is positive exactly where
 * q < 9, so max(0, .) is the cut-off itself: no per-row sphere bounds (which cost a sqrt and
 * two libm rounding calls per row) and a branch-free inner loop. */
static double eval_value(samples *S, const double *x, int n, double wscale)
{
    memset(S->dt, 0, sizeof(float) * S->n);
    for (int l = 0; l < n; l++) {
        const double *p = x + 5 * (size_t)l;
        int lo[3], hi[3];
        if (!(p[3] > 0.0) || !rbf_box(S, p, lo, hi)) continue;
        float w = (float)(p[4] * wscale);
        const float *ex = S->e[0];
        int len = hi[0] - lo[0] + 1;
        for (int k = lo[2]; k <= hi[2]; k++) {
            float qz = S->q[2][k - lo[2]], ez = S->e[2][k - lo[2]];
            for (int j = lo[1]; j <= hi[1]; j++) {
                if (qz + S->q[1][j - lo[1]] >= (float)CUT_Q) continue;
                float eyz = ez * S->e[1][j - lo[1]];
                add_row(S->dt + ((size_t)k * S->m[1] + j) * S->m[0] + lo[0], ex, len, eyz, w);
            }
        }
    }
    double sum = 0.0;
    for (size_t i = 0; i < S->n; i++) {
        float r = S->d[i] - S->dt[i];
        S->res[i] = r;
        sum += (double)r * r;
    }
    return sum;
}

/* Gradient of sum R^2 in raw units (c, r, w) from the residual of the last eval_value. */
static void eval_grad(samples *S, const double *x, int n, double wscale, double *g)
{
    for (int l = 0; l < n; l++) {
        const double *p = x + 5 * (size_t)l;
        double *gl = g + 5 * (size_t)l;
        int lo[3], hi[3];
        memset(gl, 0, 5 * sizeof(double));
        if (!(p[3] > 0.0) || !rbf_box(S, p, lo, hi)) continue;
        double sw = 0, sx = 0, sy = 0, sz = 0, sq = 0;
        const float *ex = S->e[0], *dxv = S->dx[0];
        int len = hi[0] - lo[0] + 1;
        for (int k = lo[2]; k <= hi[2]; k++) {
            float qz = S->q[2][k - lo[2]], ez = S->e[2][k - lo[2]], dz = S->dx[2][k - lo[2]];
            for (int j = lo[1]; j <= hi[1]; j++) {
                if (qz + S->q[1][j - lo[1]] >= (float)CUT_Q) continue;
                float eyz = ez * S->e[1][j - lo[1]], dy = S->dx[1][j - lo[1]];
                const float *res = S->res + ((size_t)k * S->m[1] + j) * S->m[0] + lo[0];
                float a[4];
                row_sums(res, ex, dxv, len, eyz, a);
                double b0 = a[0];
                sw += a[3];
                sx += a[1];
                sy += dy * b0;
                sz += dz * b0;
                sq += a[2] + ((double)dy * dy + (double)dz * dz) * b0;
            }
        }
        double w = p[4] * wscale, r = p[3];
        /* E = sum R^2, R = D - sum w B: dE/dθ = -2 sum R dB/dθ, with
         * dB/dc = 2 w B (x-c)/r^2, dB/dr = 2 w B |x-c|^2/r^3, dB/dw = B - e^-9. */
        gl[0] = -4.0 * w * sx / (r * r);
        gl[1] = -4.0 * w * sy / (r * r);
        gl[2] = -4.0 * w * sz / (r * r);
        gl[3] = -4.0 * w * sq / (r * r * r);
        gl[4] = -2.0 * sw;
    }
}

static int dense_ok(const vsd_crm_dense *d)
{
    return d && d->d && d->nx > 0 && d->ny > 0 && d->nz > 0 &&
           (size_t)d->nx * d->ny <= MAX_VOXELS && (size_t)d->nx * d->ny * d->nz <= MAX_VOXELS;
}

double vsd_crm_fit_objective(const vsd_crm_dense *d, int stride, const vsd_crm_rbfs *r, double *grad)
{
    samples S;
    if (!dense_ok(d) || stride < 1 || !r || r->count < 0 || (r->count > 0 && !r->rbf))
        return -1.0;
    double *x = malloc(sizeof(double) * 5 * (size_t)(r->count + 1));
    if (!x || samples_init(&S, d, stride) != 0) {
        free(x);
        return -1.0;
    }
    for (int l = 0; l < r->count; l++) {
        const vsd_crm_rbf *b = &r->rbf[l];
        double *p = x + 5 * (size_t)l;
        p[0] = b->c[0], p[1] = b->c[1], p[2] = b->c[2], p[3] = b->r, p[4] = b->w;
    }
    double e = eval_value(&S, x, r->count, 1.0);
    if (grad) eval_grad(&S, x, r->count, 1.0, grad);
    samples_free(&S);
    free(x);
    return e;
}

/* ---------------------------------------------------------------- full grid */

void vsd_crm_rasterise(const vsd_crm_rbfs *r, int nx, int ny, int nz, float *out)
{
    if (!out || nx <= 0 || ny <= 0 || nz <= 0) return;
    memset(out, 0, sizeof(float) * (size_t)nx * ny * nz);
    if (!r || !r->rbf) return;
    const int n3[3] = {nx, ny, nz};
    for (int l = 0; l < r->count; l++) {
        const vsd_crm_rbf *b = &r->rbf[l];
        int lo[3], hi[3];
        if (!(b->r > 0.0f) || !isfinite(b->r)) continue;
        for (int a = 0; a < 3; a++) {
            double h = VSD_CRM_SUPPORT * (double)b->r;
            double l0 = floor(b->c[a] - h - 0.5), u0 = ceil(b->c[a] + h - 0.5);
            if (l0 < 0) l0 = 0;
            if (u0 > n3[a] - 1) u0 = n3[a] - 1;
            lo[a] = l0 <= u0 ? (int)l0 : 0;
            hi[a] = l0 <= u0 ? (int)u0 : -1;
        }
        /* vsd_crm_rbf_eval itself, in RBF order, so D~ here is the renderer's D~ bit for bit
         * whenever it sums in the same order. */
        /* Rows wholly outside the support sphere are skipped; the margin keeps every row in
         * which float rounding could still put a voxel inside it. */
        double lim = 9.0 * (double)b->r * b->r * (1.0 + 1e-5);
        for (int k = lo[2]; k <= hi[2]; k++)
            for (int j = lo[1]; j <= hi[1]; j++) {
                double dy = j + 0.5 - b->c[1], dz = k + 0.5 - b->c[2];
                if (dy * dy + dz * dz > lim) continue;
                float *row = out + (size_t)nx * (j + (size_t)ny * k);
                for (int i = lo[0]; i <= hi[0]; i++)
                    row[i] += vsd_crm_rbf_eval(b, i + 0.5f, j + 0.5f, k + 0.5f);
            }
    }
}

double vsd_crm_rel_error(const vsd_crm_dense *d, const vsd_crm_rbfs *r)
{
    if (!dense_ok(d)) return -1.0;
    size_t n = (size_t)d->nx * d->ny * d->nz;
    float *t = malloc(sizeof(float) * n);
    if (!t) return -1.0;
    vsd_crm_rasterise(r, d->nx, d->ny, d->nz, t);
    double num = 0.0, den = 0.0;
    for (size_t i = 0; i < n; i++) {
        double v = d->d[i], e = v - t[i];
        num += e * e;
        den += v * v;
    }
    free(t);
    return den > 0.0 ? num / den : 0.0;
}

/* ---------------------------------------------------------------- the fit */

typedef struct fitctx {
    samples S;
    int n;                 /* RBFs in x */
    double wscale;         /* grid max density: x holds w / wscale */
    double inv_sum;        /* 1 / sum of D^2 at the samples */
    double rlo, rhi, wlo, whi, cmax[3]; /* bounds in x's units */
    double rfix;           /* radius of teleported and inserted RBFs */
    double *g;             /* raw gradient scratch, 5 * capacity */
    double *lb, *ub;       /* bounds, 5 * capacity */
    double *run_x;         /* best point of the current run */
    double run_f;
    int run_first, run_iters, run_limit;
    int iterations, evaluations, max_iterations, max_evaluations;
    nlopt_opt opt;
    uint64_t rng;
    size_t *nonzero;       /* samples with D > 0 (random teleports) */
    size_t n_nonzero;
} fitctx;

enum { RUN_CONVERGED = 1, RUN_CHUNK = 0, RUN_BUDGET = -1, RUN_NOMEM = -2, RUN_INTERNAL = -3 };

static uint64_t rng_next(uint64_t *s)
{
    /* splitmix64: tiny, seedable, and the same sequence on every platform. */
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double rng_uniform(uint64_t *s) { return (rng_next(s) >> 11) * (1.0 / 9007199254740992.0); }

static double clampd(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

static int budget_spent(const fitctx *F)
{
    return F->iterations >= F->max_iterations || F->evaluations >= F->max_evaluations;
}

static double nl_objective(unsigned nn, const double *x, double *grad, void *data)
{
    fitctx *F = data;
    double f = eval_value(&F->S, x, F->n, F->wscale) * F->inv_sum;
    if (grad) {
        eval_grad(&F->S, x, F->n, F->wscale, F->g);
        for (unsigned i = 0; i < nn; i++)
            grad[i] = F->g[i] * F->inv_sum * (i % 5 == 4 ? F->wscale : 1.0);
    }
    F->evaluations++;
    if (f < F->run_f) {
        /* The starting point is not a step of the minimiser. */
        if (!F->run_first) {
            F->iterations++;
            F->run_iters++;
        }
        F->run_f = f;
        memcpy(F->run_x, x, sizeof(double) * nn);
    }
    F->run_first = 0;
    if ((F->run_limit > 0 && F->run_iters >= F->run_limit) || budget_spent(F))
        nlopt_force_stop(F->opt);
    return f;
}

/* Evaluates at x without gradient (for the residual and f). */
static double eval_at(fitctx *F, const double *x)
{
    F->evaluations++;
    return eval_value(&F->S, x, F->n, F->wscale) * F->inv_sum;
}

/* One bounded L-BFGS run from x; x becomes the best point and *f its objective. chunk > 0
 * stops it after that many iterations (RUN_CHUNK). */
static int run_lbfgs(fitctx *F, double *x, double *f, int chunk)
{
    unsigned nn = 5u * (unsigned)F->n;
    if (F->n == 0) {
        *f = eval_at(F, x);
        return RUN_CONVERGED;
    }
    if (budget_spent(F)) {
        *f = eval_at(F, x);
        return RUN_BUDGET;
    }
    for (int l = 0; l < F->n; l++) {
        double *lb = F->lb + 5 * (size_t)l, *ub = F->ub + 5 * (size_t)l;
        for (int a = 0; a < 3; a++) lb[a] = 0.0, ub[a] = F->cmax[a];
        lb[3] = F->rlo, ub[3] = F->rhi, lb[4] = F->wlo, ub[4] = F->whi;
    }
    for (unsigned i = 0; i < nn; i++) x[i] = clampd(x[i], F->lb[i], F->ub[i]);
    nlopt_opt opt = nlopt_create(NLOPT_LD_LBFGS, nn);
    if (!opt) return RUN_NOMEM;
    F->opt = opt;
    F->run_f = HUGE_VAL;
    F->run_first = 1;
    F->run_iters = 0;
    F->run_limit = chunk;
    memcpy(F->run_x, x, sizeof(double) * nn);
    double fv = HUGE_VAL;
    nlopt_result rc = nlopt_set_lower_bounds(opt, F->lb);
    if (rc > 0) rc = nlopt_set_upper_bounds(opt, F->ub);
    if (rc > 0) rc = nlopt_set_min_objective(opt, nl_objective, F);
    if (rc > 0) rc = nlopt_set_ftol_rel(opt, FTOL_REL);
    if (rc > 0) rc = nlopt_set_maxeval(opt, F->max_evaluations - F->evaluations);
    if (rc > 0) rc = nlopt_optimize(opt, x, &fv);
    nlopt_destroy(opt);
    F->opt = NULL;
    if (rc == NLOPT_OUT_OF_MEMORY) return RUN_NOMEM;
    if (rc == NLOPT_INVALID_ARGS) return RUN_INTERNAL;
    /* Whatever stopped it (including a failed line search or round-off), keep its best. */
    if (F->run_f < HUGE_VAL) memcpy(x, F->run_x, sizeof(double) * nn);
    *f = F->run_f < HUGE_VAL ? F->run_f : eval_at(F, x);
    if (budget_spent(F)) return RUN_BUDGET;
    if (rc == NLOPT_FORCED_STOP) return RUN_CHUNK;
    return RUN_CONVERGED;
}

/* Index of the RBF with the smallest integral (proportional to w r^3). */
static int least_significant(const fitctx *F, const double *x)
{
    int best = 0;
    double bv = HUGE_VAL;
    for (int l = 0; l < F->n; l++) {
        const double *p = x + 5 * (size_t)l;
        double v = p[4] * p[3] * p[3] * p[3];
        if (v < bv) bv = v, best = l;
    }
    return best;
}

/* The sample of largest positive residual: where D~ lacks the most density (the weights are
 * positive, so an RBF can only help where D > D~). SIZE_MAX when D~ >= D everywhere. */
static size_t max_residual(const samples *S)
{
    size_t best = SIZE_MAX;
    float bv = 0.0f;
    for (size_t i = 0; i < S->n; i++)
        if (S->res[i] > bv) bv = S->res[i], best = i;
    return best;
}

/* Puts RBF p at sample q with the fixed radius, weight = the residual there. */
static void place_at(const fitctx *F, double *p, size_t q, double residual)
{
    sample_pos(&F->S, q, p);
    for (int a = 0; a < 3; a++) p[a] = clampd(p[a], 0.0, F->cmax[a]);
    p[3] = clampd(F->rfix, F->rlo, F->rhi);
    p[4] = clampd(residual / F->wscale, F->wlo, F->whi);
}

enum { TO_MAX_ERROR = 0, TO_RANDOM = 1 };

/* Moves the least significant RBF to the largest residual or a random nonzero sample;
 * needs the residual at x (eval_at first). */
static void teleport(fitctx *F, double *x, int where)
{
    double *p = x + 5 * (size_t)least_significant(F, x);
    size_t q = where == TO_MAX_ERROR ? max_residual(&F->S) : SIZE_MAX;
    if (q == SIZE_MAX && F->n_nonzero > 0)
        q = F->nonzero[(size_t)(rng_uniform(&F->rng) * F->n_nonzero) % F->n_nonzero];
    if (q == SIZE_MAX) return;
    double r = F->S.res[q];
    place_at(F, p, q, r > 0 ? r : F->S.d[q]);
}

/* Minimise with a teleport to the largest residual every `chunk` iterations (0: none)
 * until the minimiser converges or the budget is spent. */
static int minimise(fitctx *F, double *x, double *f, int chunk, int *teleports)
{
    double before = HUGE_VAL;
    for (;;) { /* bounded: every pass spends at least one iteration or ends */
        int rc = run_lbfgs(F, x, f, chunk);
        if (rc != RUN_CHUNK) return rc;
        /* The early stage is over once teleport_every iterations gain under EARLY_GAIN:
         * from then on each teleport costs more (a restarted L-BFGS loses its curvature
         * memory, and the moved RBF must be refitted) than the chunk gains, and with
         * hundreds of RBFs the minimiser would never converge between teleports. */
        if (*f > before * (1.0 - EARLY_GAIN)) chunk = 0;
        before = *f;
        if (chunk == 0) continue;
        *f = eval_at(F, x);
        teleport(F, x, TO_MAX_ERROR);
        (*teleports)++;
    }
}

/* Greedy placement: each RBF goes to the largest remaining residual (D minus the RBFs placed
 * so far) with that residual as weight, so every distinct blob gets an RBF before any gets a
 * second one (density-weighted random centres put several into the biggest blob and none
 * into small ones, which teleports then rarely repair). The radius roughly tiles the nonzero
 * volume. Deterministic; once D is fully covered, density-weighted random samples. */
static int initial_placement(fitctx *F, double *x, int count)
{
    samples *S = &F->S;
    double *cdf = malloc(sizeof(double) * (S->n ? S->n : 1));
    if (!cdf) return -1;
    double acc = 0.0;
    for (size_t i = 0; i < S->n; i++) {
        acc += S->d[i] > 0 ? S->d[i] : 0.0;
        cdf[i] = acc;
        S->res[i] = S->d[i];
    }
    double vox = (double)F->n_nonzero * S->s * S->s * S->s / count;
    /* Gaussians spaced L apart with r = 0.6 L overlap to about 1.2x one weight. */
    double r0 = clampd(0.6 * cbrt(vox), F->rlo, F->rhi);
    for (int l = 0; l < count; l++) {
        double *p = x + 5 * (size_t)l;
        size_t q = max_residual(S);
        if (q == SIZE_MAX) { /* all covered: density-weighted random */
            double u = rng_uniform(&F->rng) * acc;
            size_t a = 0, b = S->n - 1;
            while (a < b) { /* first cdf >= u */
                size_t m = a + (b - a) / 2;
                if (cdf[m] < u) a = m + 1; else b = m;
            }
            q = a;
        }
        sample_pos(S, q, p);
        p[3] = r0;
        p[4] = clampd((S->res[q] > 0 ? S->res[q] : 0.5 * S->d[q]) / F->wscale, F->wlo, F->whi);
        /* Subtract it: the value pass's row kernel with weight -w into the residual. */
        int lo[3], hi[3];
        if (!rbf_box(S, p, lo, hi)) continue;
        for (int k = lo[2]; k <= hi[2]; k++)
            for (int j = lo[1]; j <= hi[1]; j++) {
                if (S->q[2][k - lo[2]] + S->q[1][j - lo[1]] >= (float)CUT_Q) continue;
                add_row(S->res + ((size_t)k * S->m[1] + j) * S->m[0] + lo[0], S->e[0], hi[0] - lo[0] + 1,
                        S->e[2][k - lo[2]] * S->e[1][j - lo[1]], (float)(-p[4] * F->wscale));
            }
    }
    free(cdf);
    return 0;
}

static vsd_status run_status(int rc, char *err, size_t errlen)
{
    if (rc == RUN_NOMEM) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm fit: out of memory in NLopt");
    if (rc == RUN_INTERNAL)
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "crm fit: NLopt rejected the problem's arguments");
    return VSD_OK;
}

/* First frame: minimise with periodic teleports until the minimiser first converges; then
 * teleport alternately to the largest residual or a random nonzero sample and minimise
 * again, keep the result when it lowered the objective, and stop when both kinds failed in
 * a row (or the budget is spent). */
static int fit_first(fitctx *F, double *x, double *best, int *teleports)
{
    size_t nn = 5 * (size_t)F->n;
    double f, fbest;
    int rc = minimise(F, x, &f, F->run_limit, teleports);
    if (rc < RUN_BUDGET) return rc;
    memcpy(best, x, sizeof(double) * nn);
    fbest = f;
    int where = TO_MAX_ERROR, fails = 0;
    while (rc == RUN_CONVERGED && fails < 2) { /* bounded by the iteration budget */
        memcpy(x, best, sizeof(double) * nn);
        eval_at(F, x);
        teleport(F, x, where);
        (*teleports)++;
        /* No periodic teleports now: they serve the early stage (the paper's "entrapment in
         * local minima at early stages"); here they would move the RBF just teleported, or
         * one that is needed, before the minimiser can show whether the move paid off. */
        rc = minimise(F, x, &f, 0, teleports);
        if (rc < RUN_BUDGET) return rc;
        if (f < fbest * (1.0 - IMPROVE_REL)) {
            memcpy(best, x, sizeof(double) * nn);
            fbest = f;
            fails = 0;
        } else {
            fails++;
        }
        where = where == TO_MAX_ERROR ? TO_RANDOM : TO_MAX_ERROR;
    }
    memcpy(x, best, sizeof(double) * nn);
    return RUN_CONVERGED;
}

static void to_rbfs(const fitctx *F, const double *x, vsd_crm_rbf *out)
{
    for (int l = 0; l < F->n; l++) {
        const double *p = x + 5 * (size_t)l;
        out[l].c[0] = (float)p[0], out[l].c[1] = (float)p[1], out[l].c[2] = (float)p[2];
        out[l].r = (float)p[3];
        out[l].w = (float)(p[4] * F->wscale);
    }
}

/* Coherent frame: the previous fit, its least significant RBFs deleted, minimised without
 * teleports; then RBFs inserted one by one at the largest residual while the full-grid
 * relative error exceeds error_ratio times the first frame's. */
static int fit_coherent(fitctx *F, const vsd_crm_dense *d, const vsd_crm_fit_options *o, double *x,
                        double first_rel_error, vsd_crm_rbf *tmp, vsd_crm_fit_stats *st, int *tel)
{
    /* st->rel_error ends as the full-grid error of the returned x (it decides the loop). */
    double f;
    int del = o->delete_per_frame < F->n ? o->delete_per_frame : F->n;
    for (int k = 0; k < del; k++) {
        int l = least_significant(F, x);
        memmove(x + 5 * (size_t)l, x + 5 * (size_t)(l + 1), sizeof(double) * 5 * (size_t)(F->n - l - 1));
        F->n--;
    }
    st->deleted = del;
    int rc = minimise(F, x, &f, 0, tel);
    if (rc < RUN_BUDGET) return rc;
    for (;;) { /* bounded by insert_max */
        to_rbfs(F, x, tmp);
        vsd_crm_rbfs cur = {tmp, F->n};
        double rel = vsd_crm_rel_error(d, &cur);
        if (rel < 0) return RUN_NOMEM;
        st->rel_error = rel;
        if (!(rel > o->error_ratio * first_rel_error) || st->inserted >= o->insert_max || rc == RUN_BUDGET)
            return RUN_CONVERGED;
        eval_at(F, x);
        size_t q = max_residual(&F->S);
        if (q == SIZE_MAX) return RUN_CONVERGED;
        double *p = x + 5 * (size_t)F->n;
        F->n++;
        place_at(F, p, q, F->S.res[q]);
        st->inserted++;
        rc = minimise(F, x, &f, 0, tel);
        if (rc < RUN_BUDGET) return rc;
    }
}

/* Checks the grid (sizes, NaN/Inf) and returns its maximum and sum of squares. */
static vsd_status scan_grid(const vsd_crm_dense *d, double *dmax, char *err, size_t errlen)
{
    if (!d || !d->d)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit: no density grid given");
    if (!dense_ok(d))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit: density grid size %d x %d x %d is invalid "
                        "(each >= 1, at most 2^31 voxels)", d->nx, d->ny, d->nz);
    size_t n = (size_t)d->nx * d->ny * d->nz;
    double m = 0.0;
    for (size_t i = 0; i < n; i++) {
        float v = d->d[i];
        if (!isfinite(v)) {
            size_t x = i % d->nx, y = (i / d->nx) % d->ny, z = i / ((size_t)d->nx * d->ny);
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit: density voxel (%zu, %zu, %zu) is %s",
                            x, y, z, isnan(v) ? "NaN" : "infinite");
        }
        if (v > m) m = v;
    }
    *dmax = m;
    return VSD_OK;
}

static vsd_status check_previous(const vsd_crm_rbfs *p, double first_rel_error, char *err, size_t errlen)
{
    if (!p) return VSD_OK;
    if (p->count < 0 || p->count > MAX_RBFS || (p->count > 0 && !p->rbf))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit: previous RBF set has an invalid count %d",
                        p->count);
    for (int l = 0; l < p->count; l++) {
        const vsd_crm_rbf *b = &p->rbf[l];
        if (!isfinite(b->c[0]) || !isfinite(b->c[1]) || !isfinite(b->c[2]) || !isfinite(b->w) ||
            !isfinite(b->r) || !(b->r > 0))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit: previous RBF %d is not finite or has "
                            "radius <= 0", l);
    }
    if (p->count > 0 && !(first_rel_error >= 0 && isfinite(first_rel_error)))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit: first_rel_error = %g must be finite and >= 0",
                        first_rel_error);
    return VSD_OK;
}

static int any_positive(const samples *S)
{
    for (size_t i = 0; i < S->n; i++)
        if (S->d[i] > 0) return 1;
    return 0;
}

static void fitctx_free(fitctx *F)
{
    samples_free(&F->S);
    free(F->g);
    free(F->lb);
    free(F->ub);
    free(F->run_x);
    free(F->nonzero);
}

static int fitctx_init(fitctx *F, const vsd_crm_dense *d, const vsd_crm_fit_options *o, double dmax, int cap)
{
    memset(F, 0, sizeof *F);
    int s = vsd_crm_fit_stride(d, o);
    if (samples_init(&F->S, d, s) != 0) return -1;
    if (s > 1 && !any_positive(&F->S)) { /* the lattice missed every positive voxel */
        samples_free(&F->S);
        if (samples_init(&F->S, d, 1) != 0) return -1;
    }
    size_t nn = 5 * (size_t)cap;
    F->g = malloc(sizeof(double) * nn);
    F->lb = malloc(sizeof(double) * nn);
    F->ub = malloc(sizeof(double) * nn);
    F->run_x = malloc(sizeof(double) * nn);
    F->nonzero = malloc(sizeof(size_t) * (F->S.n ? F->S.n : 1));
    if (!F->g || !F->lb || !F->ub || !F->run_x || !F->nonzero) return -1;
    for (size_t i = 0; i < F->S.n; i++)
        if (F->S.d[i] > 0) F->nonzero[F->n_nonzero++] = i;
    double md = max_dim(d);
    F->wscale = dmax;
    F->inv_sum = 1.0 / F->S.sum_d2;
    F->rlo = o->radius_min * md;
    F->rhi = o->radius_max * md;
    F->wlo = o->weight_min;
    F->whi = o->weight_max;
    F->cmax[0] = d->nx, F->cmax[1] = d->ny, F->cmax[2] = d->nz;
    F->rfix = sqrt(F->rlo * F->rhi);
    F->max_iterations = o->max_iterations;
    /* Line searches take a few evaluations per iteration; this bounds a pathological one. */
    F->max_evaluations = o->max_iterations > INT_MAX / 4 ? INT_MAX : 3 * o->max_iterations + 100;
    F->rng = 0x63726d666974ull ^ ((uint64_t)o->seed << 17) ^ o->seed;
    F->run_limit = o->teleport_every;
    return 0;
}

vsd_status vsd_crm_fit(const vsd_crm_dense *d, const vsd_crm_fit_options *o, const vsd_crm_rbfs *previous,
                       double first_rel_error, vsd_crm_rbfs *out, vsd_crm_fit_stats *stats, char *err,
                       size_t errlen)
{
    double t0 = vsd_clock_seconds(), dmax = 0.0;
    vsd_crm_fit_stats st;
    memset(&st, 0, sizeof st);
    if (stats) memset(stats, 0, sizeof *stats);
    if (!out) return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm fit: no output RBF set given");
    out->rbf = NULL;
    out->count = 0;
    vsd_status s = vsd_crm_fit_options_check(o, err, errlen);
    if (s == VSD_OK) s = scan_grid(d, &dmax, err, errlen);
    if (s == VSD_OK) s = check_previous(previous, first_rel_error, err, errlen);
    if (s != VSD_OK) return s;
    if (dmax <= 0.0) { /* nothing positive to approximate */
        st.rel_error = vsd_crm_rel_error(d, out);
        st.seconds = vsd_clock_seconds() - t0;
        if (stats) *stats = st;
        return VSD_OK;
    }
    int coherent = previous && previous->count > 0;
    int n0 = coherent ? previous->count : o->rbf_count;
    int cap = n0 + (coherent ? o->insert_max : 0);
    fitctx F;
    double *x = NULL, *best = NULL;
    vsd_crm_rbf *res = NULL;
    int rc = RUN_NOMEM;
    if (fitctx_init(&F, d, o, dmax, cap) == 0) {
        x = malloc(sizeof(double) * 5 * (size_t)cap);
        best = malloc(sizeof(double) * 5 * (size_t)cap);
        res = malloc(sizeof(vsd_crm_rbf) * (size_t)cap);
    }
    if (x && best && res) {
        F.n = n0;
        if (coherent) {
            for (int l = 0; l < n0; l++) {
                const vsd_crm_rbf *b = &previous->rbf[l];
                double *p = x + 5 * (size_t)l;
                p[0] = b->c[0], p[1] = b->c[1], p[2] = b->c[2], p[3] = b->r, p[4] = b->w / F.wscale;
            }
            rc = fit_coherent(&F, d, o, x, first_rel_error, res, &st, &st.teleports);
        } else if (initial_placement(&F, x, n0) == 0) {
            rc = fit_first(&F, x, best, &st.teleports);
        }
    }
    if (rc >= RUN_BUDGET) {
        to_rbfs(&F, x, res);
        out->rbf = res;
        out->count = F.n;
        res = NULL;
        if (!coherent) st.rel_error = vsd_crm_rel_error(d, out);
        if (st.rel_error < 0) rc = RUN_NOMEM;
    }
    st.iterations = F.iterations;
    st.evaluations = F.evaluations;
    st.rbf_count = out->count;
    fitctx_free(&F);
    free(x);
    free(best);
    free(res);
    if (rc < RUN_BUDGET) {
        vsd_crm_rbfs_free(out);
        return rc == RUN_NOMEM ? vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm fit: out of memory (%d RBFs, "
                                          "%d x %d x %d grid)", n0, d->nx, d->ny, d->nz)
                               : run_status(rc, err, errlen);
    }
    st.seconds = vsd_clock_seconds() - t0;
    if (stats) *stats = st;
    return VSD_OK;
}
