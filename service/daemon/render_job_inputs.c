/* Step 2 of a RENDER: where the scene's files are (blob names or confined paths), every
 * missing blob named at once (ERROR missing_blob with the list, so a client uploads them
 * in one go), then the volume grids and the map from the cache — loaded (by loader.h) on
 * a miss and pinned for this job. */
#define _GNU_SOURCE
#include "render_job_steps.h"
#include "policy.h"
#include <string.h>

static void note_missing(vsdd_cache *k, const char *src, cJSON **missing)
{
    if (strncmp(src, "blob:", 5) != 0 || vsdd_cache_has_blob(k, src + 5)) return;
    if (!*missing) *missing = cJSON_CreateArray();
    cJSON_AddItemToArray(*missing, cJSON_CreateString(src + 5));
}

int vsdd_step_inputs(vsdd_run *run)
{
    const vsdd_config *cfg = &run->d->cfg;
    vsdd_cache *k = run->d->cache;
    const vsd_scene *sc = &run->sc;
    const char *ior = vsd_scene_ior_grid(&sc->volumes[0]);
    char conversion[2 * VSD_NAME_LEN + 2];
    cJSON *missing = NULL;
    if (vsdd_resolve_source(cfg, "volume.file", sc->volumes[0].file, run->frame, run->vsrc, sizeof run->vsrc, &run->err))
        return VSDD_STEP_FAILED;
    run->esrc[0] = '\0';
    if (sc->environment.file[0] && vsdd_resolve_source(cfg, "environment.file", sc->environment.file, run->frame,
                                                       run->esrc, sizeof run->esrc, &run->err))
        return VSDD_STEP_FAILED;
    note_missing(k, run->vsrc, &missing);
    note_missing(k, run->esrc, &missing);
    if (missing) {
        run->extra = cJSON_CreateObject();
        cJSON_AddItemToObject(run->extra, "missing", missing);
        vsdd_fail(&run->err, VSD_E_MISSING_BLOB, "the scene names blobs the daemon does not have (PUT them)");
        return VSDD_STEP_FAILED;
    }
    vsdd_send_progress(run->job->conn, run->job->id, "load", 0.0f);
    if (vsdd_cache_get_volume(k, run->vsrc, sc->volumes[0].grid, sc->volumes[0].grid_index, &run->pins[0], &run->hits[0],
                              &run->err))
        return VSDD_STEP_FAILED;
    if (sc->volumes[0].emission_grid[0] &&
        vsdd_cache_get_volume(k, run->vsrc, sc->volumes[0].emission_grid, -1, &run->pins[1], &run->hits[1], &run->err))
        return VSDD_STEP_FAILED;
    if (run->esrc[0] &&
        vsdd_cache_get_env(k, run->esrc, vsd_scene_env_conversion(sc, conversion, sizeof conversion), &run->pins[2],
                           &run->hits[2], &run->err))
        return VSDD_STEP_FAILED;
    /* the refractive index's grid (volume.ior_grid / medium.ior_from), from the same file */
    if (ior[0] && vsdd_cache_get_volume(k, run->vsrc, ior, -1, &run->pins[3], &run->hits[3], &run->err))
        return VSDD_STEP_FAILED;
    return VSDD_STEP_OK;
}
