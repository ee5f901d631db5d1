/* counters.h — what STATS counts about jobs and uploads (counters.c). Bottom layer: the
 * jobs, the workers and the readers add to it; STATS reads a snapshot. */
#ifndef VSD_DAEMON_COUNTERS_H
#define VSD_DAEMON_COUNTERS_H
#include "daemon_state.h"

enum {
    VSDD_COUNT_DONE,           /* jobs that sent a RESULT */
    VSDD_COUNT_FAILED,         /* jobs that sent an ERROR */
    VSDD_COUNT_CANCELLED,      /* jobs stopped by CANCEL, disconnect, timeout or shutdown */
    VSDD_COUNT_BUSY,           /* RENDERs refused because the queue was full */
    VSDD_COUNT_BLOBS,          /* blobs received by PUT */
    VSDD_COUNT_BLOB_BYTES,     /* their bytes */
    VSDD_COUNT_KINDS
};

vsdd_counters *vsdd_counters_new(void);
void vsdd_counters_free(vsdd_counters *k);
void vsdd_count(vsdd_counters *k, int which, uint64_t n);
/* Every counter at one instant. */
void vsdd_counters_get(vsdd_counters *k, uint64_t out[VSDD_COUNT_KINDS]);

#endif
