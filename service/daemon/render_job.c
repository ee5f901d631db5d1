/* Running one RENDER on a worker thread: parse the scene (blob: names or confined server
 * paths), check the limits, take volumes / map / renderer from the caches, render with
 * progress and cancel, encode the EXR (and preview PNG) with the library's writer into the
 * cache folder, and send the bytes back as RESULT. */
#define _GNU_SOURCE
#include "daemon.h"
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_JOB_OVERRIDES 256

void vsdd_slot_progress(void *user, const char *stage, float fraction)
{
    vsdd_slot *s = user;
    vsdd_job *j = s->job;
    double now = vsdd_now();
    int stage_changed;
    cJSON *o;
    if (!j) return;
    stage_changed = strcmp(stage, s->last_stage) != 0;
    if (!stage_changed && fraction < 1.0f &&
        (fraction - s->last_fraction < 0.01f || now - s->last_progress_time < 0.05))
        return;
    if (!stage_changed && fraction >= 1.0f && s->last_fraction >= 1.0f) return;
    snprintf(s->last_stage, sizeof s->last_stage, "%s", stage);
    s->last_fraction = fraction;
    s->last_progress_time = now;
    o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "id", j->id);
    cJSON_AddStringToObject(o, "stage", stage);
    cJSON_AddNumberToObject(o, "fraction", fraction);
    vsdd_send(j->conn, VSD_MSG_PROGRESS, o, NULL, 0);
}

static void send_progress(vsdd_job *j, const char *stage, float fraction)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "id", j->id);
    cJSON_AddStringToObject(o, "stage", stage);
    cJSON_AddNumberToObject(o, "fraction", fraction);
    vsdd_send(j->conn, VSD_MSG_PROGRESS, o, NULL, 0);
}

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

/* Where a scene file field points: "blob:<hash>" (checked) or a path confined to --allow-path. */
static int resolve_source(const char *field, const char *file, int frame, char *src, size_t len, const char **code,
                          char *msg, size_t msglen)
{
    char path[VSD_PATH_LEN], err[512];
    if (strncmp(file, "blob:", 5) == 0) {
        if (vsd_hash_kind_of(file + 5) == VSD_HASH_NONE) {
            *code = VSD_E_BAD_HASH;
            snprintf(msg, msglen, "%s: \"%.200s\": a blob name is blob:<32 or 64 lowercase hex digits>", field, file);
            return -1;
        }
        snprintf(src, len, "%s", file);
        return 0;
    }
    if (vsd_frame_path(file, frame, path, sizeof path, err, sizeof err)) {
        *code = VSD_E_INVALID_SCENE;
        snprintf(msg, msglen, "%s: %s", field, err);
        return -1;
    }
    if (!g_daemon.cfg.allow_count) {
        *code = VSD_E_PATH_DENIED;
        snprintf(msg, msglen, "%s: this daemon takes blob:<hash> names only (start it with --allow-path DIR "
                              "to allow server-side files)", field);
        return -1;
    }
    if (vsdd_path_allowed(path, src, len)) {
        *code = VSD_E_PATH_DENIED;
        snprintf(msg, msglen, "%s: \"%.300s\" is missing or outside the folders allowed by --allow-path", field, path);
        return -1;
    }
    return 0;
}

static const char *code_for_status(vsd_status st)
{
    switch (st) {
    case VSD_ERR_IO: case VSD_ERR_FORMAT: return VSD_E_INPUT;
    case VSD_ERR_NOT_FOUND: case VSD_ERR_TYPE: case VSD_ERR_INVALID: case VSD_ERR_UNSUPPORTED: return VSD_E_INVALID_SCENE;
    case VSD_ERR_CANCELLED: return VSD_E_CANCELLED;
    default: return VSD_E_RENDER_FAILED;
    }
}

static void prep_key_of(const vsd_scene *sc, char *out, size_t len)
{
    const double *m = sc->volume.matrix;
    const float *a = sc->medium.albedo, *e = sc->medium.emission_color, *c = sc->environment.color;
    int n = snprintf(out, len, "%.9g|%.9g,%.9g,%.9g|%.9g|%.9g,%.9g,%.9g|%.9g|%.9g|%.9g|%.9g,%.9g,%.9g|",
                     sc->medium.density, a[0], a[1], a[2], sc->medium.anisotropy, e[0], e[1], e[2],
                     sc->medium.emission_strength, sc->environment.strength, sc->environment.rotation_z, c[0], c[1],
                     c[2]);
    int i;
    for (i = 0; i < 16 && n > 0 && (size_t)n < len - 32; i++) n += snprintf(out + n, len - (size_t)n, "%.17g,", m[i]);
}

static cJSON *hit_json(int used, int hit)
{
    return used ? cJSON_CreateBool(hit) : cJSON_CreateNull();
}

void vsdd_run_job(vsdd_job *j, int worker)
{
    vsdd_conn *c = j->conn;
    const cJSON *req = j->req;
    const cJSON *jscene = cJSON_GetObjectItemCaseSensitive(req, "scene");
    const cJSON *jover = cJSON_GetObjectItemCaseSensitive(req, "overrides");
    const cJSON *jframe = cJSON_GetObjectItemCaseSensitive(req, "frame");
    const cJSON *jprev = cJSON_GetObjectItemCaseSensitive(req, "preview");
    const char *overrides[MAX_JOB_OVERRIDES];
    const char *code = NULL;
    char *text = NULL, msg[2048], err[2048];
    char vsrc[VSD_PATH_LEN + 8], esrc[VSD_PATH_LEN + 8], key[12000], prep[1024];
    char exr_path[VSD_PATH_LEN], png_path[VSD_PATH_LEN], note[512];
    vsd_scene sc, out;
    vsdd_entry *pins[VSDD_SLOT_PINS] = {NULL, NULL, NULL, NULL};
    vsdd_entry *file_pins[2] = {NULL, NULL}; /* the blobs' files while the EXR is hashed */
    vsdd_slot *slot = NULL;
    vsd_framebuffer *fb = NULL;
    vsd_render_stats stats;
    unsigned char *exr = NULL, *png = NULL;
    size_t exr_len = 0, png_len = 0;
    int n_over = 0, frame, preview = 0, hits[4] = {0, 0, 0, 0}, slot_hit = 0, prep_hit = 0, reason;
    double t_start = vsdd_now(), t_render = 0, t_encode = 0;
    vsd_status st;
    cJSON *o, *t, *cache, *missing = NULL;

    memset(&stats, 0, sizeof stats);
    vsdd_log(VSDD_LOG_INFO, "job %lu: running on worker %d (waited %.3fs)", j->seq, worker, t_start - j->queued_at);
    send_progress(j, "start", 0.0f);
    /* --- the request ------------------------------------------------------------------ */
    if (jover && !cJSON_IsArray(jover)) {
        code = VSD_E_BAD_REQUEST;
        snprintf(msg, sizeof msg, "RENDER.overrides: expected an array of \"key.path=value\" strings");
        goto fail;
    }
    if (jover) {
        const cJSON *it;
        cJSON_ArrayForEach(it, jover)
        {
            if (!cJSON_IsString(it) || n_over >= MAX_JOB_OVERRIDES) {
                code = VSD_E_BAD_REQUEST;
                snprintf(msg, sizeof msg, "RENDER.overrides: expected at most %d strings", MAX_JOB_OVERRIDES);
                goto fail;
            }
            overrides[n_over++] = it->valuestring;
        }
    }
    if (jframe && (!cJSON_IsNumber(jframe) || jframe->valuedouble != (double)(int)jframe->valuedouble ||
                   jframe->valuedouble < -1048574 || jframe->valuedouble > 1048574)) {
        code = VSD_E_BAD_REQUEST;
        snprintf(msg, sizeof msg, "RENDER.frame: expected an integer frame number");
        goto fail;
    }
    if (jprev && !cJSON_IsBool(jprev)) {
        code = VSD_E_BAD_REQUEST;
        snprintf(msg, sizeof msg, "RENDER.preview: expected true or false");
        goto fail;
    }
    preview = cJSON_IsTrue(jprev);
    text = cJSON_IsString(jscene) ? strdup(jscene->valuestring) : cJSON_PrintUnformatted(jscene);
    if (!text) {
        code = VSD_E_INTERNAL;
        snprintf(msg, sizeof msg, "out of memory");
        goto fail;
    }
    st = vsd_scene_parse(text, g_daemon.cfg.allow_count ? g_daemon.cfg.allow[0] : "", overrides, n_over, &sc, err,
                         sizeof err);
    if (st) {
        code = st == VSD_ERR_FORMAT ? VSD_E_BAD_JSON : VSD_E_INVALID_SCENE;
        snprintf(msg, sizeof msg, "scene: %.2000s", err);
        goto fail;
    }
    frame = jframe ? (int)jframe->valuedouble : sc.frames.start;
    if (sc.film.width > g_daemon.cfg.max_dim || sc.film.height > g_daemon.cfg.max_dim ||
        (uint64_t)sc.film.width * (uint64_t)sc.film.height > g_daemon.cfg.max_pixels) {
        code = VSD_E_LIMIT;
        snprintf(msg, sizeof msg, "film %dx%d is above the daemon's limits (%d per side, %llu pixels)", sc.film.width,
                 sc.film.height, g_daemon.cfg.max_dim, (unsigned long long)g_daemon.cfg.max_pixels);
        goto fail;
    }
    /* --- inputs: blob names or confined paths; every missing blob at once ------------ */
    if (resolve_source("volume.file", sc.volume.file, frame, vsrc, sizeof vsrc, &code, msg, sizeof msg)) goto fail;
    esrc[0] = '\0';
    if (sc.environment.file[0] &&
        resolve_source("environment.file", sc.environment.file, frame, esrc, sizeof esrc, &code, msg, sizeof msg))
        goto fail;
    if (strncmp(vsrc, "blob:", 5) == 0 && !vsdd_cache_has_blob(vsrc + 5)) {
        if (!missing) missing = cJSON_CreateArray();
        cJSON_AddItemToArray(missing, cJSON_CreateString(vsrc + 5));
    }
    if (strncmp(esrc, "blob:", 5) == 0 && !vsdd_cache_has_blob(esrc + 5)) {
        if (!missing) missing = cJSON_CreateArray();
        cJSON_AddItemToArray(missing, cJSON_CreateString(esrc + 5));
    }
    if (missing) {
        cJSON *x = cJSON_CreateObject();
        cJSON_AddItemToObject(x, "missing", missing);
        missing = NULL;
        vsdd_send_error_id(c, j->id, 1, VSD_E_MISSING_BLOB, "the scene names blobs the daemon does not have (PUT them)", x);
        goto failed_sent;
    }
    send_progress(j, "load", 0.0f);
    if (vsdd_cache_get_volume(vsrc, sc.volume.grid, sc.volume.grid_index, &pins[0], &hits[0], &code, msg, sizeof msg))
        goto fail;
    if (sc.volume.emission_grid[0] &&
        vsdd_cache_get_volume(vsrc, sc.volume.emission_grid, -1, &pins[1], &hits[1], &code, msg, sizeof msg))
        goto fail;
    if (esrc[0] && vsdd_cache_get_env(esrc, sc.environment.colorspace, &pins[2], &hits[2], &code, msg, sizeof msg))
        goto fail;
    /* the refractive index's grid (volume.ior_grid / medium.ior_from), from the same file */
    if (vsd_scene_ior_grid(&sc)[0] &&
        vsdd_cache_get_volume(vsrc, vsd_scene_ior_grid(&sc), -1, &pins[3], &hits[3], &code, msg, sizeof msg))
        goto fail;
    /* --- the renderer: one per (method, options, inputs) ------------------------------- */
    snprintf(key, sizeof key, "%s|%s|%s|%s|%d|%s|%s|%s|%s", sc.render.method, sc.render.options_json, vsrc,
             sc.volume.grid, sc.volume.grid_index, sc.volume.emission_grid, esrc, sc.environment.colorspace,
             vsd_scene_ior_grid(&sc));
    {
        int rc = vsdd_cache_get_slot(key, &sc, pins, &slot, &slot_hit, err, sizeof err);
        if (rc) {
            pins[0] = pins[1] = pins[2] = pins[3] = NULL; /* get_slot releases them when it fails */
            code = code_for_status((vsd_status)-rc);
            snprintf(msg, sizeof msg, "%s", err);
            goto fail;
        }
        pins[0] = pins[1] = pins[2] = pins[3] = NULL; /* the slot owns them now */
    }
    prep_key_of(&sc, prep, sizeof prep);
    prep_hit = slot_hit && strcmp(prep, slot->prep_key) == 0;
    pthread_mutex_lock(&g_daemon.lock);
    reason = j->cancel_reason;
    slot->cancel = reason != VSDD_CANCEL_NONE;
    j->cancel_flag = &slot->cancel;
    slot->job = j;
    slot->last_stage[0] = '\0';
    slot->last_fraction = 0;
    pthread_mutex_unlock(&g_daemon.lock);
    t_render = vsdd_now();
    st = vsd_renderer_render(slot->r, frame, &fb, &stats, err, sizeof err);
    t_render = vsdd_now() - t_render;
    pthread_mutex_lock(&g_daemon.lock);
    j->cancel_flag = NULL;
    slot->job = NULL;
    reason = j->cancel_reason;
    pthread_mutex_unlock(&g_daemon.lock);
    if (st == VSD_OK && reason == VSDD_CANCEL_NONE) snprintf(slot->prep_key, sizeof slot->prep_key, "%s", prep);
    if (reason != VSDD_CANCEL_NONE || st == VSD_ERR_CANCELLED) {
        static const char *const reasons[] = {"cancelled", "cancelled by the client", "client disconnected",
                                              "the job ran past max_job_seconds", "the daemon is shutting down"};
        code = reason == VSDD_CANCEL_TIMEOUT ? VSD_E_TIMEOUT : reason == VSDD_CANCEL_SHUTDOWN ? VSD_E_SHUTDOWN : VSD_E_CANCELLED;
        snprintf(msg, sizeof msg, "%s", reasons[reason < 5 ? reason : 0]);
        vsdd_log(VSDD_LOG_INFO, "job %lu: stopped after %.3fs: %s", j->seq, vsdd_now() - t_start, msg);
        pthread_mutex_lock(&g_daemon.lock);
        g_daemon.jobs_cancelled++;
        pthread_mutex_unlock(&g_daemon.lock);
        if (reason != VSDD_CANCEL_DISCONNECT) vsdd_send_error_id(c, j->id, 1, code, msg, NULL);
        goto done;
    }
    if (st) {
        code = code_for_status(st);
        snprintf(msg, sizeof msg, "%s", err);
        goto fail;
    }
    /* --- the files, written by the library's own writer ------------------------------ */
    send_progress(j, "encode", 0.0f);
    t_encode = vsdd_now();
    out = sc;
    /* vsd/scene_hash reads the files' bytes: point the copy at the daemon's files, pinned
     * until written (the hash then equals the client's own for --continue). */
    if (vsdd_cache_pin_file(vsrc, out.volume.file, sizeof out.volume.file, &file_pins[0], &code, msg, sizeof msg) ||
        (esrc[0] && vsdd_cache_pin_file(esrc, out.environment.file, sizeof out.environment.file, &file_pins[1], &code,
                                        msg, sizeof msg)))
        goto fail;
    snprintf(exr_path, sizeof exr_path, "%.960s/job-%lu.exr", g_daemon.cfg.cache_dir, j->seq);
    snprintf(png_path, sizeof png_path, "%.960s/job-%lu.png", g_daemon.cfg.cache_dir, j->seq);
    snprintf(out.output.exr, sizeof out.output.exr, "%s", exr_path);
    if (preview) snprintf(out.output.preview_png, sizeof out.output.preview_png, "%s", png_path);
    else out.output.preview_png[0] = '\0';
    st = vsd_write_frame_outputs(&out, frame, fb, &stats, NULL, 0, note, sizeof note, err, sizeof err);
    if (!st && read_whole(exr_path, &exr, &exr_len)) st = VSD_ERR_IO;
    if (!st && preview && read_whole(png_path, &png, &png_len)) st = VSD_ERR_IO;
    unlink(exr_path);
    unlink(png_path);
    t_encode = vsdd_now() - t_encode;
    if (st) {
        code = VSD_E_RENDER_FAILED;
        snprintf(msg, sizeof msg, "encoding the result failed: %.2000s", err);
        goto fail;
    }
    o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "id", j->id);
    cJSON_AddNumberToObject(o, "frame", frame);
    cJSON_AddStringToObject(o, "method", stats.method);
    cJSON_AddStringToObject(o, "device", stats.device);
    if (stats.device_name[0]) cJSON_AddStringToObject(o, "device_name", stats.device_name);
    if (stats.device_note[0]) cJSON_AddStringToObject(o, "device_note", stats.device_note);
    if (stats.warnings[0]) cJSON_AddStringToObject(o, "warnings", stats.warnings);
    cJSON_AddNumberToObject(o, "samples", stats.samples);
    cJSON_AddNumberToObject(o, "threads", stats.threads);
    cJSON_AddNumberToObject(o, "width", sc.film.width);
    cJSON_AddNumberToObject(o, "height", sc.film.height);
    cJSON_AddNumberToObject(o, "exr_bytes", (double)exr_len);
    cJSON_AddNumberToObject(o, "png_bytes", (double)png_len);
    if (preview && note[0]) cJSON_AddStringToObject(o, "preview_note", note);
    t = cJSON_AddObjectToObject(o, "timings");
    cJSON_AddNumberToObject(t, "queue", t_start - j->queued_at);
    cJSON_AddNumberToObject(t, "load", stats.load_seconds);
    cJSON_AddNumberToObject(t, "prepare", stats.prepare_seconds);
    cJSON_AddNumberToObject(t, "render", stats.render_seconds);
    cJSON_AddNumberToObject(t, "encode", t_encode);
    cJSON_AddNumberToObject(t, "total", vsdd_now() - t_start);
    cache = cJSON_AddObjectToObject(o, "cache");
    cJSON_AddItemToObject(cache, "volume", hit_json(1, hits[0]));
    cJSON_AddItemToObject(cache, "emission", hit_json(sc.volume.emission_grid[0] != 0, hits[1]));
    cJSON_AddItemToObject(cache, "environment", hit_json(esrc[0] != 0, hits[2]));
    cJSON_AddItemToObject(cache, "ior", hit_json(vsd_scene_ior_grid(&sc)[0] != 0, hits[3]));
    cJSON_AddItemToObject(cache, "renderer", cJSON_CreateBool(slot_hit));
    cJSON_AddItemToObject(cache, "preparation", cJSON_CreateBool(prep_hit));
    vsdd_log(VSDD_LOG_INFO, "job %lu: frame %d %s %dx%d done in %.3fs (prepare %.3fs%s, render %.3fs, %zu bytes)",
             j->seq, frame, stats.method, sc.film.width, sc.film.height, vsdd_now() - t_start, stats.prepare_seconds,
             prep_hit ? " cached" : "", stats.render_seconds, exr_len + png_len);
    vsdd_send2(c, VSD_MSG_RESULT, o, exr, exr_len, png, png_len);
    pthread_mutex_lock(&g_daemon.lock);
    g_daemon.jobs_done++;
    pthread_mutex_unlock(&g_daemon.lock);
    goto done;
fail:
    vsdd_send_error_id(c, j->id, 1, code ? code : VSD_E_INTERNAL, msg, NULL);
failed_sent:
    pthread_mutex_lock(&g_daemon.lock);
    g_daemon.jobs_failed++;
    pthread_mutex_unlock(&g_daemon.lock);
done:
    (void)t_render;
    if (slot) vsdd_cache_release_slot(slot, 1);
    vsdd_cache_unpin(pins[0]);
    vsdd_cache_unpin(pins[1]);
    vsdd_cache_unpin(pins[2]);
    vsdd_cache_unpin(pins[3]);
    vsdd_cache_unpin(file_pins[0]);
    vsdd_cache_unpin(file_pins[1]);
    cJSON_Delete(missing);
    vsd_framebuffer_destroy(fb);
    free(exr);
    free(png);
    free(text);
}
