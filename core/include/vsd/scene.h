/* vsd/scene.h — the scene file v1 (docs/architecture.md §4) as a plain struct.
 *
 * vsd_scene_load() parses JSON (cJSON) after applying command-line style overrides
 * ("render.samples=256"), fills every absent field with its documented default (see
 * docs/scene-file.md), rejects unknown keys and wrong types with an error naming the
 * path ("camera.fov: expected number"), resolves relative paths against the scene file's
 * folder and reduces the camera to a camera-to-world matrix plus a field of view.
 * The struct owns no heap memory: copy it, memset it, free nothing. */
#ifndef VSD_SCENE_H
#define VSD_SCENE_H
#include "vsd/status.h"
#include "vsd/image.h"   /* vsd_pass: output.passes and output.pass_names */
#ifdef __cplusplus
extern "C" {
#endif

#define VSD_PATH_LEN 1024
#define VSD_NAME_LEN 128
#define VSD_OPTIONS_LEN 4096

typedef enum vsd_env_interpolation { VSD_ENV_LINEAR = 0, VSD_ENV_CLOSEST = 1 } vsd_env_interpolation;
typedef enum vsd_camera_type { VSD_CAMERA_PERSPECTIVE = 0, VSD_CAMERA_ORTHOGRAPHIC = 1 } vsd_camera_type;
typedef enum vsd_light_type { VSD_LIGHT_SUN = 0, VSD_LIGHT_POINT = 1, VSD_LIGHT_SPOT = 2 } vsd_light_type;

/* At most this many entries in lights[] (a scene's few key lights; the environment is the
 * main light). */
#define VSD_MAX_LIGHTS 16

/* One entry of lights[]: a Blender light with Cycles' units (docs/scene-file.md). */
typedef struct vsd_scene_light {
    vsd_light_type type;
    float color[3];                      /* default 1,1,1 */
    float strength;                      /* sun: irradiance in W/m^2 at normal incidence (default 1) */
    float power;                         /* point, spot: watts (default 1000), intensity power/4pi W/sr */
    double position[3];                  /* point, spot: world position */
    double direction[3];                 /* sun, spot: the direction the light travels (Blender's
                                            local -Z), normalised; default 0,0,-1 */
    float radius;                        /* point, spot: radius of the emitting sphere (default 0) */
    float angle;                         /* sun: angular diameter, radians (default 0) */
    float spot_size;                     /* spot: full cone angle, radians (default 45 degrees) */
    float spot_blend;                    /* spot: 0..1, softness of the cone's edge (default 0.15) */
    int spot_cosine;                     /* spot: the mask includes the cosine to the axis (Cycles
                                            3.x, default) or not (Cycles 4.2+; the add-on
                                            sends false there) */
} vsd_scene_light;

/* At most this many entries in volumes[] (docs/scene-file.md "volumes"): each costs a
 * grid load, a kernel slot and its own lookups on every step of every ray. */
#define VSD_MAX_VOLUMES 16

/* The material of one volume: Blender's Principled Volume, in Cycles' units. */
typedef struct vsd_scene_medium {
    float density;                   /* default 1 */
    float albedo[3];                 /* default 0.8 (Principled Volume's default colour is 0.5; see docs) */
    float anisotropy;                /* default 0 */
    float emission_color[3];         /* default 1,1,1 */
    float emission_strength;         /* default 0 */
    float ior;                       /* default 1 */
    char ior_from[16];               /* "none" (default): ior_grid holds n;
                                        "temperature": it holds Blender's temperature */
} vsd_scene_medium;

/* One entry of volumes[]: a VDB sequence placed in the world with its own material.
 * Where volumes overlap their extinction, scattering and emission add, and the phase is
 * the scattering-weighted mixture of their lobes (as Cycles does). */
typedef struct vsd_scene_volume {
    char file[VSD_PATH_LEN];         /* resolved path, may contain #### */
    char grid[VSD_NAME_LEN];         /* default "density" ("" = first float grid) */
    int grid_index;                  /* -1 = by name (default) */
    char emission_grid[VSD_NAME_LEN];/* "" = none (default) */
    double matrix[16];               /* object matrix, row-major, default identity */
    float warn_above;                /* a grid value above this is reported (default 1e4) */
    char ior_grid[VSD_NAME_LEN];     /* "" = none: a grid of the refractive index (or, with
                                        medium.ior_from, of what it is computed from) */
    int frame_offset;                /* the file of scene frame f is #### = f + frame_offset
                                        (Blender's volume object "Offset"; default 0) */
    vsd_scene_medium medium;
} vsd_scene_volume;

typedef struct vsd_scene {
    int version;                         /* 1 */
    char base_dir[VSD_PATH_LEN];         /* folder of the scene file ("" = cwd) */

    /* volumes[0 .. volume_count-1]: at least one. A file's single `volume` + `medium`
     * reads as a list of one. */
    int volume_count;
    vsd_scene_volume volumes[VSD_MAX_VOLUMES];

    struct {
        char file[VSD_PATH_LEN];         /* "" = uniform colour */
        float color[3];                  /* used when file is "" (default 0.05 grey, Blender's world) */
        float strength;                  /* default 1 */
        float rotation_z;                /* radians, default 0 */
        char colorspace[VSD_NAME_LEN];   /* "" = file is already in the working space */
        char working_space[VSD_NAME_LEN];/* the render's space, which the map is converted
                                            to; "" = the OCIO config's scene_linear role */
        int interpolation;               /* VSD_ENV_LINEAR (default, Blender's Environment
                                            Texture default) or VSD_ENV_CLOSEST */
    } environment;

    int light_count;                     /* entries of lights[] (0..VSD_MAX_LIGHTS) */
    vsd_scene_light lights[VSD_MAX_LIGHTS];

    struct {
        vsd_camera_type type;            /* default perspective */
        double matrix[16];               /* camera-to-world, row-major; camera looks down -Z, +Y up */
        double fov;                      /* radians across the larger image dimension (perspective) */
        double ortho_scale;              /* world width across the larger dimension (orthographic) */
        double clip_start, clip_end;     /* defaults 0.1, 1000 (Blender's) */
    } camera;

    struct {
        int width, height;               /* default 640x360 */
        int transparent;                 /* default 1 */
    } film;

    struct {
        char method[VSD_NAME_LEN];       /* default "reference" */
        char device[32];                 /* "auto" (default), "cpu", "cuda" */
        int samples;                     /* default 64 */
        int seed;                        /* default 1 */
        int threads;                     /* default 0 = all cores */
        char options_json[VSD_OPTIONS_LEN]; /* method options object, serialised ("{}" default) */
    } render;

    struct { int start, end; } frames;   /* default 1..1 */

    struct {
        char exr[VSD_PATH_LEN];          /* resolved, may contain ####; default "out/frame_####.exr" */
        unsigned pass_mask;              /* vsd_pass bits; default all */
        char layer[VSD_NAME_LEN];        /* default "ViewLayer" */
        /* EXR layer name written for each pass, indexed by vsd_pass (output.pass_names);
         * default vsd's own names ("VolumeDir", ...). */
        char pass_names[VSD_PASS_COUNT][VSD_PASS_NAME_MAX + 1];
        int half;                        /* default 0 */
        /* EXR compression: "zip" (default) or "none" (transient results read at once: ZIP
         * encoding took 1.4 s at 1280x720 on the 2-core VM) */
        char compression[VSD_NAME_LEN];
        char preview_png[VSD_PATH_LEN];  /* "" = none (default) */
        char view[VSD_NAME_LEN];         /* OCIO view for the preview, "" = config default */
    } output;
} vsd_scene;

/* Fill every field with its default. */
void vsd_scene_defaults(vsd_scene *scene);

/* Parse a scene file, applying `overrides` ("key.path=value"; value parsed as JSON, else
 * taken as a string) before validation. */
vsd_status vsd_scene_load(const char *path, const char *const *overrides, int override_count,
                          vsd_scene *scene, char *err, size_t errlen);

/* Same from a JSON string; relative paths resolve against base_dir ("" = cwd). */
vsd_status vsd_scene_parse(const char *json, const char *base_dir,
                           const char *const *overrides, int override_count,
                           vsd_scene *scene, char *err, size_t errlen);

/* Replace the run of '#' in `pattern` by `frame` zero-padded to the run's length
 * ("smoke_####.vdb", 7 -> "smoke_0007.vdb"); patterns without '#' are copied. */
vsd_status vsd_frame_path(const char *pattern, int frame, char *out, size_t outlen,
                          char *err, size_t errlen);

/* The grid the refractive index of volume v comes from: its ior_grid, else "temperature"
 * when its medium.ior_from is "temperature", else "" (none). */
const char *vsd_scene_ior_grid(const vsd_scene_volume *v);
/* Whether volume v refracts: medium.ior != 1 or a refractive index grid. */
int vsd_scene_volume_refracts(const vsd_scene_volume *v);
/* The index of the scene's refracting volume, -1 when none refracts (the first when
 * several do: vsd_method_check_volumes refuses that). */
int vsd_scene_refracting_volume(const vsd_scene *sc);
/* The frame number volume v reads for scene frame `frame` (frame + frame_offset, clamped
 * to Blender's frame range). */
int vsd_scene_volume_frame(const vsd_scene_volume *v, int frame);
/* The environment map's colour conversion as one string (vsd_env_conversion: "" none,
 * "FROM", or FROM and TO joined by VSD_ENV_SPACE_SEP), written into buf. */
const char *vsd_scene_env_conversion(const vsd_scene *s, char *buf, size_t len);

#ifdef __cplusplus
}
#endif
#endif
