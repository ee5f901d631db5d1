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

/* A frame's EXR header attributes and write options, with the strings they point into. */
typedef struct frame_exr {
    char samples[32], t_load[32], t_prep[32], t_render[32], threads[16], frame_s[16], scene_hash[33];
    vsd_exr_attr attrs[16];
    const char *pass_names[VSD_PASS_COUNT];
    vsd_exr_write_options wo;
} frame_exr;

static vsd_status frame_exr_options(const vsd_scene *scene, int frame, const vsd_render_stats *stats, frame_exr *f,
                                    char *err, size_t errlen)
{
    vsd_exr_attr *attrs = f->attrs;
    vsd_status st;
    int n = 0;
    memset(f, 0, sizeof *f);
    /* What `vsd render --continue` compares before skipping this frame. */
    if ((st = vsd_scene_frame_hash(scene, frame, f->scene_hash, err, errlen))) return st;
    snprintf(f->samples, sizeof f->samples, "%d", stats->samples);
    snprintf(f->t_load, sizeof f->t_load, "%.6f", stats->load_seconds);
    snprintf(f->t_prep, sizeof f->t_prep, "%.6f", stats->prepare_seconds);
    snprintf(f->t_render, sizeof f->t_render, "%.6f", stats->render_seconds);
    snprintf(f->threads, sizeof f->threads, "%d", stats->threads);
    snprintf(f->frame_s, sizeof f->frame_s, "%d", frame);
    attrs[n].name = "vsd/version"; attrs[n++].value = vsd_version();
    attrs[n].name = "vsd/method"; attrs[n++].value = stats->method;
    attrs[n].name = "vsd/options"; attrs[n++].value = scene->render.options_json;
    attrs[n].name = "vsd/device"; attrs[n++].value = stats->device;
    attrs[n].name = "vsd/samples"; attrs[n++].value = f->samples;
    attrs[n].name = "vsd/threads"; attrs[n++].value = f->threads;
    attrs[n].name = "vsd/frame"; attrs[n++].value = f->frame_s;
    attrs[n].name = "vsd/scene_hash"; attrs[n++].value = f->scene_hash;
    attrs[n].name = "vsd/load_seconds"; attrs[n++].value = f->t_load;
    attrs[n].name = "vsd/prepare_seconds"; attrs[n++].value = f->t_prep;
    attrs[n].name = "vsd/render_seconds"; attrs[n++].value = f->t_render;
    if (stats->method_info[0]) { attrs[n].name = "vsd/method_info"; attrs[n++].value = stats->method_info; }
    if (stats->warnings[0]) { attrs[n].name = "vsd/warnings"; attrs[n++].value = stats->warnings; }
    f->wo.layer = scene->output.layer;
    for (int i = 0; i < VSD_PASS_COUNT; i++) f->pass_names[i] = scene->output.pass_names[i];
    f->wo.pass_names = f->pass_names;
    f->wo.pass_mask = scene->output.pass_mask;
    f->wo.half = scene->output.half;
    f->wo.compression = vsd_exr_compression_from_name(scene->output.compression);
    f->wo.attrs = attrs;
    f->wo.attr_count = n;
    return VSD_OK;
}

vsd_status vsd_write_frame_outputs(const vsd_scene *scene, int frame, const vsd_framebuffer *fb,
                                   const vsd_render_stats *stats, char *exr_path, size_t exr_len,
                                   char *note, size_t notelen, char *err, size_t errlen)
{
    char path[VSD_PATH_LEN];
    frame_exr f;
    vsd_status st;
    if (note && notelen) note[0] = '\0';
    st = vsd_frame_path(scene->output.exr, frame, path, sizeof path, err, errlen);
    if (st) return st;
    if (exr_path && exr_len) snprintf(exr_path, exr_len, "%s", path);
    if ((st = make_parent_dirs(path, err, errlen))) return st;
    if ((st = frame_exr_options(scene, frame, stats, &f, err, errlen))) return st;
    if ((st = vsd_exr_write(path, fb, &f.wo, err, errlen))) return st;
    if (scene->output.preview_png[0]) {
        if ((st = vsd_frame_path(scene->output.preview_png, frame, path, sizeof path, err, errlen))) return st;
        if ((st = make_parent_dirs(path, err, errlen))) return st;
        if ((st = vsd_write_frame_preview(scene, fb, path, note, notelen, err, errlen))) return st;
    }
    return VSD_OK;
}

vsd_status vsd_write_frame_preview(const vsd_scene *scene, const vsd_framebuffer *fb, const char *path, char *note,
                                   size_t notelen, char *err, size_t errlen)
{
    vsd_preview_options po;
    memset(&po, 0, sizeof po);
    po.view = scene->output.view[0] ? scene->output.view : NULL;
    return vsd_preview_write_png(path, fb, &po, note, notelen, err, errlen);
}

vsd_status vsd_encode_frame_exr(const vsd_scene *scene, int frame, const vsd_framebuffer *fb,
                                const vsd_render_stats *stats, unsigned char **bytes, size_t *len, char *err,
                                size_t errlen)
{
    frame_exr f;
    vsd_status st;
    *bytes = NULL;
    *len = 0;
    if ((st = frame_exr_options(scene, frame, stats, &f, err, errlen))) return st;
    return vsd_exr_encode(fb, &f.wo, bytes, len, err, errlen);
}
