/* Step 3 of a RENDER: a renderer for (method, options, inputs) from the cache — kept
 * between jobs, so a camera change re-renders from its preparation — then the render,
 * with progress to the client and the job's cancel (cancel.h) wired to the renderer's
 * flag. The slot's use record (cache.h) is this file's while the job holds the slot. */
#define _GNU_SOURCE
#include "render_job_steps.h"
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
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

/* Append printf text to a heap string (*buf of *cap bytes, grown); -1 when out of memory. */
static int append(char **buf, size_t *cap, size_t *used, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
static int append(char **buf, size_t *cap, size_t *used, const char *fmt, ...)
{
    va_list ap;
    int n;
    for (;;) {
        va_start(ap, fmt);
        n = vsnprintf(*buf + *used, *cap - *used, fmt, ap);
        va_end(ap);
        if (n < 0) return -1;
        if ((size_t)n < *cap - *used) break;
        {
            size_t ncap = *cap * 2 + (size_t)n;
            char *nb = realloc(*buf, ncap);
            if (!nb) return -1;
            *buf = nb;
            *cap = ncap;
        }
    }
    *used += (size_t)n;
    return 0;
}

/* The scene fields a renderer's preparation depends on (the camera is not one): every
 * volume's medium and matrix, the environment's strength, rotation and colour. Fitted into
 * out (vsdd_key_fit). */
static void prep_key_of(const vsd_scene *sc, char *out, size_t len)
{
    size_t cap = 4096, used = 0;
    char *key = malloc(cap);
    const float *c = sc->environment.color;
    int v, i, bad;
    if (!key) {
        snprintf(out, len, "(out of memory)"); /* never equal to a real key: no preparation hit */
        return;
    }
    key[0] = '\0';
    bad = append(&key, &cap, &used, "%.9g|%.9g|%.9g,%.9g,%.9g|%d", sc->environment.strength, sc->environment.rotation_z,
                 c[0], c[1], c[2], sc->volume_count);
    for (v = 0; v < sc->volume_count && !bad; v++) {
        const vsd_scene_medium *m = &sc->volumes[v].medium;
        const float *a = m->albedo, *e = m->emission_color;
        bad = append(&key, &cap, &used, "|%.9g|%.9g,%.9g,%.9g|%.9g|%.9g,%.9g,%.9g|%.9g|%.9g|", m->density, a[0], a[1],
                     a[2], m->anisotropy, e[0], e[1], e[2], m->emission_strength, m->ior);
        for (i = 0; i < 16 && !bad; i++) bad = append(&key, &cap, &used, "%.17g,", sc->volumes[v].matrix[i]);
    }
    if (bad) snprintf(out, len, "(out of memory)");
    else vsdd_key_fit(key, out, len);
    free(key);
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

/* The renderer slot's key: the method, its options, the map and every volume's sources
 * and grids (the inputs a renderer is made for); without the volumes (with_volumes 0), its
 * family: the renderers a new frame of some volumes may take over (vsdd_cache_get_slot).
 * Malloc'd; NULL when out of memory. */
static char *slot_key_of(const vsdd_run *run, int with_volumes)
{
    const vsd_scene *sc = &run->sc;
    char conversion[2 * VSD_NAME_LEN + 2];
    size_t cap = 8192, used = 0;
    char *key = malloc(cap);
    int v, bad;
    if (!key) return NULL;
    key[0] = '\0';
    bad = append(&key, &cap, &used, "%s|%s|%s|%s|%d", sc->render.method, sc->render.options_json, run->esrc,
                 vsd_scene_env_conversion(sc, conversion, sizeof conversion), sc->volume_count);
    for (v = 0; v < sc->volume_count && !bad && with_volumes; v++) {
        const vsd_scene_volume *vol = &sc->volumes[v];
        bad = append(&key, &cap, &used, "|%s|%s|%d|%s|%s", run->vsrc[v], vol->grid, vol->grid_index,
                     vol->emission_grid, vsd_scene_ior_grid(vol));
    }
    if (bad) {
        free(key);
        return NULL;
    }
    return key;
}

static int get_slot(vsdd_run *run)
{
    const vsd_scene *sc = &run->sc;
    char err[2048], *key = slot_key_of(run, 1), *family = slot_key_of(run, 0);
    volatile int wait_cancel;
    int rc;
    if (!key || !family) {
        free(key);
        free(family);
        return vsdd_fail(&run->err, VSD_E_INTERNAL, "out of memory");
    }
    /* a new renderer may wait for memory: a cancel, a disconnect or the job's time limit
     * ends the wait through this flag as it would end a render */
    vsdd_cancel_watch(run->job->cancel, &wait_cancel);
    rc = vsdd_cache_get_slot(run->d->cache, key, family, sc, run->pins, slot_progress, &wait_cancel, &run->slot,
                             &run->slot_hit, err, sizeof err);
    vsdd_cancel_unwatch(run->job->cancel);
    free(key);
    free(family);
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
    char prep[sizeof use->prep_key], err[2048];
    vsd_status st;
    int reason, rc;
    rc = get_slot(run);
    if (rc == -(int)VSD_ERR_CANCELLED) return cancelled(run, vsdd_cancel_reason(j->cancel));
    if (rc) return VSDD_STEP_FAILED;
    use = vsdd_slot_use_of(run->slot);
    prep_key_of(&run->sc, prep, sizeof prep);
    run->prep_hit = run->slot_hit == VSDD_SLOT_HIT && strcmp(prep, use->prep_key) == 0;
    use->job = j;
    use->last_stage[0] = '\0';
    use->last_fraction = 0;
    vsdd_cancel_watch(j->cancel, &use->cancel);
    {
        /* the film is the job's until it is kept with the slot after the reply
         * (vsdd_cache_keep_film), so what the render grows it by is not the renderer's */
        int64_t film_before;
        if (!run->fb) {
            run->fb = vsdd_cache_take_film(run->d->cache, run->slot);
            run->film_hit = run->fb && run->fb->width == run->sc.film.width && run->fb->height == run->sc.film.height;
        }
        film_before = vsdd_film_bytes(run->fb);
        vsdd_cache_render_begin(run->d->cache, run->slot);
        st = vsd_renderer_render(vsdd_slot_renderer(run->slot), run->frame, &run->fb, &run->stats, err, sizeof err);
        vsdd_cache_render_end(run->d->cache, run->slot, vsdd_film_bytes(run->fb) - film_before, st == VSD_OK);
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
