/* crm_diffusion.c — the diffusion solve of crm_diffusion.h (equations and conventions there). */
#define _POSIX_C_SOURCE 200809L
#include "crm_diffusion.h"
#include "crm_cg.h"
#include "vsd/sh.h"
#include <cblas.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define PI_D 3.14159265358979323846
#define SUPPORT_Q ((double)VSD_CRM_SUPPORT * (double)VSD_CRM_SUPPORT)   /* q = |x-c|^2/r^2 cut */

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- SH <-> Taylor ------------------------------------------------------------------- */

void vsd_crm_sh2_to_taylor(const double sh[4], double *t0, double t1[3])
{
    const double y00 = 0.5 / sqrt(PI_D), c1 = sqrt(3.0 / (4.0 * PI_D));
    *t0 = y00 * sh[0];
    t1[0] = -c1 * sh[3];
    t1[1] = -c1 * sh[1];
    t1[2] = c1 * sh[2];
}

void vsd_crm_taylor_to_sh2(double t0, const double t1[3], double sh[4])
{
    const double y00 = 0.5 / sqrt(PI_D), c1 = sqrt(3.0 / (4.0 * PI_D));
    sh[0] = t0 / y00;
    sh[1] = -t1[1] / c1;
    sh[2] = t1[2] / c1;
    sh[3] = -t1[0] / c1;
}

/* ---- validation ---------------------------------------------------------------------- */

static vsd_status validate_rbfs(const vsd_crm_rbfs *rbfs, char *err, size_t errlen)
{
    if (!rbfs) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: rbfs is NULL");
    if (rbfs->count < 0) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: rbfs count %d is negative", rbfs->count);
    if (rbfs->count > VSD_CRM_DIFFUSION_MAX_RBFS)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "diffusion: %d RBFs exceed the dense solver's limit of %d",
                        rbfs->count, VSD_CRM_DIFFUSION_MAX_RBFS);
    if (rbfs->count > 0 && !rbfs->rbf) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: rbfs->rbf is NULL");
    for (int l = 0; l < rbfs->count; l++) {
        const vsd_crm_rbf *b = &rbfs->rbf[l];
        if (!isfinite(b->c[0]) || !isfinite(b->c[1]) || !isfinite(b->c[2]))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: RBF %d centre is not finite", l);
        if (!(b->r > 0.0f) || !isfinite(b->r))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: RBF %d radius %g must be > 0 and finite", l, (double)b->r);
        if (!(b->w > 0.0f) || !isfinite(b->w))
            return vsd_fail(VSD_ERR_INVALID, err, errlen,
                            "diffusion: RBF %d weight %g must be > 0 and finite (D~ divides eq. 13)", l, (double)b->w);
    }
    return VSD_OK;
}

static vsd_status validate_medium(double sigma, const double *albedo, int nalbedo, double g, char *err, size_t errlen)
{
    if (!(sigma > 0.0) || !isfinite(sigma))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: sigma_per_voxel %g must be > 0 and finite", sigma);
    if (!albedo) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: albedo is NULL");
    for (int c = 0; c < nalbedo; c++)
        if (!(albedo[c] >= 0.0 && albedo[c] < 1.0))
            return vsd_fail(VSD_ERR_INVALID, err, errlen,
                            "diffusion: albedo[%d] = %g must be in [0, 1) (at 1 nothing is absorbed and the "
                            "diffusion system has no unique solution)", c, albedo[c]);
    if (!(g > -1.0 && g < 1.0)) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: g = %g must be in (-1, 1)", g);
    return VSD_OK;
}

static vsd_status validate_jss(const double *j_ss, int n, char *err, size_t errlen)
{
    if (n > 0 && !j_ss) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: j_ss_order2 is NULL");
    for (long i = 0; i < (long)n * 12; i++)
        if (!isfinite(j_ss[i]))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: j_ss_order2[%ld] (RBF %ld, channel %ld, coefficient %ld) is not finite",
                            i, i / 12, i / 4 % 3, i % 4);
    return VSD_OK;
}

/* ---- geometry of one row ---------------------------------------------------------------- */

/* Terms of every RBF l at the centre x = c_h, all cut off at q = 9 together:
 * wb = w_l B_l, g{x,y,z} = w_l grad B_l, lap = w_l lap B_l; and their sums
 * D~, grad D~, lap D~ at c_h (which is why they are cut off consistently). */
typedef struct row_terms {
    double *wb, *gx, *gy, *gz, *lap;   /* n each; wb may point into W */
    double d, grad[3], lapd;
} row_terms;

static void rbf_row(const vsd_crm_rbfs *rbfs, int h, row_terms *t)
{
    const double x = rbfs->rbf[h].c[0], y = rbfs->rbf[h].c[1], z = rbfs->rbf[h].c[2];
    t->d = t->grad[0] = t->grad[1] = t->grad[2] = t->lapd = 0.0;
    for (int l = 0; l < rbfs->count; l++) {
        const vsd_crm_rbf *b = &rbfs->rbf[l];
        double dx = x - b->c[0], dy = y - b->c[1], dz = z - b->c[2];
        double r2 = (double)b->r * (double)b->r;
        double q = (dx * dx + dy * dy + dz * dz) / r2;
        double e = q < SUPPORT_Q ? (double)b->w * exp(-q) : 0.0;
        double s = -2.0 / r2 * e;           /* grad B = -2 (x - c) / r^2 B */
        t->wb[l] = e;
        t->gx[l] = s * dx;
        t->gy[l] = s * dy;
        t->gz[l] = s * dz;
        t->lap[l] = (4.0 * q - 6.0) / r2 * e;   /* lap B = (4 q - 6) / r^2 B */
        t->d += e;
        t->grad[0] += t->gx[l];
        t->grad[1] += t->gy[l];
        t->grad[2] += t->gz[l];
        t->lapd += t->lap[l];
    }
}

/* Row h of G, the diffusion part of A times sigma_tr:
 * G_hl = [D^2 lap_l - 3 D grad D . g_l + (3 |grad D|^2 - D lap D) wb_l] / (3 D^4). */
static void diffusion_row(int n, const row_terms *t, double *grow)
{
    const double d = t->d, g2 = t->grad[0] * t->grad[0] + t->grad[1] * t->grad[1] + t->grad[2] * t->grad[2];
    const double inv = 1.0 / (3.0 * d * d * d * d);
    const double cl = d * d * inv, cg = -3.0 * d * inv, cb = (3.0 * g2 - d * t->lapd) * inv;
    /* a weighted sum of five vectors: BLAS level 1 */
    cblas_dcopy(n, t->lap, 1, grow, 1);
    cblas_dscal(n, cl, grow, 1);
    cblas_daxpy(n, cg * t->grad[0], t->gx, 1, grow, 1);
    cblas_daxpy(n, cg * t->grad[1], t->gy, 1, grow, 1);
    cblas_daxpy(n, cg * t->grad[2], t->gz, 1, grow, 1);
    cblas_daxpy(n, cb, t->wb, 1, grow, 1);
}

/* Taylor coefficients of J_ss: t0[l*3+c], t1[(l*3+c)*3+k]. */
static void jss_taylor(int n, const double *j_ss, double *t0, double *t1)
{
    for (int i = 0; i < n * 3; i++) vsd_crm_sh2_to_taylor(j_ss + 4 * i, t0 + i, t1 + 3 * i);
}

/* b_h of channel c: -sigma sum_l { wb_l J0_l - (D g_l - wb_l grad D) . J1_l / (3 sigma_tr D^2) }. */
static double source_row(int n, const row_terms *t, const double *t0, const double *t1, int c,
                         double sigma, double sigma_tr)
{
    double j0 = cblas_ddot(n, t->wb, 1, t0 + c, 3);
    const double *g[3] = { t->gx, t->gy, t->gz };
    double div = 0.0;
    for (int k = 0; k < 3; k++)
        div += t->d * cblas_ddot(n, g[k], 1, t1 + 3 * c + k, 9) - t->grad[k] * cblas_ddot(n, t->wb, 1, t1 + 3 * c + k, 9);
    return -sigma * (j0 - div / (3.0 * sigma_tr * t->d * t->d));
}

/* ---- workspace ------------------------------------------------------------------------ */

typedef struct diff_work {
    int n;
    double *G, *W, *A;         /* n * n */
    double *gx, *gy, *gz, *lap;/* n: row scratch */
    double *t0, *t1;           /* n*3, n*9: J_ss Taylor */
    double *b;                 /* n*3: right-hand sides, all channels */
    double *u;                 /* n*3: L0 coefficients */
    double *bs, *xs, *rs, *cs; /* n*3, n*3, n, n: one system's scaled b, x, row and column scales */
} diff_work;

static void work_free(diff_work *w)
{
    free(w->G); free(w->W); free(w->A);
    free(w->gx); free(w->gy); free(w->gz); free(w->lap);
    free(w->t0); free(w->t1); free(w->b); free(w->u);
    free(w->bs); free(w->xs); free(w->rs); free(w->cs);
}

static vsd_status work_alloc(diff_work *w, int n, char *err, size_t errlen)
{
    size_t nn = (size_t)n * (size_t)n, sn = (size_t)n, d = sizeof(double);
    memset(w, 0, sizeof *w);
    w->n = n;
    w->G = malloc(nn * d); w->W = malloc(nn * d); w->A = malloc(nn * d);
    w->gx = malloc(sn * d); w->gy = malloc(sn * d); w->gz = malloc(sn * d); w->lap = malloc(sn * d);
    w->t0 = malloc(3 * sn * d); w->t1 = malloc(9 * sn * d); w->b = malloc(3 * sn * d); w->u = malloc(3 * sn * d);
    w->bs = malloc(3 * sn * d); w->xs = malloc(3 * sn * d); w->rs = malloc(sn * d); w->cs = malloc(sn * d);
    if (!w->G || !w->W || !w->A || !w->gx || !w->gy || !w->gz || !w->lap || !w->t0 || !w->t1 || !w->b ||
        !w->u || !w->bs || !w->xs || !w->rs || !w->cs) {
        work_free(w);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "diffusion: cannot allocate the %d x %d system", n, n);
    }
    return VSD_OK;
}

/* G, W (= w_l B_l(c_h)) and b for the channels whose
 * sigma_tr[c] > 0 (the others get b = 0). */
static void assemble_geometry(const vsd_crm_rbfs *rbfs, double sigma, const double sigma_tr[3], diff_work *w)
{
    const int n = w->n;
    for (int h = 0; h < n; h++) {
        row_terms t = { w->W + (size_t)h * n, w->gx, w->gy, w->gz, w->lap, 0, { 0, 0, 0 }, 0 };
        rbf_row(rbfs, h, &t);
        diffusion_row(n, &t, w->G + (size_t)h * n);
        for (int c = 0; c < 3; c++)
            w->b[3 * h + c] = sigma_tr[c] > 0.0 ? source_row(n, &t, w->t0, w->t1, c, sigma, sigma_tr[c]) : 0.0;
    }
}

/* A = G / sigma_tr - sigma_a W (level-1 BLAS over the n^2 entries). */
static void form_system(const diff_work *w, double sigma_tr, double sigma_a)
{
    const int nn = w->n * w->n;
    cblas_dcopy(nn, w->G, 1, w->A, 1);
    cblas_dscal(nn, 1.0 / sigma_tr, w->A, 1);
    cblas_daxpy(nn, -sigma_a, w->W, 1, w->A, 1);
}

/* Scale rows of A to unit norm (rs: the factors, applied to b later), then columns
 * (cs: x = cs * y). A square non-singular system keeps its solution. */
static void equilibrate(diff_work *w)
{
    const int n = w->n;
    for (int h = 0; h < n; h++) {
        double nr = cblas_dnrm2(n, w->A + (size_t)h * n, 1);
        w->rs[h] = nr > 0.0 ? 1.0 / nr : 1.0;
        cblas_dscal(n, w->rs[h], w->A + (size_t)h * n, 1);
    }
    for (int l = 0; l < n; l++) {
        double nc = cblas_dnrm2(n, w->A + l, n);
        w->cs[l] = nc > 0.0 ? 1.0 / nc : 1.0;
        cblas_dscal(n, w->cs[l], w->A + l, n);
    }
}

/* ---- public ------------------------------------------------------------------------------- */

vsd_status vsd_crm_diffusion_assemble(const vsd_crm_rbfs *rbfs, double sigma_per_voxel, double albedo, double g,
                                      const double *j_ss_order2, int channel, double *A, double *b,
                                      char *err, size_t errlen)
{
    vsd_status st;
    if ((st = validate_rbfs(rbfs, err, errlen)) != VSD_OK) return st;
    if ((st = validate_medium(sigma_per_voxel, &albedo, 1, g, err, errlen)) != VSD_OK) return st;
    if ((st = validate_jss(j_ss_order2, rbfs->count, err, errlen)) != VSD_OK) return st;
    if (channel < 0 || channel > 2) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: channel %d is not 0..2", channel);
    const int n = rbfs->count;
    if (n == 0) return VSD_OK;
    if (!A || !b) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: NULL %s", !A ? "A" : "b");
    diff_work w;
    if ((st = work_alloc(&w, n, err, errlen)) != VSD_OK) return st;
    double sigma_tr[3] = { 0, 0, 0 };
    sigma_tr[channel] = (1.0 - albedo * g) * sigma_per_voxel;
    jss_taylor(n, j_ss_order2, w.t0, w.t1);
    assemble_geometry(rbfs, sigma_per_voxel, sigma_tr, &w);
    form_system(&w, sigma_tr[channel], (1.0 - albedo) * sigma_per_voxel);
    memcpy(A, w.A, (size_t)n * n * sizeof(double));
    cblas_dcopy(n, w.b + channel, 3, b, 1);
    work_free(&w);
    return VSD_OK;
}

/* Solve the system of the channels in `members` (equal albedo), writing w->u. */
static vsd_status solve_group(diff_work *w, const int *members, int k, double sigma, double albedo,
                              double g, const double *warm, double tol, int max_iter, double *form_seconds,
                              int *iterations, double *residual, char *err, size_t errlen)
{
    const int n = w->n;
    double t0 = now_seconds();
    form_system(w, (1.0 - albedo * g) * sigma, (1.0 - albedo) * sigma);
    equilibrate(w);
    *form_seconds = now_seconds() - t0;
    for (int h = 0; h < n; h++)
        for (int j = 0; j < k; j++) {
            int c = members[j];
            w->bs[h * k + j] = w->rs[h] * w->b[3 * h + c];
            w->xs[h * k + j] = warm ? warm[3 * h + c] / w->cs[h] : 0.0;   /* y = x / cs */
        }
    vsd_status st = vsd_crm_cg_normal(n, w->A, w->bs, k, w->xs, tol, max_iter, iterations, residual, err, errlen);
    if (st != VSD_OK) return st;
    for (int h = 0; h < n; h++)
        for (int j = 0; j < k; j++) w->u[3 * h + members[j]] = w->cs[h] * w->xs[h * k + j];
    return VSD_OK;
}

/* L_m's SH at every centre from u and eq. 6', then J_ms = albedo (L_m * HG). */
static void multiple_source(const vsd_crm_rbfs *rbfs, double sigma, const double albedo[3], double g,
                            diff_work *w, double *j_ms)
{
    const int n = w->n;
    double zh[2];
    vsd_sh_hg_zh(2, g, zh);
    for (int h = 0; h < n; h++) {
        /* the row's terms again (wb lands in W's row, which it already holds) */
        row_terms t = { w->W + (size_t)h * n, w->gx, w->gy, w->gz, w->lap, 0, { 0, 0, 0 }, 0 };
        rbf_row(rbfs, h, &t);
        for (int c = 0; c < 3; c++) {
            double sigma_tr = (1.0 - albedo[c] * g) * sigma;
            double nsum = cblas_ddot(n, t.wb, 1, w->u + c, 3);
            double l0f = nsum / t.d;     /* eq. 12 at c_h */
            const double *gk[3] = { t.gx, t.gy, t.gz };
            double l1[3], sh[4];
            for (int k = 0; k < 3; k++) {
                double gradn = cblas_ddot(n, gk[k], 1, w->u + c, 3);
                double gradl0 = (gradn - l0f * t.grad[k]) / t.d;
                double j1 = cblas_ddot(n, t.wb, 1, w->t1 + 3 * c + k, 9) / t.d;   /* eq. 7 */
                l1[k] = sigma / sigma_tr * j1 - gradl0 / (sigma_tr * t.d);        /* eq. 6' */
            }
            vsd_crm_taylor_to_sh2(w->u[3 * h + c], l1, sh);
            vsd_sh_convolve_zh(2, sh, zh, sh);
            for (int i = 0; i < 4; i++) j_ms[(3 * h + c) * 4 + i] = albedo[c] * sh[i];
        }
    }
}

vsd_status vsd_crm_diffusion_solve_ex(const vsd_crm_rbfs *rbfs, double sigma_per_voxel, const double albedo[3],
                                      double g, const double *j_ss_order2, double *l_m0, double *j_ms_order2,
                                      double tol, int max_iter, vsd_crm_diffusion_stats *stats,
                                      char *err, size_t errlen)
{
    const double t_start = now_seconds();
    vsd_crm_diffusion_stats s;
    memset(&s, 0, sizeof s);
    if (stats) *stats = s;
    vsd_status st;
    if ((st = validate_rbfs(rbfs, err, errlen)) != VSD_OK) return st;
    if ((st = validate_medium(sigma_per_voxel, albedo, 3, g, err, errlen)) != VSD_OK) return st;
    if ((st = validate_jss(j_ss_order2, rbfs->count, err, errlen)) != VSD_OK) return st;
    if (!(tol >= 0.0) || !isfinite(tol)) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: tol = %g must be finite and >= 0", tol);
    if (max_iter < 0) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: max_iter = %d is negative", max_iter);
    const int n = rbfs->count;
    if (n > 0 && !j_ms_order2) return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: j_ms_order2 is NULL");
    if (l_m0)
        for (long i = 0; i < 3L * n; i++)
            if (!isfinite(l_m0[i]))
                return vsd_fail(VSD_ERR_INVALID, err, errlen, "diffusion: warm start l_m0[%ld] is not finite", i);
    if (n == 0) {
        if (stats) { s.seconds = now_seconds() - t_start; *stats = s; }
        return VSD_OK;
    }

    diff_work w;
    if ((st = work_alloc(&w, n, err, errlen)) != VSD_OK) return st;
    double sigma_tr[3];
    for (int c = 0; c < 3; c++) sigma_tr[c] = (1.0 - albedo[c] * g) * sigma_per_voxel;
    double t_asm = now_seconds();
    jss_taylor(n, j_ss_order2, w.t0, w.t1);
    assemble_geometry(rbfs, sigma_per_voxel, sigma_tr, &w);
    s.assembly_seconds = now_seconds() - t_asm;

    int done[3] = { 0, 0, 0 };
    for (int c = 0; c < 3 && st == VSD_OK; c++) {
        if (done[c]) continue;
        int members[3], k = 0, it = 0;
        double res = 0.0;
        for (int c2 = c; c2 < 3; c2++)
            if (!done[c2] && albedo[c2] == albedo[c]) { members[k++] = c2; done[c2] = 1; }
        double t_form = 0.0;
        st = solve_group(&w, members, k, sigma_per_voxel, albedo[c], g, l_m0, tol, max_iter, &t_form,
                         &it, &res, err, errlen);
        s.assembly_seconds += t_form;
        s.systems++;
        for (int j = 0; j < k; j++) s.channel_iterations[members[j]] = it;
        if (it > s.iterations) s.iterations = it;
        if (res > s.residual) s.residual = res;
    }
    if (st == VSD_OK) {
        multiple_source(rbfs, sigma_per_voxel, albedo, g, &w, j_ms_order2);
        if (l_m0) memcpy(l_m0, w.u, 3 * (size_t)n * sizeof(double));
    }
    work_free(&w);
    s.seconds = now_seconds() - t_start;
    if (stats) *stats = s;
    return st;
}

vsd_status vsd_crm_diffusion_solve(const vsd_crm_rbfs *rbfs, double sigma_per_voxel, const double albedo[3],
                                   double g, const double *j_ss_order2, double *l_m0, double *j_ms_order2,
                                   vsd_crm_diffusion_stats *stats, char *err, size_t errlen)
{
    return vsd_crm_diffusion_solve_ex(rbfs, sigma_per_voxel, albedo, g, j_ss_order2, l_m0, j_ms_order2,
                                      VSD_CRM_DIFFUSION_TOL, VSD_CRM_DIFFUSION_MAX_ITER, stats, err, errlen);
}
