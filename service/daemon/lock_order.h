/* lock_order.h — every mutex of the daemon, its rank, and the one rule about them: a thread
 * takes a lock only when its rank is higher than the rank of every lock it already holds.
 * Two threads can then never wait for each other in a cycle (no deadlock), and the whole
 * order is written here, not in comments spread over the files that take the locks.
 *
 * Each lock guards the state of one file (docs/daemon-internals.md lists them). The order,
 * outermost first, and why each nesting exists:
 *
 *   JOBS        jobs.c: the queue, the running list, the workers' stop flag. Held while
 *               it raises a job's CANCEL (a CANCEL, a disconnect, the watchdog, shutdown)
 *               and while it takes the connection reference a queued job keeps.
 *   CANCEL      cancel.c: one job's cancel reason and the flag of what it runs now (the
 *               renderer, or the wait for memory). One per job; never two at once.
 *   CONNS       conns.c: the connection list, counts, references.
 *   CACHE       cache.c, cache_slots.c: entries, LRU, budgets, slots, learned sizes.
 *               Never held while calling out of the cache (loader, renderer create).
 *   LOADER      loader_isolated.c: the zygote's socket and pid.
 *   CONN_WRITE  reply.c: one connection's outgoing frames and its dead flag. One per
 *               connection; never two at once.
 *   COUNTERS    counters.c: the STATS counters. A leaf: nothing is taken inside it.
 *
 * The wrappers below check the rule on every lock (a thread-local list of what the thread
 * holds: a few compares), always, not only in debug builds: a violation is logged once per
 * pair of ranks at error level and counted (vsdd_lock_violations), and the lock is taken
 * anyway. It never aborts: a daemon that has run for weeks keeps serving; the count is
 * what a test (tests/test_daemon_locks.c) and `vsd serve`'s last log line look at. */
#ifndef VSD_DAEMON_LOCK_ORDER_H
#define VSD_DAEMON_LOCK_ORDER_H
#include <pthread.h>
#include <stdint.h>
#include <time.h>

typedef enum vsdd_rank {
    VSDD_RANK_JOBS = 1,
    VSDD_RANK_CANCEL,
    VSDD_RANK_CONNS,
    VSDD_RANK_CACHE,
    VSDD_RANK_LOADER,
    VSDD_RANK_CONN_WRITE,
    VSDD_RANK_COUNTERS,
    VSDD_RANK_END
} vsdd_rank;

typedef struct vsdd_mutex {
    pthread_mutex_t m;
    vsdd_rank rank;
} vsdd_mutex;

void vsdd_mutex_init(vsdd_mutex *m, vsdd_rank rank);
void vsdd_mutex_destroy(vsdd_mutex *m);
void vsdd_lock(vsdd_mutex *m);
void vsdd_unlock(vsdd_mutex *m);
/* Condition waits on a ranked mutex: it is given back while waiting and held again on
 * return, so the thread's list of held locks does not change. */
void vsdd_cond_wait(pthread_cond_t *c, vsdd_mutex *m);
int vsdd_cond_timedwait(pthread_cond_t *c, vsdd_mutex *m, const struct timespec *until);
/* An absolute CLOCK_REALTIME time `ms` from now, for vsdd_cond_timedwait. */
struct timespec vsdd_deadline_ms(long ms);

/* Locks taken out of order since the process started (every thread, every daemon). */
uint64_t vsdd_lock_violations(void);
const char *vsdd_rank_name(vsdd_rank rank);

#endif
