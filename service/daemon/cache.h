/* cache.h — the daemon's caches: blobs under a disk budget (--blob-mb); parsed volumes
 * and maps (decoded by loader.h on a miss) and renderers under a memory budget
 * (--cache-mb). Below the jobs, above the loader and the bottom layer. Its state is its own
 * (cache_internal.h), behind its lock (VSDD_RANK_CACHE), which is never held while it calls
 * out (the loader, a renderer's creation). */
#ifndef VSD_DAEMON_CACHE_H
#define VSD_DAEMON_CACHE_H
#include "reply.h"

/* A renderer slot's inputs: the environment map, then per volume of the scene's volumes[]
 * its density, emission and refractive index's grids (each NULL when not used):
 * pins[VSDD_PIN_ENV], pins[VSDD_PIN(v, VSDD_PIN_DENSITY)], ... */
enum { VSDD_PIN_DENSITY = 0, VSDD_PIN_EMISSION, VSDD_PIN_IOR, VSDD_PINS_PER_VOLUME };
#define VSDD_PIN_ENV 0
#define VSDD_PIN(v, what) (1 + (v) * VSDD_PINS_PER_VOLUME + (what))
#define VSDD_SLOT_PINS (1 + VSD_MAX_VOLUMES * VSDD_PINS_PER_VOLUME)

/* Make the private folder under cfg->cache_parent (removing orphans of dead daemons there);
 * misses are decoded by `loader`. cfg and loader must outlive the cache. NULL with err. */
vsdd_cache *vsdd_cache_new(const vsdd_config *cfg, vsdd_loader *loader, char *err, size_t errlen);
/* Empty it and remove its folder (no job may use it any more); then free it. */
void vsdd_cache_shutdown(vsdd_cache *k);
void vsdd_cache_free(vsdd_cache *k);
/* The private folder: jobs write their result files there. */
const char *vsdd_cache_dir(const vsdd_cache *k);
int vsdd_cache_has_blob(vsdd_cache *k, const char *hash);
/* Receive `len` bytes from fd into the blob store, verifying `hash`. Returns 0 ok (or
 * already stored), else fills e (and the stream may be unusable: *fatal). */
int vsdd_cache_put_blob(vsdd_cache *k, int fd, const char *hash, uint64_t len, vsdd_err *e, int *fatal);
cJSON *vsdd_cache_stats(vsdd_cache *k);

typedef struct vsdd_entry vsdd_entry;
/* Pinned volume / env entries (loaded on a miss). src is "blob:<hash>" or a confined path. */
int vsdd_cache_get_volume(vsdd_cache *k, const char *src, const char *grid, int grid_index, vsdd_entry **out, int *hit,
                          vsdd_err *e);
int vsdd_cache_get_env(vsdd_cache *k, const char *src, const char *conversion, vsdd_entry **out, int *hit, vsdd_err *e);
const vsd_volume *vsdd_entry_volume(const vsdd_entry *e);
const vsd_env *vsdd_entry_env(const vsdd_entry *e);
void vsdd_cache_unpin(vsdd_cache *k, vsdd_entry *e); /* NULL is fine */
/* The file behind src ("blob:<hash>", pinned into *blob until vsdd_cache_unpin, or a
 * confined path, *blob = NULL): what the EXR's vsd/scene_hash reads (the file's bytes). */
int vsdd_cache_pin_file(vsdd_cache *k, const char *src, char *path, size_t len, vsdd_entry **blob, vsdd_err *e);

/* A renderer kept per (method, options, every volume's grids, environment): a camera change
 * re-renders from its prepared state. The slot is the cache's (cache_internal.h) but for
 * its use record, which belongs to the one job holding the slot (render_job_render.c):
 * the renderer's progress callback gets it as `user`, and its cancel flag. */
struct vsdd_job_info;
typedef struct vsdd_slot_use {
    volatile int cancel;
    const struct vsdd_job_info *job; /* the job rendering now (progress goes to it) */
    double last_progress_time;
    float last_fraction;
    char last_stage[32];
    char prep_key[2048];           /* scene fields preparation depends on, last render */
} vsdd_slot_use;
typedef struct vsdd_slot vsdd_slot;
vsdd_slot_use *vsdd_slot_use_of(vsdd_slot *s);
vsd_renderer *vsdd_slot_renderer(vsdd_slot *s);
/* The renderer's progress callback; `user` is the slot's use record. Passed in by the jobs layer, so
 * the cache does not call up into it. */
typedef void (*vsdd_slot_progress_fn)(void *user, const char *stage, float fraction);
/* Find an idle renderer for key or create one (key names every input; a long one is kept
 * by its hash). A new one is handed the pinned grids of each of the scene's volumes and the
 * map (vsd_renderer_use_volume / _use_env). With several volumes, an idle renderer of the
 * same `family` (the key without the volumes: method, options, map) that holds at least one
 * of the volumes as pinned here is taken over instead: it keys anew, is handed the volumes
 * that differ, and its method prepares again only what reads them (the parts of
 * src/method/method_parts.h; a new frame of one volume in a shot of several). *hit says
 * which: VSDD_SLOT_NEW, VSDD_SLOT_HIT, VSDD_SLOT_TAKEN_OVER. A new one first waits until the memory
 * budget can hold it, or until no other renderer is busy (then it renders alone and is not
 * kept); raising *cancel ends the wait with -VSD_ERR_CANCELLED. Takes over the caller's
 * pins in every case (kept by a new slot, released on a hit or a failure); returns 0 or
 * -vsd_status. The slot is in use until vsdd_cache_release_slot. */
enum { VSDD_SLOT_NEW = 0, VSDD_SLOT_HIT = 1, VSDD_SLOT_TAKEN_OVER = 2 };
/* The film (every pass's pixels) a slot's last job rendered into, handed to its next job:
 * the renderer writes every pixel of every pass, so a kept film gives the same image as a
 * new one, and a new 1280x720 film is 63 MB of fresh pages whose first touch cost about
 * 0.04 s of every camera change through the daemon (0.46 -> 0.41 s, docs/daemon-bench.md,
 * "A film kept with its renderer"). take: out of the slot (NULL when it keeps none), the job owns it.
 * keep: the job's film back into the slot, counted with the renderer's bytes, when the
 * memory budget has room for it without evicting anything and the slot keeps none already
 * and will be kept; *film is NULL when kept. Both while the job holds the slot. */
vsd_framebuffer *vsdd_cache_take_film(vsdd_cache *k, vsdd_slot *s);
void vsdd_cache_keep_film(vsdd_cache *k, vsdd_slot *s, vsd_framebuffer **film);
/* A film's bytes: every pass's channels in float (0 for NULL). */
int64_t vsdd_film_bytes(const vsd_framebuffer *film);
int vsdd_cache_get_slot(vsdd_cache *k, const char *key, const char *family, const vsd_scene *scene,
                        vsdd_entry *pins[VSDD_SLOT_PINS],
                        vsdd_slot_progress_fn progress, volatile int *cancel, vsdd_slot **out, int *hit, char *msg,
                        size_t msglen);
void vsdd_cache_release_slot(vsdd_cache *k, vsdd_slot *s, int keep);
/* key into out[len]: as it is when it fits, else its head and the XXH3-128 of all of it. */
void vsdd_key_fit(const char *key, char *out, size_t len);
/* The heap in use now (glibc's mallinfo2: arenas plus mmap'd blocks). */
uint64_t vsdd_heap_in_use(void);
/* Around one render of slot s. A renderer's memory cannot be asked for, and a fixed
 * estimate let crm's ~50 MB renderers fill RSS to several times the budget
 * (docs/soak.md): at the end the slot is counted at what the render left allocated (the
 * growth of the heap in use, less the framebuffer_bytes it made, when ok), evicting idle
 * entries to make room, and that size becomes the first estimate of its method's next new
 * renderer. With several workers the others' growth is mixed in: an estimate. */
void vsdd_cache_render_begin(vsdd_cache *k, vsdd_slot *s);
void vsdd_cache_render_end(vsdd_cache *k, vsdd_slot *s, int64_t framebuffer_bytes, int ok);

#endif
