/* render_job.h — running one RENDER on a worker thread (called by jobs.c). */
#ifndef VSD_DAEMON_RENDER_JOB_H
#define VSD_DAEMON_RENDER_JOB_H
#include "cancel.h"

/* What a job's steps know of it: fixed by jobs.c when it is queued, read-only after. */
typedef struct vsdd_job_info {
    double id;                     /* the client's request id (JSON number) */
    unsigned long seq;             /* daemon-wide job number (logs, temp names) */
    vsdd_conn *conn;               /* jobs.c holds a reference for the job's life */
    const cJSON *req;              /* the RENDER message */
    double queued_at;
    vsdd_cancel *cancel;           /* raised by jobs.c; the steps watch it */
} vsdd_job_info;

/* Sends PROGRESS and then RESULT or ERROR (nothing to a disconnected client); counts the
 * job as done, failed or cancelled in d->counters. */
void vsdd_run_job(vsdd_daemon *d, const vsdd_job_info *job, int worker);

#endif
