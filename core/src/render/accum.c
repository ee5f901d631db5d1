#include "accum.h"
#include "device/cpu/cpu_tiles.h"
#include <stdlib.h>
#include <string.h>

void vsd_accum_store_free(vsd_accum_store *s)
{
    free(s->v);
    s->v = NULL;
    s->doubles = 0;
}

typedef struct zero_job {
    double *v;
    size_t per_row;
} zero_job;

static void zero_rows(void *user, int y0, int unused0, int y1, int unused1)
{
    const zero_job *z = user;
    (void)unused0;
    (void)unused1;
    memset(z->v + (size_t)y0 * z->per_row, 0, (size_t)(y1 - y0) * z->per_row * sizeof(double));
}

vsd_status vsd_accum_init(vsd_accum *a, vsd_accum_store *store, int threads, int width, int height, char *err,
                          size_t errlen)
{
    size_t doubles = (size_t)width * height * VSD_ACC_N;
    a->width = width;
    a->height = height;
    a->borrowed = store != NULL;
    if (!store) {
        a->v = calloc(doubles, sizeof(double));
    } else {
        if (store->doubles < doubles) {
            vsd_accum_store_free(store);
            if ((store->v = malloc(doubles * sizeof(double)))) store->doubles = doubles;
        }
        a->v = store->v;
        if (a->v) {
            zero_job z = {a->v, (size_t)width * VSD_ACC_N};
            if (vsd_cpu_run_items(height, threads, zero_rows, &z, "clearing the sums") != VSD_OK)
                memset(a->v, 0, doubles * sizeof(double));   /* (the pool cannot fail without cancel) */
        }
    }
    if (!a->v)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a %dx%d accumulation buffer", width, height);
    return VSD_OK;
}

void vsd_accum_free(vsd_accum *a)
{
    if (!a->borrowed) free(a->v);
    a->v = NULL;
}

void vsd_accum_add(vsd_accum *a, int x, int y, const vsd_sample_result *r)
{
    vsd_accum_sample(a->v + ((size_t)y * a->width + x) * VSD_ACC_N, r);
}

typedef struct resolve_job {
    const vsd_accum *a;
    double inv;
    int transparent;
    vsd_framebuffer *fb;
} resolve_job;

/* rows [y0, y1) of the image: items of a height x 1 job */
static void resolve_rows(void *user, int y0, int unused0, int y1, int unused1)
{
    const resolve_job *j = user;
    const vsd_accum *a = j->a;
    vsd_framebuffer *fb = j->fb;
    size_t i, end = (size_t)y1 * a->width;
    double inv = j->inv;
    int transparent = j->transparent;
    (void)unused0;
    (void)unused1;
    for (i = (size_t)y0 * a->width; i < end; i++) {
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

void vsd_accum_resolve(const vsd_accum *a, int samples, int transparent, int threads, vsd_framebuffer *fb)
{
    resolve_job j = {a, samples > 0 ? 1.0 / samples : 0.0, transparent, fb};
    if (vsd_cpu_run_items(a->height, threads, resolve_rows, &j, "resolving the passes") != VSD_OK)
        resolve_rows(&j, 0, 0, a->height, 1);   /* (the pool cannot fail without cancel) */
}
