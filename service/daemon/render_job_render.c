/* Step 3 of a RENDER: a renderer for (method, options, inputs) from the cache — kept
 * between jobs, so a camera change re-renders from its preparation — then the render,
 * with progress to the client and the job's cancel (cancel.h) wired to the renderer's
 * flag. The slot's use record (cache.h) is this file's while the job holds the slot. */
#define _GNU_SOURCE
#include "render_job_steps.h"
#include <stdio.h>
#include <string.h>

static const char *code_for_status(vsd_status st)
{
    switch (st) {
    case VSD_ERR_IO: case VSD_ERR_FORMAT: return VSD_E_INPUT;
    case VSD_ERR_NOT_FOUND: case VSD_ERR_TYPE: case VSD_ERR_INVALID: case VSD_ERR_UNSUPPORTED: return VSD_E_INVALID_SCENE;
    case VSD_ERR_CANCELLED: return VSD_E_CANCELLED;
    default: return VSD_E_RENDER_FAILED;
    }
}

/* The scene fields a renderer's preparation depends on (the camera is not one). */
static void prep_key_of(const vsd_scene *sc, char *out, size_t len)
{
    const double *m = sc->volumes[0].matrix;
    const float *a = sc->volumes[0].medium.albedo, *e = sc->volumes[0].medium.emission_color, *c = sc->environment.color;
    int n = snprintf(out, len, "%.9g|%.9g,%.9g,%.9g|%.9g|%.9g,%.9g,%.9g|%.9g|%.9g|%.9g|%.9g,%.9g,%.9g|",
                     sc->volumes[0].medium.density, a[0], a[1], a[2], sc->volumes[0].medium.anisotropy, e[0], e[1], e[2],
                     sc->volumes[0].medium.emission_strength, sc->environment.strength, sc->environment.rotation_z, c[0], c[1],
                     c[2]);
    int i;
    for (i = 0; i < 16 && n > 0 && (size_t)n < len - 32; i++) n += snprintf(out + n, len - (size_t)n, "%.17g,", m[i]);
}

/* The renderer's progress callback (user = the slot): PROGRESS to the job rendering now on
 * every new stage and at its end; within a stage at most every 50 ms, when the fraction has
 * grown by 1%, or by anything once a second has passed (a slow render, e.g. raymarch at its
 * defaults, finishes a 16x16 tile every few seconds, far less than 1% of a large image: its
 * client still sees it advance and can estimate the time left). */
static void slot_progress(void *user, const char *stage, float fraction)
{
    vsdd_slot_use *s = user;
    const vsdd_job_info *j = s->job;
    double now = vsd_clock_seconds();
    int stage_changed;
    if (!j) return;
    stage_changed = strcmp(stage, s->last_stage) != 0;
    if (!stage_changed && fraction < 1.0f &&
        (now - s->last_progress_time < 0.05 || fraction <= s->last_fraction ||
         (fraction - s->last_fraction < 0.01f && now - s->last_progress_time < 1.0)))
        return;
    if (!stage_changed && fraction >= 1.0f && s->last_fraction >= 1.0f) return;
    snprintf(s->last_stage, sizeof s->last_stage, "%s", stage);
    s->last_fraction = fraction;
    s->last_progress_time = now;
    vsdd_send_progress(j->conn, j->id, stage, fraction);
}

static int get_slot(vsdd_run *run)
{
    const vsd_scene *sc = &run->sc;
    char key[12000], err[2048];
    volatile int wait_cancel;
    int rc;
    char conversion[2 * VSD_NAME_LEN + 2];
    snprintf(key, sizeof key, "%s|%s|%s|%s|%d|%s|%s|%s|%s", sc->render.method, sc->render.options_json, run->vsrc,
             sc->volumes[0].grid, sc->volumes[0].grid_index, sc->volumes[0].emission_grid, run->esrc,
             vsd_scene_env_conversion(sc, conversion, sizeof conversion), vsd_scene_ior_grid(&sc->volumes[0]));
    /* a new renderer may wait for memory: a cancel, a disconnect or the job's time limit
     * ends the wait through this flag as it would end a render */
    vsdd_cancel_watch(run->job->cancel, &wait_cancel);
    rc = vsdd_cache_get_slot(run->d->cache, key, sc, run->pins, slot_progress, &wait_cancel, &run->slot,
                             &run->slot_hit, err, sizeof err);
    vsdd_cancel_unwatch(run->job->cancel);
    memset(run->pins, 0, sizeof run->pins); /* the slot owns them now, or get_slot released them */
    if (rc == -(int)VSD_ERR_CANCELLED) return rc;
    if (rc) return vsdd_fail(&run->err, code_for_status((vsd_status)-rc), "%s", err);
    return 0;
}

/* The job's one error for a cancel (VSDD_CANCEL_* reason), while waiting or rendering. */
static int cancelled(vsdd_run *run, int reason)
{
    static const char *const reasons[] = {"cancelled", "cancelled by the client", "client disconnected",
                                          "the job ran past max_job_seconds", "the daemon is shutting down"};
    run->cancel_reason = reason;
    vsdd_fail(&run->err,
              reason == VSDD_CANCEL_TIMEOUT    ? VSD_E_TIMEOUT
              : reason == VSDD_CANCEL_SHUTDOWN ? VSD_E_SHUTDOWN
                                               : VSD_E_CANCELLED,
              "%s", reasons[reason >= 0 && reason < 5 ? reason : 0]);
    return VSDD_STEP_CANCELLED;
}

int vsdd_step_render(vsdd_run *run)
{
    const vsdd_job_info *j = run->job;
    vsdd_slot_use *use;
    char prep[1024], err[2048];
    vsd_status st;
    int reason, rc;
    rc = get_slot(run);
    if (rc == -(int)VSD_ERR_CANCELLED) return cancelled(run, vsdd_cancel_reason(j->cancel));
    if (rc) return VSDD_STEP_FAILED;
    use = vsdd_slot_use_of(run->slot);
    prep_key_of(&run->sc, prep, sizeof prep);
    run->prep_hit = run->slot_hit && strcmp(prep, use->prep_key) == 0;
    use->job = j;
    use->last_stage[0] = '\0';
    use->last_fraction = 0;
    vsdd_cancel_watch(j->cancel, &use->cancel);
    {
        /* the framebuffer the render makes is the job's (freed after the reply), not the
         * renderer's */
        int64_t fb_bytes = run->fb ? 0 : (int64_t)run->sc.film.width * run->sc.film.height * 17 * (int64_t)sizeof(float);
        vsdd_cache_render_begin(run->d->cache, run->slot);
        st = vsd_renderer_render(vsdd_slot_renderer(run->slot), run->frame, &run->fb, &run->stats, err, sizeof err);
        vsdd_cache_render_end(run->d->cache, run->slot, run->fb ? fb_bytes : 0, st == VSD_OK);
    }
    reason = vsdd_cancel_unwatch(j->cancel);
    use->job = NULL;
    if (st == VSD_OK && reason == VSDD_CANCEL_NONE) snprintf(use->prep_key, sizeof use->prep_key, "%s", prep);
    if (reason != VSDD_CANCEL_NONE || st == VSD_ERR_CANCELLED) return cancelled(run, reason);
    if (st) {
        vsdd_fail(&run->err, code_for_status(st), "%s", err);
        return VSDD_STEP_FAILED;
    }
    return VSDD_STEP_OK;
}
