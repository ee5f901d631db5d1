#include "cpu_tiles.h"
#include "src/common/coprime.h"
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

typedef struct pool_state {
    const vsd_tile_job *job;
    int range_x;        /* columns per tile: VSD_TILE_SIZE, or an item list's item_range */
    int tiles_x, tiles_total, stride;
    atomic_int next, done;
    pthread_mutex_t lock;
} pool_state;

static void *worker(void *arg)
{
    pool_state *ps = arg;
    const vsd_tile_job *job = ps->job;
    const int range_x = ps->range_x;
    for (;;) {
        int t, tx, ty, finished;
        if (job->cancel && *job->cancel) break;
        t = atomic_fetch_add(&ps->next, 1);
        if (t >= ps->tiles_total) break;
        if (ps->stride > 1) t = (int)(((long long)t * ps->stride) % ps->tiles_total);
        tx = t % ps->tiles_x;
        ty = t / ps->tiles_x;
        {
            int x0 = tx * range_x, y0 = ty * VSD_TILE_SIZE, x, y;
            int x1 = x0 + range_x, y1 = y0 + VSD_TILE_SIZE;
            if (x1 > job->width) x1 = job->width;
            if (y1 > job->height) y1 = job->height;
            /* An image tile runs pixel by pixel with the cancel flag checked between
             * pixels: a 16x16 tile of a heavy scene (fire96 raymarch, 256 lights) took 8
             * CPU-seconds, and a row through the fire's core most of that, so a cancel or a
             * daemon's SIGTERM waited that long per thread (38.5 s measured). Every image
             * tile function computes each (x, y) on its own, so the result is the same; a
             * call per pixel costs nanoseconds beside a pixel's rays. Item lists (height 1:
             * lights, records, RBFs, slices) keep their 16-item ranges, since some of their
             * functions set up scratch per call (lbl's light march: a lattice-sized one). */
            if (job->height == 1) {
                job->fn(job->user, x0, y0, x1, y1);
            } else {
                for (y = y0; y < y1; y++)
                    for (x = x0; x < x1; x++) {
                        if (job->cancel && *job->cancel) goto cancelled;
                        job->fn(job->user, x, y, x + 1, y + 1);
                    }
            }
        }
        finished = atomic_fetch_add(&ps->done, 1) + 1;
        if (job->progress) {
            pthread_mutex_lock(&ps->lock);
            job->progress(job->progress_user, job->stage,
                          job->progress_base + job->progress_span * (float)finished / (float)ps->tiles_total);
            pthread_mutex_unlock(&ps->lock);
        }
    }
cancelled:
    return NULL;
}

/* The stride of a spread order over `count` tiles (see cpu_tiles.h); 1 = in order. */
static int spread_stride(int count)
{
    int s;
    if (count < 3) return 1;
    s = (int)(count * 0.6180339887 + 0.5);
    return vsd_coprime_at_least(s, count);
}

vsd_status vsd_cpu_run_tiles(const vsd_tile_job *job)
{
    pool_state ps;
    int n = vsd_cpu_thread_count(job->threads), i;
    pthread_t *th;
    ps.job = job;
    ps.range_x = job->height == 1 && job->item_range > 0 ? job->item_range : VSD_TILE_SIZE;
    ps.tiles_x = (job->width + ps.range_x - 1) / ps.range_x;
    ps.tiles_total = ps.tiles_x * ((job->height + VSD_TILE_SIZE - 1) / VSD_TILE_SIZE);
    ps.stride = job->spread ? spread_stride(ps.tiles_total) : 1;
    if (job->progress) job->progress(job->progress_user, job->stage, job->progress_base);
    atomic_init(&ps.next, 0);
    atomic_init(&ps.done, 0);
    pthread_mutex_init(&ps.lock, NULL);
    if (n > ps.tiles_total) n = ps.tiles_total > 0 ? ps.tiles_total : 1;
    th = calloc((size_t)n, sizeof *th);
    /* the calling thread works too; extra threads are a bonus if creation fails */
    for (i = 1; th && i < n; i++)
        if (pthread_create(&th[i], NULL, worker, &ps) != 0) { n = i; break; }
    worker(&ps);
    for (i = 1; th && i < n; i++) pthread_join(th[i], NULL);
    free(th);
    pthread_mutex_destroy(&ps.lock);
    if (job->cancel && *job->cancel) return VSD_ERR_CANCELLED;
    return VSD_OK;
}

static vsd_status run_list(int count, int range, int threads, vsd_tile_fn fn, void *user, const char *stage)
{
    vsd_tile_job job;
    memset(&job, 0, sizeof job);
    job.width = count;
    job.height = 1;
    job.threads = threads;
    job.fn = fn;
    job.user = user;
    job.stage = stage;
    job.item_range = range;
    return vsd_cpu_run_tiles(&job);
}

vsd_status vsd_cpu_run_items(int count, int threads, vsd_tile_fn fn, void *user, const char *stage)
{
    return run_list(count, VSD_TILE_SIZE, threads, fn, user, stage);
}

vsd_status vsd_cpu_run_each(int count, int threads, vsd_tile_fn fn, void *user, const char *stage)
{
    return run_list(count, 1, threads, fn, user, stage);
}
