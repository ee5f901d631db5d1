/* jobs.h — the job queue (jobs.c): a bounded FIFO run by --workers threads, with a
 * watchdog for --max-job-seconds. Called by the connection readers and daemon.c. */
#ifndef VSD_DAEMON_JOBS_H
#define VSD_DAEMON_JOBS_H
#include "daemon_state.h"

/* Start d->cfg.workers workers and the watchdog; they run jobs in d (its configuration,
 * connections, counters, cache). NULL when a thread cannot start. */
vsdd_jobs *vsdd_jobs_start(vsdd_daemon *d);
/* Queue a RENDER (takes ownership of req). Returns 0 queued, -1 busy, -2 stopping,
 * -3 the id is in use on this connection. */
int vsdd_job_submit(vsdd_jobs *js, vsdd_conn *c, double id, cJSON *req, int *position);
/* Cancel by (conn, id); returns 1 when found. */
int vsdd_job_cancel(vsdd_jobs *js, vsdd_conn *c, double id);
void vsdd_jobs_cancel_conn(vsdd_jobs *js, vsdd_conn *c); /* on disconnect */
void vsdd_jobs_stop(vsdd_jobs *js);                      /* cancel everything, join the threads */
void vsdd_jobs_free(vsdd_jobs *js);                      /* after vsdd_jobs_stop */
int vsdd_jobs_stopping(vsdd_jobs *js);
void vsdd_jobs_counts(vsdd_jobs *js, int *queued, int *running);

#endif
