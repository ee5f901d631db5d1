/* cancel.h — one job's cancellation (cancel.c): why it was cancelled (the first reason
 * raised stays) and the flag of what the job runs now, a renderer or a wait for memory,
 * which a raise sets. jobs.c raises (CANCEL, disconnect, watchdog, shutdown); the job's own
 * steps (render_job_render.c) point it at the flag they pass on and ask for the reason.
 * Bottom layer; its lock is VSDD_RANK_CANCEL. */
#ifndef VSD_DAEMON_CANCEL_H
#define VSD_DAEMON_CANCEL_H
#include "daemon_state.h"

typedef struct vsdd_cancel vsdd_cancel;

vsdd_cancel *vsdd_cancel_new(void);
void vsdd_cancel_free(vsdd_cancel *x);
/* Keep `reason` (VSDD_CANCEL_*) unless one is kept already; set the watched flag. */
void vsdd_cancel_raise(vsdd_cancel *x, int reason);
/* From now on a raise sets *flag; *flag is set at once when a reason is kept already. */
void vsdd_cancel_watch(vsdd_cancel *x, volatile int *flag);
/* Stop setting the flag; returns the reason kept (VSDD_CANCEL_NONE when none). */
int vsdd_cancel_unwatch(vsdd_cancel *x);
int vsdd_cancel_reason(vsdd_cancel *x);

#endif
