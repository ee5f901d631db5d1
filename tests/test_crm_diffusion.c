/* test_crm_diffusion.c — CG on the normal equations (crm_cg.h) and the multiple-scattering
 * diffusion solve at the RBF centres (crm_diffusion.h; Zhou et al. 2008 §3, §5.4).
 *
 * CG: agreement with LAPACKE direct solves (dgesv, dposv on A^T A, dgelsd's minimum-norm
 * least squares for a singular A), warm starts, the iteration bound, errors.
 * Diffusion: SH <-> Taylor against vsd_sh_eval; every matrix entry and right-hand side of
 * eq. 13 against a finite-difference evaluation of the continuous operator of eq. 5'; the
 * exact infinite-medium solutions (isotropic and anisotropic uniform sources, a quadratic
 * source that exercises the Laplacian, a diverging J1 that exercises div J1, with the sign
 * of the flux); one RBF; zero sources; invalid inputs.
 * `test_crm_diffusion --bench` times 100/400/1000 random smoke-like RBFs instead. */
#define _POSIX_C_SOURCE 200809L
#include "test_common.h"
#include "methods/crm/crm_cg.h"
#include "methods/crm/crm_diffusion.h"
#include "vsd/clock.h"
#include "vsd/sh.h"
#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define PI_D 3.14159265358979323846

/* ---- small helpers ----------------------------------------------------------------------- */

static uint64_t rng_state = 0x9e3779b97f4a7c15ULL;
static double urand(void)   /* [0, 1) */
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}
static double srand1(void) { return 2.0 * urand() - 1.0; }
static double gauss(void) { return sqrt(-2.0 * log(1.0 - urand())) * cos(2.0 * PI_D * urand()); }

static double max_abs(const double *v, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++) m = fmax(m, fabs(v[i]));
    return m;
}
static double max_abs_diff(const double *a, const double *b, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++) m = fmax(m, fabs(a[i] - b[i]));
    return m;
}
/* ---- CG --------------------------------------------------------------------------------------- */

/* A = 2 I + R / sqrt(n), R uniform in [-1, 1]: singular values within about [0.8, 3.2]. */
static void well_conditioned(int n, double *A)
{
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) A[i * n + j] = (i == j ? 2.0 : 0.0) + srand1() / sqrt((double)n);
}

static void test_cg_direct(void)
{
    enum { N = 40, K = 3 };
    static double A[N * N], b[N * K], x[N * K], xd[N * K], lu[N * N], ata[N * N], atb[N * K], xp[N * K];
    lapack_int ipiv[N];
    char err[256] = "";
    well_conditioned(N, A);
    for (int i = 0; i < N * K; i++) b[i] = srand1();

    memcpy(lu, A, sizeof A);
    memcpy(xd, b, sizeof b);
    CHECK(LAPACKE_dgesv(LAPACK_ROW_MAJOR, N, K, lu, N, ipiv, xd, K) == 0);
    /* the normal equations directly: A^T A x = A^T b by Cholesky */
    cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, N, N, N, 1.0, A, N, A, N, 0.0, ata, N);
    cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, N, K, N, 1.0, A, N, b, K, 0.0, atb, K);
    CHECK(LAPACKE_dposv(LAPACK_ROW_MAJOR, 'U', N, K, ata, N, atb, K) == 0);
    memcpy(xp, atb, sizeof xp);

    int it = -1;
    double res = -1.0;
    memset(x, 0, sizeof x);
    CHECK(vsd_crm_cg_normal(N, A, b, K, x, 1e-12, 500, &it, &res, err, sizeof err) == VSD_OK);
    double rel = max_abs_diff(x, xd, N * K) / max_abs(xd, N * K);
    double relp = max_abs_diff(x, xp, N * K) / max_abs(xp, N * K);
    printf("cg random %dx%d, %d rhs: %d iterations, residual %.2e, rel. error vs dgesv %.2e, vs dposv %.2e\n",
           N, N, K, it, res, rel, relp);
    CHECK(rel < 1e-8);
    CHECK(relp < 1e-8);
    CHECK(res <= 1e-12);
    CHECK(it > 0 && it < 500);

    /* warm start from the direct solution: nothing (or one step) left to do */
    memcpy(x, xd, sizeof x);
    CHECK(vsd_crm_cg_normal(N, A, b, K, x, 1e-10, 500, &it, &res, err, sizeof err) == VSD_OK);
    printf("cg warm start from the dgesv solution: %d iterations, residual %.2e\n", it, res);
    CHECK(it <= 1);
    CHECK(max_abs_diff(x, xd, N * K) / max_abs(xd, N * K) < 1e-10);

    /* the bound is honoured and reported; not an error */
    memset(x, 0, sizeof x);
    CHECK(vsd_crm_cg_normal(N, A, b, K, x, 1e-14, 3, &it, &res, err, sizeof err) == VSD_OK);
    CHECK(it == 3);
    CHECK(res > 1e-14);
    double res3 = res;
    memset(x, 0, sizeof x);
    CHECK(vsd_crm_cg_normal(N, A, b, K, x, 1e-14, 6, &it, &res, err, sizeof err) == VSD_OK);
    CHECK(it == 6 && res < res3);   /* more iterations, smaller residual */
    for (int i = 0; i < N * K; i++) x[i] = 0.25;
    CHECK(vsd_crm_cg_normal(N, A, b, K, x, 1e-14, 0, &it, &res, err, sizeof err) == VSD_OK);
    CHECK(it == 0 && x[0] == 0.25 && x[N * K - 1] == 0.25);   /* max_iter 0: x untouched */
}

/* Orthogonal n x n matrix (Q of a random matrix's QR). */
static void random_orthogonal(int n, double *Q)
{
    double tau[64];
    for (int i = 0; i < n * n; i++) Q[i] = gauss();
    LAPACKE_dgeqrf(LAPACK_ROW_MAJOR, n, n, Q, n, tau);
    LAPACKE_dorgqr(LAPACK_ROW_MAJOR, n, n, n, Q, n, tau);
}

/* A singular square A = U S V^T (rank 24 of 30, singular values 1..10) and an inconsistent
 * b: CG from zero must find the minimum-norm least-squares solution, as dgelsd does. */
static void test_cg_least_squares(void)
{
    enum { N = 30, K = 2, RANK = 24 };
    static double U[N * N], V[N * N], US[N * N], A[N * N], b[N * K], x[N * K], Ac[N * N], bc[N * K], sv[N];
    char err[256] = "";
    random_orthogonal(N, U);
    random_orthogonal(N, V);
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) US[i * N + j] = U[i * N + j] * (j < RANK ? 1.0 + 9.0 * j / (RANK - 1) : 0.0);
    cblas_dgemm(CblasRowMajor, CblasNoTrans, CblasTrans, N, N, N, 1.0, US, N, V, N, 0.0, A, N);
    for (int i = 0; i < N * K; i++) b[i] = srand1();

    memcpy(Ac, A, sizeof A);
    memcpy(bc, b, sizeof b);
    lapack_int rank = 0;
    CHECK(LAPACKE_dgelsd(LAPACK_ROW_MAJOR, N, N, K, Ac, N, bc, K, sv, 1e-10, &rank) == 0);
    CHECK(rank == RANK);

    int it = -1;
    double res = -1.0;
    memset(x, 0, sizeof x);
    CHECK(vsd_crm_cg_normal(N, A, b, K, x, 1e-13, 500, &it, &res, err, sizeof err) == VSD_OK);
    double rel = max_abs_diff(x, bc, N * K) / max_abs(bc, N * K);
    printf("cg singular least squares (rank %d of %d): %d iterations, rel. error vs dgelsd %.2e\n", RANK, N, it, rel);
    CHECK(rel < 1e-8);
    /* the residual b - A x is not 0 (inconsistent b) but orthogonal to A's range */
    CHECK(res <= 1e-13);
}

static void test_cg_edges(void)
{
    double A[4] = { 2, 1, 1, 3 }, b[4] = { 1, 0, 2, 0 }, x[4] = { 5, 5, 5, 5 };
    char err[256] = "";
    int it = -1;
    double res = -1;
    /* column 1 of b is zero: x there must become 0 whatever the warm start */
    CHECK(vsd_crm_cg_normal(2, A, b, 2, x, 1e-12, 50, &it, &res, err, sizeof err) == VSD_OK);
    CHECK(x[1] == 0.0 && x[3] == 0.0);
    CHECK_NEAR(2 * x[0] + 1 * x[2], 1.0, 1e-10);
    CHECK_NEAR(1 * x[0] + 3 * x[2], 2.0, 1e-10);
    CHECK(vsd_crm_cg_normal(0, NULL, NULL, 3, NULL, 1e-6, 10, &it, &res, err, sizeof err) == VSD_OK);
    CHECK(it == 0 && res == 0.0);

    double bad[4] = { 2, 1, NAN, 3 };
    CHECK(vsd_crm_cg_normal(2, bad, b, 2, x, 1e-6, 10, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "A[1][0]");
    double badb[4] = { 1, INFINITY, 0, 0 };
    CHECK(vsd_crm_cg_normal(2, A, badb, 2, x, 1e-6, 10, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "b[0][1]");
    double badx[4] = { 0, 0, 0, NAN };
    CHECK(vsd_crm_cg_normal(2, A, b, 2, badx, 1e-6, 10, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "x[1][1]");
    CHECK(vsd_crm_cg_normal(-1, A, b, 2, x, 1e-6, 10, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "n = -1");
    CHECK(vsd_crm_cg_normal(2, A, b, 0, x, 1e-6, 10, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "k = 0");
    CHECK(vsd_crm_cg_normal(2, A, b, 2, NULL, 1e-6, 10, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "NULL x");
    CHECK(vsd_crm_cg_normal(2, A, b, 2, x, -1.0, 10, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "tol");
    CHECK(vsd_crm_cg_normal(2, A, b, 2, x, 1e-6, -2, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "max_iter");
}

/* ---- SH <-> Taylor ---------------------------------------------------------------------- */

static void test_sh_taylor(void)
{
    double worst = 0.0, worst_back = 0.0;
    for (int trial = 0; trial < 20; trial++) {
        double t0 = srand1(), t1[3] = { srand1(), srand1(), srand1() }, sh[4], u0, u1[3];
        vsd_crm_taylor_to_sh2(t0, t1, sh);
        for (int k = 0; k < 10; k++) {
            double d[3] = { gauss(), gauss(), gauss() }, len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (int a = 0; a < 3; a++) d[a] /= len;
            double y[4];
            vsd_sh_eval(2, d, y);
            double f = sh[0] * y[0] + sh[1] * y[1] + sh[2] * y[2] + sh[3] * y[3];
            worst = fmax(worst, fabs(f - (t0 + t1[0] * d[0] + t1[1] * d[1] + t1[2] * d[2])));
        }
        vsd_crm_sh2_to_taylor(sh, &u0, u1);
        worst_back = fmax(worst_back, fmax(fabs(u0 - t0), max_abs_diff(u1, t1, 3)));
    }
    CHECK(worst < 1e-13);
    CHECK(worst_back < 1e-14);
    /* the constants themselves: a constant 1 has f0 = 2 sqrt(pi); z has f2 = sqrt(4pi/3) */
    double sh[4], z[3] = { 0, 0, 1 }, zero[3] = { 0, 0, 0 };
    vsd_crm_taylor_to_sh2(1.0, zero, sh);
    CHECK_NEAR(sh[0], 2.0 * sqrt(PI_D), 1e-14);
    vsd_crm_taylor_to_sh2(0.0, z, sh);
    CHECK_NEAR(sh[2], sqrt(4.0 * PI_D / 3.0), 1e-14);
}

/* ---- the continuous operator, evaluated independently -------------------------------------- */

typedef struct field_ctx {
    const vsd_crm_rbfs *rb;
    const double *coef;   /* per RBF value to interpolate (eq. 12 / eq. 7), stride `stride` */
    int stride;
} field_ctx;

static double dens(const vsd_crm_rbfs *rb, const double x[3])
{
    double d = 0.0;
    for (int l = 0; l < rb->count; l++) {
        const vsd_crm_rbf *b = &rb->rbf[l];
        double dx = x[0] - b->c[0], dy = x[1] - b->c[1], dz = x[2] - b->c[2];
        double q = (dx * dx + dy * dy + dz * dz) / ((double)b->r * b->r);
        if (q < 9.0) d += b->w * exp(-q);
    }
    return d;
}

/* (1/D~) sum_l w_l B_l(x) coef_l */
static double interp(const field_ctx *f, const double x[3])
{
    double num = 0.0;
    for (int l = 0; l < f->rb->count; l++) {
        const vsd_crm_rbf *b = &f->rb->rbf[l];
        double dx = x[0] - b->c[0], dy = x[1] - b->c[1], dz = x[2] - b->c[2];
        double q = (dx * dx + dy * dy + dz * dz) / ((double)b->r * b->r);
        if (q < 9.0) num += b->w * exp(-q) * f->coef[l * f->stride];
    }
    return num / dens(f->rb, x);
}

/* div(kappa grad L0) - sigma_a D L0 at x by central differences of the flux form. */
static double operator_fd(const field_ctx *f, const double x[3], double sigma_tr, double sigma_a, double e)
{
    double l0 = interp(f, x), acc = 0.0;
    for (int a = 0; a < 3; a++) {
        double xp[3] = { x[0], x[1], x[2] }, xm[3] = { x[0], x[1], x[2] }, hp[3] = { x[0], x[1], x[2] },
               hm[3] = { x[0], x[1], x[2] };
        xp[a] += e; xm[a] -= e; hp[a] += 0.5 * e; hm[a] -= 0.5 * e;
        double kp = 1.0 / (3.0 * sigma_tr * dens(f->rb, hp)), km = 1.0 / (3.0 * sigma_tr * dens(f->rb, hm));
        acc += (kp * (interp(f, xp) - l0) - km * (l0 - interp(f, xm))) / (e * e);
    }
    return acc - sigma_a * dens(f->rb, x) * l0;
}

static void test_assembly_fd(void)
{
    enum { N = 4 };
    vsd_crm_rbf r[N] = {
        { { 20.0f, 21.0f, 19.5f }, 3.0f, 0.8f },
        { { 23.5f, 20.0f, 21.0f }, 2.5f, 0.5f },
        { { 21.0f, 24.0f, 18.0f }, 3.5f, 0.3f },
        { { 18.0f, 18.5f, 22.0f }, 2.0f, 0.6f },
    };
    vsd_crm_rbfs rb = { r, N };
    const double sigma = 0.7, albedo = 0.6, g = 0.3, sigma_tr = (1 - albedo * g) * sigma, sigma_a = (1 - albedo) * sigma;
    double jss[N * 12], A[N * N], b[N];
    char err[256] = "";
    for (int i = 0; i < N * 12; i++) jss[i] = srand1() + (i % 4 == 0 ? 2.0 : 0.0);
    const int ch = 1;
    CHECK(vsd_crm_diffusion_assemble(&rb, sigma, albedo, g, jss, ch, A, b, err, sizeof err) == VSD_OK);

    /* column l of A is the operator applied to the field of u = e_l */
    double worst = 0.0, scale = max_abs(A, N * N);
    for (int l = 0; l < N; l++) {
        double unit[N] = { 0 };
        unit[l] = 1.0;
        field_ctx f = { &rb, unit, 1 };
        for (int h = 0; h < N; h++) {
            double x[3] = { r[h].c[0], r[h].c[1], r[h].c[2] };
            worst = fmax(worst, fabs(operator_fd(&f, x, sigma_tr, sigma_a, 1e-3) - A[h * N + l]));
        }
    }
    printf("eq. 13 matrix vs finite differences of eq. 5': max |diff| %.2e (entries up to %.2e)\n", worst, scale);
    CHECK(worst < 1e-6 * scale);

    /* b = -(sigma D J0 - sigma / (3 sigma_tr) div J1), J0 and J1 interpolated by eq. 7 */
    double t0[N], t1[N * 3];
    for (int l = 0; l < N; l++) vsd_crm_sh2_to_taylor(jss + (l * 3 + ch) * 4, t0 + l, t1 + 3 * l);
    double worst_b = 0.0;
    for (int h = 0; h < N; h++) {
        double x[3] = { r[h].c[0], r[h].c[1], r[h].c[2] }, div = 0.0, e = 1e-4;
        field_ctx f0 = { &rb, t0, 1 };
        for (int a = 0; a < 3; a++) {
            field_ctx fa = { &rb, t1 + a, 3 };
            double xp[3] = { x[0], x[1], x[2] }, xm[3] = { x[0], x[1], x[2] };
            xp[a] += e; xm[a] -= e;
            div += (interp(&fa, xp) - interp(&fa, xm)) / (2 * e);
        }
        double s = sigma * dens(&rb, x) * interp(&f0, x) - sigma / (3 * sigma_tr) * div;
        worst_b = fmax(worst_b, fabs(-s - b[h]));
    }
    printf("eq. 13 right-hand side vs finite differences: max |diff| %.2e (entries up to %.2e)\n", worst_b, max_abs(b, N));
    CHECK(worst_b < 1e-6 * max_abs(b, N));

    /* one RBF: L0 = w B u / (w B) is constant, the diffusion term vanishes: A = -sigma_a w */
    vsd_crm_rbfs one = { r, 1 };
    CHECK(vsd_crm_diffusion_assemble(&one, sigma, albedo, g, jss, ch, A, b, err, sizeof err) == VSD_OK);
    CHECK_NEAR(A[0], -sigma_a * r[0].w, 1e-12);
    CHECK_NEAR(b[0], -sigma * r[0].w * t0[0], 1e-12);
}

/* ---- solves with analytic answers ---------------------------------------------------------------- */

/* J_ss = t0 + t1 . w at every centre and channel (channel c scaled by 1 + c/4). */
static void uniform_source(int n, double t0, const double t1[3], double *jss)
{
    for (int l = 0; l < n; l++)
        for (int c = 0; c < 3; c++) {
            double s = 1.0 + 0.25 * c, tt[3] = { s * t1[0], s * t1[1], s * t1[2] };
            vsd_crm_taylor_to_sh2(s * t0, tt, jss + (l * 3 + c) * 4);
        }
}

/* Random smoke-like RBFs: a wavy plume in a 128^3 volume, radii 0.015..0.09 of it (the
 * paper's bounds), weights 0.01..1. */
static void smoke_rbfs(int n, vsd_crm_rbf *r)
{
    for (int l = 0; l < n; l++) {
        double t = urand();
        r[l].c[0] = (float)(64 + 20 * sin(3 * t) + 8 * gauss());
        r[l].c[1] = (float)(64 + 15 * cos(2 * t) + 8 * gauss());
        r[l].c[2] = (float)(10 + 108 * t + 3 * gauss());
        r[l].r = (float)(1.92 + (11.52 - 1.92) * urand());
        r[l].w = (float)(0.01 + 0.99 * urand());
    }
}

/* Infinite homogeneous medium, uniform source: L_l = J_l / (1 - a g^l) per band, so
 * u = J0 / (1 - a), J_ms = a g^l J_l / (1 - a g^l). Exact for ANY RBF set here (eq. 12
 * reproduces constants), so also checked on an irregular smoke-like set. */
static void test_uniform_source(void)
{
    enum { N = 200 };
    static vsd_crm_rbf r[N];
    static double jss[N * 12], jms[N * 12], u[N * 3];
    char err[256] = "";
    smoke_rbfs(N, r);
    vsd_crm_rbfs rb = { r, N };
    const double albedo[3] = { 0.8, 0.6, 0.3 }, g = 0.5, t1[3] = { 0.2, -0.1, 0.3 };
    uniform_source(N, 1.0, t1, jss);
    memset(u, 0, sizeof u);
    vsd_crm_diffusion_stats st;
    CHECK(vsd_crm_diffusion_solve_ex(&rb, 0.1, albedo, g, jss, u, jms, 1e-10, 5000, &st, err, sizeof err) == VSD_OK);
    printf("uniform source, %d smoke RBFs: %d systems, iterations %d/%d/%d, residual %.1e\n", N, st.systems,
           st.channel_iterations[0], st.channel_iterations[1], st.channel_iterations[2], st.residual);
    CHECK(st.systems == 3);
    double worst_u = 0.0, worst_f = 0.0, worst_j = 0.0;
    for (int l = 0; l < N; l++)
        for (int c = 0; c < 3; c++) {
            const double *js = jss + (l * 3 + c) * 4, *jm = jms + (l * 3 + c) * 4;
            double a = albedo[c], t0 = 1.0 + 0.25 * c, x[3] = { r[l].c[0], r[l].c[1], r[l].c[2] };
            field_ctx f = { &rb, u + c, 3 };
            worst_u = fmax(worst_u, fabs(u[l * 3 + c] - t0 / (1 - a)) / (t0 / (1 - a)));
            worst_f = fmax(worst_f, fabs(interp(&f, x) - t0 / (1 - a)) / (t0 / (1 - a)));
            worst_j = fmax(worst_j, fabs(jm[0] - a / (1 - a) * js[0]) / js[0]);
            for (int i = 1; i < 4; i++) worst_j = fmax(worst_j, fabs(jm[i] - a * g / (1 - a * g) * js[i]) / js[0]);
        }
    printf("  max rel. error: L0 coefficients %.2e, L0 field (eq. 12) at the centres %.2e, J_ms %.2e "
           "(analytic J0/(1-a), a g^l J_l/(1-a g^l))\n", worst_u, worst_f, worst_j);
    /* the coefficients are less determined than the field they make (overlapping Gaussians) */
    CHECK(worst_u < 1e-4);
    CHECK(worst_f < 1e-6);
    CHECK(worst_j < 1e-4);

    /* warm start from that solution: at most one iteration */
    CHECK(vsd_crm_diffusion_solve_ex(&rb, 0.1, albedo, g, jss, u, jms, 1e-8, 2000, &st, err, sizeof err) == VSD_OK);
    printf("  warm start from the solution: %d iterations\n", st.iterations);
    CHECK(st.iterations <= 1);

    /* zero single scattering: zero multiple scattering, also from a non-zero warm start */
    memset(jss, 0, sizeof jss);
    for (int i = 0; i < N * 3; i++) u[i] = 3.0;
    CHECK(vsd_crm_diffusion_solve(&rb, 0.1, albedo, g, jss, u, jms, &st, err, sizeof err) == VSD_OK);
    CHECK(max_abs(u, N * 3) == 0.0);
    CHECK(max_abs(jms, N * 12) == 0.0);
}

/* One RBF, three different albedos (three systems). */
static void test_single_rbf(void)
{
    vsd_crm_rbf r = { { 5, 6, 7 }, 2.0f, 0.4f };
    vsd_crm_rbfs rb = { &r, 1 };
    double jss[12], jms[12], u[3];
    const double albedo[3] = { 0.9, 0.5, 0.0 }, g = -0.4, t1[3] = { 0.1, 0.2, -0.3 };
    char err[256] = "";
    vsd_crm_diffusion_stats st;
    uniform_source(1, 2.0, t1, jss);
    CHECK(vsd_crm_diffusion_solve(&rb, 0.3, albedo, g, jss, NULL, jms, &st, err, sizeof err) == VSD_OK);
    CHECK(st.systems == 3);
    u[0] = u[1] = u[2] = 0.0;
    CHECK(vsd_crm_diffusion_solve(&rb, 0.3, albedo, g, jss, u, jms, &st, err, sizeof err) == VSD_OK);
    for (int c = 0; c < 3; c++) {
        double a = albedo[c], t0 = 2.0 * (1 + 0.25 * c);
        CHECK_NEAR(u[c], t0 / (1 - a), 1e-9 * t0 / (1 - a));
        CHECK_NEAR(jms[c * 4], a / (1 - a) * jss[c * 4], 1e-9 * jss[c * 4]);
        for (int i = 1; i < 4; i++) CHECK_NEAR(jms[c * 4 + i], a * g / (1 - a * g) * jss[c * 4 + i], 1e-9 * jss[c * 4]);
    }
    /* no RBFs: nothing to do */
    vsd_crm_rbfs none = { NULL, 0 };
    CHECK(vsd_crm_diffusion_solve(&none, 0.3, albedo, g, NULL, NULL, NULL, &st, err, sizeof err) == VSD_OK);
    CHECK(st.iterations == 0 && st.systems == 0);
}

/* A cubic lattice of m^3 equal RBFs, spacing = radius = 2 voxels (overlapping: D~ is
 * constant to ~1e-4 inside), D~ ~ 1 in the interior. */
enum { LM = 9, LN = LM * LM * LM };
static void lattice(vsd_crm_rbf *r, double *x0)
{
    const double h = 2.0, w = 1.0 / pow(PI_D, 1.5);
    for (int k = 0; k < LM; k++)
        for (int j = 0; j < LM; j++)
            for (int i = 0; i < LM; i++) {
                vsd_crm_rbf *b = &r[i + LM * (j + LM * k)];
                b->c[0] = (float)(10 + h * i); b->c[1] = (float)(10 + h * j); b->c[2] = (float)(10 + h * k);
                b->r = (float)h;
                b->w = (float)w;
            }
    x0[0] = x0[1] = x0[2] = 10 + h * (LM - 1) / 2.0;
}
static int interior(int l) { int i = l % LM, j = l / LM % LM, k = l / (LM * LM);
    return i >= 3 && i < LM - 3 && j >= 3 && j < LM - 3 && k >= 3 && k < LM - 3; }

/* The lattice problem both source tests solve, in static storage (too large for the stack):
 * the RBFs, the single-scattered source J_ss a test fills in, and the solution u, J_ms. */
typedef struct {
    vsd_crm_rbf r[LN];
    vsd_crm_rbfs rb;
    double jss[LN * 12], jms[LN * 12], u[LN * 3];
    double x0[3]; /* the lattice's centre */
    double xm[3]; /* the RBF centre nearest x0 */
} lattice_problem;

static lattice_problem *lattice_problem_make(void)
{
    static lattice_problem p;
    const int mid = (LM / 2) * (1 + LM + LM * LM);
    lattice(p.r, p.x0);
    p.rb.rbf = p.r;
    p.rb.count = LN;
    for (int k = 0; k < 3; k++) p.xm[k] = p.r[mid].c[k];
    return &p;
}

/* Solve from u = 0 to a tight tolerance (1e-10, at most 3000 iterations). */
static int lattice_problem_solve(lattice_problem *p, double sigma, const double albedo[3], double g,
                                 vsd_crm_diffusion_stats *st)
{
    char err[256] = "";
    memset(p->u, 0, sizeof p->u);
    return vsd_crm_diffusion_solve_ex(&p->rb, sigma, albedo, g, p->jss, p->u, p->jms, 1e-10, 3000, st, err,
                                      sizeof err) == VSD_OK;
}

/* Quadratic isotropic source J0(x) = A0 + C |x - x0|^2 (as a field; its coefficients carry
 * the interpolation offset), J1 = 0, in an infinite homogeneous medium D:
 *   kappa lap L0 - sigma_a D L0 + sigma D J0 = 0  =>  L0 = alpha + beta rho^2,
 *   beta = C / (1 - a),  alpha = A0 / (1 - a) + 2 beta / (sigma_tr sigma_a D^2),
 * and the flux term L1 = -grad L0 / (sigma_tr D) = -2 beta (x - x0) / (sigma_tr D): light
 * flows from the bright outside inwards (propagation convention). The Laplacian adds ~9% to
 * alpha here, so a factor 3 in kappa or a wrong sign fails by far. */
static void test_quadratic_source(void)
{
    enum { N = LN };
    lattice_problem *p = lattice_problem_make();
    const vsd_crm_rbf *r = p->r;
    const double *x0 = p->x0, *xm = p->xm, *u = p->u, *jms = p->jms;
    const double sigma = 1.0, a = 0.5, g = 0.5, albedo[3] = { a, a, a }, C = 0.1, A0 = 0.5;
    const double sigma_tr = (1 - a * g) * sigma, sigma_a = (1 - a) * sigma;
    /* interpolation offset delta: the field of coefficients rho_l^2 at a lattice centre is
     * rho^2 + delta (delta = sum w B |c_l - x|^2 / D~ there, ~1.5 r^2) */
    double num = 0.0;
    for (int l = 0; l < N; l++) {
        double dx = r[l].c[0] - xm[0], dy = r[l].c[1] - xm[1], dz = r[l].c[2] - xm[2], q = (dx * dx + dy * dy + dz * dz) / 4.0;
        if (q < 9.0) num += r[l].w * exp(-q) * q * 4.0;
    }
    const double D = dens(&p->rb, xm), delta = num / D;
    const double beta = C / (1 - a), alpha = (A0 + C * delta) / (1 - a) + 2 * beta / (sigma_tr * sigma_a * D * D);
    for (int l = 0; l < N; l++) {
        double dx = r[l].c[0] - x0[0], dy = r[l].c[1] - x0[1], dz = r[l].c[2] - x0[2], zero[3] = { 0, 0, 0 };
        for (int c = 0; c < 3; c++) vsd_crm_taylor_to_sh2(A0 + C * (dx * dx + dy * dy + dz * dz), zero, p->jss + (l * 3 + c) * 4);
    }
    vsd_crm_diffusion_stats st;
    CHECK(lattice_problem_solve(p, sigma, albedo, g, &st));
    double worst = 0.0, worst_l1 = 0.0, lap_share = 2 * beta / (sigma_tr * sigma_a * D * D) / alpha;
    for (int l = 0; l < N; l++) {
        if (!interior(l)) continue;
        double d[3] = { r[l].c[0] - x0[0], r[l].c[1] - x0[1], r[l].c[2] - x0[2] };
        double rho2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        double expect = alpha - beta * delta + beta * rho2;   /* the coefficient of that field */
        worst = fmax(worst, fabs(u[l * 3] - expect) / expect);
        double l1[3], t0, jt1[3];
        for (int k = 0; k < 3; k++) l1[k] = -2 * beta * d[k] / (sigma_tr * D);
        vsd_crm_sh2_to_taylor(jms + l * 12, &t0, jt1);   /* J_ms's l=1 part is a g L1 */
        for (int k = 0; k < 3; k++) worst_l1 = fmax(worst_l1, fabs(jt1[k] - a * g * l1[k]) / (a * g * 2 * beta * 2.0 / (sigma_tr * D)));
    }
    printf("quadratic source, %d lattice RBFs: %d iterations (%.2f s), interior L0 max rel. error %.2e "
           "(the Laplacian term is %.1f%% of alpha), L1 error %.2e of the flux at 1 spacing\n",
           N, st.iterations, st.seconds, worst, 100 * lap_share, worst_l1);
    /* The 3r cut-off makes the lattice's interpolant of rho^2 slightly non-quadratic (its
     * Laplacian is a few % off 6), so the interior matches to ~4% of the Laplacian term;
     * a factor 3 in kappa would be 67%, a wrong sign 200%. */
    CHECK(lap_share > 0.25);
    CHECK(worst < 0.1 * lap_share);
    CHECK(worst_l1 < 2e-2);
}

/* Diverging J1 = S (x - x0) (propagation convention: source light heading outwards),
 * J0 = A0: div J1 = 3 S, so in the interior L0 = A0 / (1 - a) - S / ((1 - a)(1 - a g) sigma D)
 * (light that leaves is not there) and L1 = J1 / (1 - a g). */
static void test_diverging_source(void)
{
    enum { N = LN };
    lattice_problem *p = lattice_problem_make();
    const vsd_crm_rbf *r = p->r;
    const double *x0 = p->x0, *u = p->u, *jms = p->jms;
    const double sigma = 1.0, a = 0.5, g = 0.5, albedo[3] = { a, a, a }, S = 0.1, A0 = 1.0;
    const double D = dens(&p->rb, p->xm);
    for (int l = 0; l < N; l++) {
        double t1[3] = { S * (r[l].c[0] - x0[0]), S * (r[l].c[1] - x0[1]), S * (r[l].c[2] - x0[2]) };
        for (int c = 0; c < 3; c++) vsd_crm_taylor_to_sh2(A0, t1, p->jss + (l * 3 + c) * 4);
    }
    vsd_crm_diffusion_stats st;
    CHECK(lattice_problem_solve(p, sigma, albedo, g, &st));
    const double expect = A0 / (1 - a) - S / ((1 - a) * (1 - a * g) * sigma * D);
    double worst = 0.0, worst_l1 = 0.0;
    for (int l = 0; l < N; l++) {
        if (!interior(l)) continue;
        worst = fmax(worst, fabs(u[l * 3] - expect) / expect);
        double t0, jt1[3];
        vsd_crm_sh2_to_taylor(jms + l * 12, &t0, jt1);
        for (int k = 0; k < 3; k++) {
            double j1 = S * (r[l].c[k] - x0[k]);
            worst_l1 = fmax(worst_l1, fabs(jt1[k] - a * g * j1 / (1 - a * g)) / (a * g * S * 2.0 / (1 - a * g)));
        }
    }
    const double div_share = S / ((1 - a * g) * sigma * D) / A0;
    printf("diverging J1, %d lattice RBFs: %d iterations, interior L0 max rel. error %.2e (div term %.1f%% of L0), "
           "L1 error %.2e\n", N, st.iterations, worst, 100 * div_share, worst_l1);
    CHECK(div_share > 0.1);
    CHECK(worst < 0.05 * div_share);   /* factor 3: 67% of the term, wrong sign: 200% */
    CHECK(worst_l1 < 2e-2);
}

static void test_invalid(void)
{
    vsd_crm_rbf r[2] = { { { 1, 2, 3 }, 2.0f, 0.5f }, { { 2, 2, 3 }, 2.0f, 0.5f } };
    vsd_crm_rbfs rb = { r, 2 };
    double jss[24] = { 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0 }, jms[24], u[6] = { 0 };
    const double ok[3] = { 0.5, 0.5, 0.5 };
    char err[256] = "";
    double one[3] = { 0.5, 1.0, 0.5 };
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, one, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "albedo[1]");
    CHECK(vsd_crm_diffusion_solve(&rb, 0.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "sigma_per_voxel");
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 1.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "g = 1");
    jss[13] = NAN;
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "j_ss_order2[13] (RBF 1, channel 0, coefficient 1)");
    jss[13] = 0.0;
    u[4] = INFINITY;
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "l_m0[4]");
    u[4] = 0.0;
    r[1].r = 0.0f;
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "RBF 1 radius");
    r[1].r = 2.0f;
    r[0].w = -0.1f;
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "RBF 0 weight");
    r[0].w = 0.5f;
    r[0].c[2] = NAN;
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "RBF 0 centre");
    r[0].c[2] = 3.0f;
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 0.0, NULL, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "j_ss_order2 is NULL");
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 0.0, jss, u, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "j_ms_order2 is NULL");
    CHECK(vsd_crm_diffusion_solve(NULL, 1.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "rbfs is NULL");
    CHECK(vsd_crm_diffusion_solve_ex(&rb, 1.0, ok, 0.0, jss, u, jms, 1e-6, -1, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "max_iter");
    vsd_crm_rbfs big = { r, VSD_CRM_DIFFUSION_MAX_RBFS + 1 };
    CHECK(vsd_crm_diffusion_solve(&big, 1.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_ERR_NOMEM);
    CHECK_CONTAINS(err, "limit");
    /* and the valid call works */
    CHECK(vsd_crm_diffusion_solve(&rb, 1.0, ok, 0.0, jss, u, jms, NULL, err, sizeof err) == VSD_OK);
}

/* ---- bench ------------------------------------------------------------------------------------------ */

/* A plausible J_ss: light from +z, attenuated with depth below the top of the plume, J1
 * along the light's propagation (-z). Channel c slightly different. */
static void smoke_source(int n, const vsd_crm_rbf *r, double tilt, double *jss)
{
    for (int l = 0; l < n; l++)
        for (int c = 0; c < 3; c++) {
            double t0 = (0.9 - 0.1 * c) * exp(-0.03 * (128.0 - r[l].c[2])) + 0.05;
            double t1[3] = { 0.3 * t0 * sin(tilt), 0.0, -0.3 * t0 * cos(tilt) };
            vsd_crm_taylor_to_sh2(t0, t1, jss + (l * 3 + c) * 4);
        }
}

static int bench(void)
{
    const int sizes[3] = { 100, 400, 1000 };
    const double sigma = 0.08, albedo[3] = { 0.8, 0.8, 0.8 }, albedo_rgb[3] = { 0.85, 0.8, 0.7 }, g = 0.3;
    char err[256] = "";
    printf("random smoke-like RBFs, sigma %.2f/voxel, albedo 0.8, g %.1f, one core (OPENBLAS_NUM_THREADS)\n", sigma, g);
    for (int s = 0; s < 3; s++) {
        int n = sizes[s];
        vsd_crm_rbf *r = malloc(n * sizeof *r);
        double *jss = malloc(n * 12 * sizeof(double)), *jms = malloc(n * 12 * sizeof(double));
        double *u = calloc(n * 3, sizeof(double)), *u40 = calloc(n * 3, sizeof(double));
        smoke_rbfs(n, r);
        smoke_source(n, r, 0.0, jss);
        vsd_crm_rbfs rb = { r, n };
        vsd_crm_diffusion_stats d40, w40, tight, same, tilt, rgb;
        vsd_status st = vsd_crm_diffusion_solve(&rb, sigma, albedo, g, jss, u40, jms, &d40, err, sizeof err);
        st |= vsd_crm_diffusion_solve_ex(&rb, sigma, albedo, g, jss, u, jms, 1e-6, 1000, &tight, err, sizeof err);
        st |= vsd_crm_diffusion_solve_ex(&rb, sigma, albedo, g, jss, u, jms, 1e-6, 1000, &same, err, sizeof err);
        smoke_source(n, r, 5.0 * PI_D / 180.0, jss);
        st |= vsd_crm_diffusion_solve_ex(&rb, sigma, albedo, g, jss, u, jms, 1e-6, 1000, &tilt, err, sizeof err);
        st |= vsd_crm_diffusion_solve(&rb, sigma, albedo, g, jss, u40, jms, &w40, err, sizeof err);
        memset(u, 0, n * 3 * sizeof(double));
        st |= vsd_crm_diffusion_solve(&rb, sigma, albedo_rgb, g, jss, u, jms, &rgb, err, sizeof err);
        if (st != VSD_OK) printf("error: %s\n", err);
        printf("n %4d: assembly %.4f s | default (40 it): cold %.4f s (measure %.1e), warm after 5 deg light turn %.4f s (%.1e)"
               " | rgb albedos: %d systems %.4f s\n", n, d40.assembly_seconds, d40.seconds - d40.assembly_seconds,
               d40.residual, w40.seconds - w40.assembly_seconds, w40.residual, rgb.systems, rgb.seconds - rgb.assembly_seconds);
        printf("        tol 1e-6 (max 1000): cold %4d it %.3f s (measure %.1e); warm, same input %d it; warm after 5 deg turn %d it %.3f s\n",
               tight.iterations, tight.seconds - tight.assembly_seconds, tight.residual, same.iterations, tilt.iterations,
               tilt.seconds - tilt.assembly_seconds);
        free(r); free(jss); free(jms); free(u); free(u40);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "--bench") == 0) return bench();
    double t = vsd_clock_seconds();
    test_cg_direct();
    test_cg_least_squares();
    test_cg_edges();
    test_sh_taylor();
    test_assembly_fd();
    test_single_rbf();
    test_uniform_source();
    test_quadratic_source();
    test_diverging_source();
    test_invalid();
    printf("total %.2f s\n", vsd_clock_seconds() - t);
    return test_finish("test_crm_diffusion");
}
