#include "accum.h"
#include <stdlib.h>

vsd_status vsd_accum_init(vsd_accum *a, int width, int height, char *err, size_t errlen)
{
    a->width = width;
    a->height = height;
    a->v = calloc((size_t)width * height * VSD_ACC_N, sizeof(double));
    if (!a->v)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a %dx%d accumulation buffer", width, height);
    return VSD_OK;
}

void vsd_accum_free(vsd_accum *a)
{
    free(a->v);
    a->v = NULL;
}

void vsd_accum_add(vsd_accum *a, int x, int y, const vsd_sample_result *r)
{
    vsd_accum_sample(a->v + ((size_t)y * a->width + x) * VSD_ACC_N, r);
}

void vsd_accum_resolve(const vsd_accum *a, int samples, int transparent, vsd_framebuffer *fb)
{
    size_t i, n = (size_t)a->width * a->height;
    double inv = samples > 0 ? 1.0 / samples : 0.0;
    for (i = 0; i < n; i++) {
        const double *p = a->v + i * VSD_ACC_N;
        float *comb = fb->pass[VSD_PASS_COMBINED] + 4 * i;
        float *dir = fb->pass[VSD_PASS_VOLUME_DIR] + 3 * i, *ind = fb->pass[VSD_PASS_VOLUME_IND] + 3 * i;
        float *emit = fb->pass[VSD_PASS_EMIT] + 3 * i, *tr = fb->pass[VSD_PASS_TRANSMITTANCE] + 3 * i;
        float t = (float)(p[VSD_ACC_T] * inv);
        int c;
        for (c = 0; c < 3; c++) {
            dir[c] = (float)(p[VSD_ACC_DIR + c] * inv);
            ind[c] = (float)(p[VSD_ACC_IND + c] * inv);
            emit[c] = (float)(p[VSD_ACC_EMIT + c] * inv);
            tr[c] = t;
            comb[c] = dir[c] + ind[c] + emit[c] + (transparent ? 0.0f : (float)(p[VSD_ACC_BG + c] * inv));
        }
        comb[3] = transparent ? 1.0f - t : 1.0f;
        fb->pass[VSD_PASS_DEPTH][i] = p[VSD_ACC_DEPTH_N] > 0 ? (float)(p[VSD_ACC_DEPTH] / p[VSD_ACC_DEPTH_N])
                                                               : VSD_DEPTH_EMPTY;
    }
}
