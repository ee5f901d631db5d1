/* cache_internal.h — what cache.c (entries, LRU, budgets, blobs, volumes, maps) shares
 * with cache_slots.c (renderer slots: admission, heap sampling, learned sizes). Only these
 * two files include it; everything here is guarded by g_cache.lock unless it says otherwise. */
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

typedef struct vsdd_cache_state {
    pthread_mutex_t lock;
    vsdd_entry *head, *tail;
    pthread_cond_t room;              /* broadcast when memory may have been freed */
    uint64_t used, reserved, peak;    /* memory budget: volumes, maps, kept renderers */
    uint64_t uncached;                /* renderers rendering outside the budget */
    uint64_t disk_used, disk_reserved, disk_peak; /* disk budget: blobs */
    int busy_slots;                   /* renderers in use by a job */
    uint64_t admission_waits;         /* new renderers that had to wait for memory */
    int trim;                         /* a decoded entry or renderer was freed since the last trim */
    uint64_t hits[ENT_KINDS], misses[ENT_KINDS], evictions, count[ENT_KINDS];
    char blob_dir[VSD_PATH_LEN];
    int owner_fd;                     /* flock'd "owner" file: this folder's daemon is alive */
} vsdd_cache_state;
extern vsdd_cache_state g_cache; /* guarded by g_cache.lock */

void vsdd_cache_lru_push(vsdd_entry *e);
void vsdd_cache_touch(vsdd_entry *e);
void vsdd_cache_note_peaks(void);
/* add (1) or remove (0) e's bytes from its budget's counter */
void vsdd_cache_account(vsdd_entry *e, int add);
void vsdd_cache_evict(vsdd_entry *e);          /* refs == 0: unlink, free */
void vsdd_cache_unpin_locked(vsdd_entry *e);
/* Evict idle memory-budget entries until `need` more bytes fit; -1 if they cannot. */
int vsdd_cache_make_room(uint64_t need);
vsdd_entry *vsdd_cache_find(int kind, const char *key, int idle_only);
/* Lock NOT held: return heap freed by evictions to the system. */
void vsdd_cache_trim_after_evictions(void);

#endif
