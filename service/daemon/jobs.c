/* The job queue: a bounded FIFO (--queue) run by --workers threads, a watchdog for
 * max_job_seconds, and cancellation by CANCEL, disconnect, timeout or shutdown. */
#define _GNU_SOURCE
#include "jobs.h"
#include "render_job.h"
#include "reply.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static pthread_t *workers;
static int worker_count;
static pthread_t watchdog;
static int watchdog_started;

/* Lock held. */
static void set_cancel(vsdd_job *j, int reason)
{
    if (j->cancel_reason == VSDD_CANCEL_NONE) j->cancel_reason = reason;
    if (j->cancel_flag) *j->cancel_flag = 1;
}

static void *worker_main(void *arg)
{
    int index = (int)(long)arg;
    pthread_mutex_lock(&g_daemon.lock);
    for (;;) {
        vsdd_job *j;
        while (!g_daemon.queue_head && !g_daemon.stopping) pthread_cond_wait(&g_daemon.queue_cond, &g_daemon.lock);
        if (!g_daemon.queue_head) break;
        j = g_daemon.queue_head;
        g_daemon.queue_head = j->next;
        if (!g_daemon.queue_head) g_daemon.queue_tail = NULL;
        g_daemon.queued--;
        j->state = VSDD_JOB_RUNNING;
        j->started_at = vsd_clock_seconds();
        j->next = g_daemon.running;
        g_daemon.running = j;
        pthread_mutex_unlock(&g_daemon.lock);

        vsdd_run_job(j, index);

        pthread_mutex_lock(&g_daemon.lock);
        {
            vsdd_job **p;
            for (p = &g_daemon.running; *p; p = &(*p)->next)
                if (*p == j) {
                    *p = j->next;
                    break;
                }
        }
        vsdd_conn_release_locked(j->conn);
        cJSON_Delete(j->req);
        free(j);
    }
    pthread_mutex_unlock(&g_daemon.lock);
    return NULL;
}

static void *watchdog_main(void *arg)
{
    (void)arg;
    pthread_mutex_lock(&g_daemon.lock);
    while (!g_daemon.stopping) {
        struct timespec ts;
        vsdd_job *j;
        double now = vsd_clock_seconds();
        for (j = g_daemon.running; j; j = j->next)
            if (g_daemon.cfg.max_job_seconds > 0 && now - j->started_at > g_daemon.cfg.max_job_seconds)
                set_cancel(j, VSDD_CANCEL_TIMEOUT);
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_nsec += 100 * 1000000L;
        if (ts.tv_nsec >= 1000000000L) {
            ts.tv_sec++;
            ts.tv_nsec -= 1000000000L;
        }
        pthread_cond_timedwait(&g_daemon.queue_cond, &g_daemon.lock, &ts);
    }
    pthread_mutex_unlock(&g_daemon.lock);
    return NULL;
}

int vsdd_jobs_start(void)
{
    int i;
    worker_count = g_daemon.cfg.workers;
    workers = calloc((size_t)worker_count, sizeof *workers);
    if (!workers) return -1;
    for (i = 0; i < worker_count; i++)
        if (pthread_create(&workers[i], NULL, worker_main, (void *)(long)i) != 0) {
            worker_count = i;
            return -1;
        }
    if (pthread_create(&watchdog, NULL, watchdog_main, NULL) != 0) return -1;
    watchdog_started = 1;
    return 0;
}

int vsdd_job_submit(vsdd_conn *c, double id, cJSON *req, int *position)
{
    vsdd_job *j, *k;
    pthread_mutex_lock(&g_daemon.lock);
    if (g_daemon.stopping) {
        pthread_mutex_unlock(&g_daemon.lock);
        cJSON_Delete(req);
        return -2;
    }
    for (k = g_daemon.queue_head; k; k = k->next)
        if (k->conn == c && k->id == id) break;
    if (!k)
        for (k = g_daemon.running; k; k = k->next)
            if (k->conn == c && k->id == id) break;
    if (k) {
        pthread_mutex_unlock(&g_daemon.lock);
        cJSON_Delete(req);
        return -3;
    }
    if (g_daemon.queued >= g_daemon.cfg.queue_max) {
        g_daemon.jobs_busy++;
        pthread_mutex_unlock(&g_daemon.lock);
        cJSON_Delete(req);
        return -1;
    }
    j = calloc(1, sizeof *j);
    if (!j) {
        pthread_mutex_unlock(&g_daemon.lock);
        cJSON_Delete(req);
        return -1;
    }
    j->id = id;
    j->seq = ++g_daemon.next_job_seq;
    j->conn = c;
    c->refs++;
    j->req = req;
    j->state = VSDD_JOB_QUEUED;
    j->queued_at = vsd_clock_seconds();
    if (g_daemon.queue_tail) g_daemon.queue_tail->next = j;
    else g_daemon.queue_head = j;
    g_daemon.queue_tail = j;
    g_daemon.queued++;
    *position = g_daemon.queued;
    vsdd_log(VSDD_LOG_INFO, "conn %u: job %lu (id %.0f) queued at position %d", c->id, j->seq, id, *position);
    pthread_cond_broadcast(&g_daemon.queue_cond);
    pthread_mutex_unlock(&g_daemon.lock);
    return 0;
}

/* Lock held: drop queued jobs matching (c, id) — id < 0 with all_ids = every job of c. */
static int cancel_matching(vsdd_conn *c, double id, int all_ids, int reason, vsdd_job **removed)
{
    vsdd_job **p = &g_daemon.queue_head, *j, *prev = NULL;
    int found = 0;
    while ((j = *p)) {
        if ((c == NULL || j->conn == c) && (all_ids || j->id == id)) {
            *p = j->next;
            if (g_daemon.queue_tail == j) g_daemon.queue_tail = prev;
            g_daemon.queued--;
            j->cancel_reason = reason;
            j->next = *removed;
            *removed = j;
            found = 1;
            continue;
        }
        prev = j;
        p = &j->next;
    }
    for (j = g_daemon.running; j; j = j->next)
        if ((c == NULL || j->conn == c) && (all_ids || j->id == id)) {
            set_cancel(j, reason);
            found = 1;
        }
    return found;
}

static void finish_removed(vsdd_job *removed, int tell)
{
    while (removed) {
        vsdd_job *j = removed;
        removed = j->next;
        if (tell) {
            int shutdown = j->cancel_reason == VSDD_CANCEL_SHUTDOWN;
            vsdd_send_error_id(j->conn, j->id, 1, shutdown ? VSD_E_SHUTDOWN : VSD_E_CANCELLED,
                               shutdown ? "the daemon is shutting down" : "cancelled before it started", NULL);
        }
        pthread_mutex_lock(&g_daemon.lock);
        g_daemon.jobs_cancelled++;
        vsdd_conn_release_locked(j->conn);
        pthread_mutex_unlock(&g_daemon.lock);
        cJSON_Delete(j->req);
        free(j);
    }
}

int vsdd_job_cancel(vsdd_conn *c, double id)
{
    vsdd_job *removed = NULL;
    int found;
    pthread_mutex_lock(&g_daemon.lock);
    found = cancel_matching(c, id, 0, VSDD_CANCEL_CLIENT, &removed);
    pthread_mutex_unlock(&g_daemon.lock);
    finish_removed(removed, 1);
    if (found) vsdd_log(VSDD_LOG_INFO, "conn %u: job id %.0f cancelled by the client", c->id, id);
    return found;
}

void vsdd_jobs_cancel_conn(vsdd_conn *c)
{
    vsdd_job *removed = NULL;
    int found;
    pthread_mutex_lock(&g_daemon.lock);
    found = cancel_matching(c, 0, 1, VSDD_CANCEL_DISCONNECT, &removed);
    pthread_mutex_unlock(&g_daemon.lock);
    finish_removed(removed, 0);
    if (found) vsdd_log(VSDD_LOG_INFO, "conn %u: disconnected: its jobs are cancelled", c->id);
}

void vsdd_jobs_counts(int *queued, int *running)
{
    vsdd_job *j;
    int n = 0;
    pthread_mutex_lock(&g_daemon.lock);
    *queued = g_daemon.queued;
    for (j = g_daemon.running; j; j = j->next) n++;
    *running = n;
    pthread_mutex_unlock(&g_daemon.lock);
}

void vsdd_jobs_stop(void)
{
    vsdd_job *removed = NULL;
    int i;
    pthread_mutex_lock(&g_daemon.lock);
    g_daemon.stopping = 1;
    cancel_matching(NULL, 0, 1, VSDD_CANCEL_SHUTDOWN, &removed);
    pthread_cond_broadcast(&g_daemon.queue_cond);
    pthread_mutex_unlock(&g_daemon.lock);
    finish_removed(removed, 1);
    for (i = 0; i < worker_count; i++) pthread_join(workers[i], NULL);
    if (watchdog_started) pthread_join(watchdog, NULL);
    free(workers);
    workers = NULL;
    worker_count = 0;
}
