/* render_job_steps.h — the four steps of a RENDER (render_job.c runs them in order) and
 * the record they share. Each step returns VSDD_STEP_OK, or fills run->err (the one error
 * of the job) and returns VSDD_STEP_FAILED or VSDD_STEP_CANCELLED. */
#ifndef VSD_DAEMON_RENDER_JOB_STEPS_H
#define VSD_DAEMON_RENDER_JOB_STEPS_H
#include "cache.h"
#include "render_job.h"

#define VSDD_MAX_JOB_OVERRIDES 256
enum { VSDD_STEP_OK = 0, VSDD_STEP_FAILED = -1, VSDD_STEP_CANCELLED = -2 };

typedef struct vsdd_run {
    vsdd_daemon *d;                /* the configuration and the cache the steps use */
    const vsdd_job_info *job;
    double t_start;
    /* parse: the request */
    const char *overrides[VSDD_MAX_JOB_OVERRIDES];
    int n_over;
    char *scene_text;
    vsd_scene sc;
    int frame, preview;
    /* inputs: sources and the cache entries pinned for this job. vsrc[v]: where volumes[v]
     * reads its frame (vsd_scene_volume_frame) from, "blob:<hash>" or a confined path */
    char vsrc[VSD_MAX_VOLUMES][VSD_PATH_LEN + 8], esrc[VSD_PATH_LEN + 8];
    /* the map and each volume's density, emission, ior grid (cache.h: VSDD_PIN_ENV,
     * VSDD_PIN(v, ...)); NULL once a slot owns them. hits: each was found in the cache */
    vsdd_entry *pins[VSDD_SLOT_PINS];
    int hits[VSDD_SLOT_PINS];
    /* render */
    vsdd_slot *slot;
    int slot_hit, prep_hit, film_hit, cancel_reason; /* film_hit: rendered into the slot's kept film */
    vsd_framebuffer *fb;
    vsd_render_stats stats;
    /* the outcome when not OK; extra: fields added to the ERROR (e.g. "missing"), owned */
    vsdd_err err;
    cJSON *extra;
} vsdd_run;

int vsdd_step_parse(vsdd_run *run);   /* render_job_parse.c: request fields, scene, film limits */
int vsdd_step_inputs(vsdd_run *run);  /* render_job_inputs.c: sources, missing blobs, cache fetches */
int vsdd_step_render(vsdd_run *run);  /* render_job_render.c: renderer slot, render, cancel */
int vsdd_step_reply(vsdd_run *run);   /* render_job_reply.c: EXR (+PNG) written and sent as RESULT */

#endif
