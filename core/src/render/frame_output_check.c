/* Is a frame already rendered? The scene hash a frame's EXR records, and the check that
 * `vsd render --continue` and `vsd farm status` make before rendering it again. */
#define _POSIX_C_SOURCE 200809L
#include "vsd/render.h"
#include <errno.h>
#include <pthread.h>
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

/* The last files digested, by identity (device, inode, size, modification time): a
 * sequence's environment map, a volume whose file has no frame number, and a frame's VDBs
 * that the --continue check and the writer both hash, are read once, not once per frame and
 * per use. A file rewritten in place changes its modification time, so it is read again. A
 * hit is checked with stat() before the file is opened. Room for two frames of a scene with
 * the most volumes (each volume's VDB and the map), so the map stays cached from frame to
 * frame. */
typedef struct file_digest {
    dev_t dev;
    ino_t ino;
    off_t size;
    struct timespec mtime;
    XXH128_hash_t digest;
    int used;
    unsigned long long last_use;  /* the least recently used entry is replaced */
} file_digest;

static file_digest g_digests[2 * (VSD_MAX_VOLUMES + 1)];
static unsigned long long g_digest_clock;
static pthread_mutex_t g_digest_lock = PTHREAD_MUTEX_INITIALIZER;

static int same_file(const file_digest *c, const struct stat *sb)
{
    return c->used && c->dev == sb->st_dev && c->ino == sb->st_ino && c->size == sb->st_size &&
           c->mtime.tv_sec == sb->st_mtim.tv_sec && c->mtime.tv_nsec == sb->st_mtim.tv_nsec;
}

/* XXH3-128 of a file's bytes into *out. */
static vsd_status file_digest_of(const char *path, XXH128_hash_t *out, char *err, size_t errlen)
{
    unsigned char buf[1 << 16];
    struct stat sb;
    size_t n;
    unsigned i;
    int known;
    XXH3_state_t *h;
    FILE *f;
    known = stat(path, &sb) == 0;
    if (known) {
        pthread_mutex_lock(&g_digest_lock);
        for (i = 0; i < sizeof g_digests / sizeof g_digests[0]; i++)
            if (same_file(&g_digests[i], &sb)) {
                *out = g_digests[i].digest;
                g_digests[i].last_use = ++g_digest_clock;
                pthread_mutex_unlock(&g_digest_lock);
                return VSD_OK;
            }
        pthread_mutex_unlock(&g_digest_lock);
    }
    f = fopen(path, "rb");
    if (!f) return vsd_fail(VSD_ERR_IO, err, errlen, "%s: %s", path, strerror(errno));
    /* the identity of what is read (the file may have been replaced since the stat) */
    known = fstat(fileno(f), &sb) == 0;
    if (!(h = XXH3_createState())) {
        fclose(f);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "out of memory hashing %s", path);
    }
    XXH3_128bits_reset(h);
    while ((n = fread(buf, 1, sizeof buf, f)) > 0) XXH3_128bits_update(h, buf, n);
    *out = XXH3_128bits_digest(h);
    XXH3_freeState(h);
    if (ferror(f)) {
        fclose(f);
        return vsd_fail(VSD_ERR_IO, err, errlen, "%s: read error", path);
    }
    fclose(f);
    if (!known) return VSD_OK;
    pthread_mutex_lock(&g_digest_lock);
    {
        file_digest *c = &g_digests[0];
        for (i = 1; i < sizeof g_digests / sizeof g_digests[0]; i++)
            if (g_digests[i].last_use < c->last_use) c = &g_digests[i];
        c->dev = sb.st_dev;
        c->ino = sb.st_ino;
        c->size = sb.st_size;
        c->mtime = sb.st_mtim;
        c->digest = *out;
        c->used = 1;
        c->last_use = ++g_digest_clock;
    }
    pthread_mutex_unlock(&g_digest_lock);
    return VSD_OK;
}

static vsd_status hash_file(XXH3_state_t *h, const char *path, char *err, size_t errlen)
{
    XXH128_hash_t d;
    vsd_status st = file_digest_of(path, &d, err, errlen);
    if (!st) hash_bytes(h, &d, sizeof d);
    return st;
}

/* A volume's fields that change pixels: all but its file (hashed by content, for the frame
 * it reads), warn_above (it only adds a warning) and frame_offset (see hash_scene_fields). */
static void hash_volume_fields(XXH3_state_t *h, const vsd_scene_volume *v)
{
    hash_str(h, v->grid);
    hash_int(h, v->grid_index);
    hash_str(h, v->emission_grid);
    hash_doubles(h, v->matrix, 16);
    hash_str(h, v->ior_grid);
    hash_floats(h, &v->medium.density, 1);
    hash_floats(h, v->medium.albedo, 3);
    hash_floats(h, &v->medium.anisotropy, 1);
    hash_floats(h, v->medium.emission_color, 3);
    hash_floats(h, &v->medium.emission_strength, 1);
    hash_floats(h, &v->medium.ior, 1);
    hash_str(h, v->medium.ior_from);
}

static void hash_light(XXH3_state_t *h, const vsd_scene_light *l)
{
    hash_int(h, (int)l->type);
    hash_floats(h, l->color, 3);
    hash_floats(h, &l->strength, 1);
    hash_floats(h, &l->power, 1);
    hash_doubles(h, l->position, 3);
    hash_doubles(h, l->direction, 3);
    hash_floats(h, &l->radius, 1);
    hash_floats(h, &l->angle, 1);
    hash_floats(h, &l->spot_size, 1);
    hash_floats(h, &l->spot_blend, 1);
    hash_int(h, l->spot_cosine);
}

/* Everything in vsd_scene that changes pixels. Left out: base_dir, frames (a farm splits
 * the range), render.threads (images do not depend on it), output.exr/preview_png/view
 * (where and how the preview goes). A new scene field that changes pixels belongs here.
 *
 * Compatibility with the hashes EXRs already record (--continue keeps their frames): the
 * fields of a scene with one volume, frame_offset 0 and no lights are hashed in the same
 * order as before volumes[] and lights[] existed, and what came later is appended only when
 * present. So a one-volume scene without an offset keeps its hash; a scene with several
 * volumes (volume_count, then each volume's frame_offset and, from volumes[1] on, its
 * fields), an offset or lights gets a new one. */
static void hash_scene_fields(XXH3_state_t *h, const vsd_scene *s)
{
    int p, v;
    hash_int(h, s->version);
    hash_volume_fields(h, &s->volumes[0]);
    hash_floats(h, s->environment.color, 3);
    hash_floats(h, &s->environment.strength, 1);
    hash_floats(h, &s->environment.rotation_z, 1);
    hash_str(h, s->environment.colorspace);
    if (s->environment.working_space[0]) /* only when set: earlier outputs keep their hash */
        hash_str(h, s->environment.working_space);
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
    /* Appended, only when present (see above). The lights' count was hashed from the start,
     * their settings only since (a light moved or dimmed is another image). */
    for (p = 0; p < s->light_count && p < VSD_MAX_LIGHTS; p++) hash_light(h, &s->lights[p]);
    if (s->volume_count > 1 || s->volumes[0].frame_offset != 0) {
        hash_int(h, s->volume_count);
        for (v = 0; v < s->volume_count && v < VSD_MAX_VOLUMES; v++) {
            hash_int(h, s->volumes[v].frame_offset);
            if (v > 0) hash_volume_fields(h, &s->volumes[v]);
        }
    }
}

/* The contents of the VDB that volume v reads for scene frame `frame` (its frame_offset
 * applied). */
static vsd_status hash_volume_file(XXH3_state_t *h, const vsd_scene_volume *v, int frame, char *err,
                                   size_t errlen)
{
    char vdb[VSD_PATH_LEN];
    vsd_status st = vsd_frame_path(v->file, vsd_scene_volume_frame(v, frame), vdb, sizeof vdb, err, errlen);
    return st ? st : hash_file(h, vdb, err, errlen);
}

vsd_status vsd_scene_frame_hash(const vsd_scene *scene, int frame, char hex[33], char *err, size_t errlen)
{
    XXH128_hash_t d;
    vsd_status st;
    int v;
    XXH3_state_t *h = XXH3_createState();
    hex[0] = '\0';
    if (!h) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "out of memory hashing the scene");
    XXH3_128bits_reset(h);
    hash_scene_fields(h, scene);
    /* The files' contents, not their names: a re-simulated cache under the same name is
     * a new frame, a renamed copy is the same one. volumes[0]'s VDB and the map come first
     * (the order of one-volume scenes before volumes[]), the other volumes' VDBs after. */
    st = hash_volume_file(h, &scene->volumes[0], frame, err, errlen);
    if (!st && scene->environment.file[0]) st = hash_file(h, scene->environment.file, err, errlen);
    for (v = 1; !st && v < scene->volume_count && v < VSD_MAX_VOLUMES; v++)
        st = hash_volume_file(h, &scene->volumes[v], frame, err, errlen);
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
