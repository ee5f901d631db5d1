/* render_job.h — running one RENDER on a worker thread (called by jobs.c). */
#ifndef VSD_DAEMON_RENDER_JOB_H
#define VSD_DAEMON_RENDER_JOB_H
#include "daemon_state.h"

/* Sends PROGRESS and then RESULT or ERROR (nothing to a disconnected client); counts the
 * job as done, failed or cancelled. */
void vsdd_run_job(vsdd_job *job, int worker);

#endif
