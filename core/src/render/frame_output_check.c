/* Is a frame already rendered? The scene hash a frame's EXR records, and the check that
 * `vsd render --continue` and `vsd farm status` make before rendering it again. */
#include "vsd/render.h"
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <xxhash.h>

/* Fields are hashed one by one, strings up to their terminator, so that bytes after a
 * string's end or struct padding never make two equal scenes differ. */
static void hash_bytes(XXH3_state_t *h, const void *p, size_t n) { XXH3_128bits_update(h, p, n); }
static void hash_str(XXH3_state_t *h, const char *s) { hash_bytes(h, s, strlen(s) + 1); }
static void hash_int(XXH3_state_t *h, int v) { hash_bytes(h, &v, sizeof v); }
static void hash_floats(XXH3_state_t *h, const float *v, int n) { hash_bytes(h, v, sizeof *v * (size_t)n); }
static void hash_doubles(XXH3_state_t *h, const double *v, int n) { hash_bytes(h, v, sizeof *v * (size_t)n); }

static vsd_status hash_file(XXH3_state_t *h, const char *path, char *err, size_t errlen)
{
    unsigned char buf[1 << 16];
    size_t n;
    FILE *f = fopen(path, "rb");
    if (!f) return vsd_fail(VSD_ERR_IO, err, errlen, "%s: %s", path, strerror(errno));
    while ((n = fread(buf, 1, sizeof buf, f)) > 0) hash_bytes(h, buf, n);
    if (ferror(f)) {
        fclose(f);
        return vsd_fail(VSD_ERR_IO, err, errlen, "%s: read error", path);
    }
    fclose(f);
    return VSD_OK;
}

/* Everything in vsd_scene that changes pixels. Left out: base_dir, frames (a farm splits
 * the range), render.threads (images do not depend on it), output.exr/preview_png/view
 * (where and how the preview goes). A new scene field that changes pixels belongs here. */
static void hash_scene_fields(XXH3_state_t *h, const vsd_scene *s)
{
    int p;
    hash_int(h, s->version);
    hash_str(h, s->volume.grid);
    hash_int(h, s->volume.grid_index);
    hash_str(h, s->volume.emission_grid);
    hash_doubles(h, s->volume.matrix, 16);
    hash_str(h, s->volume.ior_grid);
    hash_floats(h, &s->medium.density, 1);
    hash_floats(h, s->medium.albedo, 3);
    hash_floats(h, &s->medium.anisotropy, 1);
    hash_floats(h, s->medium.emission_color, 3);
    hash_floats(h, &s->medium.emission_strength, 1);
    hash_floats(h, &s->medium.ior, 1);
    hash_str(h, s->medium.ior_from);
    hash_floats(h, s->environment.color, 3);
    hash_floats(h, &s->environment.strength, 1);
    hash_floats(h, &s->environment.rotation_z, 1);
    hash_str(h, s->environment.colorspace);
    hash_int(h, s->environment.interpolation);
    hash_int(h, s->light_count);
    hash_int(h, (int)s->camera.type);
    hash_doubles(h, s->camera.matrix, 16);
    hash_doubles(h, &s->camera.fov, 1);
    hash_doubles(h, &s->camera.ortho_scale, 1);
    hash_doubles(h, &s->camera.clip_start, 1);
    hash_doubles(h, &s->camera.clip_end, 1);
    hash_int(h, s->film.width);
    hash_int(h, s->film.height);
    hash_int(h, s->film.transparent);
    hash_str(h, s->render.method);
    hash_str(h, s->render.device);
    hash_int(h, s->render.samples);
    hash_int(h, s->render.seed);
    hash_str(h, s->render.options_json);
    hash_int(h, (int)s->output.pass_mask);
    hash_str(h, s->output.layer);
    for (p = 0; p < VSD_PASS_COUNT; p++) hash_str(h, s->output.pass_names[p]);
    hash_int(h, s->output.half);
}

vsd_status vsd_scene_frame_hash(const vsd_scene *scene, int frame, char hex[33], char *err, size_t errlen)
{
    char vdb[VSD_PATH_LEN];
    XXH128_hash_t d;
    vsd_status st;
    XXH3_state_t *h = XXH3_createState();
    hex[0] = '\0';
    if (!h) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "out of memory hashing the scene");
    XXH3_128bits_reset(h);
    hash_scene_fields(h, scene);
    /* The files' contents, not their names: a re-simulated cache under the same name is
     * a new frame, a renamed copy is the same one. */
    st = vsd_frame_path(scene->volume.file, frame, vdb, sizeof vdb, err, errlen);
    if (!st) st = hash_file(h, vdb, err, errlen);
    if (!st && scene->environment.file[0]) st = hash_file(h, scene->environment.file, err, errlen);
    d = XXH3_128bits_digest(h);
    XXH3_freeState(h);
    if (st) return st;
    snprintf(hex, 33, "%016llx%016llx", (unsigned long long)d.high64, (unsigned long long)d.low64);
    return VSD_OK;
}

vsd_frame_output_state vsd_frame_output_check(const vsd_scene *scene, int frame, char *why, size_t whylen)
{
    char path[VSD_PATH_LEN], err[1024], recorded[64], now[33];
    struct stat sb;
    vsd_exr_image *img = NULL;
    vsd_status st;
    if (vsd_frame_path(scene->output.exr, frame, path, sizeof path, err, sizeof err)) {
        snprintf(why, whylen, "%s", err);
        return VSD_FRAME_BROKEN;
    }
    if (stat(path, &sb) != 0) {
        snprintf(why, whylen, "no file");
        return VSD_FRAME_MISSING;
    }
    st = vsd_exr_read_attr(path, "vsd/scene_hash", recorded, sizeof recorded, err, sizeof err);
    if (st == VSD_ERR_NOT_FOUND) {
        /* Tell an unreadable file from a readable one without our hash. */
        if (vsd_exr_read(path, &img, err, sizeof err)) {
            snprintf(why, whylen, "does not read: %s", err);
            return VSD_FRAME_BROKEN;
        }
        vsd_exr_image_destroy(img);
        snprintf(why, whylen, "no vsd/scene_hash in its header (not written by vsd render)");
        return VSD_FRAME_STALE;
    }
    if (st) {
        snprintf(why, whylen, "header does not read: %s", err);
        return VSD_FRAME_BROKEN;
    }
    if (vsd_exr_read(path, &img, err, sizeof err)) {
        snprintf(why, whylen, "pixels do not read: %s", err);
        return VSD_FRAME_BROKEN;
    }
    if (img->width != scene->film.width || img->height != scene->film.height) {
        snprintf(why, whylen, "%dx%d, the scene is %dx%d", img->width, img->height, scene->film.width,
                 scene->film.height);
        vsd_exr_image_destroy(img);
        return VSD_FRAME_STALE;
    }
    vsd_exr_image_destroy(img);
    if (vsd_scene_frame_hash(scene, frame, now, err, sizeof err)) {
        snprintf(why, whylen, "cannot hash the scene: %s", err);
        return VSD_FRAME_STALE;
    }
    if (strcmp(recorded, now) != 0) {
        snprintf(why, whylen, "rendered from another scene (hash %.8s…, now %.8s…)", recorded, now);
        return VSD_FRAME_STALE;
    }
    snprintf(why, whylen, "complete");
    return VSD_FRAME_DONE;
}
