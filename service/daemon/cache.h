/* cache.h — the daemon's caches: blobs under a disk budget (--blob-mb); parsed volumes
 * and maps (decoded by loader.h on a miss) and renderers under a memory budget
 * (--cache-mb). Below the jobs, above the loader and the bottom layer; takes its own lock
 * (never g_daemon.lock inside it). */
#ifndef VSD_DAEMON_CACHE_H
#define VSD_DAEMON_CACHE_H
#include "reply.h"

/* A renderer slot's inputs: density, emission, environment, the refractive index's grid */
#define VSDD_SLOT_PINS 4

int vsdd_cache_init(char *err, size_t errlen);
void vsdd_cache_shutdown(void);
int vsdd_cache_has_blob(const char *hash);
/* Receive `len` bytes from fd into the blob store, verifying `hash`. Returns 0 ok (or
 * already stored), else fills e (and the stream may be unusable: *fatal). */
int vsdd_cache_put_blob(int fd, const char *hash, uint64_t len, vsdd_err *e, int *fatal);
cJSON *vsdd_cache_stats(void);

typedef struct vsdd_entry vsdd_entry;
/* Pinned volume / env entries (loaded on a miss). src is "blob:<hash>" or a confined path. */
int vsdd_cache_get_volume(const char *src, const char *grid, int grid_index, vsdd_entry **out, int *hit, vsdd_err *e);
int vsdd_cache_get_env(const char *src, const char *conversion, vsdd_entry **out, int *hit, vsdd_err *e);
const vsd_volume *vsdd_entry_volume(const vsdd_entry *e);
const vsd_env *vsdd_entry_env(const vsdd_entry *e);
void vsdd_cache_unpin(vsdd_entry *e);
/* The file behind src ("blob:<hash>", pinned into *blob until vsdd_cache_unpin, or a
 * confined path, *blob = NULL): what the EXR's vsd/scene_hash reads (the file's bytes). */
int vsdd_cache_pin_file(const char *src, char *path, size_t len, vsdd_entry **blob, vsdd_err *e);

/* A renderer kept per (method, options, volume, emission, environment): a camera change
 * re-renders from its prepared state. */
typedef struct vsdd_slot {
    vsd_renderer *r;
    volatile int cancel;
    vsdd_job *job;                 /* the job rendering now (progress goes to it) */
    double last_progress_time;
    float last_fraction;
    char last_stage[32];
    char prep_key[2048];           /* scene fields preparation depends on, last render */
    vsdd_entry *pins[VSDD_SLOT_PINS]; /* density, emission, env, ior grid entries (may be NULL) */
    vsdd_entry *self;
    char method[32];               /* render.method: what learned_bytes is kept by */
    int64_t held;                  /* heap bytes the renderer was seen to keep (sum of the
                                      allocator's in-use growth over its create and renders) */
    uint64_t heap_start;           /* the heap in use at the render's begin */
} vsdd_slot;
/* The renderer's progress callback; `user` is the slot. Passed in by the jobs layer, so
 * the cache does not call up into it. */
typedef void (*vsdd_slot_progress_fn)(void *user, const char *stage, float fraction);
/* Find an idle renderer for key or create one. A new one first waits until the memory
 * budget can hold it, or until no other renderer is busy (then it renders alone and is not
 * kept); raising *cancel ends the wait with -VSD_ERR_CANCELLED. Takes over the caller's
 * pins in every case (kept by a new slot, released on a hit or a failure); returns 0 or
 * -vsd_status. The slot is in use until vsdd_cache_release_slot. */
int vsdd_cache_get_slot(const char *key, const vsd_scene *scene, vsdd_entry *pins[VSDD_SLOT_PINS],
                        vsdd_slot_progress_fn progress, volatile int *cancel, vsdd_slot **out, int *hit, char *msg,
                        size_t msglen);
void vsdd_cache_release_slot(vsdd_slot *s, int keep);
/* The heap in use now (glibc's mallinfo2: arenas plus mmap'd blocks). */
uint64_t vsdd_heap_in_use(void);
/* Around one render of slot s. A renderer's memory cannot be asked for, and a fixed
 * estimate let crm's ~50 MB renderers fill RSS to several times the budget
 * (docs/soak.md): at the end the slot is counted at what the render left allocated (the
 * growth of the heap in use, less the framebuffer_bytes it made, when ok), evicting idle
 * entries to make room, and that size becomes the first estimate of its method's next new
 * renderer. With several workers the others' growth is mixed in: an estimate. */
void vsdd_cache_render_begin(vsdd_slot *s);
void vsdd_cache_render_end(vsdd_slot *s, int64_t framebuffer_bytes, int ok);

#endif
