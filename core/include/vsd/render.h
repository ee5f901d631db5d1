/* vsd/render.h — rendering a scene: the one pipeline the CLI, the daemon and the tests use.
 *
 * A vsd_renderer holds what one scene needs across frames and views: the loaded volume
 * frame, the environment map with its sampling tables, and the method's prepared state.
 * vsd_renderer_render() reuses whatever is still valid (same frame file, same map) so a new
 * camera or a second view costs only the view pass.
 *
 * Ownership: vsd_renderer_create copies the scene; vsd_renderer_destroy frees everything.
 * The framebuffer passed to render is the caller's. */
#ifndef VSD_RENDER_H
#define VSD_RENDER_H
#include "vsd/status.h"
#include "vsd/scene.h"
#include "vsd/image.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#ifdef __cplusplus
extern "C" {
#endif

/* Called from worker threads under a lock; `fraction` in [0,1] of the current stage. */
typedef void (*vsd_progress_fn)(void *user, const char *stage, float fraction);

typedef struct vsd_render_options {
    int threads;                 /* 0 = all cores (overrides render.threads when > 0) */
    vsd_progress_fn progress;    /* 0 = silent */
    void *user;
    volatile int *cancel;        /* set non-zero from anywhere to stop: VSD_ERR_CANCELLED */
    const char *cache_dir;       /* where methods keep per-frame work between runs (crm's RBF
                                    fits); NULL or "" = nowhere. Copied at create. */
    unsigned long long max_voxels; /* the most active voxels of the scene's density grids
                                    together, checked from the files before loading them
                                    (0 = VSD_DEFAULT_MAX_VOXELS; the daemon's --max-voxels) */
} vsd_render_options;

#define VSD_DEFAULT_MAX_VOXELS 1000000000ull

typedef struct vsd_render_stats {
    double load_seconds;         /* reading VDB and environment files */
    double prepare_seconds;      /* method preparation (per frame / per lighting) */
    double render_seconds;       /* the view pass */
    int samples;                 /* samples per pixel actually taken */
    int threads;
    unsigned long long active_voxels;
    char method[64];
    char device[16];             /* "cpu" or "cuda" */
    char device_name[128];       /* the GPU's name on "cuda" */
    char device_note[512];       /* why render.device "auto" uses the CPU, when it tried CUDA */
    unsigned long long device_uploaded_bytes; /* host-to-device copies during this render */
    double device_pass_seconds;     /* of the render's seconds: inside device passes (kernels) */
    double device_download_seconds; /* of them: copying results back from the device */
    char method_info[512];       /* the method's own figures, "key=value ..." (crm: RBFs, fit) */
    int relit;                   /* 1: the lighting stage ran (a new frame or a lighting change); 0: the
                                    prepared lighting served (a view change, or the map's strength alone) */
    int reframed;                /* 1: the frame stage ran (a new frame, volume, transform, or a density
                                    edit for a method that reads the density only in its frame stage) */
    float strength_scale;        /* the radiance passes' scale for a change of the map's strength alone
                                    (nothing else lights the scene: no scene lights, no emission), 1 else */
    char warnings[512];          /* what in the input looks wrong but renders ("" = nothing) */
} vsd_render_stats;

typedef struct vsd_renderer vsd_renderer;

/* The per-user folder for vsd_render_options.cache_dir: $VSD_CACHE_DIR ("none" = no
 * cache), else $XDG_CACHE_HOME/vsd, else $HOME/.cache/vsd. Written into buf; NULL = none. */
const char *vsd_default_cache_dir(char *buf, size_t len);

/* Does a CUDA device answer? VSD_OK with its name (what render.device "auto" would use),
 * else the reason in err. Opens and closes a device context: call it once, not per frame. */
vsd_status vsd_render_cuda_probe(char *name, size_t namelen, char *err, size_t errlen);

vsd_status vsd_renderer_create(const vsd_scene *scene, const vsd_render_options *opt,
                               vsd_renderer **out, char *err, size_t errlen);
/* Replace the scene (camera, medium, options...); caches stay where still valid. */
vsd_status vsd_renderer_set_scene(vsd_renderer *r, const vsd_scene *scene, char *err, size_t errlen);
/* Render `frame` into fb (resized to the film if needed). */
vsd_status vsd_renderer_render(vsd_renderer *r, int frame, vsd_framebuffer **fb,
                               vsd_render_stats *stats, char *err, size_t errlen);
void vsd_renderer_destroy(vsd_renderer *r);

/* Render volume `index` of the scene's volumes[] (0 .. VSD_MAX_VOLUMES-1), or the
 * environment, from grids / a map already in memory instead of the scene's files (the
 * daemon's blob caches, tests, synthetic scenes): its density grid, its emission grid
 * (NULL = none) and the grid its ior_grid / medium.ior_from names (NULL = none).
 * Borrowed: the caller keeps them alive until the renderer is destroyed or they are
 * replaced; a NULL density returns that volume to its files. The pointer identity is the
 * cache key, so pass a new object for new contents. */
void vsd_renderer_use_volume(vsd_renderer *r, int index, const vsd_volume *density, const vsd_volume *emission,
                             const vsd_volume *ior);
void vsd_renderer_use_env(vsd_renderer *r, const vsd_env *env);

/* Write the frame's EXR (and preview PNG when the scene asks for one) with header
 * attributes recording method, options, timings and version. `note` (may be NULL) gets
 * the preview's colour-management note. Paths come from scene->output with #### filled. */
vsd_status vsd_write_frame_outputs(const vsd_scene *scene, int frame, const vsd_framebuffer *fb,
                                   const vsd_render_stats *stats, char *exr_path, size_t exr_len,
                                   char *note, size_t notelen, char *err, size_t errlen);
/* The preview PNG vsd_write_frame_outputs writes (the scene's output.view), to `path`. */
vsd_status vsd_write_frame_preview(const vsd_scene *scene, const vsd_framebuffer *fb, const char *path, char *note,
                                   size_t notelen, char *err, size_t errlen);
/* The EXR vsd_write_frame_outputs writes (the same channels and attributes), as bytes in
 * memory (*bytes malloc'd): the daemon's result. */
vsd_status vsd_encode_frame_exr(const vsd_scene *scene, int frame, const vsd_framebuffer *fb,
                                const vsd_render_stats *stats, unsigned char **bytes, size_t *len, char *err,
                                size_t errlen);

/* What a frame's output EXR holds, for `vsd render --continue` and `vsd farm status`. */
typedef enum vsd_frame_output_state {
    VSD_FRAME_DONE = 0,      /* complete: header with this scene's hash, every pixel reads */
    VSD_FRAME_MISSING,       /* no file */
    VSD_FRAME_STALE,         /* a complete file of another scene (hash differs or absent) */
    VSD_FRAME_BROKEN         /* a file that does not read: truncated, not an EXR, ... */
} vsd_frame_output_state;

/* The hash a frame's EXR records as "vsd/scene_hash" (32 hex digits): XXH3-128 over
 * everything that changes the frame's pixels — the scene with the frame range, output
 * paths, thread count and preview settings left out — and the contents of the frame's
 * VDB file and the environment map. Two runs that would render the same image agree;
 * splitting a sequence into frame ranges does not change it. VSD_ERR_IO when a file
 * cannot be read. */
vsd_status vsd_scene_frame_hash(const vsd_scene *scene, int frame, char hex[33],
                                char *err, size_t errlen);

/* The state of scene->output.exr for `frame`; `why` gets a line for the log ("complete",
 * "no file", "rendered from another scene (hash 1a2b.. , now 3c4d..)", "pixels do not
 * read: ..."). A leftover "<path>.tmp-<pid>" of a killed run is not the frame. */
vsd_frame_output_state vsd_frame_output_check(const vsd_scene *scene, int frame, char *why,
                                              size_t whylen);

/* Names of the methods this build renders (NULL-terminated, static), in the registry's
 * order (core/methods/registry.h). */
const char *const *vsd_method_names(void);

/* What a method renders; the catalog spells each bit as a name (in brackets). */
enum {
    VSD_METHOD_CAP_MULTIPLE_SCATTERING = 1u << 0, /* light scattered more than once ("multiple_scattering") */
    VSD_METHOD_CAP_REFRACTION = 1u << 1,          /* bends rays by medium.ior / volume.ior_grid ("refraction") */
    VSD_METHOD_CAP_SCENE_LIGHTS = 1u << 2,        /* the scene's lights[]: sun, point, spot ("scene_lights") */
    VSD_METHOD_CAP_EMISSION_SCATTERING = 1u << 3, /* the medium scatters its own emission ("emission_scattering") */
    VSD_METHOD_CAP_CUDA_VIEW = 1u << 4,           /* renders on render.device "cuda" ("cuda_view") */
    VSD_METHOD_CAP_SEVERAL_VOLUMES = 1u << 5      /* scenes with several volumes[] ("several_volumes") */
};

/* The VSD_METHOD_CAP_* bits of method `name`; 0 for an unknown name. */
unsigned vsd_method_capabilities(const char *name);

/* Every method as JSON, in registry order: [{"name", "label", "summary", "capabilities":
 * {"multiple_scattering": bool, ...}, "roles": ["final_default" | "viewport_default"],
 * "options": [rows as vsd_method_options_json], "preview_options": {key: value, ...} (the
 * render.options of a quick first look at a changed scene, {} when the method has none)},
 * ...]: what `vsd methods --json` prints
 * and the daemon's HELLO carries as "method_catalog" (docs/protocol.md). Malloc'd; free()
 * it. NULL when out of memory. */
char *vsd_method_catalog_json(void);

/* Every method's render.options table as JSON, {"method": [{"key", "type", "min", "max",
 * "default", "choices", "doc", "auto_zero", "unit"}, ...], ...}: what `vsd methods --json`
 * prints and the daemon's HELLO carries (docs/protocol.md). Malloc'd; free() it. NULL
 * when out of memory. */
char *vsd_method_options_json(void);

const char *vsd_version(void);

#ifdef __cplusplus
}
#endif
#endif
