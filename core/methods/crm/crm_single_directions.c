#include "crm_single_directions.h"
#include "vsd/sh.h"
#include <math.h>
#include "device/cpu/cpu_tiles.h"
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846

/* The light side of single scattering, shared by every point: per direction d, the
 * order-n SH basis at d times the environment's radiance L_in(d) times the quadrature weight
 * 4pi/M, RGB-major ([d][c * n2 + i]), so a point's projection is one weighted row sum. */
typedef struct sky_weights {
    int order, n2, m;
    float *w;                 /* [m * 3 * n2] */
    double hg[16];            /* the phase's zonal coefficients */
} sky_weights;

typedef struct depth_job {
    const double *points;
    vsd_crm_depth_fn depth;
    const void *user;
    const double *dirs;       /* [m * 3] */
    int m;
    float *od;
} depth_job;

typedef struct project_job {
    const sky_weights *sky;
    const float *od;
    float scale;
    const double *albedo;
    double *j_ss;
} project_job;

/* Points [l0, l1): the CPU backend's thread pool hands out ranges as the x of a count x 1
 * "image" (vsd_cpu_run_tiles). */
static void run_depths(void *arg, int l0, int y0, int l1, int y1)
{
    const depth_job *j = arg;
    int l, d;
    (void)y0;
    (void)y1;
    for (l = l0; l < l1; l++)
        for (d = 0; d < j->m; d++)
            j->od[(size_t)l * j->m + d] = (float)j->depth(j->user, j->points + 3 * (size_t)l, j->dirs + 3 * (size_t)d);
}

static void run_project(void *arg, int l0, int y0, int l1, int y1)
{
    const project_job *j = arg;
    const sky_weights *sky = j->sky;
    const int n2 = sky->n2, row = 3 * n2;
    float f[3 * 16];
    double g[16];
    int l, d, c, i, band, m;
    (void)y0;
    (void)y1;
    for (l = l0; l < l1; l++) {
        const float *od = j->od + (size_t)l * sky->m;
        double *out = j->j_ss + (size_t)l * row;
        memset(f, 0, sizeof f);
        for (d = 0; d < sky->m; d++) {
            const float *w = sky->w + (size_t)d * row;
            float tau = expf(-j->scale * od[d]);
            /* the hot loop: 48 contiguous floats per direction, vectorised */
            for (i = 0; i < row; i++) f[i] += tau * w[i];
        }
        for (c = 0; c < 3; c++) {
            for (i = 0; i < n2; i++) g[i] = f[c * n2 + i];
            vsd_sh_convolve_zh(sky->order, g, sky->hg, g);
            /* as vsd_crm_single_scatter: J_ss(w_o) is the convolution at -w_o */
            for (band = 0; band < sky->order; band++)
                for (m = -band; m <= band; m++) {
                    int idx = band * (band + 1) + m;
                    out[(size_t)c * n2 + idx] = ((band & 1) ? -j->albedo[c] : j->albedo[c]) * g[idx];
                }
        }
    }
}

static vsd_status check_sky(int order, int directions, double g, char *err, size_t errlen)
{
    if (order < 1 || order > CRM_PHASE_BANDS || !vsd_sh_healpix_nside(directions) || !(fabs(g) < 1.0))
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "crm single scattering: order %d (1..4), %d directions (12 nside^2) or g %g out of range", order,
                        directions, g);
    return VSD_OK;
}

vsd_status vsd_crm_optical_depths(int count, const double *points, vsd_crm_depth_fn optical_depth, const void *user,
                                  const double *dirs, int directions, int threads, float *od, char *err, size_t errlen)
{
    depth_job job;
    (void)err;
    (void)errlen;
    if (count == 0 || directions == 0) return VSD_OK;
    job.points = points;
    job.depth = optical_depth;
    job.user = user;
    job.dirs = dirs;
    job.m = directions;
    job.od = od;
    return vsd_cpu_run_items(count, threads, run_depths, &job, "crm transmittance");
}

vsd_status vsd_crm_single_from_depths(int count, const float *od, float scale, const double albedo[3],
                                      const vsd_crm_phase *phase, int order, const double *env_sh, const float *sky_radiance, int directions,
                                      int threads, double *j_ss, char *err, size_t errlen)
{
    long nside = vsd_sh_healpix_nside(directions);
    int n2 = order * order, m = directions, d, c, i;
    double *dirs = NULL, y[16];
    sky_weights sky;
    project_job job;
    vsd_status st;
    if ((st = check_sky(order, directions, phase->chi[1], err, errlen))) return st;
    if (count == 0) return VSD_OK;
    dirs = malloc(sizeof(double) * 3 * (size_t)m);
    sky.w = malloc(sizeof(float) * 3 * (size_t)n2 * m);
    if (!dirs || !sky.w) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm single scattering: no memory for %d directions", m);
        goto done;
    }
    if ((st = vsd_sh_healpix_dirs(nside, dirs, err, errlen))) goto done;
    for (d = 0; d < m; d++) {
        vsd_sh_eval(order, dirs + 3 * (size_t)d, y);
        for (c = 0; c < 3; c++) {
            double v = 0.0;
            if (sky_radiance) v = sky_radiance[4 * (size_t)d + c];
            else
                for (i = 0; i < n2; i++) v += env_sh[c * n2 + i] * y[i];
            /* not clamped: the SH reconstruction rings below zero where the map is dark, and
             * clamping there would add light (+10% VolumeDir on smoke128's forest map) */
            for (i = 0; i < n2; i++) sky.w[((size_t)d * 3 + c) * n2 + i] = (float)(v * y[i] * 4.0 * PI_D / (double)m);
        }
    }
    sky.order = order;
    sky.n2 = n2;
    sky.m = m;
    for (i = 0; i < order; i++) sky.hg[i] = sqrt((2 * i + 1) / (4.0 * PI_D)) * phase->chi[i];
    job.sky = &sky;
    job.od = od;
    job.scale = scale;
    job.albedo = albedo;
    job.j_ss = j_ss;
    st = vsd_cpu_run_items(count, threads, run_project, &job, "crm single scattering");
done:
    free(dirs);
    free(sky.w);
    return st;
}
