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

/* a->v: the store's memory (grown when too small), or without a store a buffer of its own,
 * zeroed by calloc when `zero_own` (fresh pages are zero already) */
static vsd_status take_sums(vsd_accum *a, vsd_accum_store *store, int zero_own, int width, int height, char *err,
                            size_t errlen)
{
    size_t doubles = (size_t)width * height * VSD_ACC_N;
    a->width = width;
    a->height = height;
    a->borrowed = store != NULL;
    if (!store) {
        a->v = zero_own ? calloc(doubles, sizeof(double)) : malloc(doubles * sizeof(double));
    } else {
        if (store->doubles < doubles) {
            vsd_accum_store_free(store);
            if ((store->v = malloc(doubles * sizeof(double)))) store->doubles = doubles;
        }
        a->v = store->v;
    }
    if (!a->v)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a %dx%d accumulation buffer", width, height);
    return VSD_OK;
}

vsd_status vsd_accum_borrow(vsd_accum *a, vsd_accum_store *store, int width, int height, char *err, size_t errlen)
{
    return take_sums(a, store, 0, width, height, err, errlen);
}

vsd_status vsd_accum_init(vsd_accum *a, vsd_accum_store *store, int threads, int width, int height, char *err,
                          size_t errlen)
{
    zero_job z;
    vsd_status st = take_sums(a, store, 1, width, height, err, errlen);
    if (st || !store) return st;
    z.v = a->v;
    z.per_row = (size_t)width * VSD_ACC_N;
    if (vsd_cpu_run_items(height, threads, zero_rows, &z, "clearing the sums") != VSD_OK)
        memset(a->v, 0, (size_t)height * z.per_row * sizeof(double));   /* (the pool cannot fail without cancel) */
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
    const double inv = j->inv;
    const int transparent = j->transparent;
    (void)unused0;
    (void)unused1;
    for (i = (size_t)y0 * a->width; i < end; i++) vsd_accum_resolve_pixel(a->v + i * VSD_ACC_N, inv, transparent, fb, i);
}

void vsd_accum_resolve(const vsd_accum *a, int samples, int transparent, int threads, vsd_framebuffer *fb)
{
    resolve_job j = {a, samples > 0 ? 1.0 / samples : 0.0, transparent, fb};
    if (vsd_cpu_run_items(a->height, threads, resolve_rows, &j, "resolving the passes") != VSD_OK)
        resolve_rows(&j, 0, 0, a->height, 1);   /* (the pool cannot fail without cancel) */
}
