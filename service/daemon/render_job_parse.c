/* Step 1 of a RENDER: the request's fields (overrides, frame, preview), the scene (an
 * object or its JSON text; file names resolve against the first --allow-path folder) and
 * the film limits. */
#define _GNU_SOURCE
#include "render_job_steps.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int parse_fields(vsdd_run *run, const cJSON *req)
{
    const cJSON *jover = cJSON_GetObjectItemCaseSensitive(req, "overrides");
    const cJSON *jframe = cJSON_GetObjectItemCaseSensitive(req, "frame");
    const cJSON *jprev = cJSON_GetObjectItemCaseSensitive(req, "preview");
    const cJSON *it;
    if (jover && !cJSON_IsArray(jover))
        return vsdd_fail(&run->err, VSD_E_BAD_REQUEST, "RENDER.overrides: expected an array of \"key.path=value\" strings");
    cJSON_ArrayForEach(it, jover)
    {
        if (!cJSON_IsString(it) || run->n_over >= VSDD_MAX_JOB_OVERRIDES)
            return vsdd_fail(&run->err, VSD_E_BAD_REQUEST, "RENDER.overrides: expected at most %d strings",
                             VSDD_MAX_JOB_OVERRIDES);
        run->overrides[run->n_over++] = it->valuestring;
    }
    if (jframe && (!cJSON_IsNumber(jframe) || jframe->valuedouble != (double)(int)jframe->valuedouble ||
                   jframe->valuedouble < -1048574 || jframe->valuedouble > 1048574))
        return vsdd_fail(&run->err, VSD_E_BAD_REQUEST, "RENDER.frame: expected an integer frame number");
    if (jprev && !cJSON_IsBool(jprev))
        return vsdd_fail(&run->err, VSD_E_BAD_REQUEST, "RENDER.preview: expected true or false");
    run->preview = cJSON_IsTrue(jprev);
    return 0;
}

int vsdd_step_parse(vsdd_run *run)
{
    const vsdd_config *cfg = &run->d->cfg;
    const cJSON *req = run->job->req;
    const cJSON *jscene = cJSON_GetObjectItemCaseSensitive(req, "scene");
    const cJSON *jframe = cJSON_GetObjectItemCaseSensitive(req, "frame");
    char err[2048];
    vsd_status st;
    if (parse_fields(run, req)) return VSDD_STEP_FAILED;
    run->scene_text = cJSON_IsString(jscene) ? strdup(jscene->valuestring) : cJSON_PrintUnformatted(jscene);
    if (!run->scene_text) {
        vsdd_fail(&run->err, VSD_E_INTERNAL, "out of memory");
        return VSDD_STEP_FAILED;
    }
    st = vsd_scene_parse(run->scene_text, cfg->allow_count ? cfg->allow[0] : "", run->overrides, run->n_over, &run->sc,
                         err, sizeof err);
    if (st) {
        vsdd_fail(&run->err, st == VSD_ERR_FORMAT ? VSD_E_BAD_JSON : VSD_E_INVALID_SCENE, "scene: %.2000s", err);
        return VSDD_STEP_FAILED;
    }
    run->frame = jframe ? (int)jframe->valuedouble : run->sc.frames.start;
    if (run->sc.film.width > cfg->max_dim || run->sc.film.height > cfg->max_dim ||
        (uint64_t)run->sc.film.width * (uint64_t)run->sc.film.height > cfg->max_pixels) {
        vsdd_fail(&run->err, VSD_E_LIMIT, "film %dx%d is above the daemon's limits (%d per side, %llu pixels)",
                  run->sc.film.width, run->sc.film.height, cfg->max_dim, (unsigned long long)cfg->max_pixels);
        return VSDD_STEP_FAILED;
    }
    return VSDD_STEP_OK;
}
