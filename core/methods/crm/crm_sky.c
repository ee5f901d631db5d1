#include "crm_sky.h"
#include "kernel/kernel_phase.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* HG averaged over a cap of solid angle `omega` around a direction at angle acos(mu) from
 * the outgoing one, for CRM_SKY_PHASE_N values of mu from -1 to 1 (uniform: the cap's
 * average is smooth on the scale of its 20 degrees, so a step of 0.001 in mu resolves it,
 * and the lookup needs no square root). */
static void phase_table(double g, double omega, float *table)
{
    /* a cap of half-angle alpha has solid angle 2 pi (1 - cos alpha); its directions are
     * sampled at equal areas (uniform in cos beta, midpoints) and equal azimuths, half of
     * them (the phase is even in the azimuth about the plane of the axis and w_o) */
    enum { RINGS = 24, AZIMUTHS = 32 };
    double cos_alpha = 1.0 - omega / (2.0 * PI);
    int i, b, a;
    if (cos_alpha < -1.0) cos_alpha = -1.0;
    for (i = 0; i < CRM_SKY_PHASE_N; i++) {
        double ct = -1.0 + 2.0 * i / (CRM_SKY_PHASE_N - 1), st = sqrt(fmax(0.0, 1.0 - ct * ct)), sum = 0.0;
        for (b = 0; b < RINGS; b++) {
            double cb = 1.0 - (1.0 - cos_alpha) * (b + 0.5) / RINGS, sb = sqrt(fmax(0.0, 1.0 - cb * cb));
            for (a = 0; a < AZIMUTHS; a++) {
                double phi = PI * (a + 0.5) / AZIMUTHS;
                sum += vsd_hg_eval((float)(cb * ct + sb * cos(phi) * st), (float)g);
            }
        }
        table[i] = (float)(sum / (RINGS * AZIMUTHS));
    }
}

/* exp(-scale od) per node with density and pixel, and each node's row (-1 without density),
 * unless they were made from the same march at the same scale: a map rotation or strength,
 * an albedo or phase edit keep them. */
static vsd_status transmittance_rows(vsd_crm_sky *sky, const vsd_crm_node_depths *depths, long long marches,
                                     float scale, char *err, size_t errlen)
{
    size_t nodes = (size_t)depths->res[0] * depths->res[1] * depths->res[2], i;
    int n = depths->directions, j;
    if (sky->tr && sky->row_nodes == nodes && sky->rows == depths->count && sky->tr_marches == marches &&
        sky->tr_scale == scale)
        return VSD_OK;
    if (sky->row_nodes != nodes || sky->rows != depths->count) {
        free(sky->row);
        free(sky->tr);
        sky->row_nodes = sky->rows = 0;
        sky->row = malloc((nodes ? nodes : 1) * sizeof *sky->row);
        sky->tr = malloc((depths->count ? depths->count : 1) * (size_t)n * sizeof *sky->tr);
        if (!sky->row || !sky->tr)
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the sky's transmittance of %zu nodes x %d",
                            depths->count, n);
        sky->row_nodes = nodes;
        sky->rows = depths->count;
    }
    for (i = 0; i < nodes; i++) sky->row[i] = -1;
    for (i = 0; i < depths->count; i++) {
        const float *od = depths->od + i * (size_t)n;
        float *t = sky->tr + i * (size_t)n;
        sky->row[depths->which[i]] = (int32_t)i;
        for (j = 0; j < n; j++) t[j] = expf(-scale * od[j]);
    }
    sky->tr_marches = marches;
    sky->tr_scale = scale;
    return VSD_OK;
}

vsd_status vsd_crm_sky_update(vsd_crm_sky *sky, const vsd_crm_node_depths *depths, long long marches, float scale,
                              const float *radiance, const double albedo[3], double g, char *err, size_t errlen)
{
    int n = depths->directions, j, c;
    double omega = 4.0 * PI / (n > 0 ? n : 1);
    vsd_status st;
    if (n <= 0 || !depths->dirs) return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "internal: crm sky without directions");
    if (sky->count != n) {
        free(sky->pixels);
        sky->count = 0;
        if (!(sky->pixels = malloc(8 * (size_t)n * sizeof *sky->pixels)))
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the sky of %d directions", n);
        sky->count = n;
        sky->phase_ready = 0;
    }
    for (j = 0; j < n; j++) {
        for (c = 0; c < 3; c++) {
            sky->pixels[8 * j + c] = (float)depths->dirs[3 * j + c];
            sky->pixels[8 * j + 4 + c] = (float)(albedo[c] * radiance[4 * j + c] * omega);
        }
        sky->pixels[8 * j + 3] = sky->pixels[8 * j + 7] = 0.0f;
    }
    if ((st = transmittance_rows(sky, depths, marches, scale, err, errlen))) return st;
    if (!sky->phase_ready || sky->phase_g != g) {
        phase_table(g, omega, sky->phase);
        sky->phase_g = g;
        sky->phase_ready = 1;
    }
    return VSD_OK;
}

void vsd_crm_sky_free(vsd_crm_sky *sky)
{
    free(sky->pixels);
    free(sky->tr);
    free(sky->row);
    memset(sky, 0, sizeof *sky);
}
