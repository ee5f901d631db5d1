/* Step 2 of a RENDER: where the scene's files are (blob names or confined paths, each volume
 * with the frame it reads), every missing blob of every volume named at once (ERROR
 * missing_blob with the list, so a client uploads them in one go), then each volume's
 * grids and the map from the cache — loaded (by loader.h) on a miss and pinned for this
 * job — with the voxel limit over all the volumes together. */
#define _GNU_SOURCE
#include "render_job_steps.h"
#include "policy.h"
#include <stdio.h>
#include <string.h>

static void note_missing(vsdd_cache *k, const char *src, cJSON **missing)
{
    const cJSON *it;
    if (strncmp(src, "blob:", 5) != 0 || vsdd_cache_has_blob(k, src + 5)) return;
    if (!*missing) *missing = cJSON_CreateArray();
    cJSON_ArrayForEach(it, *missing)
    {
        if (strcmp(it->valuestring, src + 5) == 0) return; /* two volumes of one file: listed once */
    }
    cJSON_AddItemToArray(*missing, cJSON_CreateString(src + 5));
}

/* An error about volumes[v] names it when the scene has several ("volumes[1]: ..."). */
static int name_volume(vsdd_run *run, int v)
{
    char inner[sizeof run->err.msg];
    if (run->sc.volume_count < 2) return -1;
    snprintf(inner, sizeof inner, "%s", run->err.msg);
    snprintf(run->err.msg, sizeof run->err.msg, "volumes[%d]: %.2030s", v, inner);
    return -1;
}

/* Where every file of the scene is; the blobs the daemon lacks go to *missing. */
static int resolve_sources(vsdd_run *run, cJSON **missing)
{
    const vsdd_config *cfg = &run->d->cfg;
    const vsd_scene *sc = &run->sc;
    int v;
    for (v = 0; v < sc->volume_count; v++) {
        const vsd_scene_volume *vol = &sc->volumes[v];
        char field[32];
        if (sc->volume_count > 1) snprintf(field, sizeof field, "volumes[%d].file", v);
        else snprintf(field, sizeof field, "volume.file");
        if (vsdd_resolve_source(cfg, field, vol->file, vsd_scene_volume_frame(vol, run->frame), run->vsrc[v],
                                sizeof run->vsrc[v], &run->err))
            return -1;
        note_missing(run->d->cache, run->vsrc[v], missing);
    }
    run->esrc[0] = '\0';
    if (sc->environment.file[0] && vsdd_resolve_source(cfg, "environment.file", sc->environment.file, run->frame,
                                                       run->esrc, sizeof run->esrc, &run->err))
        return -1;
    note_missing(run->d->cache, run->esrc, missing);
    return 0;
}

/* The density grid of every volume, and the limit on the voxels they hold together
 * (--max-voxels: one grid above it is refused by the decoder; here the sum over the
 * volumes). Checked as each is fetched, so a scene far above the limit loads no more. */
static int get_densities(vsdd_run *run)
{
    const vsd_scene *sc = &run->sc;
    uint64_t total = 0, max = run->d->cfg.max_voxels;
    int v;
    for (v = 0; v < sc->volume_count; v++) {
        const vsd_scene_volume *vol = &sc->volumes[v];
        int p = VSDD_PIN(v, VSDD_PIN_DENSITY);
        const vsd_volume *grid;
        if (vsdd_cache_get_volume(run->d->cache, run->vsrc[v], vol->grid, vol->grid_index, &run->pins[p],
                                  &run->hits[p], &run->err))
            return name_volume(run, v);
        grid = vsdd_entry_volume(run->pins[p]);
        total += grid ? grid->active_voxels : 0;
        if (total > max) {
            if (v + 1 == sc->volume_count)
                return vsdd_fail(&run->err, VSD_E_LIMIT,
                                 "volumes: %d volumes hold %llu active voxels together, above the daemon's limit of "
                                 "%llu (--max-voxels, the total over a scene's volumes)",
                                 sc->volume_count, (unsigned long long)total, (unsigned long long)max);
            return vsdd_fail(&run->err, VSD_E_LIMIT,
                             "volumes: volumes[0] to volumes[%d] of the scene's %d already hold %llu active voxels "
                             "together, above the daemon's limit of %llu (--max-voxels, the total over a scene's "
                             "volumes)",
                             v, sc->volume_count, (unsigned long long)total, (unsigned long long)max);
        }
    }
    return 0;
}

int vsdd_step_inputs(vsdd_run *run)
{
    vsdd_cache *k = run->d->cache;
    const vsd_scene *sc = &run->sc;
    char conversion[2 * VSD_NAME_LEN + 2];
    cJSON *missing = NULL;
    int v;
    if (resolve_sources(run, &missing)) {
        cJSON_Delete(missing);
        return VSDD_STEP_FAILED;
    }
    if (missing) {
        run->extra = cJSON_CreateObject();
        cJSON_AddItemToObject(run->extra, "missing", missing);
        vsdd_fail(&run->err, VSD_E_MISSING_BLOB, "the scene names blobs the daemon does not have (PUT them)");
        return VSDD_STEP_FAILED;
    }
    vsdd_send_progress(run->job->conn, run->job->id, "load", 0.0f);
    if (get_densities(run)) return VSDD_STEP_FAILED;
    for (v = 0; v < sc->volume_count; v++) {
        const vsd_scene_volume *vol = &sc->volumes[v];
        /* the refractive index's grid (ior_grid / medium.ior_from) comes from the same file */
        const char *ior = vsd_scene_ior_grid(vol);
        int pe = VSDD_PIN(v, VSDD_PIN_EMISSION), pi = VSDD_PIN(v, VSDD_PIN_IOR);
        if ((vol->emission_grid[0] && vsdd_cache_get_volume(k, run->vsrc[v], vol->emission_grid, -1, &run->pins[pe],
                                                            &run->hits[pe], &run->err)) ||
            (ior[0] && vsdd_cache_get_volume(k, run->vsrc[v], ior, -1, &run->pins[pi], &run->hits[pi], &run->err))) {
            name_volume(run, v);
            return VSDD_STEP_FAILED;
        }
    }
    if (run->esrc[0] &&
        vsdd_cache_get_env(k, run->esrc, vsd_scene_env_conversion(sc, conversion, sizeof conversion),
                           &run->pins[VSDD_PIN_ENV], &run->hits[VSDD_PIN_ENV], &run->err))
        return VSDD_STEP_FAILED;
    return VSDD_STEP_OK;
}
