/* `vsd render --remote`: hash the scene's local inputs (each volume's file for the frame
 * it reads, and the map), upload what the daemon lacks,
 * render each frame through it, and write the returned EXR / PNG bytes where in-process
 * rendering writes its files. The daemon encodes them with the same library writer
 * (vsd_write_frame_outputs), so the files carry the same channels and attributes. */
#define _GNU_SOURCE
#include "render_remote.h"
#include "commands.h"
#include "render_progress.h"
#include "vsd_client.h"
#include <cjson/cJSON.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_SENT_OVERRIDES 300

static int read_text(const char *path, char **out)
{
    FILE *f = fopen(path, "rb");
    long n;
    *out = NULL;
    if (!f) return -1;
    if (fseek(f, 0, SEEK_END) || (n = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) || !(*out = malloc((size_t)n + 1)) ||
        fread(*out, 1, (size_t)n, f) != (size_t)n) {
        free(*out);
        *out = NULL;
        fclose(f);
        return -1;
    }
    (*out)[n] = '\0';
    fclose(f);
    return 0;
}

static int make_parent_dirs(const char *path)
{
    char buf[VSD_PATH_LEN];
    char *p;
    snprintf(buf, sizeof buf, "%s", path);
    p = strrchr(buf, '/');
    if (!p || p == buf) return 0;
    *p = '\0';
    for (p = buf + 1; *p; p++) {
        if (*p != '/') continue;
        *p = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST) return -1;
        *p = '/';
    }
    return mkdir(buf, 0777) != 0 && errno != EEXIST ? -1 : 0;
}

/* Write bytes to path through a temporary file in the same folder, renamed on success. */
static int write_file_atomic(const char *path, const unsigned char *data, size_t len, char *err, size_t errlen)
{
    char tmp[VSD_PATH_LEN + 16];
    FILE *f;
    if (make_parent_dirs(path)) {
        snprintf(err, errlen, "%s: cannot create its folder: %s", path, strerror(errno));
        return -1;
    }
    snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid());
    f = fopen(tmp, "wb");
    if (!f || fwrite(data, 1, len, f) != len || fclose(f) != 0) {
        snprintf(err, errlen, "%s: cannot write: %s", tmp, strerror(errno));
        if (f) unlink(tmp);
        return -1;
    }
    if (rename(tmp, path) != 0) {
        snprintf(err, errlen, "%s: cannot rename into place: %s", path, strerror(errno));
        unlink(tmp);
        return -1;
    }
    return 0;
}

static int exit_code_for_server(const char *code)
{
    static const char *const input[] = {"invalid_scene", "bad_input", "missing_blob", "path_denied",
                                        "limit", "bad_hash", "bad_json", "bad_request", NULL};
    int i;
    if (strcmp(code, "cancelled") == 0) return VSD_EXIT_CANCELLED;
    for (i = 0; input[i]; i++)
        if (strcmp(code, input[i]) == 0) return VSD_EXIT_INPUT;
    return VSD_EXIT_RENDER_FAILED;
}

static double num(const cJSON *o, const char *a, const char *b)
{
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(o, a);
    if (b) x = cJSON_GetObjectItemCaseSensitive(x, b);
    return cJSON_IsNumber(x) ? x->valuedouble : 0;
}

static const char *str(const cJSON *o, const char *a)
{
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(o, a);
    return cJSON_IsString(x) ? x->valuestring : "";
}

/* Upload the file each volume of the scene reads for `frame` (its frame_offset applied),
 * unless the daemon has it, and name it in overrides[v] ("volume.file=\"blob:...\"" for a
 * scene of one volume, which every daemon reads, else "volumes.V.file=..."). *sent gets the
 * bytes uploaded. A file two volumes read is hashed once. */
static int upload_volumes(vsdc *c, const vsd_scene *scene, int frame, char overrides[][200], uint64_t *sent,
                          char *err, size_t errlen)
{
    char paths[VSD_MAX_VOLUMES][VSD_PATH_LEN], blobs[VSD_MAX_VOLUMES][128];
    int v, w;
    *sent = 0;
    for (v = 0; v < scene->volume_count && v < VSD_MAX_VOLUMES; v++) {
        const vsd_scene_volume *vol = &scene->volumes[v];
        uint64_t up = 0;
        if (vsd_frame_path(vol->file, vsd_scene_volume_frame(vol, frame), paths[v], sizeof paths[v], err, errlen))
            return -1;
        for (w = 0; w < v && strcmp(paths[w], paths[v]) != 0; w++) {}
        if (w < v) {
            snprintf(blobs[v], sizeof blobs[v], "%s", blobs[w]);
        } else if (vsdc_upload_file(c, paths[v], blobs[v], sizeof blobs[v], &up, err, errlen)) {
            if (scene->volume_count > 1) {
                char inner[1024];
                snprintf(inner, sizeof inner, "%.1000s", err);
                snprintf(err, errlen, "volumes[%d]: %.1000s", v, inner);
            }
            return -1;
        }
        *sent += up;
        if (scene->volume_count == 1) snprintf(overrides[v], 200, "volume.file=\"%.120s\"", blobs[v]);
        else snprintf(overrides[v], 200, "volumes.%d.file=\"%.120s\"", v, blobs[v]);
    }
    return 0;
}

int vsd_render_remote(const char *scene_path, const vsd_scene *scene, const char *const *overrides,
                      int override_count, const vsd_remote_options *opt)
{
    char err[2048], token[512] = "", env_blob[128] = "", env_override[200] = "";
    const char *sent[MAX_SENT_OVERRIDES];
    char vol_override[VSD_MAX_VOLUMES][200];
    char *text = NULL;
    vsdc *c = NULL;
    int frame, i, rc = VSD_EXIT_OK, n;
    if (override_count > MAX_SENT_OVERRIDES - VSD_MAX_VOLUMES - 1) {
        fprintf(stderr, "vsd render: too many overrides\n");
        return VSD_EXIT_USAGE;
    }
    if (read_text(scene_path, &text)) {
        fprintf(stderr, "vsd render: %s: cannot read\n", scene_path);
        return VSD_EXIT_INPUT;
    }
    if (opt->token_file) {
        FILE *f = fopen(opt->token_file, "r");
        size_t k;
        if (!f) {
            fprintf(stderr, "vsd render: --token-file %s: %s\n", opt->token_file, strerror(errno));
            free(text);
            return VSD_EXIT_USAGE;
        }
        k = fread(token, 1, sizeof token - 1, f);
        fclose(f);
        token[k] = '\0';
        while (k > 0 && strchr("\r\n \t", token[k - 1])) token[--k] = '\0';
    } else if (getenv("VSD_TOKEN")) {
        snprintf(token, sizeof token, "%s", getenv("VSD_TOKEN"));
    }
    if (vsdc_connect(opt->address, token[0] ? token : NULL, &c, err, sizeof err)) {
        fprintf(stderr, "vsd render: %s\n", err);
        free(text);
        return VSD_EXIT_RENDER_FAILED;
    }
    for (frame = scene->frames.start; frame <= scene->frames.end && rc == VSD_EXIT_OK; frame++) {
        vsdc_render_request rq;
        vsdc_result res;
        cJSON *info;
        char out_path[VSD_PATH_LEN];
        uint64_t up = 0;
        int attempt, st = 0;
        if (opt->skip_frame && opt->skip_frame(opt->skip_user, frame)) continue;
        if (opt->begin_frame) opt->begin_frame(opt->user, frame);
        for (attempt = 0; attempt < 2; attempt++) {
            /* each volume's VDB for this frame and the map: sent only when the daemon lacks them */
            if (upload_volumes(c, scene, frame, vol_override, &up, err, sizeof err)) {
                fprintf(stderr, "vsd render: frame %d: %s\n", frame, err);
                rc = strcmp(vsdc_error_code(c), "") ? exit_code_for_server(vsdc_error_code(c)) : VSD_EXIT_INPUT;
                break;
            }
            if (scene->environment.file[0] &&
                vsdc_upload_file(c, scene->environment.file, env_blob, sizeof env_blob, NULL, err, sizeof err)) {
                fprintf(stderr, "vsd render: %s\n", err);
                rc = strcmp(vsdc_error_code(c), "") ? exit_code_for_server(vsdc_error_code(c)) : VSD_EXIT_INPUT;
                break;
            }
            n = 0;
            for (i = 0; i < override_count; i++) sent[n++] = overrides[i];
            for (i = 0; i < scene->volume_count && i < VSD_MAX_VOLUMES; i++) sent[n++] = vol_override[i];
            if (env_blob[0]) {
                snprintf(env_override, sizeof env_override, "environment.file=\"%s\"", env_blob);
                sent[n++] = env_override;
            }
            memset(&rq, 0, sizeof rq);
            rq.scene_json = text;
            rq.overrides = sent;
            rq.override_count = n;
            rq.frame = frame;
            rq.has_frame = 1;
            rq.preview = scene->output.preview_png[0] != 0;
            rq.progress = opt->progress;
            rq.user = opt->user;
            rq.cancel = opt->cancel;
            st = vsdc_render(c, &rq, &res, err, sizeof err);
            /* evicted between upload and render by another client's data: send again */
            if (st == VSDC_ERR_SERVER && strcmp(vsdc_error_code(c), "missing_blob") == 0 && attempt == 0) continue;
            break;
        }
        if (rc != VSD_EXIT_OK) break;
        if (opt->end_frame) opt->end_frame(opt->user, st == 0);
        if (st) {
            fprintf(stderr, "vsd render: frame %d: %s\n", frame, err);
            rc = st == VSDC_ERR_SERVER ? exit_code_for_server(vsdc_error_code(c)) : VSD_EXIT_RENDER_FAILED;
            break;
        }
        info = cJSON_Parse(res.json);
        if (vsd_frame_path(scene->output.exr, frame, out_path, sizeof out_path, err, sizeof err) ||
            write_file_atomic(out_path, res.exr, res.exr_len, err, sizeof err)) {
            fprintf(stderr, "vsd render: frame %d: %s\n", frame, err);
            rc = VSD_EXIT_RENDER_FAILED;
        } else if (scene->output.preview_png[0]) {
            char png_path[VSD_PATH_LEN];
            if (vsd_frame_path(scene->output.preview_png, frame, png_path, sizeof png_path, err, sizeof err) ||
                write_file_atomic(png_path, res.png, res.png_len, err, sizeof err)) {
                fprintf(stderr, "vsd render: frame %d: %s\n", frame, err);
                rc = VSD_EXIT_RENDER_FAILED;
            }
        }
        if (rc == VSD_EXIT_OK && !opt->quiet) {
            printf("frame %d: %s  (%s, %d spp, load %.2fs, prepare %.2fs, render %.2fs, %d threads, remote%s)\n", frame,
                   out_path, str(info, "method"), (int)num(info, "samples", NULL), num(info, "timings", "load"),
                   num(info, "timings", "prepare"), num(info, "timings", "render"), (int)num(info, "threads", NULL),
                   up ? "" : scene->volume_count > 1 ? ", volumes cached" : ", volume cached");
            if (str(info, "preview_note")[0]) printf("  preview: %s\n", str(info, "preview_note"));
            fflush(stdout);
        }
        if (rc == VSD_EXIT_OK && opt->report) opt->report(opt->user);
        cJSON_Delete(info);
        vsdc_result_free(&res);
    }
    vsdc_close(c);
    free(text);
    return rc;
}

static void end_frame_cb(void *user, int ok) { render_progress_end_frame(user, ok); }
static void report_cb(void *user) { render_progress_report(user); }

int vsd_render_job_remote(const vsd_scene *scene, const vsd_render_job *job, int to_render,
                          int (*skip)(void *skip_user, int frame), void *skip_user, volatile int *cancel)
{
    render_progress prog;
    vsd_remote_options ro = {0};
    render_progress_init(&prog, job->quiet, to_render);
    ro.address = job->remote_address;
    ro.token_file = job->token_file[0] ? job->token_file : NULL;
    ro.quiet = job->quiet;
    ro.progress = render_progress_update;
    ro.user = &prog;
    ro.begin_frame = render_progress_begin_frame;
    ro.end_frame = end_frame_cb;
    ro.report = report_cb;
    ro.skip_frame = skip;
    ro.skip_user = skip_user;
    ro.cancel = cancel;
    return vsd_render_remote(job->scene_path, scene, job->overrides, job->override_count, &ro);
}
