/* crm_cg.c — CGLS: conjugate gradients on A^T A x = A^T b without forming A^T A.
 *
 * Per column c (right-hand side), from x0:
 *   r = b - A x,  s = A^T r,  p = s,  gamma = s.s
 *   repeat: q = A p;  alpha = gamma / q.q;  x += alpha p;  r -= alpha q;
 *           s = A^T r;  gamma' = s.s;  p = s + (gamma'/gamma) p
 * (q.q = p^T A^T A p, so these are exactly CG's iterates on the normal equations.)
 * All columns share the two dgemm per iteration; a converged column is frozen. */
#include "crm_cg.h"
#include <cblas.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct cg_work {
    double *r, *s, *p, *q;   /* n * k each */
    double *gamma, *bnorm;   /* k each: s.s and ||b|| per column */
    double anorm;            /* ||A||_F */
    unsigned char *active;   /* k: column still iterating */
} cg_work;

static void work_free(cg_work *w)
{
    free(w->r); free(w->s); free(w->p); free(w->q);
    free(w->gamma); free(w->bnorm); free(w->active);
}

static vsd_status work_alloc(cg_work *w, size_t nk, int k, char *err, size_t errlen)
{
    memset(w, 0, sizeof *w);
    w->r = malloc(nk * sizeof(double));
    w->s = malloc(nk * sizeof(double));
    w->p = malloc(nk * sizeof(double));
    w->q = malloc(nk * sizeof(double));
    w->gamma = malloc((size_t)k * sizeof(double));
    w->bnorm = malloc((size_t)k * sizeof(double));
    w->active = malloc((size_t)k);
    if (!w->r || !w->s || !w->p || !w->q || !w->gamma || !w->bnorm || !w->active) {
        work_free(w);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "cg: cannot allocate %zu work doubles", 4 * nk + 2 * (size_t)k);
    }
    return VSD_OK;
}

/* Index of the first non-finite entry of v[0 .. count), or -1. */
static long first_nonfinite(const double *v, size_t count)
{
    for (size_t i = 0; i < count; i++)
        if (!isfinite(v[i])) return (long)i;
    return -1;
}

static vsd_status validate(int n, const double *A, const double *b, int k, const double *x, double tol,
                           int max_iter, char *err, size_t errlen)
{
    if (n < 0) return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: n = %d is negative", n);
    if (k < 1) return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: k = %d right-hand sides, need >= 1", k);
    if (!(tol >= 0.0) || !isfinite(tol))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: tol = %g must be finite and >= 0", tol);
    if (max_iter < 0) return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: max_iter = %d is negative", max_iter);
    if (n == 0) return VSD_OK;
    if (!A || !b || !x) return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: NULL %s", !A ? "A" : !b ? "b" : "x");
    /* n*n and n*k must fit in size_t and in BLAS's int counts (n*n is one in ||A||_F). */
    if ((size_t)n > SIZE_MAX / sizeof(double) / (size_t)n || (size_t)n > (size_t)INT32_MAX / (size_t)n ||
        (size_t)n > (size_t)INT32_MAX / (size_t)k)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "cg: n = %d, k = %d is too large", n, k);
    long i = first_nonfinite(A, (size_t)n * (size_t)n);
    if (i >= 0) return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: A[%ld][%ld] is not finite", i / n, i % n);
    i = first_nonfinite(b, (size_t)n * (size_t)k);
    if (i >= 0) return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: b[%ld][%ld] is not finite", i / k, i % k);
    i = first_nonfinite(x, (size_t)n * (size_t)k);
    if (i >= 0) return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: warm start x[%ld][%ld] is not finite", i / k, i % k);
    return VSD_OK;
}

/* r = b - A x (all columns). */
static void residual_of(int n, int k, const double *A, const double *b, const double *x, double *r)
{
    cblas_dcopy(n * k, b, 1, r, 1);
    cblas_dgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, n, k, n, -1.0, A, n, x, k, 1.0, r, k);
}

/* out = A^T v (all columns). */
static void normal_of(int n, int k, const double *A, const double *v, double *out)
{
    cblas_dgemm(CblasRowMajor, CblasTrans, CblasNoTrans, n, k, n, 1.0, A, n, v, k, 0.0, out, k);
}

static double col_norm2(int n, int k, const double *v, int c) { return cblas_ddot(n, v + c, k, v + c, k); }

/* The stopping measure of column c (LSQR's two tests, Paige & Saunders 1982):
 *   ||r|| / ||b||                      small when A x = b is solved (consistent systems),
 *   ||A^T r|| / (||A||_F ||r||)        small when r is orthogonal to A's range (least squares),
 * whichever is smaller. Both bound the error of x by cond(A) times the measure, while the
 * plain normal-equation residual ||A^T r|| / ||A^T b|| would only bound it by cond(A)^2
 * times it. ss = ||A^T r||^2. */
static double column_measure(int n, int k, const cg_work *w, int c, double ss)
{
    if (w->bnorm[c] <= 0.0) return 0.0;
    double rr = sqrt(col_norm2(n, k, w->r, c));
    double consistent = rr / w->bnorm[c];
    double ls = rr > 0.0 && w->anorm > 0.0 ? sqrt(ss) / (w->anorm * rr) : 0.0;
    return fmin(consistent, ls);
}

/* The largest measure over the columns from the current x (r and s recomputed). */
static double true_residual(int n, int k, const double *A, const double *b, const double *x, cg_work *w)
{
    double worst = 0.0;
    residual_of(n, k, A, b, x, w->r);
    normal_of(n, k, A, w->r, w->s);
    for (int c = 0; c < k; c++) worst = fmax(worst, column_measure(n, k, w, c, col_norm2(n, k, w->s, c)));
    return worst;
}

/* Set up the columns: norms, zero columns, first residuals and directions.
 * Returns the number of active columns. */
static int start_columns(int n, int k, const double *A, const double *b, double *x, double tol, cg_work *w)
{
    int active = 0;
    w->anorm = cblas_dnrm2(n * n, A, 1);
    for (int c = 0; c < k; c++) {
        w->bnorm[c] = sqrt(col_norm2(n, k, b, c));
        if (w->bnorm[c] <= 0.0) cblas_dscal(n, 0.0, x + c, k);   /* b = 0: x = 0 is the answer */
    }
    residual_of(n, k, A, b, x, w->r);
    normal_of(n, k, A, w->r, w->s);
    cblas_dcopy(n * k, w->s, 1, w->p, 1);
    for (int c = 0; c < k; c++) {
        w->gamma[c] = col_norm2(n, k, w->s, c);
        w->active[c] = column_measure(n, k, w, c, w->gamma[c]) > tol;
        active += w->active[c];
    }
    return active;
}

/* One CGLS step for every active column; returns active columns left, or -1 on a
 * non-finite iterate. `iter` is the 1-based number of this iteration. */
static int step(int n, int k, const double *A, const double *b, double *x, double tol, int iter, cg_work *w)
{
    int active = 0;
    cblas_dgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, n, k, n, 1.0, A, n, w->p, k, 0.0, w->q, k);
    for (int c = 0; c < k; c++) {
        if (!w->active[c]) continue;
        double qq = col_norm2(n, k, w->q, c);
        if (!isfinite(qq)) return -1;
        if (qq <= 0.0) { w->active[c] = 0; continue; }   /* A p = 0: nothing left to gain */
        double alpha = w->gamma[c] / qq;
        cblas_daxpy(n, alpha, w->p + c, k, x + c, k);
        cblas_daxpy(n, -alpha, w->q + c, k, w->r + c, k);
    }
    if (iter % VSD_CRM_CG_RESTART_RESIDUAL == 0) residual_of(n, k, A, b, x, w->r);
    normal_of(n, k, A, w->r, w->s);
    for (int c = 0; c < k; c++) {
        if (!w->active[c]) continue;
        double gnew = col_norm2(n, k, w->s, c);
        if (!isfinite(gnew)) return -1;
        if (column_measure(n, k, w, c, gnew) <= tol) { w->active[c] = 0; continue; }
        double beta = gnew / w->gamma[c];
        w->gamma[c] = gnew;
        cblas_dscal(n, beta, w->p + c, k);
        cblas_daxpy(n, 1.0, w->s + c, k, w->p + c, k);
        active++;
    }
    return active;
}

vsd_status vsd_crm_cg_normal(int n, const double *A, const double *b, int k, double *x, double tol,
                             int max_iter, int *iterations, double *residual, char *err, size_t errlen)
{
    if (iterations) *iterations = 0;
    if (residual) *residual = 0.0;
    vsd_status st = validate(n, A, b, k, x, tol, max_iter, err, errlen);
    if (st != VSD_OK || n == 0) return st;

    cg_work w;
    st = work_alloc(&w, (size_t)n * (size_t)k, k, err, errlen);
    if (st != VSD_OK) return st;
    int active = start_columns(n, k, A, b, x, tol, &w);
    int it = 0;
    while (active > 0 && it < max_iter) {
        active = step(n, k, A, b, x, tol, ++it, &w);
        if (active < 0) {
            work_free(&w);
            return vsd_fail(VSD_ERR_INVALID, err, errlen,
                            "cg: non-finite iterate at iteration %d (the system is too badly scaled)", it);
        }
    }
    double res = true_residual(n, k, A, b, x, &w);
    work_free(&w);
    if (first_nonfinite(x, (size_t)n * (size_t)k) >= 0 || !isfinite(res))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "cg: non-finite solution after %d iterations", it);
    if (iterations) *iterations = it;
    if (residual) *residual = res;
    return VSD_OK;
}
