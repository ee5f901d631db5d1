/* cache_internal.h — the cache's own state (struct vsdd_cache), which cache.c (entries,
 * LRU, budgets, blobs, volumes, maps) shares with cache_slots.c (renderer slots:
 * admission, heap sampling, learned sizes). Only these two files include it; everything
 * here is guarded by k->lock (VSDD_RANK_CACHE) unless it says otherwise. */
#ifndef VSD_DAEMON_CACHE_INTERNAL_H
#define VSD_DAEMON_CACHE_INTERNAL_H
#include "cache.h"
#include <pthread.h>

enum { ENT_BLOB, ENT_VOLUME, ENT_ENV, ENT_SLOT, ENT_KINDS };

struct vsdd_entry {
    int kind;
    char key[1400];
    uint64_t bytes;
    int refs;
    int uncached;                     /* a renderer running outside the budget, dropped after its job */
    struct vsdd_entry *prev, *next;   /* head = most recently used */
    char path[VSD_PATH_LEN];          /* blob file */
    vsd_volume *vol;
    vsd_env *env;
    vsdd_slot *slot;
};

struct vsdd_slot {
    vsdd_slot_use use;                /* its holder's (cache.h); never read here */
    vsd_renderer *r;
    vsdd_entry *pins[VSDD_SLOT_PINS]; /* the map, each volume's density, emission, ior grid (cache.h; may be NULL) */
    vsdd_entry *self;
    char method[32];                  /* render.method: what learned bytes are kept by */
    char family[1400];                /* its key without the volumes (vsdd_cache_get_slot), fitted */
    int64_t held;                     /* heap bytes the renderer was seen to keep (sum of the
                                         allocator's in-use growth over its create and renders) */
    uint64_t heap_start;              /* the heap in use at the render's begin */
    vsd_framebuffer *film;            /* the last job's film, kept for the next (vsdd_cache_keep_film);
                                         counted in held while here */
};

struct vsdd_cache {
    const vsdd_config *cfg;           /* the daemon's, read-only (budgets, threads, method cache) */
    vsdd_loader *loader;              /* decodes a volume or map on a miss (without the lock) */
    vsdd_mutex lock;
    vsdd_entry *head, *tail;
    pthread_cond_t room;              /* broadcast when memory may have been freed */
    uint64_t used, reserved, peak;    /* memory budget: volumes, maps, kept renderers */
    uint64_t uncached;                /* renderers rendering outside the budget */
    uint64_t disk_used, disk_reserved, disk_peak; /* disk budget: blobs */
    int busy_slots;                   /* renderers in use by a job */
    uint64_t admission_waits;         /* new renderers that had to wait for memory */
    int trim;                         /* a decoded entry or renderer was freed since the last trim */
    uint64_t hits[ENT_KINDS], misses[ENT_KINDS], evictions, count[ENT_KINDS];
    uint64_t taken_over;              /* renderer misses served by another frame's renderer */
    struct { char method[32]; uint64_t bytes; } learned[16]; /* cache_slots.c's learned sizes */
    char dir[VSD_PATH_LEN];           /* the private folder, made at start, removed at shutdown;
                                         set before any thread, read-only after */
    char blob_dir[VSD_PATH_LEN];      /* likewise */
    int owner_fd;                     /* flock'd "owner" file: this folder's daemon is alive */
};

void vsdd_cache_lru_push(vsdd_cache *k, vsdd_entry *e);
void vsdd_cache_touch(vsdd_cache *k, vsdd_entry *e);
void vsdd_cache_note_peaks(vsdd_cache *k);
/* add (1) or remove (0) e's bytes from its budget's counter */
void vsdd_cache_account(vsdd_cache *k, vsdd_entry *e, int add);
void vsdd_cache_evict(vsdd_cache *k, vsdd_entry *e);          /* refs == 0: unlink, free */
void vsdd_cache_unpin_locked(vsdd_cache *k, vsdd_entry *e);
/* Evict idle memory-budget entries until `need` more bytes fit; -1 if they cannot. */
int vsdd_cache_make_room(vsdd_cache *k, uint64_t need);
vsdd_entry *vsdd_cache_find(vsdd_cache *k, int kind, const char *key, int idle_only);
/* Lock NOT held: return heap freed by evictions to the system. */
void vsdd_cache_trim_after_evictions(vsdd_cache *k);

#endif
