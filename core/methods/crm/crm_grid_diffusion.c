#include "crm_grid_diffusion.h"
#include "crm_kernel.h"
#include "src/common/clock.h"
#include <cblas.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846

/* The operator of one channel: per medium node its diagonal and its six face couplings
 * (0 where the neighbour is empty or outside: those faces are in the diagonal). */
typedef struct grid_system {
    int32_t res[3];
    size_t n;               /* nodes */
    int32_t *index;         /* node -> unknown, -1 for empty nodes */
    size_t unknowns;
    int32_t *node;          /* unknown -> node */
    double *diag;           /* [unknowns] */
    double *off;            /* [unknowns * 6]: -x, +x, -y, +y, -z, +z couplings (>= 0) */
    int32_t *nbr;           /* [unknowns * 6]: neighbour unknown or -1 */
} grid_system;

static void system_free(grid_system *s)
{
    free(s->index);
    free(s->node);
    free(s->diag);
    free(s->off);
    free(s->nbr);
}

static double kappa_of(double sigma_t, double albedo, double g)
{
    return 1.0 / (3.0 * sigma_t * (1.0 - albedo * g));
}

static vsd_status system_build(const int32_t res[3], double h, const float *sigma_t, double albedo, double g,
                               grid_system *s, char *err, size_t errlen)
{
    size_t i, u = 0;
    float smax = 0.0f;
    int a;
    memset(s, 0, sizeof *s);
    for (a = 0; a < 3; a++) s->res[a] = res[a];
    s->n = (size_t)res[0] * res[1] * res[2];
    for (i = 0; i < s->n; i++) smax = sigma_t[i] > smax ? sigma_t[i] : smax;
    s->index = malloc(s->n * sizeof *s->index);
    if (!s->index) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm diffusion: no memory for %zu nodes", s->n);
    for (i = 0; i < s->n; i++) s->index[i] = smax > 0.0f && sigma_t[i] > VSD_CRM_GRID_EMPTY * smax ? (int32_t)u++ : -1;
    s->unknowns = u;
    s->node = malloc((u ? u : 1) * sizeof *s->node);
    s->diag = malloc((u ? u : 1) * sizeof *s->diag);
    s->off = malloc((u ? u : 1) * 6 * sizeof *s->off);
    s->nbr = malloc((u ? u : 1) * 6 * sizeof *s->nbr);
    if (!s->node || !s->diag || !s->off || !s->nbr) {
        system_free(s);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm diffusion: no memory for %zu unknowns", u);
    }
    for (i = 0; i < s->n; i++) {
        int32_t k = (int32_t)(i / ((size_t)res[0] * res[1])), j = (int32_t)((i / res[0]) % res[1]), x = (int32_t)(i % res[0]);
        int32_t c[3] = {x, j, k}, q = s->index[i], f;
        double ki, sa;
        if (q < 0) continue;
        s->node[q] = (int32_t)i;
        ki = kappa_of(sigma_t[i], albedo, g);
        sa = (1.0 - albedo) * sigma_t[i];
        s->diag[q] = sa;
        for (f = 0; f < 6; f++) {
            int32_t ax = f / 2, dir = (f & 1) ? 1 : -1, cc[3] = {c[0], c[1], c[2]}, nq = -1;
            double coupling;
            cc[ax] += dir;
            if (cc[ax] >= 0 && cc[ax] < res[ax]) nq = s->index[((size_t)cc[2] * res[1] + cc[1]) * res[0] + cc[0]];
            if (nq >= 0) {
                double kj = kappa_of(sigma_t[((size_t)cc[2] * res[1] + cc[1]) * res[0] + cc[0]], albedo, g);
                coupling = 2.0 * ki * kj / (ki + kj) / (h * h);
                s->diag[q] += coupling;
            } else {
                /* Marshak: flux to zero fluence 2 kappa beyond the face */
                s->diag[q] += ki / (h * (0.5 * h + 2.0 * ki));
                coupling = 0.0;
            }
            s->off[(size_t)q * 6 + f] = coupling;
            s->nbr[(size_t)q * 6 + f] = nq;
        }
    }
    return VSD_OK;
}

static void apply(const grid_system *s, const double *x, double *y)
{
    size_t q;
    for (q = 0; q < s->unknowns; q++) {
        double v = s->diag[q] * x[q];
        int f;
        for (f = 0; f < 6; f++) {
            int32_t nq = s->nbr[q * 6 + f];
            if (nq >= 0) v -= s->off[q * 6 + f] * x[nq];
        }
        y[q] = v;
    }
}

/* Jacobi-preconditioned CG on A x = b from the given x; returns iterations. */
static int solve(const grid_system *s, const double *b, double *x, double tol, int max_iter, double *rel, double *work)
{
    size_t n = s->unknowns, q;
    double *r = work, *z = work + n, *p = work + 2 * n, *ap = work + 3 * n;
    double bnorm = cblas_dnrm2((int)n, b, 1), rz, rnorm;
    int it = 0;
    if (!(bnorm > 0.0)) {
        memset(x, 0, n * sizeof *x);
        *rel = 0.0;
        return 0;
    }
    apply(s, x, r);
    for (q = 0; q < n; q++) r[q] = b[q] - r[q];
    for (q = 0; q < n; q++) z[q] = r[q] / s->diag[q];
    memcpy(p, z, n * sizeof *p);
    rz = cblas_ddot((int)n, r, 1, z, 1);
    rnorm = cblas_dnrm2((int)n, r, 1);
    while (rnorm > tol * bnorm && it < max_iter) {
        double alpha, rz2;
        apply(s, p, ap);
        alpha = rz / cblas_ddot((int)n, p, 1, ap, 1);
        cblas_daxpy((int)n, alpha, p, 1, x, 1);
        cblas_daxpy((int)n, -alpha, ap, 1, r, 1);
        for (q = 0; q < n; q++) z[q] = r[q] / s->diag[q];
        rz2 = cblas_ddot((int)n, r, 1, z, 1);
        /* p = z + (rz2 / rz) p */
        cblas_dscal((int)n, rz2 / rz, p, 1);
        cblas_daxpy((int)n, 1.0, z, 1, p, 1);
        rz = rz2;
        rnorm = cblas_dnrm2((int)n, r, 1);
        it++;
    }
    *rel = rnorm / bnorm;
    return it;
}

/* J_ms's order-2 SH at every node from the fluence of channel ch (see the header). */
static void write_ms(const grid_system *s, const float *sigma_t, double albedo, double g, double h, const double *x,
                     float *nodes, uint8_t *valid, int ch)
{
    const double c1 = sqrt(3.0 / (4.0 * PI_D)), inv2sqrtpi = 1.0 / (2.0 * sqrt(PI_D));
    size_t i;
    for (i = 0; i < s->n; i++) {
        float *ms = nodes + i * CRM_NODE_FLOATS + 3 * CRM_SS_N + ch * CRM_MS_N;
        int32_t q = s->index[i], ax, c[3];
        double phi, grad[3], kappa;
        if (q < 0) {
            ms[0] = ms[1] = ms[2] = ms[3] = 0.0f;
            valid[i] &= (uint8_t)~CRM_NODE_MULTIPLE;
            continue;
        }
        valid[i] |= CRM_NODE_MULTIPLE;
        c[0] = (int32_t)(i % s->res[0]);
        c[1] = (int32_t)((i / s->res[0]) % s->res[1]);
        c[2] = (int32_t)(i / ((size_t)s->res[0] * s->res[1]));
        phi = x[q];
        for (ax = 0; ax < 3; ax++) {
            int32_t lo = s->nbr[(size_t)q * 6 + 2 * ax], hi = s->nbr[(size_t)q * 6 + 2 * ax + 1];
            grad[ax] = ((hi >= 0 ? x[hi] : 0.0) - (lo >= 0 ? x[lo] : 0.0)) / (2.0 * h);
        }
        (void)c;
        kappa = kappa_of(sigma_t[i], albedo, g);
        {
            /* flux limiter: where the medium is thin, kappa grad phi overshoots (diffusion
             * assumes many collisions); |F| <= phi / 3 keeps phi/4pi + 3/(4pi) F.w >= 0 */
            double f = kappa * sqrt(grad[0] * grad[0] + grad[1] * grad[1] + grad[2] * grad[2]), lim = fmax(phi, 0.0) / 3.0;
            if (f > lim) kappa *= lim / f;
        }
        /* F = -kappa grad phi; SH l=1 of F.w: (-c1 F_y, c1 F_z, -c1 F_x) (vsd/sh.h's real basis) */
        ms[0] = (float)(albedo * phi * inv2sqrtpi);
        ms[1] = (float)(albedo * g * -c1 * (-kappa * grad[1]));
        ms[2] = (float)(albedo * g * c1 * (-kappa * grad[2]));
        ms[3] = (float)(albedo * g * -c1 * (-kappa * grad[0]));
    }
}

vsd_status vsd_crm_grid_diffusion(const int32_t res[3], double h, const float *sigma_t, const double albedo[3],
                                  double g, float *nodes, uint8_t *valid, double *phi, double tol, int max_iter,
                                  vsd_crm_grid_diffusion_stats *stats, char *err, size_t errlen)
{
    double t0 = vsd_clock_seconds(), *b = NULL, *x = NULL, *work = NULL;
    int ch, grey = albedo[0] == albedo[1] && albedo[1] == albedo[2];
    vsd_status st = VSD_OK;
    memset(stats, 0, sizeof *stats);
    if (!(h > 0.0) || !(fabs(g) < 1.0) || max_iter < 0 || !(tol >= 0.0))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm diffusion: spacing %g, g %g, iterations %d or tol %g out of range",
                        h, g, max_iter, tol);
    for (ch = 0; ch < 3; ch++)
        if (!(albedo[ch] >= 0.0 && albedo[ch] <= 1.0))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm diffusion: albedo[%d] = %g is outside [0, 1]", ch, albedo[ch]);
    stats->systems = grey ? 1 : 3;
    for (ch = 0; ch < 3 && !st; ch++) {
        grid_system s;
        size_t q;
        int it;
        double rel;
        if (grey && ch > 0) {
            /* the same operator and source: copy channel 0's answer */
            size_t i;
            for (i = 0; i < (size_t)res[0] * res[1] * res[2]; i++) {
                float *ms = nodes + i * CRM_NODE_FLOATS + 3 * CRM_SS_N;
                memcpy(ms + ch * CRM_MS_N, ms, CRM_MS_N * sizeof *ms);
                phi[3 * i + ch] = phi[3 * i];
            }
            continue;
        }
        if ((st = system_build(res, h, sigma_t, albedo[ch], g, &s, err, errlen))) break;
        b = malloc((s.unknowns ? s.unknowns : 1) * sizeof *b);
        x = malloc((s.unknowns ? s.unknowns : 1) * sizeof *x);
        work = malloc((s.unknowns ? s.unknowns : 1) * 4 * sizeof *work);
        if (!b || !x || !work) {
            st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm diffusion: no memory for %zu unknowns", s.unknowns);
        } else {
            for (q = 0; q < s.unknowns; q++) {
                size_t i = (size_t)s.node[q];
                /* sigma_s phi_ri = sigma_t 2 sqrt(pi) J_ss,00 (J_ss carries the albedo) */
                double jss00 = (valid[i] & CRM_NODE_SINGLE) ? nodes[i * CRM_NODE_FLOATS + ch * CRM_SS_N] : 0.0;
                b[q] = sigma_t[i] * 2.0 * sqrt(PI_D) * jss00;
                x[q] = phi[3 * i + ch];
            }
            it = solve(&s, b, x, tol, max_iter, &rel, work);
            if (it > stats->iterations) stats->iterations = it;
            if (rel > stats->residual) stats->residual = rel;
            write_ms(&s, sigma_t, albedo[ch], g, h, x, nodes, valid, ch);
            for (q = 0; q < s.n; q++) phi[3 * q + ch] = s.index[q] >= 0 ? x[s.index[q]] : 0.0;
        }
        free(b);
        free(x);
        free(work);
        b = x = work = NULL;
        system_free(&s);
    }
    stats->seconds = vsd_clock_seconds() - t0;
    return st;
}
