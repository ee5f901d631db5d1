/* The job queue: a bounded FIFO (--queue) run by --workers threads, a watchdog for
 * max_job_seconds, and cancellation by CANCEL, disconnect, timeout or shutdown. The queue,
 * the running list and the job records are this file's, under js->lock (VSDD_RANK_JOBS);
 * a job's cancel state is cancel.c's, raised from here and watched by the job's steps. */
#define _GNU_SOURCE
#include "jobs.h"
#include "cancel.h"
#include "conns.h"
#include "counters.h"
#include "render_job.h"
#include "reply.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct job {
    vsdd_job_info info;            /* what the job's steps read; fixed once queued */
    cJSON *req;                    /* the RENDER message, owned (info.req) */
    double started_at;
    struct job *next;              /* queue or running list */
} job;

struct vsdd_jobs {
    vsdd_daemon *d;
    vsdd_mutex lock;
    pthread_cond_t wake;           /* workers wait for jobs; the watchdog for its next look */
    job *queue_head, *queue_tail, *running;
    int queued;
    int stopping;
    unsigned long next_seq;
    pthread_t *workers;
    int worker_count;
    pthread_t watchdog;
    int watchdog_started;
};

static void free_job(vsdd_jobs *js, job *j)
{
    vsdd_conn_release(js->d->conns, j->info.conn);
    vsdd_cancel_free(j->info.cancel);
    cJSON_Delete(j->req);
    free(j);
}

/* Lock held: the next queued job, moved to the running list; NULL when stopping. */
static job *next_job(vsdd_jobs *js)
{
    job *j;
    while (!js->queue_head && !js->stopping) vsdd_cond_wait(&js->wake, &js->lock);
    j = js->queue_head;
    if (!j) return NULL;
    js->queue_head = j->next;
    if (!js->queue_head) js->queue_tail = NULL;
    js->queued--;
    j->started_at = vsd_clock_seconds();
    j->next = js->running;
    js->running = j;
    return j;
}

static void unlink_running(vsdd_jobs *js, job *j)
{
    job **p;
    for (p = &js->running; *p; p = &(*p)->next)
        if (*p == j) {
            *p = j->next;
            break;
        }
}

typedef struct worker_arg {
    vsdd_jobs *js;
    int index;
} worker_arg;

static void *worker_main(void *arg)
{
    worker_arg *w = arg;
    vsdd_jobs *js = w->js;
    for (;;) {
        job *j;
        vsdd_lock(&js->lock);
        j = next_job(js);
        vsdd_unlock(&js->lock);
        if (!j) break;
        vsdd_run_job(js->d, &j->info, w->index);
        vsdd_lock(&js->lock);
        unlink_running(js, j);
        vsdd_unlock(&js->lock);
        free_job(js, j);
    }
    free(w);
    return NULL;
}

static void *watchdog_main(void *arg)
{
    vsdd_jobs *js = arg;
    double limit = js->d->cfg.max_job_seconds;
    vsdd_lock(&js->lock);
    while (!js->stopping) {
        struct timespec until = vsdd_deadline_ms(100);
        double now = vsd_clock_seconds();
        job *j;
        for (j = js->running; j; j = j->next)
            if (limit > 0 && now - j->started_at > limit) vsdd_cancel_raise(j->info.cancel, VSDD_CANCEL_TIMEOUT);
        vsdd_cond_timedwait(&js->wake, &js->lock, &until);
    }
    vsdd_unlock(&js->lock);
    return NULL;
}

vsdd_jobs *vsdd_jobs_start(vsdd_daemon *d)
{
    vsdd_jobs *js = calloc(1, sizeof *js);
    int i;
    if (!js) return NULL;
    js->d = d;
    vsdd_mutex_init(&js->lock, VSDD_RANK_JOBS);
    pthread_cond_init(&js->wake, NULL);
    js->workers = calloc((size_t)d->cfg.workers, sizeof *js->workers);
    if (!js->workers) goto failed;
    for (i = 0; i < d->cfg.workers; i++) {
        worker_arg *w = malloc(sizeof *w);
        if (!w) goto failed;
        w->js = js;
        w->index = i;
        if (pthread_create(&js->workers[i], NULL, worker_main, w) != 0) {
            free(w);
            goto failed;
        }
        js->worker_count++;
    }
    if (pthread_create(&js->watchdog, NULL, watchdog_main, js) != 0) goto failed;
    js->watchdog_started = 1;
    return js;
failed:
    vsdd_jobs_stop(js);
    vsdd_jobs_free(js);
    return NULL;
}

/* Lock held: the job of (c, id) queued or running, or NULL. */
static job *find(vsdd_jobs *js, vsdd_conn *c, double id)
{
    job *lists[2] = {js->queue_head, js->running}, *k;
    int i;
    for (i = 0; i < 2; i++)
        for (k = lists[i]; k; k = k->next)
            if (k->info.conn == c && k->info.id == id) return k;
    return NULL;
}

int vsdd_job_submit(vsdd_jobs *js, vsdd_conn *c, double id, cJSON *req, int *position)
{
    job *j = NULL;
    int rc = 0;
    vsdd_lock(&js->lock);
    if (js->stopping) rc = -2;
    else if (find(js, c, id)) rc = -3;
    else if (js->queued >= js->d->cfg.queue_max) {
        vsdd_count(js->d->counters, VSDD_COUNT_BUSY, 1);
        rc = -1;
    } else if (!(j = calloc(1, sizeof *j)) || !(j->info.cancel = vsdd_cancel_new())) {
        free(j);
        rc = -1;
    }
    if (rc) {
        vsdd_unlock(&js->lock);
        cJSON_Delete(req);
        return rc;
    }
    j->info.id = id;
    j->info.seq = ++js->next_seq;
    j->info.conn = c;
    vsdd_conn_hold(js->d->conns, c); /* the job's reference, released by free_job */
    j->info.req = j->req = req;
    j->info.queued_at = vsd_clock_seconds();
    if (js->queue_tail) js->queue_tail->next = j;
    else js->queue_head = j;
    js->queue_tail = j;
    js->queued++;
    *position = js->queued;
    vsdd_log(VSDD_LOG_INFO, "conn %u: job %lu (id %.0f) queued at position %d", c->id, j->info.seq, id, *position);
    pthread_cond_broadcast(&js->wake);
    vsdd_unlock(&js->lock);
    return 0;
}

/* Lock held: take queued jobs matching (c, id) — all_ids = every job of c, c NULL = of
 * every connection — out of the queue into *removed, and raise the running ones' cancel. */
static int cancel_matching(vsdd_jobs *js, vsdd_conn *c, double id, int all_ids, int reason, job **removed)
{
    job **p = &js->queue_head, *j, *prev = NULL;
    int found = 0;
    while ((j = *p)) {
        if ((c == NULL || j->info.conn == c) && (all_ids || j->info.id == id)) {
            *p = j->next;
            if (js->queue_tail == j) js->queue_tail = prev;
            js->queued--;
            vsdd_cancel_raise(j->info.cancel, reason);
            j->next = *removed;
            *removed = j;
            found = 1;
            continue;
        }
        prev = j;
        p = &j->next;
    }
    for (j = js->running; j; j = j->next)
        if ((c == NULL || j->info.conn == c) && (all_ids || j->info.id == id)) {
            vsdd_cancel_raise(j->info.cancel, reason);
            found = 1;
        }
    return found;
}

/* Lock not held: tell the removed jobs' clients (when `tell`) and free them. */
static void finish_removed(vsdd_jobs *js, job *removed, int tell)
{
    while (removed) {
        job *j = removed;
        removed = j->next;
        if (tell) {
            int shutdown = vsdd_cancel_reason(j->info.cancel) == VSDD_CANCEL_SHUTDOWN;
            vsdd_send_error_id(j->info.conn, j->info.id, 1, shutdown ? VSD_E_SHUTDOWN : VSD_E_CANCELLED,
                               shutdown ? "the daemon is shutting down" : "cancelled before it started", NULL);
        }
        vsdd_count(js->d->counters, VSDD_COUNT_CANCELLED, 1);
        free_job(js, j);
    }
}

static int cancel_and_finish(vsdd_jobs *js, vsdd_conn *c, double id, int all_ids, int reason, int tell)
{
    job *removed = NULL;
    int found;
    vsdd_lock(&js->lock);
    found = cancel_matching(js, c, id, all_ids, reason, &removed);
    vsdd_unlock(&js->lock);
    finish_removed(js, removed, tell);
    return found;
}

int vsdd_job_cancel(vsdd_jobs *js, vsdd_conn *c, double id)
{
    int found = cancel_and_finish(js, c, id, 0, VSDD_CANCEL_CLIENT, 1);
    if (found) vsdd_log(VSDD_LOG_INFO, "conn %u: job id %.0f cancelled by the client", c->id, id);
    return found;
}

void vsdd_jobs_cancel_conn(vsdd_jobs *js, vsdd_conn *c)
{
    if (cancel_and_finish(js, c, 0, 1, VSDD_CANCEL_DISCONNECT, 0))
        vsdd_log(VSDD_LOG_INFO, "conn %u: disconnected: its jobs are cancelled", c->id);
}

void vsdd_jobs_counts(vsdd_jobs *js, int *queued, int *running)
{
    job *j;
    int n = 0;
    vsdd_lock(&js->lock);
    *queued = js->queued;
    for (j = js->running; j; j = j->next) n++;
    *running = n;
    vsdd_unlock(&js->lock);
}

int vsdd_jobs_stopping(vsdd_jobs *js)
{
    int stopping;
    vsdd_lock(&js->lock);
    stopping = js->stopping;
    vsdd_unlock(&js->lock);
    return stopping;
}

void vsdd_jobs_stop(vsdd_jobs *js)
{
    job *removed = NULL;
    int i;
    /* in one hold of the lock, so that no worker starts a queued job meanwhile */
    vsdd_lock(&js->lock);
    js->stopping = 1;
    cancel_matching(js, NULL, 0, 1, VSDD_CANCEL_SHUTDOWN, &removed);
    pthread_cond_broadcast(&js->wake);
    vsdd_unlock(&js->lock);
    finish_removed(js, removed, 1);
    for (i = 0; i < js->worker_count; i++) pthread_join(js->workers[i], NULL);
    if (js->watchdog_started) pthread_join(js->watchdog, NULL);
    js->worker_count = 0;
    js->watchdog_started = 0;
}

void vsdd_jobs_free(vsdd_jobs *js)
{
    if (!js) return;
    free(js->workers);
    pthread_cond_destroy(&js->wake);
    vsdd_mutex_destroy(&js->lock);
    free(js);
}
