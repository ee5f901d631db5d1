#include "cpu_wavefront.h"
#include "cpu_tiles.h"
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>

typedef struct wavefront {
    int nu, nv;
    vsd_wavefront_fn fn;
    void *user;
    int *order;              /* [nu * nv] the tiles by anti-diagonal: u + v * nu */
    atomic_int *done;        /* [nu * nv] 1 once the tile has run */
} wavefront;

static void wait_done(const wavefront *w, int u, int v)
{
    if (u < 0 || v < 0) return;
    while (!atomic_load_explicit(&w->done[u + v * w->nu], memory_order_acquire)) sched_yield();
}

/* The pool hands its items out in increasing order (vsd_cpu_run_each), and every tile
 * comes after the two it waits for in `order`: those were taken before it, by threads that
 * are running them or the tiles they wait for, down to one whose waits are over, so the
 * waits end. */
static void run_tile(void *user, int k0, int y0, int k1, int y1)
{
    wavefront *w = user;
    int k;
    (void)y0;
    (void)y1;
    for (k = k0; k < k1; k++) {
        int t = w->order[k], u = t % w->nu, v = t / w->nu;
        wait_done(w, u - 1, v);
        wait_done(w, u, v - 1);
        w->fn(w->user, u, v);
        atomic_store_explicit(&w->done[t], 1, memory_order_release);
    }
}

vsd_status vsd_cpu_run_wavefront(int nu, int nv, int threads, vsd_wavefront_fn fn, void *user, const char *stage)
{
    wavefront w = {nu, nv, fn, user, NULL, NULL};
    const int count = nu > 0 && nv > 0 ? nu * nv : 0;
    int d, k = 0, i;
    vsd_status st;
    if (count == 0) return VSD_OK;
    w.order = malloc((size_t)count * sizeof *w.order);
    w.done = malloc((size_t)count * sizeof *w.done);
    if (!w.order || !w.done) {
        free(w.order);
        free(w.done);
        return VSD_ERR_NOMEM;
    }
    for (i = 0; i < count; i++) atomic_init(&w.done[i], 0);
    for (d = 0; d < nu + nv - 1; d++) {
        int v = d - (nu - 1) > 0 ? d - (nu - 1) : 0;
        for (; v < nv && v <= d; v++) w.order[k++] = (d - v) + v * nu;
    }
    st = vsd_cpu_run_each(count, threads, run_tile, &w, stage);
    free(w.order);
    free(w.done);
    return st;
}
