/* Step 4 of a RENDER: the frame's files, written by the library's own writer (the EXR,
 * and the preview PNG when asked) into the private cache folder, read back and sent as
 * RESULT with the job's stats, timings and cache hits. */
#define _GNU_SOURCE
#include "render_job_steps.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int read_whole(const char *path, unsigned char **data, size_t *len)
{
    FILE *f = fopen(path, "rb");
    long n;
    *data = NULL;
    *len = 0;
    if (!f) return -1;
    if (fseek(f, 0, SEEK_END) || (n = ftell(f)) < 0 || fseek(f, 0, SEEK_SET)) {
        fclose(f);
        return -1;
    }
    *data = malloc(n > 0 ? (size_t)n : 1);
    if (!*data || fread(*data, 1, (size_t)n, f) != (size_t)n) {
        free(*data);
        *data = NULL;
        fclose(f);
        return -1;
    }
    fclose(f);
    *len = (size_t)n;
    return 0;
}

static cJSON *hit_json(int used, int hit) { return used ? cJSON_CreateBool(hit) : cJSON_CreateNull(); }

/* "volume", "emission", "ior" of volumes[v]: found in the cache (true), loaded (false), not
 * used (null). */
static void add_volume_hits(cJSON *o, const vsdd_run *run, int v)
{
    const vsd_scene_volume *vol = &run->sc.volumes[v];
    cJSON_AddItemToObject(o, "volume", hit_json(1, run->hits[VSDD_PIN(v, VSDD_PIN_DENSITY)]));
    cJSON_AddItemToObject(o, "emission", hit_json(vol->emission_grid[0] != 0, run->hits[VSDD_PIN(v, VSDD_PIN_EMISSION)]));
    cJSON_AddItemToObject(o, "ior", hit_json(vsd_scene_ior_grid(vol)[0] != 0, run->hits[VSDD_PIN(v, VSDD_PIN_IOR)]));
}

static cJSON *result_json(const vsdd_run *run, size_t exr_len, size_t png_len, const char *note, double t_encode)
{
    const vsd_render_stats *stats = &run->stats;
    const vsd_scene *sc = &run->sc;
    cJSON *o = cJSON_CreateObject(), *t, *cache, *list;
    int v;
    cJSON_AddNumberToObject(o, "id", run->job->id);
    cJSON_AddNumberToObject(o, "frame", run->frame);
    cJSON_AddStringToObject(o, "method", stats->method);
    cJSON_AddStringToObject(o, "device", stats->device);
    if (stats->device_name[0]) cJSON_AddStringToObject(o, "device_name", stats->device_name);
    if (stats->device_note[0]) cJSON_AddStringToObject(o, "device_note", stats->device_note);
    if (stats->warnings[0]) cJSON_AddStringToObject(o, "warnings", stats->warnings);
    cJSON_AddNumberToObject(o, "samples", stats->samples);
    /* the method's own figures (what `vsd render` prints after the frame) */
    cJSON_AddStringToObject(o, "method_info", stats->method_info);
    cJSON_AddNumberToObject(o, "threads", stats->threads);
    cJSON_AddNumberToObject(o, "width", sc->film.width);
    cJSON_AddNumberToObject(o, "height", sc->film.height);
    cJSON_AddNumberToObject(o, "exr_bytes", (double)exr_len);
    cJSON_AddNumberToObject(o, "png_bytes", (double)png_len);
    if (run->preview && note[0]) cJSON_AddStringToObject(o, "preview_note", note);
    t = cJSON_AddObjectToObject(o, "timings");
    cJSON_AddNumberToObject(t, "queue", run->t_start - run->job->queued_at);
    cJSON_AddNumberToObject(t, "load", stats->load_seconds);
    cJSON_AddNumberToObject(t, "prepare", stats->prepare_seconds);
    cJSON_AddNumberToObject(t, "render", stats->render_seconds);
    cJSON_AddNumberToObject(t, "encode", t_encode);
    cJSON_AddNumberToObject(t, "total", vsd_clock_seconds() - run->t_start);
    cache = cJSON_AddObjectToObject(o, "cache");
    /* volumes[0]'s at the top (clients from before volumes[]), every volume's in "volumes" */
    add_volume_hits(cache, run, 0);
    cJSON_AddItemToObject(cache, "environment", hit_json(run->esrc[0] != 0, run->hits[VSDD_PIN_ENV]));
    cJSON_AddItemToObject(cache, "renderer", cJSON_CreateBool(run->slot_hit == VSDD_SLOT_HIT));
    /* a renderer of another frame of these volumes, handed the ones that changed */
    cJSON_AddItemToObject(cache, "renderer_taken_over", cJSON_CreateBool(run->slot_hit == VSDD_SLOT_TAKEN_OVER));
    cJSON_AddItemToObject(cache, "preparation", cJSON_CreateBool(run->prep_hit));
    cJSON_AddItemToObject(cache, "film", cJSON_CreateBool(run->film_hit));
    list = cJSON_AddArrayToObject(cache, "volumes");
    for (v = 0; v < sc->volume_count; v++) {
        cJSON *one = cJSON_CreateObject();
        add_volume_hits(one, run, v);
        cJSON_AddItemToArray(list, one);
    }
    return o;
}

/* The EXR in memory (the library's encoder of the file `vsd render` writes: no disk write,
 * fsync or read-back of a result sent at once; 1280x720 float passes, 63 MB: 0.11 s -> see
 * docs/daemon-bench.md) and the preview PNG through a file; the blobs' files stay pinned
 * meanwhile, because vsd/scene_hash reads them (the hash then equals the client's own). */
static int encode(vsdd_run *run, vsd_scene *out, unsigned char **exr, size_t *exr_len, unsigned char **png,
                  size_t *png_len, char *note, size_t notelen)
{
    char png_path[VSD_PATH_LEN], err[2048];
    vsdd_cache *k = run->d->cache;
    vsdd_entry *file_pins[VSD_MAX_VOLUMES + 1]; /* each volume's file, the map's */
    vsd_status st;
    int rc = -1, v;
    memset(file_pins, 0, sizeof file_pins);
    *out = run->sc;
    for (v = 0; v < out->volume_count; v++)
        if (vsdd_cache_pin_file(k, run->vsrc[v], out->volumes[v].file, sizeof out->volumes[v].file, &file_pins[v],
                                &run->err))
            goto done;
    if (run->esrc[0] && vsdd_cache_pin_file(k, run->esrc, out->environment.file, sizeof out->environment.file,
                                            &file_pins[VSD_MAX_VOLUMES], &run->err))
        goto done;
    snprintf(png_path, sizeof png_path, "%.960s/job-%lu.png", vsdd_cache_dir(k), run->job->seq);
    st = vsd_encode_frame_exr(out, run->frame, run->fb, &run->stats, exr, exr_len, err, sizeof err);
    if (!st && run->preview) {
        st = vsd_write_frame_preview(out, run->fb, png_path, note, notelen, err, sizeof err);
        if (!st && read_whole(png_path, png, png_len)) st = VSD_ERR_IO;
        unlink(png_path);
    }
    if (st) vsdd_fail(&run->err, VSD_E_RENDER_FAILED, "encoding the result failed: %.2000s", err);
    else rc = 0;
done:
    for (v = 0; v <= VSD_MAX_VOLUMES; v++) vsdd_cache_unpin(k, file_pins[v]);
    return rc;
}

int vsdd_step_reply(vsdd_run *run)
{
    const vsdd_job_info *j = run->job;
    vsd_scene *out = malloc(sizeof *out);
    unsigned char *exr = NULL, *png = NULL;
    size_t exr_len = 0, png_len = 0;
    char note[512] = "";
    double t_encode;
    int rc = VSDD_STEP_FAILED;
    if (!out) {
        vsdd_fail(&run->err, VSD_E_INTERNAL, "out of memory");
        return VSDD_STEP_FAILED;
    }
    vsdd_send_progress(j->conn, j->id, "encode", 0.0f);
    t_encode = vsd_clock_seconds();
    if (encode(run, out, &exr, &exr_len, &png, &png_len, note, sizeof note) == 0) {
        cJSON *o;
        t_encode = vsd_clock_seconds() - t_encode;
        o = result_json(run, exr_len, png_len, note, t_encode);
        vsdd_log(VSDD_LOG_INFO, "job %lu: frame %d %s %dx%d done in %.3fs (prepare %.3fs%s, render %.3fs, %zu bytes)",
                 j->seq, run->frame, run->stats.method, run->sc.film.width, run->sc.film.height,
                 vsd_clock_seconds() - run->t_start, run->stats.prepare_seconds, run->prep_hit ? " cached" : "",
                 run->stats.render_seconds, exr_len + png_len);
        vsdd_send2(j->conn, VSD_MSG_RESULT, o, exr, exr_len, png, png_len);
        rc = VSDD_STEP_OK;
    }
    free(out);
    free(exr);
    free(png);
    return rc;
}
