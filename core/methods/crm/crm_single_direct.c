#include "crm_single_direct.h"
#include "vsd/sh.h"
#include <math.h>
#include "device/cpu/cpu_tiles.h"
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846

typedef struct direct_job {
    const double *points;
    vsd_crm_depth_fn depth;
    const void *user;
    const double *albedo, *hg;
    int order, n2, m;
    const double *dirs;       /* [m * 3] */
    const double *basis;      /* [m * n2] */
    const double *radiance;   /* [m * 3] L_in per direction (the SH reconstruction) */
    double *j_ss;
} direct_job;

/* Optical depth (unscaled) of RBF b along the ray from p toward unit w, to infinity. */
static double line_depth(const vsd_crm_rbf *b, const double p[3], const double w[3])
{
    double v[3] = {b->c[0] - p[0], b->c[1] - p[1], b->c[2] - p[2]};
    double tc = v[0] * w[0] + v[1] * w[1] + v[2] * w[2], r = b->r;
    double d2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2] - tc * tc, cut = 3.0 * r;
    if (d2 > cut * cut || tc < -cut) return 0.0;
    return b->w * exp(-d2 / (r * r)) * r * 0.8862269254527580 * (1.0 + erf(tc / r));
}

typedef struct rbf_depth {
    const vsd_crm_rbfs *rbfs;
    double sigma;         /* sigma_t per unit density, world units */
    double w2i[9];        /* world direction -> index displacement per world unit */
} rbf_depth;

/* The RBFs are isotropic in index space: integrate there along the direction the volume's
 * transform gives w, and convert the index length to world length (1/|v| per index unit). */
static double rbf_optical_depth(const void *user, const double p[3], const double w[3])
{
    const rbf_depth *r = user;
    double v[3], len, od = 0.0;
    int h, a;
    for (a = 0; a < 3; a++) v[a] = r->w2i[3 * a] * w[0] + r->w2i[3 * a + 1] * w[1] + r->w2i[3 * a + 2] * w[2];
    len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0.0)) return 0.0;
    for (a = 0; a < 3; a++) v[a] /= len;
    for (h = 0; h < r->rbfs->count; h++) od += line_depth(r->rbfs->rbf + h, p, v);
    return r->sigma * od / len;
}

/* Points [l0, l1): the CPU backend's thread pool hands out ranges as the x of a count x 1
 * "image" (vsd_cpu_run_tiles). */
static void run(void *arg, int l0, int y0, int l1, int y1)
{
    const direct_job *j = arg;
    const int n2 = j->n2;
    double f[3][16], tau;
    int l, d, c, i, band, m;
    (void)y0;
    (void)y1;
    for (l = l0; l < l1; l++) {
        const double *p = j->points + 3 * (size_t)l;
        double *out = j->j_ss + (size_t)l * 3 * n2;
        memset(f, 0, sizeof f);
        for (d = 0; d < j->m; d++) {
            const double *w = j->dirs + 3 * (size_t)d, *y = j->basis + (size_t)d * n2;
            tau = exp(-j->depth(j->user, p, w)) * 4.0 * PI_D / (double)j->m;
            for (c = 0; c < 3; c++) {
                double v = j->radiance[3 * (size_t)d + c] * tau;
                for (i = 0; i < n2; i++) f[c][i] += v * y[i];
            }
        }
        for (c = 0; c < 3; c++) {
            vsd_sh_convolve_zh(j->order, f[c], j->hg, f[c]);
            /* as vsd_crm_single_scatter: J_ss(w_o) is the convolution at -w_o */
            for (band = 0; band < j->order; band++)
                for (m = -band; m <= band; m++) {
                    int idx = band * (band + 1) + m;
                    out[(size_t)c * n2 + idx] = ((band & 1) ? -j->albedo[c] : j->albedo[c]) * f[c][idx];
                }
        }
    }
}

vsd_status vsd_crm_single_scatter_direct(const vsd_crm_rbfs *rbfs, double sigma, const double w2i[9],
                                         const double albedo[3], double g, int order, const double *env_sh,
                                         int directions, int threads, double *j_ss, char *err, size_t errlen)
{
    rbf_depth depth;
    double *points;
    vsd_status st;
    int l;
    if (!(sigma >= 0.0))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm direct single scattering: sigma %g is negative", sigma);
    depth.rbfs = rbfs;
    depth.sigma = sigma;
    memcpy(depth.w2i, w2i, sizeof depth.w2i);
    if (rbfs->count == 0) return VSD_OK;
    if (!(points = malloc(sizeof(double) * 3 * (size_t)rbfs->count)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm direct single scattering: no memory for %d centres", rbfs->count);
    for (l = 0; l < rbfs->count; l++) {
        points[3 * l] = rbfs->rbf[l].c[0];
        points[3 * l + 1] = rbfs->rbf[l].c[1];
        points[3 * l + 2] = rbfs->rbf[l].c[2];
    }
    st = vsd_crm_single_scatter_points(rbfs->count, points, rbf_optical_depth, &depth, albedo, g, order, env_sh,
                                       directions, threads, j_ss, err, errlen);
    free(points);
    return st;
}

vsd_status vsd_crm_single_scatter_points(int count, const double *points, vsd_crm_depth_fn optical_depth,
                                         const void *user, const double albedo[3], double g, int order,
                                         const double *env_sh, int directions, int threads, double *j_ss,
                                         char *err, size_t errlen)
{
    long nside = vsd_sh_healpix_nside(directions);
    int n2 = order * order, m = directions, d, c, i;
    double *dirs = NULL, *basis = NULL, *radiance = NULL, hg[16];
    direct_job job;
    vsd_tile_job tiles;
    vsd_status st;
    if (order < 1 || order > 4 || !nside || !(fabs(g) < 1.0))
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "crm single scattering: order %d (1..4), %d directions (12 nside^2) or g %g out of range", order,
                        directions, g);
    if (count == 0) return VSD_OK;
    dirs = malloc(sizeof(double) * 3 * (size_t)m);
    basis = malloc(sizeof(double) * (size_t)n2 * m);
    radiance = malloc(sizeof(double) * 3 * (size_t)m);
    if (!dirs || !basis || !radiance) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm direct single scattering: no memory for %d directions", m);
        goto done;
    }
    if ((st = vsd_sh_healpix_dirs(nside, dirs, err, errlen))) goto done;
    for (d = 0; d < m; d++) {
        vsd_sh_eval(order, dirs + 3 * (size_t)d, basis + (size_t)d * n2);
        for (c = 0; c < 3; c++) {
            double v = 0.0;
            for (i = 0; i < n2; i++) v += env_sh[c * n2 + i] * basis[(size_t)d * n2 + i];
            /* not clamped: the SH reconstruction rings below zero where the map is dark, and
             * clamping there would add light (+10% VolumeDir on smoke128's forest map) */
            radiance[3 * (size_t)d + c] = v;
        }
    }
    vsd_sh_hg_zh(order, g, hg);
    job.points = points;
    job.depth = optical_depth;
    job.user = user;
    job.albedo = albedo;
    job.hg = hg;
    job.order = order;
    job.n2 = n2;
    job.m = m;
    job.dirs = dirs;
    job.basis = basis;
    job.radiance = radiance;
    job.j_ss = j_ss;
    memset(&tiles, 0, sizeof tiles);
    tiles.width = count;
    tiles.height = 1;
    tiles.threads = threads;
    tiles.fn = run;
    tiles.user = &job;
    tiles.stage = "crm single scattering";
    st = vsd_cpu_run_tiles(&tiles);
done:
    free(dirs);
    free(basis);
    free(radiance);
    return st;
}
