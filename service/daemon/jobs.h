/* jobs.h — the job queue (jobs.c): a bounded FIFO run by --workers threads, with a
 * watchdog for --max-job-seconds. Called by the connection readers and serve.c. */
#ifndef VSD_DAEMON_JOBS_H
#define VSD_DAEMON_JOBS_H
#include "daemon_state.h"

int vsdd_jobs_start(void);
/* Queue a RENDER (takes ownership of req). Returns 0 queued, -1 busy, -2 stopping,
 * -3 the id is in use on this connection. */
int vsdd_job_submit(vsdd_conn *c, double id, cJSON *req, int *position);
/* Cancel by (conn, id); returns 1 when found. */
int vsdd_job_cancel(vsdd_conn *c, double id);
void vsdd_jobs_cancel_conn(vsdd_conn *c);        /* on disconnect */
void vsdd_jobs_stop(void);                       /* cancel everything, join workers */
void vsdd_jobs_counts(int *queued, int *running);

#endif
