/* The lock-order checker (lock_order.h): each thread keeps the ranks it holds in a small
 * thread-local list; taking a lock whose rank is not above all of them is a violation,
 * logged (once per pair of ranks, so a hot path cannot flood the log) and counted. The
 * count and the "reported" marks are the only process-wide state: they describe the
 * process's threads, whichever daemon record those threads serve. */
#define _GNU_SOURCE
#include "lock_order.h"
#include "daemon_state.h"
#include <stdatomic.h>

#define MAX_HELD 16 /* far more than the deepest nesting (two) */

static _Thread_local vsdd_rank held[MAX_HELD];
static _Thread_local int held_count;
static atomic_uint_fast64_t violations;
static atomic_int reported[VSDD_RANK_END][VSDD_RANK_END];

const char *vsdd_rank_name(vsdd_rank rank)
{
    static const char *const names[VSDD_RANK_END] = {"?", "jobs", "cancel", "conns", "cache", "loader",
                                                     "conn_write", "counters"};
    return rank > 0 && rank < VSDD_RANK_END ? names[rank] : "?";
}

static void check_and_push(vsdd_rank rank)
{
    int i;
    for (i = 0; i < held_count; i++)
        if (held[i] >= rank) {
            atomic_fetch_add(&violations, 1);
            if (!atomic_exchange(&reported[held[i]][rank], 1))
                vsdd_log(VSDD_LOG_ERROR, "lock order violated: %s (rank %d) taken while holding %s (rank %d)",
                         vsdd_rank_name(rank), (int)rank, vsdd_rank_name(held[i]), (int)held[i]);
            break;
        }
    if (held_count < MAX_HELD) held[held_count] = rank;
    held_count++; /* past MAX_HELD only counted, so unlocks still balance */
}

static void pop(vsdd_rank rank)
{
    int i, top = held_count < MAX_HELD ? held_count : MAX_HELD;
    if (held_count > MAX_HELD) {
        held_count--;
        return;
    }
    /* usually the last one taken; an out-of-order unlock is allowed (it cannot deadlock) */
    for (i = top - 1; i >= 0; i--)
        if (held[i] == rank) {
            for (; i + 1 < top; i++) held[i] = held[i + 1];
            held_count--;
            return;
        }
}

void vsdd_mutex_init(vsdd_mutex *m, vsdd_rank rank)
{
    pthread_mutex_init(&m->m, NULL);
    m->rank = rank;
}

void vsdd_mutex_destroy(vsdd_mutex *m) { pthread_mutex_destroy(&m->m); }

void vsdd_lock(vsdd_mutex *m)
{
    check_and_push(m->rank);
    pthread_mutex_lock(&m->m);
}

void vsdd_unlock(vsdd_mutex *m)
{
    vsdd_rank rank = m->rank; /* read first: once unlocked, another thread may free m */
    pthread_mutex_unlock(&m->m);
    pop(rank);
}

void vsdd_cond_wait(pthread_cond_t *c, vsdd_mutex *m) { pthread_cond_wait(c, &m->m); }

int vsdd_cond_timedwait(pthread_cond_t *c, vsdd_mutex *m, const struct timespec *until)
{
    return pthread_cond_timedwait(c, &m->m, until);
}

struct timespec vsdd_deadline_ms(long ms)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    ts.tv_sec += ms / 1000;
    ts.tv_nsec += (ms % 1000) * 1000000L;
    if (ts.tv_nsec >= 1000000000L) {
        ts.tv_sec++;
        ts.tv_nsec -= 1000000000L;
    }
    return ts;
}

uint64_t vsdd_lock_violations(void) { return (uint64_t)atomic_load(&violations); }
