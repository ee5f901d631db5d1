/* Running one RENDER: parse the request, resolve and load its inputs, render, reply —
 * four steps sharing one record (render_job_steps.h) and one error; this file only runs
 * them, reports the outcome and releases what they took. */
#define _GNU_SOURCE
#include "render_job.h"
#include "render_job_steps.h"
#include "counters.h"
#include <stdlib.h>
#include <string.h>

static void report_outcome(vsdd_run *run, int rc)
{
    const vsdd_job_info *j = run->job;
    vsdd_counters *k = run->d->counters;
    if (rc == VSDD_STEP_OK) {
        vsdd_count(k, VSDD_COUNT_DONE, 1);
        return;
    }
    if (rc == VSDD_STEP_CANCELLED) {
        vsdd_log(VSDD_LOG_INFO, "job %lu: stopped after %.3fs: %s", j->seq, vsd_clock_seconds() - run->t_start,
                 run->err.msg);
        vsdd_count(k, VSDD_COUNT_CANCELLED, 1);
        if (run->cancel_reason == VSDD_CANCEL_DISCONNECT) return; /* nobody to tell */
    } else {
        vsdd_count(k, VSDD_COUNT_FAILED, 1);
    }
    vsdd_send_error_id(j->conn, j->id, 1, run->err.code ? run->err.code : VSD_E_INTERNAL, run->err.msg, run->extra);
    run->extra = NULL;
}

void vsdd_run_job(vsdd_daemon *d, const vsdd_job_info *j, int worker)
{
    vsdd_run *run = calloc(1, sizeof *run); /* ~100 KiB (16 volumes): off the worker's stack */
    int rc, i;
    if (!run) {
        vsdd_send_error_id(j->conn, j->id, 1, VSD_E_INTERNAL, "out of memory", NULL);
        vsdd_count(d->counters, VSDD_COUNT_FAILED, 1);
        return;
    }
    run->d = d;
    run->job = j;
    run->t_start = vsd_clock_seconds();
    vsdd_log(VSDD_LOG_INFO, "job %lu: running on worker %d (waited %.3fs)", j->seq, worker, run->t_start - j->queued_at);
    vsdd_send_progress(j->conn, j->id, "start", 0.0f);
    rc = vsdd_step_parse(run);
    if (rc == VSDD_STEP_OK) rc = vsdd_step_inputs(run);
    if (rc == VSDD_STEP_OK) rc = vsdd_step_render(run);
    if (rc == VSDD_STEP_OK) rc = vsdd_step_reply(run);
    report_outcome(run, rc);
    if (run->slot) {
        /* the next job of this renderer renders into this one's film (cache.h) */
        if (rc == VSDD_STEP_OK) vsdd_cache_keep_film(d->cache, run->slot, &run->fb);
        vsdd_cache_release_slot(d->cache, run->slot, 1);
    }
    for (i = 0; i < VSDD_SLOT_PINS; i++) vsdd_cache_unpin(d->cache, run->pins[i]);
    cJSON_Delete(run->extra);
    vsd_framebuffer_destroy(run->fb);
    free(run->scene_text);
    free(run);
}
