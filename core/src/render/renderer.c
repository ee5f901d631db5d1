/* The frame pipeline shared by the CLI, the daemon and the tests: load (or reuse) the
 * volume frame and the environment, build the kernel data, let the method prepare what
 * changed, then render the view. Cache keys are strings of everything a stage depends on,
 * so "what changed" is one comparison per stage. */
#include "vsd/render.h"
#include "vsd/vdbio.h"
#include "src/method/method.h"
#include "kernel_setup.h"
#include "accum.h"
#include "kernel/kernel_lights.h"
#include "device/cpu/cpu_tiles.h"
#include "device/cuda/cuda_backend.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <xxhash.h>
#include "src/common/clock.h"

#define KEY_LEN 4096
_Static_assert(VSD_MAX_VOLUMES == VSD_KMAX_VOLUMES, "the scene's and the kernel's volume limits must agree");

/* One entry of the scene's volumes[] as loaded: its grids, owned (read from the frame's
 * file) or borrowed (vsd_renderer_use_volume), and the key of what is loaded. */
typedef struct loaded_volume {
    char key[KEY_LEN];
    const vsd_volume *density, *emission, *ior;   /* in use: owned_* or borrowed */
    vsd_volume *owned_density, *owned_emission, *owned_ior;
    const vsd_volume *ext_density, *ext_emission, *ext_ior;
    unsigned long serial;   /* bumped by use_volume: new contents may sit at a freed address */
} loaded_volume;

struct vsd_renderer {
    vsd_scene scene;
    vsd_render_options opt;
    vsd_accum_store accum_store;   /* a view's sums, kept for the next view (accum.h) */
    char cache_dir[4096];
    const vsd_method *method;
    void *method_state;
    loaded_volume volumes[VSD_MAX_VOLUMES];
    /* the kernel form of every volume (kd.volumes points here, so it outlives the render) */
    vsd_kobject kvolumes[VSD_MAX_VOLUMES];
    char env_key[KEY_LEN];
    const vsd_env *env;
    vsd_env *owned_env;
    const vsd_env *ext_env;
    vsd_env_tables tables;
    char frame_key[KEY_LEN], lighting_key[KEY_LEN];
    /* the map's strength the lighting was prepared with (strength_scales) */
    float lit_strength;
    /* CUDA: opened on the first render that asks for it and kept (with its resident data)
     * for the renderer's life; cuda_error remembers why `auto` fell back to the CPU. */
    vsd_cuda *cuda;
    char cuda_error[512];
    /* generations of the loaded inputs and of the method's stages (method.h): one counter,
     * bumped where the data they stand for changes */
    uint64_t generation, frame_gen, lighting_gen, volume_gen, env_gen;
    /* bumped by use_env and part of its cache key: a new map may sit at a freed address */
    unsigned long env_serial;
    /* the scene's lights[] in kernel layout; kd.scene_lights points here, so the device
     * copy's key (lighting generation, address) stays valid between renders */
    float scene_lights[VSD_KLIGHT_FLOATS * VSD_MAX_LIGHTS];
};

const char *vsd_version(void) { return VSD_VERSION_STRING; }

static void release_method(vsd_renderer *r)
{
    if (r->method && r->method->destroy) r->method->destroy(r->method_state);
    r->method_state = NULL;
    r->frame_key[0] = r->lighting_key[0] = '\0';
}

static vsd_status pick_method(vsd_renderer *r, char *err, size_t errlen)
{
    const vsd_scene *sc = &r->scene;
    const vsd_method *m = vsd_method_find(sc->render.method);
    vsd_status st = VSD_OK;
    if (!m) {
        char known[512] = "";
        const char *const *n;
        for (n = vsd_method_names(); *n; n++) {
            if (known[0]) strncat(known, ", ", sizeof known - strlen(known) - 1);
            strncat(known, *n, sizeof known - strlen(known) - 1);
        }
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                        "render.method: unknown method '%s' (available: %s)", sc->render.method, known);
    }
    if ((st = vsd_method_check_lights(m, sc, err, errlen)) || (st = vsd_method_check_volumes(m, sc, err, errlen)))
        return st;
    void *options;
    st = vsd_method_parse_options(m, sc, &options, err, errlen);
    if (st) return st;
    release_method(r);
    r->method = m;
    if (m->create) st = m->create(&r->method_state, sc, options, err, errlen);
    free(options);
    return st;
}

vsd_status vsd_renderer_create(const vsd_scene *scene, const vsd_render_options *opt,
                               vsd_renderer **out, char *err, size_t errlen)
{
    vsd_renderer *r = calloc(1, sizeof *r);
    vsd_status st;
    *out = NULL;
    if (!r) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a renderer");
    r->scene = *scene;
    if (opt) r->opt = *opt;
    if (opt && opt->cache_dir) snprintf(r->cache_dir, sizeof r->cache_dir, "%s", opt->cache_dir);
    r->opt.cache_dir = NULL;   /* borrowed by the caller; the copy above is what is used */
    st = pick_method(r, err, errlen);
    if (st) {
        vsd_renderer_destroy(r);
        return st;
    }
    *out = r;
    return VSD_OK;
}

vsd_status vsd_renderer_set_scene(vsd_renderer *r, const vsd_scene *scene, char *err, size_t errlen)
{
    int same_method = strcmp(r->scene.render.method, scene->render.method) == 0 &&
                      strcmp(r->scene.render.options_json, scene->render.options_json) == 0;
    r->scene = *scene;
    if (same_method) return VSD_OK;
    return pick_method(r, err, errlen);
}

static void free_owned_volume(loaded_volume *v)
{
    vsd_volume_destroy(v->owned_density);
    vsd_volume_destroy(v->owned_emission);
    vsd_volume_destroy(v->owned_ior);
    v->owned_density = v->owned_emission = v->owned_ior = NULL;
    v->density = v->emission = v->ior = NULL;
    v->key[0] = '\0';
}

static void free_owned_volumes(vsd_renderer *r)
{
    for (int i = 0; i < VSD_MAX_VOLUMES; i++) free_owned_volume(&r->volumes[i]);
}

static void free_owned_env(vsd_renderer *r)
{
    vsd_env_destroy(r->owned_env);
    vsd_env_tables_free(&r->tables);
    r->owned_env = NULL;
    r->env = NULL;
    r->env_key[0] = '\0';
}

void vsd_renderer_use_volume(vsd_renderer *r, int index, const vsd_volume *density, const vsd_volume *emission,
                             const vsd_volume *ior)
{
    if (index < 0 || index >= VSD_MAX_VOLUMES) return;
    loaded_volume *v = &r->volumes[index];
    free_owned_volume(v);
    v->serial++;
    v->ext_density = density;
    v->ext_emission = density ? emission : NULL;
    v->ext_ior = density ? ior : NULL;
}

void vsd_renderer_use_env(vsd_renderer *r, const vsd_env *env)
{
    free_owned_env(r);
    r->env_serial++;
    r->ext_env = env;
}

/* What identifies a volume's files: its frame's path and the grids it reads. */
static void volume_key(const vsd_scene_volume *sv, const char *path, char key[KEY_LEN])
{
    snprintf(key, KEY_LEN, "%s|%s|%d|%s|%s", path, sv->grid, sv->grid_index, sv->emission_grid, vsd_scene_ior_grid(sv));
}

/* Volume `index` of the scene for scene frame `frame` (its own frame_offset applied):
 * reused when its key is unchanged; *changed tells whether it was (re)loaded. */
static vsd_status load_volume(vsd_renderer *r, int index, int frame, int *changed, char *err, size_t errlen)
{
    const vsd_scene_volume *sv = &r->scene.volumes[index];
    loaded_volume *v = &r->volumes[index];
    char path[VSD_PATH_LEN], key[KEY_LEN];
    vsd_grid_select sel;
    vsd_status st;
    *changed = 0;
    if (v->ext_density) {
        v->density = v->ext_density;
        v->emission = v->ext_emission;
        v->ior = v->ext_ior;
        snprintf(key, sizeof key, "memory:%lu:%p:%p:%p", v->serial, (const void *)v->density,
                 (const void *)v->emission, (const void *)v->ior);
        if (strcmp(key, v->key) != 0) {
            *changed = 1;
            snprintf(v->key, sizeof v->key, "%s", key);
        }
        return VSD_OK;
    }
    st = vsd_frame_path(sv->file, vsd_scene_volume_frame(sv, frame), path, sizeof path, err, errlen);
    if (st) return st;
    volume_key(sv, path, key);
    if (v->owned_density && strcmp(key, v->key) == 0) return VSD_OK;
    free_owned_volume(v);
    *changed = 1;
    sel.name = sv->grid;
    sel.index = sv->grid_index;
    st = vsd_vdb_load(path, sel, &v->owned_density, err, errlen);
    if (!st && sv->emission_grid[0]) {
        sel.name = sv->emission_grid;
        sel.index = -1;
        st = vsd_vdb_load(path, sel, &v->owned_emission, err, errlen);
    }
    if (!st && vsd_scene_ior_grid(sv)[0]) {
        /* the refractive index's grid (volume.ior_grid / medium.ior_from): a missing one is
         * the loader's error, which names it and lists what the file has */
        sel.name = vsd_scene_ior_grid(sv);
        sel.index = -1;
        st = vsd_vdb_load(path, sel, &v->owned_ior, err, errlen);
    }
    if (st) {
        free_owned_volume(v);
        return st;
    }
    v->density = v->owned_density;
    v->emission = v->owned_emission;
    v->ior = v->owned_ior;
    snprintf(v->key, sizeof v->key, "%s", key);
    return VSD_OK;
}

/* The scene's density grids together stay within the voxel limit, counted from what the
 * files state before any of them is loaded (a loaded or in-memory volume counts what it
 * holds). A file that cannot be read is left to the load, whose error names it. */
static vsd_status check_voxels(const vsd_renderer *r, int frame, char *err, size_t errlen)
{
    const vsd_scene *sc = &r->scene;
    unsigned long long total = 0, limit = r->opt.max_voxels ? r->opt.max_voxels : VSD_DEFAULT_MAX_VOXELS;
    for (int i = 0; i < sc->volume_count; i++) {
        const vsd_scene_volume *sv = &sc->volumes[i];
        const loaded_volume *v = &r->volumes[i];
        char path[VSD_PATH_LEN], why[256], key[KEY_LEN];
        vsd_grid_info info;
        vsd_grid_select sel = {sv->grid, sv->grid_index};
        if (v->ext_density) {
            total += v->ext_density->active_voxels;
            continue;
        }
        if (vsd_frame_path(sv->file, vsd_scene_volume_frame(sv, frame), path, sizeof path, why, sizeof why)) continue;
        volume_key(sv, path, key);
        if (v->owned_density && strcmp(key, v->key) == 0) {
            /* loaded already (a camera or material edit): what it holds */
            total += v->owned_density->active_voxels;
            continue;
        }
        if (vsd_vdb_select_info(path, sel, &info, why, sizeof why)) continue;
        total += info.active_voxels;
        if (info.active_voxels > limit || total > limit)
            return sc->volume_count > 1
                       ? vsd_fail(VSD_ERR_NOMEM, err, errlen,
                                  "volumes: the scene's density grids hold %llu active voxels or more at frame %d "
                                  "(volumes[%d] %s: %llu); the limit is %llu (vsd render --max-voxels)",
                                  total, frame, i, path, (unsigned long long)info.active_voxels, limit)
                       : vsd_fail(VSD_ERR_NOMEM, err, errlen,
                                  "%s: grid '%s' has %llu active voxels; the limit is %llu (vsd render --max-voxels)",
                                  path, info.name, (unsigned long long)info.active_voxels, limit);
    }
    if (total > limit)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen,
                        "volumes: the scene's density grids hold %llu active voxels at frame %d; the limit is %llu "
                        "(vsd render --max-voxels)",
                        total, frame, limit);
    return VSD_OK;
}

/* Every volume of the scene; an error names the volume (index and file) when there are
 * several. A new volume generation whenever any of them changed. */
static vsd_status load_volumes(vsd_renderer *r, int frame, char *err, size_t errlen)
{
    const vsd_scene *sc = &r->scene;
    int any = 0;
    vsd_status limit = check_voxels(r, frame, err, errlen);
    if (limit) return limit;
    for (int i = 0; i < sc->volume_count; i++) {
        int changed = 0;
        vsd_status st = load_volume(r, i, frame, &changed, err, errlen);
        if (st) {
            if (sc->volume_count > 1 && err && errlen) {
                char inner[1024];
                snprintf(inner, sizeof inner, "%s", err);
                snprintf(err, errlen, "volumes[%d] (%s): %s", i, sc->volumes[i].file, inner);
            }
            return st;
        }
        any |= changed;
    }
    for (int i = sc->volume_count; i < VSD_MAX_VOLUMES; i++)
        if (r->volumes[i].key[0]) {
            free_owned_volume(&r->volumes[i]);
            any = 1;
        }
    if (any) r->volume_gen = ++r->generation;
    return VSD_OK;
}

static vsd_status load_env(vsd_renderer *r, char *err, size_t errlen)
{
    const vsd_scene *sc = &r->scene;
    const float *c = sc->environment.color;
    char key[KEY_LEN];
    vsd_status st;
    char conversion[2 * VSD_NAME_LEN + 2];
    vsd_scene_env_conversion(sc, conversion, sizeof conversion);
    if (r->ext_env) snprintf(key, sizeof key, "memory:%lu:%p", r->env_serial, (const void *)r->ext_env);
    else snprintf(key, sizeof key, "%s|%s|%g,%g,%g", sc->environment.file, conversion, c[0], c[1], c[2]);
    /* the sampling tables follow the interpolation */
    snprintf(key + strlen(key), sizeof key - strlen(key), "|%d", sc->environment.interpolation);
    if (r->env && strcmp(key, r->env_key) == 0) return VSD_OK;
    free_owned_env(r);
    if (r->ext_env) st = VSD_OK;
    else if (sc->environment.file[0])
        st = vsd_env_load(sc->environment.file, conversion, &r->owned_env, err, errlen);
    else
        st = vsd_env_create_uniform(c, 64, 32, &r->owned_env, err, errlen);
    if (st) return st;
    r->env = r->ext_env ? r->ext_env : r->owned_env;
    st = vsd_env_tables_build(r->env, sc->environment.interpolation, &r->tables, err, errlen);
    if (st) return st;
    r->env_gen = ++r->generation;
    snprintf(r->env_key, sizeof r->env_key, "%s", key);
    return VSD_OK;
}

/* Whether the image is linear in the map's strength alone: nothing else lights the scene
 * (no scene lights, no emission), so every radiance pass scales with it, in every method
 * (the lighting stages and the view are linear in the light; their adaptive choices and
 * cut-offs are relative or the transmittance's). A change of the strength alone then keeps
 * the prepared lighting and scales the image (render_on): an artist's most common world
 * edit costs a view pass, not a lighting stage. */
static int strength_scales(const vsd_scene *sc)
{
    if (sc->light_count > 0 || !(sc->environment.strength > 0.0f) || !isfinite(sc->environment.strength)) return 0;
    for (int v = 0; v < sc->volume_count; v++)
        if (sc->volumes[v].medium.emission_strength != 0.0f) return 0;
    return 1;
}

/* The frame key: every volume's grids, density, ior and matrix. The lighting key adds
 * the map, the lights and every volume's material, and the map's strength unless the image
 * scales with it (strength_scales). A method whose frame stage reads only whether the
 * density is > 0 (density_in_lighting, one volume) finds the density's value in the
 * lighting key instead. Long scenes hash rather than list. */
static void make_keys(const vsd_renderer *r, char *frame_key, char *lighting_key, uint64_t *volume_keys)
{
    const vsd_scene *sc = &r->scene;
    XXH3_state_t *fh = XXH3_createState(), *lh = XXH3_createState();
    XXH3_64bits_reset(fh);
    XXH3_64bits_reset(lh);
    const int lit_density = r->method->density_in_lighting && sc->volume_count == 1;
    for (int v = 0; v < sc->volume_count; v++) {
        const vsd_scene_volume *sv = &sc->volumes[v];
        const vsd_scene_medium *m = &sv->medium;
        char part[KEY_LEN + 512];
        int n = snprintf(part, sizeof part, "%d:%s|%g|%g|", v, r->volumes[v].key,
                         lit_density ? (double)(m->density > 0.0f) : (double)m->density, m->ior);
        for (int i = 0; i < 16 && n < (int)sizeof part - 32; i++) n += snprintf(part + n, sizeof part - n, "%.9g,", sv->matrix[i]);
        XXH3_64bits_update(fh, part, strlen(part));
        volume_keys[v] = XXH3_64bits(part, strlen(part));
        n = snprintf(part, sizeof part, "%d:%g,%g,%g|%g|%g,%g,%g|%g|%g;", v, m->albedo[0], m->albedo[1], m->albedo[2],
                     m->anisotropy, m->emission_color[0], m->emission_color[1], m->emission_color[2],
                     m->emission_strength, lit_density ? m->density : 0.0f);
        XXH3_64bits_update(lh, part, (size_t)n);
    }
    unsigned long long fk = XXH3_64bits_digest(fh), lk = XXH3_64bits_digest(lh);
    XXH3_freeState(fh);
    XXH3_freeState(lh);
    snprintf(frame_key, KEY_LEN, "%d volumes:%016llx", sc->volume_count, fk);
    float lights[VSD_KLIGHT_FLOATS * VSD_MAX_LIGHTS];
    int count = vsd_kscene_lights_setup(lights, sc);
    /* the lights by the hash of their kernel layout (every float of it defined) */
    char strength[32] = "scales";
    if (!strength_scales(sc)) snprintf(strength, sizeof strength, "%g", sc->environment.strength);
    snprintf(lighting_key, KEY_LEN, "%.64s|%.3000s|%s|%g|%016llx|%d:%016llx", frame_key, r->env_key, strength,
             sc->environment.rotation_z, lk, count,
             (unsigned long long)XXH3_64bits(lights, (size_t)count * VSD_KLIGHT_FLOATS * sizeof *lights));
}

vsd_status vsd_render_cuda_probe(char *name, size_t namelen, char *err, size_t errlen)
{
    vsd_cuda *c;
    vsd_status st = vsd_cuda_open(&c, err, errlen);
    if (st) return st;
    if (name && namelen) snprintf(name, namelen, "%s", vsd_cuda_device_name(c));
    vsd_cuda_close(c);
    return VSD_OK;
}

/* The backend for this render: render.device "cpu", "cuda" (an error when no GPU answers)
 * or "auto" (CUDA when a device opens, else the CPU). */
static vsd_status pick_device(vsd_renderer *r, vsd_cuda **cuda, char *err, size_t errlen)
{
    const char *want = r->scene.render.device;
    vsd_status st;
    *cuda = NULL;
    if (strcmp(want, "cpu") == 0) return VSD_OK;
    if (!r->cuda && !r->cuda_error[0]) {
        st = vsd_cuda_open(&r->cuda, r->cuda_error, sizeof r->cuda_error);
        if (st && !r->cuda_error[0]) snprintf(r->cuda_error, sizeof r->cuda_error, "CUDA unavailable");
    }
    if (r->cuda) {
        *cuda = r->cuda;
        return VSD_OK;
    }
    if (strcmp(want, "cuda") == 0)
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen, "render.device: 'cuda' requested, but %s", r->cuda_error);
    return VSD_OK;
}

/* Closes the device and forgets what the method prepared for it (it prepares again on the
 * next render, on whichever backend that uses). */
static void drop_device(vsd_renderer *r)
{
    vsd_cuda_close(r->cuda);
    r->cuda = NULL;
    r->frame_key[0] = r->lighting_key[0] = '\0';
}

/* One attempt at the frame on the chosen backend. */
static vsd_status render_on(vsd_renderer *r, vsd_cuda *cuda, int frame, vsd_framebuffer **fbp,
                            vsd_render_stats *stats, char *err, size_t errlen);

vsd_status vsd_renderer_render(vsd_renderer *r, int frame, vsd_framebuffer **fbp,
                               vsd_render_stats *stats, char *err, size_t errlen)
{
    vsd_render_stats local;
    vsd_cuda *cuda;
    vsd_status st;
    if (!stats) stats = &local;
    if ((st = pick_device(r, &cuda, err, errlen))) return st;
    st = render_on(r, cuda, frame, fbp, stats, err, errlen);
    if (cuda && st == VSD_ERR_DEVICE && strcmp(r->scene.render.device, "cuda") == 0) {
        /* a failed launch can leave the context unusable: open a fresh one next time */
        drop_device(r);
    }
    if (cuda && strcmp(r->scene.render.device, "auto") == 0 &&
        (st == VSD_ERR_NOMEM || st == VSD_ERR_DEVICE)) {
        /* `auto` promised a picture, not a GPU: drop the device (and what the methods
         * prepared for it) and render this and later frames on the CPU */
        snprintf(r->cuda_error, sizeof r->cuda_error, "%.500s", err ? err : "CUDA failed");
        drop_device(r);
        st = render_on(r, NULL, frame, fbp, stats, err, errlen);
    }
    return st;
}

/* What render_on decided for render_keyed: the stages to run (the frame's and the
 * lighting's when their keys changed), and the clocks and device counters at its start. */
typedef struct render_plan {
    char frame_key[KEY_LEN], lighting_key[KEY_LEN];
    int frame_changed, lighting_changed;
    double t_loaded;
    uint64_t uploaded0;
    double passes0, downloads0;
} render_plan;

static vsd_status render_keyed(vsd_renderer *r, vsd_cuda *cuda, vsd_frame_ctx *ctx_in, const render_plan *plan,
                               vsd_framebuffer **fbp, vsd_render_stats *stats, char *err, size_t errlen);

/* Radiance passes times `scale` (Combined's colour, VolumeDir, VolumeInd, Emit; not alpha,
 * transmittance or depth). */
static void scale_radiance(vsd_framebuffer *fb, float scale)
{
    const size_t npix = (size_t)fb->width * fb->height;
    const vsd_pass radiance[] = {VSD_PASS_COMBINED, VSD_PASS_VOLUME_DIR, VSD_PASS_VOLUME_IND, VSD_PASS_EMIT};
    for (size_t k = 0; k < sizeof radiance / sizeof *radiance; k++) {
        const int nc = vsd_pass_channels(radiance[k]);
        float *v = fb->pass[radiance[k]];
        for (size_t i = 0; i < npix; i++)
            for (int c = 0; c < 3; c++) v[i * (size_t)nc + c] *= scale;
    }
}

static vsd_status render_on(vsd_renderer *r, vsd_cuda *cuda, int frame, vsd_framebuffer **fbp,
                            vsd_render_stats *stats, char *err, size_t errlen)
{
    const vsd_scene *sc = &r->scene;
    const float asked = sc->environment.strength;
    float scale = 1.0f;
    vsd_frame_ctx ctx;
    render_plan plan;
    double t0 = vsd_clock_seconds();
    vsd_status st;
    memset(&plan, 0, sizeof plan);
    plan.uploaded0 = cuda ? vsd_cuda_uploaded_bytes(cuda) : 0;
    if (cuda) vsd_cuda_seconds(cuda, &plan.passes0, &plan.downloads0);
    memset(stats, 0, sizeof *stats);
    snprintf(stats->method, sizeof stats->method, "%s", r->method->name);
    snprintf(stats->device, sizeof stats->device, "%s", cuda ? "cuda" : "cpu");
    if (cuda) snprintf(stats->device_name, sizeof stats->device_name, "%s", vsd_cuda_device_name(cuda));
    else if (strcmp(sc->render.device, "auto") == 0)
        snprintf(stats->device_note, sizeof stats->device_note, "%s", r->cuda_error);
    /* set_scene may have brought more volumes than the method renders */
    if ((st = vsd_method_check_volumes(r->method, sc, err, errlen))) return st;

    if ((st = load_volumes(r, frame, err, errlen)) || (st = load_env(r, err, errlen))) return st;
    plan.t_loaded = vsd_clock_seconds();
    stats->load_seconds = plan.t_loaded - t0;
    /* values no real medium has (a corrupt file, or a grid in the wrong units) render, but
     * as opaque and with the trackers at their cap (docs/reliability.md): say so */
    {
        size_t used = 0;
        for (int i = 0; i < sc->volume_count; i++) {
            const vsd_volume *vols[2] = {r->volumes[i].density, r->volumes[i].emission};
            float above = sc->volumes[i].warn_above;
            stats->active_voxels += r->volumes[i].density->active_voxels;
            for (int v = 0; v < 2; v++)
                if (vols[v] && vols[v]->value_max > above && used < sizeof stats->warnings)
                    used += (size_t)snprintf(stats->warnings + used, sizeof stats->warnings - used,
                                             "%s%s: grid '%s' has values up to %g, above volume.warn_above (%g): check "
                                             "its units",
                                             used ? "; " : "", vols[v]->file[0] ? vols[v]->file : "(in memory)",
                                             vols[v]->grid_name, (double)vols[v]->value_max, (double)above);
        }
    }

    memset(&ctx, 0, sizeof ctx);
    make_keys(r, plan.frame_key, plan.lighting_key, ctx.volume_key);
    plan.frame_changed = strcmp(plan.frame_key, r->frame_key) != 0;
    plan.lighting_changed = plan.frame_changed || strcmp(plan.lighting_key, r->lighting_key) != 0;
    if (!plan.lighting_changed && strength_scales(sc) && asked != r->lit_strength) {
        /* only the strength changed, and the image scales with it (strength_scales; its key
           says so, so the lighting was prepared with a strength > 0): the methods see the
           strength they prepared with, and the passes are scaled after */
        scale = asked / r->lit_strength;
        r->scene.environment.strength = r->lit_strength;
    }
    st = render_keyed(r, cuda, &ctx, &plan, fbp, stats, err, errlen);
    r->scene.environment.strength = asked;
    stats->relit = plan.lighting_changed;
    stats->reframed = plan.frame_changed;
    stats->strength_scale = scale;
    if (st == VSD_OK && scale != 1.0f) scale_radiance(*fbp, scale);
    return st;
}

/* render_on's stages, the keys decided: the methods' frame and lighting stages where their
 * keys changed, then the view. */
static vsd_status render_keyed(vsd_renderer *r, vsd_cuda *cuda, vsd_frame_ctx *ctx_in, const render_plan *plan,
                               vsd_framebuffer **fbp, vsd_render_stats *stats, char *err, size_t errlen)
{
    const vsd_scene *sc = &r->scene;
    vsd_frame_ctx ctx = *ctx_in;   /* (the volume keys make_keys gave) */
    double t2;
    vsd_status st = VSD_OK;
    ctx.scene = sc;
    ctx.density = r->volumes[0].density;
    ctx.emission = r->volumes[0].emission;
    for (int i = 0; i < sc->volume_count; i++) {
        ctx.volume_density[i] = r->volumes[i].density;
        ctx.volume_emission[i] = r->volumes[i].emission;
        ctx.volume_ior[i] = r->volumes[i].ior;
    }
    ctx.env = r->env;
    ctx.threads = vsd_cpu_thread_count(r->opt.threads > 0 ? r->opt.threads : sc->render.threads);
    ctx.progress = r->opt.progress;
    ctx.user = r->opt.user;
    ctx.cancel = r->opt.cancel;
    ctx.cuda = cuda;
    ctx.cache_dir = r->cache_dir[0] ? r->cache_dir : NULL;
    ctx.accum_store = &r->accum_store;
    ctx.info = stats->method_info;
    ctx.info_len = sizeof stats->method_info;
    stats->threads = ctx.threads;
    vsd_kernel_data_from_scene(&ctx.kd, sc);
    ctx.kd.scene_light_count = vsd_kscene_lights_setup(r->scene_lights, sc);
    ctx.kd.scene_lights = ctx.kd.scene_light_count ? r->scene_lights : NULL;
    for (int i = 0; i < sc->volume_count; i++) {
        const vsd_scene_volume *sv = &sc->volumes[i];
        vsd_kobject *o = &r->kvolumes[i];
        const vsd_volume *em = r->volumes[i].emission;
        if ((st = vsd_kvolume_setup(&o->density, r->volumes[i].density, sv->matrix, sv->medium.density, err, errlen)) ||
            (st = vsd_kvolume_setup(&o->emission, em, sv->matrix, 1.0f, err, errlen)))
            return st;
        vsd_kmedium_setup(&o->medium, &sv->medium);
        o->medium.has_emission = em && em->brick_dims[0] > 0 && sv->medium.emission_strength > 0.0f;
    }
    ctx.kd.density = r->kvolumes[0].density;
    ctx.kd.emission = r->kvolumes[0].emission;
    ctx.kd.medium = r->kvolumes[0].medium;
    ctx.kd.volume_count = sc->volume_count;
    ctx.kd.volumes = r->kvolumes;
    ctx.volume_count = sc->volume_count;
    vsd_kenv_setup(&ctx.kd.env, r->env, &r->tables, sc->environment.interpolation, sc->environment.strength,
                   sc->environment.rotation_z);

    {
        /* A stage's generation is new whenever its data may change; a new frame also
         * starts a new lighting generation before prepare_frame runs, so nothing a method
         * uploads while preparing the frame can match a key of the previous frame. */
        const int frame_changed = plan->frame_changed, lighting_changed = plan->lighting_changed;
        if (frame_changed) {
            r->frame_key[0] = r->lighting_key[0] = '\0';
            r->frame_gen = ++r->generation;
        }
        if (lighting_changed) r->lighting_gen = ++r->generation;
        ctx.frame_gen = r->frame_gen;
        ctx.lighting_gen = r->lighting_gen;
        ctx.volume_gen = r->volume_gen;
        ctx.env_gen = r->env_gen;
        if (frame_changed) {
            if (r->method->prepare_frame && (st = r->method->prepare_frame(r->method_state, &ctx, err, errlen)))
                return st;
            snprintf(r->frame_key, KEY_LEN, "%s", plan->frame_key);
        }
        if (lighting_changed) {
            /* a lighting stage that fails (cancelled by a newer edit) has freed the old
               lighting: no key may match it until one succeeds */
            r->lighting_key[0] = '\0';
            if (r->method->prepare_lighting && (st = r->method->prepare_lighting(r->method_state, &ctx, err, errlen)))
                return st;
            snprintf(r->lighting_key, KEY_LEN, "%s", plan->lighting_key);
            r->lit_strength = sc->environment.strength;
        }
    }
    t2 = vsd_clock_seconds();
    stats->prepare_seconds = t2 - plan->t_loaded;

    if (!*fbp || (*fbp)->width != sc->film.width || (*fbp)->height != sc->film.height) {
        vsd_framebuffer_destroy(*fbp);
        *fbp = NULL;
        if ((st = vsd_framebuffer_create(sc->film.width, sc->film.height, fbp, err, errlen))) return st;
    }
    /* not cleared: every method's render writes every pixel of every pass (the sums'
     * resolve, or the adaptive view pixel by pixel), and a kept film of 1280x720 is 63 MB
     * to clear on one thread (test_adaptive_view [5]: a kept renderer's view is a fresh
     * one's bit for bit) */
    st = r->method->render(r->method_state, &ctx, *fbp, &stats->samples, err, errlen);
    stats->render_seconds = vsd_clock_seconds() - t2;
    if (cuda) {
        double passes, downloads;
        stats->device_uploaded_bytes = vsd_cuda_uploaded_bytes(cuda) - plan->uploaded0;
        vsd_cuda_seconds(cuda, &passes, &downloads);
        stats->device_pass_seconds = passes - plan->passes0;
        stats->device_download_seconds = downloads - plan->downloads0;
    }
    return st;
}

void vsd_renderer_destroy(vsd_renderer *r)
{
    if (!r) return;
    vsd_accum_store_free(&r->accum_store);
    release_method(r);
    free_owned_volumes(r);
    free_owned_env(r);
    vsd_cuda_close(r->cuda);
    free(r);
}
