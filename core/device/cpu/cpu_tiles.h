/* cpu_tiles.h — the CPU backend: a pool of POSIX threads pulling image tiles from an
 * atomic counter. Each pixel's result depends only on its own (seed, pixel, sample)
 * random stream, so the image is identical whatever the thread count or tile order. */
#ifndef VSD_CPU_TILES_H
#define VSD_CPU_TILES_H
#include "vsd/status.h"
#include "vsd/render.h"

#define VSD_TILE_SIZE 16

/* Work on the pixel rectangle [x0,x1) x [y0,y1). For an image (height > 1) the pool
 * passes one pixel at a time, checking the cancel flag between pixels, so each (x, y) must
 * be computed on its own; item lists (height 1) come in ranges of VSD_TILE_SIZE. */
typedef void (*vsd_tile_fn)(void *user, int x0, int y0, int x1, int y1);

typedef struct vsd_tile_job {
    int width, height;
    int threads;                 /* 0 = all cores */
    vsd_tile_fn fn;
    void *user;
    const char *stage;           /* progress stage name */
    vsd_progress_fn progress;    /* may be 0; called under a lock */
    void *progress_user;
    float progress_base, progress_span; /* fraction reported = base + span * done/total */
    volatile int *cancel;        /* may be 0 */
    int spread;                  /* hand the tiles out scattered over the image (below) */
    int item_range;              /* item lists (height 1): items per call (0 = VSD_TILE_SIZE) */
} vsd_tile_job;

/* Runs every tile; VSD_ERR_CANCELLED when *cancel became non-zero (seen within one pixel of
 * an image, or 16 items of a list, per thread). With a progress callback it reports
 * progress_base when it starts (so a client sees the stage begin and can time it), then
 * after every tile. With `spread` the k-th tile handed out is tile (k * stride) mod count,
 * the stride coprime with the count and near count / golden ratio: consecutive tiles lie
 * far apart, so the fraction of tiles done follows the fraction of the work done even when
 * the cost varies across the image (a plume below empty sky), which is what an ETA from the
 * progress needs. The image is the same in any order (above). */
vsd_status vsd_cpu_run_tiles(const vsd_tile_job *job);

/* fn over items [0, count) in ranges, as the x range of a count x 1 image (no progress,
 * no cancel): the form the lighting stages of the methods use. */
vsd_status vsd_cpu_run_items(int count, int threads, vsd_tile_fn fn, void *user, const char *stage);

/* fn over items [0, count) one item per call: for lists of a few large items (crm's sweep
 * per direction), which ranges of VSD_TILE_SIZE would hand to one thread. Items are handed
 * out in increasing order, each to the next thread free (cpu_wavefront.c relies on it). */
vsd_status vsd_cpu_run_each(int count, int threads, vsd_tile_fn fn, void *user, const char *stage);

/* The thread count a request for `threads` (0 = all) resolves to: vsd_cpu_thread_count,
 * src/common/cpu_count.h (shared with the EXR writer). */
#include "src/common/cpu_count.h"

#endif
