/* Writing a rendered frame: the EXR (always) and the preview PNG (when asked), with the
 * header attributes that let a compositor or a later bench run know how it was made. */
#include "vsd/render.h"
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

/* mkdir -p of the folder part of `path`. */
static vsd_status make_parent_dirs(const char *path, char *err, size_t errlen)
{
    char buf[VSD_PATH_LEN];
    char *p;
    snprintf(buf, sizeof buf, "%s", path);
    p = strrchr(buf, '/');
    if (!p || p == buf) return VSD_OK;
    *p = '\0';
    for (p = buf + 1; *p; p++) {
        if (*p != '/') continue;
        *p = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
            return vsd_fail(VSD_ERR_IO, err, errlen, "%s: cannot create folder: %s", buf, strerror(errno));
        *p = '/';
    }
    if (mkdir(buf, 0777) != 0 && errno != EEXIST)
        return vsd_fail(VSD_ERR_IO, err, errlen, "%s: cannot create folder: %s", buf, strerror(errno));
    return VSD_OK;
}

vsd_status vsd_write_frame_outputs(const vsd_scene *scene, int frame, const vsd_framebuffer *fb,
                                   const vsd_render_stats *stats, char *exr_path, size_t exr_len,
                                   char *note, size_t notelen, char *err, size_t errlen)
{
    char path[VSD_PATH_LEN], samples[32], t_load[32], t_prep[32], t_render[32], threads[16], frame_s[16], scene_hash[33];
    vsd_exr_attr attrs[16];
    vsd_exr_write_options wo;
    vsd_status st;
    int n = 0;
    if (note && notelen) note[0] = '\0';
    st = vsd_frame_path(scene->output.exr, frame, path, sizeof path, err, errlen);
    if (st) return st;
    if (exr_path && exr_len) snprintf(exr_path, exr_len, "%s", path);
    if ((st = make_parent_dirs(path, err, errlen))) return st;
    /* What `vsd render --continue` compares before skipping this frame. */
    if ((st = vsd_scene_frame_hash(scene, frame, scene_hash, err, errlen))) return st;
    snprintf(samples, sizeof samples, "%d", stats->samples);
    snprintf(t_load, sizeof t_load, "%.6f", stats->load_seconds);
    snprintf(t_prep, sizeof t_prep, "%.6f", stats->prepare_seconds);
    snprintf(t_render, sizeof t_render, "%.6f", stats->render_seconds);
    snprintf(threads, sizeof threads, "%d", stats->threads);
    snprintf(frame_s, sizeof frame_s, "%d", frame);
    attrs[n].name = "vsd/version"; attrs[n++].value = vsd_version();
    attrs[n].name = "vsd/method"; attrs[n++].value = stats->method;
    attrs[n].name = "vsd/options"; attrs[n++].value = scene->render.options_json;
    attrs[n].name = "vsd/device"; attrs[n++].value = stats->device;
    attrs[n].name = "vsd/samples"; attrs[n++].value = samples;
    attrs[n].name = "vsd/threads"; attrs[n++].value = threads;
    attrs[n].name = "vsd/frame"; attrs[n++].value = frame_s;
    attrs[n].name = "vsd/scene_hash"; attrs[n++].value = scene_hash;
    attrs[n].name = "vsd/load_seconds"; attrs[n++].value = t_load;
    attrs[n].name = "vsd/prepare_seconds"; attrs[n++].value = t_prep;
    attrs[n].name = "vsd/render_seconds"; attrs[n++].value = t_render;
    if (stats->method_info[0]) { attrs[n].name = "vsd/method_info"; attrs[n++].value = stats->method_info; }
    if (stats->warnings[0]) { attrs[n].name = "vsd/warnings"; attrs[n++].value = stats->warnings; }
    memset(&wo, 0, sizeof wo);
    wo.layer = scene->output.layer;
    const char *pass_names[VSD_PASS_COUNT];
    for (int i = 0; i < VSD_PASS_COUNT; i++) pass_names[i] = scene->output.pass_names[i];
    wo.pass_names = pass_names;
    wo.pass_mask = scene->output.pass_mask;
    wo.half = scene->output.half;
    wo.uncompressed = strcmp(scene->output.compression, "none") == 0;
    wo.attrs = attrs;
    wo.attr_count = n;
    if ((st = vsd_exr_write(path, fb, &wo, err, errlen))) return st;
    if (scene->output.preview_png[0]) {
        vsd_preview_options po;
        memset(&po, 0, sizeof po);
        po.view = scene->output.view[0] ? scene->output.view : NULL;
        if ((st = vsd_frame_path(scene->output.preview_png, frame, path, sizeof path, err, errlen))) return st;
        if ((st = make_parent_dirs(path, err, errlen))) return st;
        if ((st = vsd_preview_write_png(path, fb, &po, note, notelen, err, errlen))) return st;
    }
    return VSD_OK;
}
