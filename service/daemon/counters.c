/* The STATS counters (counters.h), under their own lock (VSDD_RANK_COUNTERS, a leaf), so
 * that counting never waits for the queue or the connection list. */
#include "counters.h"
#include <stdlib.h>
#include <string.h>

struct vsdd_counters {
    vsdd_mutex lock;
    uint64_t n[VSDD_COUNT_KINDS];
};

vsdd_counters *vsdd_counters_new(void)
{
    vsdd_counters *k = calloc(1, sizeof *k);
    if (k) vsdd_mutex_init(&k->lock, VSDD_RANK_COUNTERS);
    return k;
}

void vsdd_counters_free(vsdd_counters *k)
{
    if (!k) return;
    vsdd_mutex_destroy(&k->lock);
    free(k);
}

void vsdd_count(vsdd_counters *k, int which, uint64_t n)
{
    vsdd_lock(&k->lock);
    k->n[which] += n;
    vsdd_unlock(&k->lock);
}

void vsdd_counters_get(vsdd_counters *k, uint64_t out[VSDD_COUNT_KINDS])
{
    vsdd_lock(&k->lock);
    memcpy(out, k->n, sizeof k->n);
    vsdd_unlock(&k->lock);
}
