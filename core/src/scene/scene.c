/* Scene file v1 (docs/architecture.md §3-4): JSON -> vsd_scene.
 *
 * Every field is described once, in the tables below (key, kind, destination, default,
 * range); one walker applies a table to a cJSON object. Defaults, type checks, range
 * checks and the "known keys" list of the unknown-key error therefore come from the same
 * line and cannot disagree. Rules that involve several fields of a section (the camera
 * forms, environment file-or-colour, frame order, film area) run in the section's
 * `finish` step, after its fields are read.
 *
 * Pipeline: text -> cJSON tree -> overrides edit the tree -> version check -> walk the
 * tables (fill, validate, resolve paths) -> copy to the caller's struct on success only,
 * so a failed load never leaves a half-filled scene behind. */
#include "vsd/scene.h"
#include "vsd/image.h"
#include "vsd/env.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
/* Blender's default camera: 50 mm lens on a 36 mm sensor. */
#define BLENDER_FOV 0.6911111611634243 /* 2 atan(18 / 50), 39.6 degrees */
#define BLENDER_ORTHO_SCALE 7.314285755157471
#define MAX_PIXELS (64ll * 1024 * 1024)
#define MAX_SCENE_BYTES (64u * 1024 * 1024)
/* Blender's frame limits (MINAFRAME, MAXFRAME). */
#define MIN_FRAME (-1048574)
#define MAX_FRAME 1048574
#define KEYPATH_LEN 256

/* The scene plus what the file says that vsd_scene reduces away: the camera inputs that
 * become camera.matrix and camera.fov in the camera's finish step. */
typedef struct scene_ext {
    vsd_scene s;
    struct {
        double position[3], look_at[3], up[3], matrix[16];
        double lens, sensor_width;
    } cam;
    vsd_scene_light light;   /* the lights[] entry being read, copied into s.lights */
    vsd_scene_volume vol;    /* the volumes[] entry being read, copied into s.volumes */
} scene_ext;

typedef struct parser {
    scene_ext *out;
    const char *base_dir;   /* relative paths resolve against it ("" = keep relative) */
    const char *prefix;     /* the scene file's path for messages, "" for strings */
    int defaults_only;      /* vsd_scene_defaults: no JSON, so nothing is required */
    int single_volume;      /* the file wrote one `volume` + `medium`: messages use those names */
    char *err;
    size_t errlen;
} parser;

typedef enum kind {
    K_OBJECT,  /* a nested table */
    K_NUMBER,  /* float or double, chosen by the member's size */
    K_INT,
    K_BOOL,    /* stored as int 0/1 */
    K_STRING,
    K_PATH,    /* string resolved against base_dir */
    K_CHOICE,  /* string that must be one of `choices`, stored as the string */
    K_ENUM,    /* string that must be one of `choices`, stored as its int index */
    K_RGB,     /* 3 numbers -> float[3] */
    K_VEC3,    /* 3 numbers -> double[3] */
    K_MAT4,    /* 16 numbers, row-major, affine -> double[16] */
    K_CUSTOM   /* `apply` does everything, including the default */
} kind;

enum {
    R_MIN = 1u << 0,      /* value >= lo (> lo with R_LO_OPEN) */
    R_MAX = 1u << 1,      /* value <= hi (< hi with R_HI_OPEN) */
    R_LO_OPEN = 1u << 2,
    R_HI_OPEN = 1u << 3,
    F_REQUIRED = 1u << 4, /* absent or "" is an error */
    F_NULLABLE = 1u << 5, /* JSON null means the default */
    F_NONEMPTY = 1u << 6, /* "" is an error */
    F_FRAMES = 1u << 7    /* path may hold one run of '#' (frame number) */
};

typedef struct field field;
typedef struct table table;
/* `item` is NULL when the key is absent (or null where F_NULLABLE): apply the default. */
typedef vsd_status (*apply_fn)(parser *p, const field *f, const cJSON *item, const char *path);
typedef vsd_status (*finish_fn)(parser *p, const cJSON *obj, const char *path);

struct field {
    const char *key;
    kind kind;
    size_t off, size;            /* destination inside scene_ext and its size */
    unsigned flags;
    double lo, hi;               /* range, with R_MIN / R_MAX */
    double def;                  /* numbers, ints, bools, each component of an RGB */
    const char *sdef;            /* strings, paths, choices */
    const double *vdef;          /* K_VEC3 */
    const char *const *choices;  /* K_CHOICE, K_ENUM: NULL-terminated */
    const table *sub;            /* K_OBJECT */
    apply_fn apply;              /* K_CUSTOM */
};

struct table {
    const field *fields;
    size_t count;
    finish_fn finish;
};

/* ---- table-building macros: one line per field ------------------------------------ */
#define AT(m) .off = offsetof(scene_ext, m), .size = sizeof(((scene_ext *)0)->m)
#define F_NUM(k, m, d, fl, l, h) \
    { .key = k, .kind = K_NUMBER, AT(m), .def = d, .flags = (fl), .lo = l, .hi = h }
#define F_INT(k, m, d, l, h) \
    { .key = k, .kind = K_INT, AT(m), .def = d, .flags = R_MIN | R_MAX, .lo = l, .hi = h }
#define F_BOOL(k, m, d) { .key = k, .kind = K_BOOL, AT(m), .def = d }
#define F_STR(k, m, d, fl) { .key = k, .kind = K_STRING, AT(m), .sdef = d, .flags = (fl) }
#define F_PATH(k, m, d, fl) { .key = k, .kind = K_PATH, AT(m), .sdef = d, .flags = (fl) }
#define F_CHOICE(k, m, list, d) { .key = k, .kind = K_CHOICE, AT(m), .choices = list, .sdef = d }
#define F_ENUM(k, m, list) { .key = k, .kind = K_ENUM, AT(m), .choices = list }
#define F_RGB(k, m, d, fl, l, h) \
    { .key = k, .kind = K_RGB, AT(m), .def = d, .flags = (fl), .lo = l, .hi = h }
#define F_VEC3(k, m, d) { .key = k, .kind = K_VEC3, AT(m), .vdef = d }
#define F_MAT4(k, m) { .key = k, .kind = K_MAT4, AT(m) }
#define F_OBJ(k, t) { .key = k, .kind = K_OBJECT, .sub = &t }
#define F_CUSTOM(k, fn) { .key = k, .kind = K_CUSTOM, .apply = fn }
#define TABLE(name, fin) static const table name##_table = { name##_fields, \
    sizeof name##_fields / sizeof name##_fields[0], fin }

#define GE0 (R_MIN)                  /* >= 0 */
#define GT0 (R_MIN | R_LO_OPEN)      /* > 0 */
#define UNIT (R_MIN | R_MAX)         /* closed [lo, hi] */

static vsd_status apply_grid(parser *p, const field *f, const cJSON *item, const char *path);
static vsd_status apply_lights(parser *p, const field *f, const cJSON *item, const char *path);
static vsd_status apply_volumes(parser *p, const field *f, const cJSON *item, const char *path);
static vsd_status apply_medium(parser *p, const field *f, const cJSON *item, const char *path);
static vsd_status apply_options(parser *p, const field *f, const cJSON *item, const char *path);
static vsd_status apply_passes(parser *p, const field *f, const cJSON *item, const char *path);
static vsd_status apply_pass_names(parser *p, const field *f, const cJSON *item, const char *path);
static vsd_status environment_finish(parser *p, const cJSON *obj, const char *path);
static vsd_status camera_finish(parser *p, const cJSON *obj, const char *path);
static vsd_status film_finish(parser *p, const cJSON *obj, const char *path);
static vsd_status frames_finish(parser *p, const cJSON *obj, const char *path);
static vsd_status light_finish(parser *p, const cJSON *obj, const char *path);

static const double default_position[3] = {0, -6, 1};
static const double default_look_at[3] = {0, 0, 0};
static const double default_up[3] = {0, 0, 1};
static const char *const camera_types[] = {"perspective", "orthographic", NULL};
static const char *const devices[] = {"auto", "cpu", "cuda", NULL};
static const char *const ior_sources[] = {"none", "temperature", NULL};
/* Blender's Environment Texture interpolations vsd reads (index = vsd_env_interpolation). */
static const char *const env_interpolations[] = {"linear", "closest", NULL};

static const char *const light_types[] = {"sun", "point", "spot", NULL};
static const double default_light_position[3] = {0, 0, 0};
static const double default_light_direction[3] = {0, 0, -1};

/* One table for the three types; light_finish refuses the keys a type does not have. */
static const field light_fields[] = {
    {.key = "type", .kind = K_ENUM, AT(light.type), .choices = light_types, .flags = F_REQUIRED},
    F_RGB("color", light.color, 1, GE0, 0, 0),
    F_NUM("strength", light.strength, 1, GE0, 0, 0),
    F_NUM("power", light.power, 1000, GE0, 0, 0),
    F_VEC3("position", light.position, default_light_position),
    F_VEC3("direction", light.direction, default_light_direction),
    F_NUM("radius", light.radius, 0, GE0, 0, 0),
    F_NUM("angle", light.angle, 0, R_MIN | R_MAX | R_HI_OPEN, 0, PI),
    F_NUM("spot_size", light.spot_size, PI / 4, R_MIN | R_MAX | R_LO_OPEN, 0, PI),
    F_NUM("spot_blend", light.spot_blend, 0.15, UNIT, 0, 1),
    F_BOOL("spot_cosine", light.spot_cosine, 1),
};
TABLE(light, light_finish);

static const field medium_fields[] = {
    F_NUM("density", vol.medium.density, 1, GE0, 0, 0),
    F_RGB("albedo", vol.medium.albedo, 0.8, UNIT, 0, 1),
    F_NUM("anisotropy", vol.medium.anisotropy, 0, R_MIN | R_MAX | R_LO_OPEN | R_HI_OPEN, -1, 1),
    F_RGB("emission_color", vol.medium.emission_color, 1, GE0, 0, 0),
    F_NUM("emission_strength", vol.medium.emission_strength, 0, GE0, 0, 0),
    F_NUM("ior", vol.medium.ior, 1, GT0, 0, 0),
    F_CHOICE("ior_from", vol.medium.ior_from, ior_sources, "none"),
};
TABLE(medium, NULL);

/* One entry of volumes[]; a file's single `volume` + `medium` arrive here as one entry
 * (normalise_volumes). */
static const field volume_fields[] = {
    F_PATH("file", vol.file, "", F_REQUIRED | F_FRAMES),
    F_CUSTOM("grid", apply_grid),
    F_STR("emission_grid", vol.emission_grid, "", F_NULLABLE),
    F_MAT4("matrix", vol.matrix),
    F_NUM("warn_above", vol.warn_above, 1e4, GT0, 0, 0),
    F_STR("ior_grid", vol.ior_grid, "", F_NULLABLE),
    F_INT("frame_offset", vol.frame_offset, 0, MIN_FRAME, MAX_FRAME),
    F_CUSTOM("medium", apply_medium),
};
TABLE(volume, NULL);

static const field environment_fields[] = {
    F_PATH("file", s.environment.file, "", F_NULLABLE),
    F_RGB("color", s.environment.color, 0.05, GE0, 0, 0),
    F_NUM("strength", s.environment.strength, 1, GE0, 0, 0),
    F_NUM("rotation_z", s.environment.rotation_z, 0, 0, 0, 0),
    F_STR("colorspace", s.environment.colorspace, "", F_NULLABLE),
    F_STR("working_space", s.environment.working_space, "", F_NULLABLE),
    F_ENUM("interpolation", s.environment.interpolation, env_interpolations),
};
TABLE(environment, environment_finish);

static const field camera_fields[] = {
    F_ENUM("type", s.camera.type, camera_types),
    F_VEC3("position", cam.position, default_position),
    F_VEC3("look_at", cam.look_at, default_look_at),
    F_VEC3("up", cam.up, default_up),
    F_MAT4("matrix", cam.matrix),
    F_NUM("fov", s.camera.fov, BLENDER_FOV, R_MIN | R_MAX | R_LO_OPEN | R_HI_OPEN, 0, PI),
    F_NUM("lens", cam.lens, 50, GT0, 0, 0),
    F_NUM("sensor_width", cam.sensor_width, 36, GT0, 0, 0),
    F_NUM("ortho_scale", s.camera.ortho_scale, BLENDER_ORTHO_SCALE, GT0, 0, 0),
    F_NUM("clip_start", s.camera.clip_start, 0.1, GT0, 0, 0),
    F_NUM("clip_end", s.camera.clip_end, 1000, GT0, 0, 0),
};
TABLE(camera, camera_finish);

static const field film_fields[] = {
    F_INT("width", s.film.width, 640, 1, 16384),
    F_INT("height", s.film.height, 360, 1, 16384),
    F_BOOL("transparent", s.film.transparent, 1),
};
TABLE(film, film_finish);

static const field render_fields[] = {
    F_STR("method", s.render.method, "reference", F_NONEMPTY),
    F_CHOICE("device", s.render.device, devices, "auto"),
    F_INT("samples", s.render.samples, 64, 1, 1000000),
    F_INT("seed", s.render.seed, 1, 0, INT_MAX),
    F_INT("threads", s.render.threads, 0, 0, 4096),
    F_CUSTOM("options", apply_options),
};
TABLE(render, NULL);

static const field frames_fields[] = {
    F_INT("start", s.frames.start, 1, MIN_FRAME, MAX_FRAME),
    F_INT("end", s.frames.end, 1, MIN_FRAME, MAX_FRAME),
};
TABLE(frames, frames_finish);


static const field output_fields[] = {
    F_PATH("exr", s.output.exr, "out/frame_####.exr", F_NONEMPTY | F_FRAMES),
    F_CUSTOM("passes", apply_passes),
    F_CUSTOM("pass_names", apply_pass_names),
    F_STR("layer", s.output.layer, "ViewLayer", F_NONEMPTY),
    F_BOOL("half", s.output.half, 0),
    F_CHOICE("compression", s.output.compression, vsd_exr_compression_names, "zip"),
    F_PATH("preview_png", s.output.preview_png, "", F_NULLABLE | F_FRAMES),
    F_STR("view", s.output.view, "", F_NULLABLE),
};
TABLE(output, NULL);

static const field root_fields[] = {
    F_INT("version", s.version, 1, 1, 1), /* checked first, see check_version() */
    F_CUSTOM("volumes", apply_volumes),
    F_OBJ("environment", environment_table),
    F_CUSTOM("lights", apply_lights),
    F_OBJ("camera", camera_table),
    F_OBJ("film", film_table),
    F_OBJ("render", render_table),
    F_OBJ("frames", frames_table),
    F_OBJ("output", output_table),
};
TABLE(root, NULL);

/* ---- messages ----------------------------------------------------------------------- */

/* "<file>: <path>: <message>", leaving out the parts that are empty. */
static vsd_status fail(parser *p, vsd_status st, const char *path, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
static vsd_status fail(parser *p, vsd_status st, const char *path, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return vsd_fail(st, p->err, p->errlen, "%s%s%s%s%s", p->prefix, p->prefix[0] ? ": " : "",
                    path, path[0] ? ": " : "", msg);
}

/* Integers without an exponent ("1000000", not "1e+06"), everything else as %g. */
static const char *fmt_num(double v, char *buf, size_t n)
{
    if (v == floor(v) && fabs(v) < 1e15)
        snprintf(buf, n, "%.0f", v);
    else
        snprintf(buf, n, "%g", v);
    return buf;
}

static void join_path(char *out, size_t n, const char *parent, const char *key)
{
    snprintf(out, n, "%s%s%s", parent, parent[0] ? "." : "", key);
}

/* The list of a table's keys, for "unknown key (known: ...)". */
static vsd_status unknown_key(parser *p, const table *t, const char *path)
{
    char known[512] = "";
    size_t used = 0;
    for (size_t i = 0; i < t->count && used < sizeof known; i++) {
        int n = snprintf(known + used, sizeof known - used, "%s%s", i ? ", " : "", t->fields[i].key);
        if (n < 0)
            break;
        used += (size_t)n;
    }
    return fail(p, VSD_ERR_INVALID, path, "unknown key (known: %s)", known);
}

/* ---- reading typed values ----------------------------------------------------------- */

static void *dest(parser *p, const field *f)
{
    return (char *)p->out + f->off;
}

static vsd_status read_number(parser *p, const cJSON *item, const char *path, double *v)
{
    if (!cJSON_IsNumber(item))
        return fail(p, VSD_ERR_TYPE, path, "expected number");
    if (!isfinite(item->valuedouble))
        return fail(p, VSD_ERR_INVALID, path, "expected a finite number");
    *v = item->valuedouble;
    return VSD_OK;
}

/* JSON has one number type: an integer field takes any number without a fraction. */
static vsd_status read_int(parser *p, const cJSON *item, const char *path, double *v)
{
    if (!cJSON_IsNumber(item) || !isfinite(item->valuedouble) ||
        item->valuedouble != floor(item->valuedouble))
        return fail(p, VSD_ERR_TYPE, path, "expected integer");
    *v = item->valuedouble;
    return VSD_OK;
}

/* Exactly n finite numbers; anything else (wrong length, non-number element) is a type error. */
static vsd_status read_numbers(parser *p, const cJSON *item, const char *path, int n, double *out)
{
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != n)
        return fail(p, VSD_ERR_TYPE, path, "expected %d numbers", n);
    int i = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, item) {
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble))
            return fail(p, VSD_ERR_TYPE, path, "expected %d numbers", n);
        out[i++] = e->valuedouble;
    }
    return VSD_OK;
}

static vsd_status check_range(parser *p, const field *f, const char *path, double v)
{
    unsigned fl = f->flags;
    int lo_ok = !(fl & R_MIN) || ((fl & R_LO_OPEN) ? v > f->lo : v >= f->lo);
    int hi_ok = !(fl & R_MAX) || ((fl & R_HI_OPEN) ? v < f->hi : v <= f->hi);
    if (lo_ok && hi_ok)
        return VSD_OK;
    char val[32], lo[32], hi[32], range[96];
    fmt_num(v, val, sizeof val);
    fmt_num(f->lo, lo, sizeof lo);
    fmt_num(f->hi, hi, sizeof hi);
    if ((fl & R_MIN) && (fl & R_MAX) && !(fl & (R_LO_OPEN | R_HI_OPEN)))
        snprintf(range, sizeof range, "%s..%s", lo, hi);
    else if ((fl & R_MIN) && (fl & R_MAX))
        snprintf(range, sizeof range, "%c%s, %s%c", (fl & R_LO_OPEN) ? '(' : '[', lo, hi,
                 (fl & R_HI_OPEN) ? ')' : ']');
    else if (fl & R_MIN)
        snprintf(range, sizeof range, "(must be %s %s)", (fl & R_LO_OPEN) ? ">" : ">=", lo);
    else
        snprintf(range, sizeof range, "(must be %s %s)", (fl & R_HI_OPEN) ? "<" : "<=", hi);
    return fail(p, VSD_ERR_INVALID, path, "%s is out of range %s", val, range);
}

/* Checks shared by strings and paths: type, null, emptiness, length. *value is NULL for
 * an absent (or allowed null) value, meaning "use the default". */
static vsd_status read_string(parser *p, const field *f, const cJSON *item, const char *path,
                              const char **value)
{
    *value = NULL;
    if (!item)
        return VSD_OK;
    if (!cJSON_IsString(item))
        return fail(p, VSD_ERR_TYPE, path, "expected string%s",
                    (f->flags & F_NULLABLE) ? " or null" : "");
    const char *s = item->valuestring;
    if (!s[0] && (f->flags & F_REQUIRED))
        return fail(p, VSD_ERR_INVALID, path, "required (got an empty string)");
    if (!s[0] && (f->flags & F_NONEMPTY))
        return fail(p, VSD_ERR_INVALID, path, "must not be empty");
    if (strlen(s) >= f->size)
        return fail(p, VSD_ERR_INVALID, path, "too long (%zu characters, max %zu)", strlen(s),
                    f->size - 1);
    *value = s;
    return VSD_OK;
}

/* ---- kinds ---------------------------------------------------------------------------- */

/* The value of a number or integer field: the default when the key is absent, else the
 * item read and checked against the field's range. */
static vsd_status read_in_range(parser *p, const field *f, const cJSON *item, const char *path, int integer,
                                double *v)
{
    vsd_status st;
    *v = f->def;
    if (!item)
        return VSD_OK;
    st = integer ? read_int(p, item, path, v) : read_number(p, item, path, v);
    return st ? st : check_range(p, f, path, *v);
}

static vsd_status apply_number(parser *p, const field *f, const cJSON *item, const char *path)
{
    double v;
    vsd_status st = read_in_range(p, f, item, path, 0, &v);
    if (st)
        return st;
    if (f->size == sizeof(float))
        *(float *)dest(p, f) = (float)v;
    else
        *(double *)dest(p, f) = v;
    return VSD_OK;
}

static vsd_status apply_int(parser *p, const field *f, const cJSON *item, const char *path)
{
    double v;
    vsd_status st = read_in_range(p, f, item, path, 1, &v); /* every int field has a range inside int */
    if (st)
        return st;
    *(int *)dest(p, f) = (int)v;
    return VSD_OK;
}

static vsd_status apply_bool(parser *p, const field *f, const cJSON *item, const char *path)
{
    int v = f->def != 0;
    if (item) {
        if (!cJSON_IsBool(item))
            return fail(p, VSD_ERR_TYPE, path, "expected boolean (true or false)");
        v = cJSON_IsTrue(item);
    }
    *(int *)dest(p, f) = v;
    return VSD_OK;
}

static vsd_status apply_string(parser *p, const field *f, const cJSON *item, const char *path)
{
    const char *v;
    vsd_status st = read_string(p, f, item, path, &v);
    if (st)
        return st;
    snprintf(dest(p, f), f->size, "%s", v ? v : f->sdef);
    return VSD_OK;
}

/* Relative paths are relative to the scene file's folder (base_dir); absolute paths and
 * the daemon's content-addressed "blob:<hash>" names are kept as they are. */
static vsd_status store_path(parser *p, const field *f, const char *value, const char *path)
{
    char *dst = dest(p, f);
    const char *base = p->base_dir;
    int keep = !value[0] || value[0] == '/' || !strncmp(value, "blob:", 5) || !base[0];
    size_t blen = strlen(base);
    const char *sep = (blen && base[blen - 1] == '/') ? "" : "/";
    int n = keep ? snprintf(dst, f->size, "%s", value)
                 : snprintf(dst, f->size, "%s%s%s", base, sep, value);
    if (n < 0 || (size_t)n >= f->size) {
        dst[0] = '\0';
        return fail(p, VSD_ERR_INVALID, path, "path too long (%d characters, max %zu)", n,
                    f->size - 1);
    }
    return VSD_OK;
}

static vsd_status apply_path(parser *p, const field *f, const cJSON *item, const char *path)
{
    const char *v;
    vsd_status st = read_string(p, f, item, path, &v);
    if (st)
        return st;
    st = store_path(p, f, v ? v : f->sdef, path);
    if (st || !(f->flags & F_FRAMES))
        return st;
    /* Reject a bad frame pattern now rather than at the first frame of a long render. */
    char probe[VSD_PATH_LEN + 16], why[256];
    if (vsd_frame_path(dest(p, f), 0, probe, sizeof probe, why, sizeof why) != VSD_OK)
        return fail(p, VSD_ERR_INVALID, path, "%s", why);
    return VSD_OK;
}

static int choice_index(const char *const *choices, const char *s)
{
    for (int i = 0; choices[i]; i++)
        if (!strcmp(choices[i], s))
            return i;
    return -1;
}

/* K_CHOICE and K_ENUM: a string from a fixed list; the error lists the list. */
static vsd_status apply_choice(parser *p, const field *f, const cJSON *item, const char *path)
{
    int idx = f->sdef ? choice_index(f->choices, f->sdef) : 0;
    if (item) {
        if (!cJSON_IsString(item))
            return fail(p, VSD_ERR_TYPE, path, "expected string");
        idx = choice_index(f->choices, item->valuestring);
        if (idx < 0) {
            char list[256] = "";
            for (int i = 0; f->choices[i]; i++) {
                size_t used = strlen(list);
                snprintf(list + used, sizeof list - used, "%s\"%s\"", i ? ", " : "", f->choices[i]);
            }
            return fail(p, VSD_ERR_INVALID, path, "\"%s\" is not one of %s", item->valuestring, list);
        }
    }
    if (f->kind == K_ENUM)
        *(int *)dest(p, f) = idx;
    else
        snprintf(dest(p, f), f->size, "%s", f->choices[idx]);
    return VSD_OK;
}

static vsd_status apply_rgb(parser *p, const field *f, const cJSON *item, const char *path)
{
    double v[3] = {f->def, f->def, f->def};
    if (item) {
        vsd_status st = read_numbers(p, item, path, 3, v);
        for (int i = 0; i < 3 && !st; i++) {
            char sub[KEYPATH_LEN];
            snprintf(sub, sizeof sub, "%s[%d]", path, i);
            st = check_range(p, f, sub, v[i]);
        }
        if (st)
            return st;
    }
    float *dst = dest(p, f);
    for (int i = 0; i < 3; i++)
        dst[i] = (float)v[i];
    return VSD_OK;
}

static vsd_status apply_vec3(parser *p, const field *f, const cJSON *item, const char *path)
{
    double *dst = dest(p, f);
    if (!item) {
        memcpy(dst, f->vdef, 3 * sizeof *dst);
        return VSD_OK;
    }
    return read_numbers(p, item, path, 3, dst);
}

/* Object and camera matrices are Blender matrix_world values: affine, and invertible
 * because renderers map world rays back into the volume's (or camera's) frame. */
static vsd_status apply_mat4(parser *p, const field *f, const cJSON *item, const char *path)
{
    double m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    if (item) {
        vsd_status st = read_numbers(p, item, path, 16, m);
        if (st)
            return st;
        if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1)
            return fail(p, VSD_ERR_INVALID, path,
                        "last row must be 0, 0, 0, 1 (an affine transform, row-major)");
        double det = m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
                     m[2] * (m[4] * m[9] - m[5] * m[8]);
        /* Scale-free test: |det| relative to the product of the column lengths. */
        double c0 = sqrt(m[0] * m[0] + m[4] * m[4] + m[8] * m[8]);
        double c1 = sqrt(m[1] * m[1] + m[5] * m[5] + m[9] * m[9]);
        double c2 = sqrt(m[2] * m[2] + m[6] * m[6] + m[10] * m[10]);
        if (!(fabs(det) > 1e-9 * c0 * c1 * c2))
            return fail(p, VSD_ERR_INVALID, path, "singular (the 3x3 part has no inverse)");
    }
    memcpy(dest(p, f), m, sizeof m);
    return VSD_OK;
}

static vsd_status walk(parser *p, const table *t, const cJSON *obj, const char *path);

static vsd_status apply_field(parser *p, const field *f, const cJSON *item, const char *path)
{
    if (item && cJSON_IsNull(item) && (f->flags & F_NULLABLE))
        item = NULL;
    switch (f->kind) {
    case K_OBJECT: return walk(p, f->sub, item, path);
    case K_NUMBER: return apply_number(p, f, item, path);
    case K_INT: return apply_int(p, f, item, path);
    case K_BOOL: return apply_bool(p, f, item, path);
    case K_STRING: return apply_string(p, f, item, path);
    case K_PATH: return apply_path(p, f, item, path);
    case K_CHOICE:
    case K_ENUM: return apply_choice(p, f, item, path);
    case K_RGB: return apply_rgb(p, f, item, path);
    case K_VEC3: return apply_vec3(p, f, item, path);
    case K_MAT4: return apply_mat4(p, f, item, path);
    case K_CUSTOM: return f->apply(p, f, item, path);
    }
    return fail(p, VSD_ERR_INTERNAL, path, "field kind %d not handled", (int)f->kind);
}

/* ---- the walker ----------------------------------------------------------------------- */

static const field *find_field(const table *t, const char *key)
{
    for (size_t i = 0; i < t->count; i++)
        if (!strcmp(t->fields[i].key, key))
            return &t->fields[i];
    return NULL;
}

/* cJSON keeps both copies of a repeated key; which one wins would be an accident. */
static int is_duplicate(const cJSON *obj, const cJSON *item)
{
    for (const cJSON *c = obj->child; c != item; c = c->next)
        if (!strcmp(c->string, item->string))
            return 1;
    return 0;
}

/* Apply table `t` to `obj` (NULL = section absent): every key present must be known, then
 * every field not present gets its default (or fails if required), then `finish`. */
static vsd_status walk(parser *p, const table *t, const cJSON *obj, const char *path)
{
    char sub[KEYPATH_LEN];
    vsd_status st;
    if (obj && !cJSON_IsObject(obj))
        return fail(p, VSD_ERR_TYPE, path[0] ? path : "(top level)", "expected object");
    const cJSON *item;
    cJSON_ArrayForEach(item, obj) {
        join_path(sub, sizeof sub, path, item->string);
        if (is_duplicate(obj, item))
            return fail(p, VSD_ERR_INVALID, sub, "duplicate key");
        const field *f = find_field(t, item->string);
        if (!f)
            return unknown_key(p, t, sub);
        if ((st = apply_field(p, f, item, sub)))
            return st;
    }
    for (size_t i = 0; i < t->count; i++) {
        const field *f = &t->fields[i];
        if (obj && cJSON_GetObjectItemCaseSensitive(obj, f->key))
            continue;
        join_path(sub, sizeof sub, path, f->key);
        if ((f->flags & F_REQUIRED) && !p->defaults_only)
            return fail(p, VSD_ERR_INVALID, sub, "required");
        if ((st = apply_field(p, f, NULL, sub)))
            return st;
    }
    return t->finish ? t->finish(p, obj, path) : VSD_OK;
}

/* ---- custom fields ---------------------------------------------------------------------- */

/* A grid by name, or by index for files that repeat a name (several "density" grids). */
static vsd_status apply_grid(parser *p, const field *f, const cJSON *item, const char *path)
{
    (void)f;
    vsd_scene_volume *vol = &p->out->vol;
    vol->grid_index = -1;
    if (!item || cJSON_IsString(item)) {
        const char *name = item ? item->valuestring : "density";
        if (strlen(name) >= sizeof vol->grid)
            return fail(p, VSD_ERR_INVALID, path, "too long (%zu characters, max %zu)",
                        strlen(name), sizeof vol->grid - 1);
        snprintf(vol->grid, sizeof vol->grid, "%s", name);
        return VSD_OK;
    }
    double idx = 0;
    if (read_int(p, item, path, &idx) != VSD_OK)
        return fail(p, VSD_ERR_TYPE, path, "expected string (grid name) or integer (grid index)");
    if (idx < 0 || idx > INT_MAX) {
        char num[32];
        return fail(p, VSD_ERR_INVALID, path, "%s is out of range (must be >= 0)",
                    fmt_num(idx, num, sizeof num));
    }
    vol->grid[0] = '\0';
    vol->grid_index = (int)idx;
    return VSD_OK;
}

static vsd_status apply_lights(parser *p, const field *f, const cJSON *item, const char *path)
{
    (void)f;
    p->out->s.light_count = 0;
    if (!item)
        return VSD_OK;
    if (!cJSON_IsArray(item))
        return fail(p, VSD_ERR_TYPE, path, "expected array");
    if (cJSON_GetArraySize(item) > VSD_MAX_LIGHTS)
        return fail(p, VSD_ERR_UNSUPPORTED, path, "%d lights; at most %d are supported (the environment is the main light)",
                    cJSON_GetArraySize(item), VSD_MAX_LIGHTS);
    const cJSON *e;
    cJSON_ArrayForEach(e, item) {
        char sub[KEYPATH_LEN];
        vsd_status st;
        snprintf(sub, sizeof sub, "%s[%d]", path, p->out->s.light_count);
        if (!cJSON_IsObject(e))
            return fail(p, VSD_ERR_TYPE, sub, "expected object");
        if ((st = walk(p, &light_table, e, sub)))
            return st;
        p->out->s.lights[p->out->s.light_count++] = p->out->light;
    }
    return VSD_OK;
}

/* volumes[]: one to VSD_MAX_VOLUMES entries (normalise_volumes has already turned a
 * single `volume` + `medium` into a list of one). */
static vsd_status apply_volumes(parser *p, const field *f, const cJSON *item, const char *path)
{
    (void)f;
    vsd_scene *s = &p->out->s;
    s->volume_count = 0;
    if (!item) {
        if (!p->defaults_only)
            return fail(p, VSD_ERR_INVALID, path, "required (a list of volumes, or one `volume` with its `medium`)");
        vsd_status st = walk(p, &volume_table, NULL, "volumes[0]");
        s->volumes[s->volume_count++] = p->out->vol;
        return st;
    }
    if (!cJSON_IsArray(item))
        return fail(p, VSD_ERR_TYPE, path, "expected array (of volume objects)");
    int n = cJSON_GetArraySize(item);
    if (n == 0)
        return fail(p, VSD_ERR_INVALID, path, "empty; a scene holds at least one volume");
    if (n > VSD_MAX_VOLUMES)
        return fail(p, VSD_ERR_UNSUPPORTED, path, "%d volumes; at most %d are supported", n, VSD_MAX_VOLUMES);
    if (n > 1) /* an override appended to a single `volume`: name the entries by index */
        p->single_volume = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, item) {
        char sub[KEYPATH_LEN];
        vsd_status st;
        if (p->single_volume)
            snprintf(sub, sizeof sub, "volume");
        else
            snprintf(sub, sizeof sub, "%s[%d]", path, s->volume_count);
        if (!cJSON_IsObject(e))
            return fail(p, VSD_ERR_TYPE, sub, "expected object");
        memset(&p->out->vol, 0, sizeof p->out->vol); /* entries equal field for field compare equal */
        if ((st = walk(p, &volume_table, e, sub)))
            return st;
        s->volumes[s->volume_count++] = p->out->vol;
    }
    return VSD_OK;
}

/* A volume's `medium`; in a file with one `volume` it is the top-level `medium`, and
 * messages say so. */
static vsd_status apply_medium(parser *p, const field *f, const cJSON *item, const char *path)
{
    (void)f;
    return walk(p, &medium_table, item, p->single_volume ? "medium" : path);
}

/* What each type has (Blender's light properties): a sun has a strength (W/m^2), a
 * direction and an angle; a point a power (W), a position and a radius; a spot a point's
 * keys plus a direction, spot_size and spot_blend. A key of another type is an error, so
 * a sun given "power" is not silently lit at the default strength. */
static vsd_status light_finish(parser *p, const cJSON *obj, const char *path)
{
    static const char *const sun_keys[] = {"type", "color", "strength", "direction", "angle", NULL};
    static const char *const point_keys[] = {"type", "color", "power", "position", "radius", NULL};
    static const char *const spot_keys[] = {"type", "color", "power", "position", "radius", "direction",
                                            "spot_size", "spot_blend", "spot_cosine", NULL};
    static const char *const *const keys[] = {sun_keys, point_keys, spot_keys};
    vsd_scene_light *l = &p->out->light;
    const cJSON *item;
    cJSON_ArrayForEach(item, obj) {
        const char *const *k;
        for (k = keys[l->type]; *k && strcmp(*k, item->string); k++)
            ;
        if (!*k) {
            char sub[KEYPATH_LEN];
            join_path(sub, sizeof sub, path, item->string);
            return fail(p, VSD_ERR_INVALID, sub, "a %s light has no '%s'%s", light_types[l->type], item->string,
                        l->type == VSD_LIGHT_SUN && !strcmp(item->string, "power") ? " (its strength is in W/m^2)"
                        : l->type != VSD_LIGHT_SUN && !strcmp(item->string, "strength") ? " (its power is in watts)"
                                                                                           : "");
        }
    }
    double *d = l->direction, n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(n > 1e-12)) {
        char sub[KEYPATH_LEN];
        join_path(sub, sizeof sub, path, "direction");
        return fail(p, VSD_ERR_INVALID, sub, "must not be the zero vector");
    }
    d[0] /= n;
    d[1] /= n;
    d[2] /= n;
    return VSD_OK;
}

/* Method options are free-form (each method documents its own); they travel as text so
 * the struct stays plain and copyable. */
static vsd_status apply_options(parser *p, const field *f, const cJSON *item, const char *path)
{
    (void)f;
    char *dst = p->out->s.render.options_json;
    if (!item) {
        snprintf(dst, VSD_OPTIONS_LEN, "{}");
        return VSD_OK;
    }
    if (!cJSON_IsObject(item))
        return fail(p, VSD_ERR_TYPE, path, "expected object");
    char *text = cJSON_PrintUnformatted(item);
    if (!text)
        return fail(p, VSD_ERR_NOMEM, path, "out of memory");
    size_t n = strlen(text);
    vsd_status st = VSD_OK;
    if (n >= VSD_OPTIONS_LEN)
        st = fail(p, VSD_ERR_INVALID, path, "too long (%zu bytes serialised, max %d)", n,
                  VSD_OPTIONS_LEN - 1);
    else
        memcpy(dst, text, n + 1);
    cJSON_free(text);
    return st;
}

static vsd_status unknown_pass(parser *p, const char *path, const char *name)
{
    char known[256] = "";
    for (int i = 0; i < VSD_PASS_COUNT; i++) {
        size_t used = strlen(known);
        snprintf(known + used, sizeof known - used, "%s%s", i ? ", " : "", vsd_pass_name((vsd_pass)i));
    }
    return fail(p, VSD_ERR_INVALID, path, "unknown pass \"%s\" (known: %s)", name, known);
}

/* output.pass_names: {vsd pass: EXR layer name}, for a Blender whose pass names differ from
 * vsd's (5.0 calls VolumeDir "Volume Direct"); RenderResult.load_from_file matches names
 * exactly. Every pass not listed keeps its own name. The names follow the EXR writer's
 * rules (vsd_pass_name_problem, vsd_pass_names_clash), checked here so that a bad scene
 * file fails when it is read, naming the field. */
static vsd_status apply_pass_names(parser *p, const field *f, const cJSON *item, const char *path)
{
    (void)f;
    char (*names)[VSD_PASS_NAME_MAX + 1] = p->out->s.output.pass_names;
    for (int i = 0; i < VSD_PASS_COUNT; i++)
        snprintf(names[i], sizeof names[i], "%s", vsd_pass_name((vsd_pass)i));
    if (!item || cJSON_IsNull(item))
        return VSD_OK;
    if (!cJSON_IsObject(item))
        return fail(p, VSD_ERR_TYPE, path, "expected object {\"VolumeDir\": \"Volume Direct\", ...}");
    const cJSON *e;
    cJSON_ArrayForEach(e, item) {
        char sub[KEYPATH_LEN];
        snprintf(sub, sizeof sub, "%s.%s", path, e->string);
        vsd_pass pass = vsd_pass_from_name(e->string);
        if ((int)pass < 0 || pass >= VSD_PASS_COUNT)
            return unknown_pass(p, sub, e->string);
        if (!cJSON_IsString(e))
            return fail(p, VSD_ERR_TYPE, sub, "expected string");
        const char *v = e->valuestring;
        char why[160];
        if (vsd_pass_name_problem(v, why, sizeof why))
            return fail(p, VSD_ERR_INVALID, sub, "%s", why);
        snprintf(names[pass], sizeof names[pass], "%s", v);
    }
    const char *list[VSD_PASS_COUNT];
    int a, b;
    for (int i = 0; i < VSD_PASS_COUNT; i++) list[i] = names[i];
    if (vsd_pass_names_clash(list, VSD_PASS_ALL, &a, &b))
        return fail(p, VSD_ERR_INVALID, path, "%s and %s are both named \"%s\"", vsd_pass_name((vsd_pass)a),
                    vsd_pass_name((vsd_pass)b), names[a]);
    return VSD_OK;
}

/* Pass names are Blender's ("Combined", "VolumeDir", ...), parsed by the image module so
 * that one table names the passes for files and for scenes alike. */
static vsd_status apply_passes(parser *p, const field *f, const cJSON *item, const char *path)
{
    (void)f;
    unsigned mask = 0;
    if (!item) {
        p->out->s.output.pass_mask = VSD_PASS_ALL;
        return VSD_OK;
    }
    if (!cJSON_IsArray(item))
        return fail(p, VSD_ERR_TYPE, path, "expected array of pass names");
    if (cJSON_GetArraySize(item) == 0)
        return fail(p, VSD_ERR_INVALID, path, "empty (name at least one pass, e.g. [\"Combined\"])");
    int i = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, item) {
        char sub[KEYPATH_LEN];
        snprintf(sub, sizeof sub, "%s[%d]", path, i++);
        if (!cJSON_IsString(e))
            return fail(p, VSD_ERR_TYPE, sub, "expected string");
        vsd_pass pass = vsd_pass_from_name(e->valuestring);
        if ((int)pass < 0 || pass >= VSD_PASS_COUNT)
            return unknown_pass(p, sub, e->valuestring);
        mask |= VSD_PASS_BIT(pass);
    }
    p->out->s.output.pass_mask = mask;
    return VSD_OK;
}

/* ---- section finish steps ------------------------------------------------------------- */

static int has(const cJSON *obj, const char *key)
{
    const cJSON *item = obj ? cJSON_GetObjectItemCaseSensitive(obj, key) : NULL;
    return item && !cJSON_IsNull(item);
}

static vsd_status environment_finish(parser *p, const cJSON *obj, const char *path)
{
    if (has(obj, "file") && has(obj, "color"))
        return fail(p, VSD_ERR_INVALID, path,
                    "give either file (an image) or color (uniform), not both");
    return VSD_OK;
}

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double norm3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/* Form (a): Blender's "Track To" with -Z toward the target and +Y up. Columns of the
 * camera-to-world matrix: right, up, back (= -view), position. */
static vsd_status camera_look_at(parser *p, double m[16])
{
    const double *pos = p->out->cam.position, *target = p->out->cam.look_at, *up = p->out->cam.up;
    double f[3] = {target[0] - pos[0], target[1] - pos[1], target[2] - pos[2]};
    double fl = norm3(f);
    if (!(fl > 1e-9 * (1.0 + norm3(pos))))
        return fail(p, VSD_ERR_INVALID, "camera.look_at", "equals camera.position (no view direction)");
    double ul = norm3(up);
    if (!(ul > 0))
        return fail(p, VSD_ERR_INVALID, "camera.up", "is the zero vector");
    double x[3], y[3];
    cross(f, up, x);
    double xl = norm3(x);
    if (!(xl > 1e-6 * fl * ul))
        return fail(p, VSD_ERR_INVALID, "camera.up",
                    "is parallel to the view direction (camera.look_at - camera.position)");
    for (int i = 0; i < 3; i++) {
        x[i] /= xl;
        f[i] /= fl;
    }
    cross(x, f, y);
    for (int r = 0; r < 3; r++) {
        m[r * 4 + 0] = x[r];
        m[r * 4 + 1] = y[r];
        m[r * 4 + 2] = -f[r];
        m[r * 4 + 3] = pos[r];
    }
    m[12] = m[13] = m[14] = 0;
    m[15] = 1;
    return VSD_OK;
}

/* Form (b)/(c): a Blender matrix_world. Cycles drops the camera object's scale
 * (transform_clear_scale), so the axes are normalised here; a sheared matrix has no
 * camera meaning and is refused. */
static vsd_status camera_from_matrix(parser *p, double m[16])
{
    memcpy(m, p->out->cam.matrix, 16 * sizeof *m);
    double axis[3][3];
    for (int c = 0; c < 3; c++) {
        double v[3] = {m[c], m[4 + c], m[8 + c]};
        double l = norm3(v); /* > 0: apply_mat4 refused singular matrices */
        for (int r = 0; r < 3; r++)
            axis[c][r] = m[r * 4 + c] = v[r] / l;
    }
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3;
        double d = axis[a][0] * axis[b][0] + axis[a][1] * axis[b][1] + axis[a][2] * axis[b][2];
        if (fabs(d) > 1e-4)
            return fail(p, VSD_ERR_INVALID, "camera.matrix",
                        "rotation part is sheared (its axes are not perpendicular)");
    }
    return VSD_OK;
}

/* The three camera forms reduce to camera.matrix + camera.fov. Keys of different forms
 * must not be mixed: which one should win would be a guess. */
static vsd_status camera_finish(parser *p, const cJSON *obj, const char *path)
{
    (void)path;
    scene_ext *x = p->out;
    int look = has(obj, "position") || has(obj, "look_at") || has(obj, "up");
    if (look && has(obj, "matrix"))
        return fail(p, VSD_ERR_INVALID, "camera.matrix",
                    "cannot be combined with camera.position/look_at/up (two camera forms; give one)");
    if (has(obj, "fov") && has(obj, "lens"))
        return fail(p, VSD_ERR_INVALID, "camera.lens", "cannot be combined with camera.fov (give one)");
    if (has(obj, "sensor_width") && !has(obj, "lens"))
        return fail(p, VSD_ERR_INVALID, "camera.sensor_width", "needs camera.lens");
    /* Sensor fit AUTO: the sensor spans the larger image dimension, so does the fov. */
    if (has(obj, "lens"))
        x->s.camera.fov = 2.0 * atan(x->cam.sensor_width / 2.0 / x->cam.lens);
    vsd_status st = has(obj, "matrix") ? camera_from_matrix(p, x->s.camera.matrix)
                                       : camera_look_at(p, x->s.camera.matrix);
    if (st)
        return st;
    if (!(x->s.camera.clip_end > x->s.camera.clip_start)) {
        char a[32], b[32];
        return fail(p, VSD_ERR_INVALID, "camera.clip_end", "%s must be greater than camera.clip_start (%s)",
                    fmt_num(x->s.camera.clip_end, a, sizeof a), fmt_num(x->s.camera.clip_start, b, sizeof b));
    }
    return VSD_OK;
}

static vsd_status film_finish(parser *p, const cJSON *obj, const char *path)
{
    (void)obj;
    long long w = p->out->s.film.width, h = p->out->s.film.height;
    if (w * h > MAX_PIXELS)
        return fail(p, VSD_ERR_INVALID, path, "%lldx%lld = %lld pixels is too many (max %lld)", w, h,
                    w * h, MAX_PIXELS);
    return VSD_OK;
}

static vsd_status frames_finish(parser *p, const cJSON *obj, const char *path)
{
    (void)obj;
    (void)path;
    if (p->out->s.frames.end < p->out->s.frames.start)
        return fail(p, VSD_ERR_INVALID, "frames.end", "%d is before frames.start (%d)",
                    p->out->s.frames.end, p->out->s.frames.start);
    return VSD_OK;
}

/* ---- overrides ------------------------------------------------------------------------ */

/* The value is JSON when it parses as JSON (256, true, [1,2,3], "text"), else the raw
 * text, so `render.method=shgrid` needs no shell-escaped quotes. */
static cJSON *override_value(const char *text)
{
    cJSON *v = cJSON_ParseWithOpts(text, NULL, 1);
    return v ? v : cJSON_CreateString(text);
}

/* A key-path component that indexes an array ("volumes.1.medium"): 0 .. size-1 names an
 * entry, size appends one. -1 when comp is not such an index. */
static int array_index(const cJSON *arr, const char *comp)
{
    char *end = NULL;
    long i = strtol(comp, &end, 10);
    if (!comp[0] || *end || i < 0 || i > cJSON_GetArraySize(arr))
        return -1;
    return (int)i;
}

/* The child `comp` of an object or array on an override's path, created as an object when
 * it is missing (an array grows by one at index size). NULL with err set. */
static cJSON *override_child(parser *p, cJSON *obj, const char *comp, const char *ov, const char *key)
{
    cJSON *child = NULL;
    if (cJSON_IsArray(obj)) {
        int i = array_index(obj, comp);
        if (i < 0) {
            vsd_fail(VSD_ERR_INVALID, p->err, p->errlen,
                     "override \"%s\": %s: an index 0..%d of the list expected", ov, key, cJSON_GetArraySize(obj));
            return NULL;
        }
        child = cJSON_GetArrayItem(obj, i);
        if (!child && (child = cJSON_CreateObject()))
            cJSON_AddItemToArray(obj, child);
    } else {
        child = cJSON_GetObjectItemCaseSensitive(obj, comp);
        if (!child)
            child = cJSON_AddObjectToObject(obj, comp);
    }
    if (!child)
        vsd_fail(VSD_ERR_NOMEM, p->err, p->errlen, "override \"%s\": out of memory", ov);
    else if (!cJSON_IsObject(child) && !cJSON_IsArray(child)) {
        vsd_fail(VSD_ERR_INVALID, p->err, p->errlen, "override \"%s\": %s is not an object", ov, key);
        return NULL;
    }
    return child;
}

/* Set root.a.b.c = value (a number component indexes a list: volumes.1.medium.density),
 * creating missing objects on the way. What it writes is validated afterwards like the
 * file itself, so a misspelt key fails there. */
static vsd_status apply_override(parser *p, cJSON *root, const char *ov)
{
    const char *eq = strchr(ov, '=');
    if (!eq)
        return vsd_fail(VSD_ERR_INVALID, p->err, p->errlen,
                        "override \"%s\": expected key.path=value (e.g. render.samples=256)", ov);
    char key[KEYPATH_LEN];
    if ((size_t)(eq - ov) >= sizeof key)
        return vsd_fail(VSD_ERR_INVALID, p->err, p->errlen, "override \"%s\": key too long", ov);
    memcpy(key, ov, (size_t)(eq - ov));
    key[eq - ov] = '\0';

    cJSON *obj = root;
    char *comp = key;
    for (;;) {
        char *dot = strchr(comp, '.');
        if (dot)
            *dot = '\0';
        if (!comp[0])
            return vsd_fail(VSD_ERR_INVALID, p->err, p->errlen,
                            "override \"%s\": empty key name in the key path", ov);
        if (!dot)
            break;
        cJSON *child = override_child(p, obj, comp, ov, key);
        if (!child)
            return VSD_ERR_INVALID;
        *dot = '.'; /* restore, so `key` names the path so far in messages */
        obj = child;
        comp = dot + 1;
    }
    cJSON *value = override_value(eq + 1);
    int ok;
    if (cJSON_IsArray(obj)) {
        int i = array_index(obj, comp);
        if (i < 0) {
            cJSON_Delete(value);
            return vsd_fail(VSD_ERR_INVALID, p->err, p->errlen,
                            "override \"%s\": %s: an index 0..%d of the list expected", ov, key,
                            cJSON_GetArraySize(obj));
        }
        ok = value && (i < cJSON_GetArraySize(obj) ? cJSON_ReplaceItemInArray(obj, i, value)
                                                   : cJSON_AddItemToArray(obj, value));
    } else {
        ok = value && (cJSON_GetObjectItemCaseSensitive(obj, comp)
                           ? cJSON_ReplaceItemInObjectCaseSensitive(obj, comp, value)
                           : cJSON_AddItemToObject(obj, comp, value));
    }
    if (!ok) {
        cJSON_Delete(value);
        return vsd_fail(VSD_ERR_NOMEM, p->err, p->errlen, "override \"%s\": out of memory", ov);
    }
    return VSD_OK;
}

/* ---- one volume or a list ----------------------------------------------------------- */

/* A file with the single form (`volume`, `medium` at the top level) becomes a list of one
 * in the tree, so one table reads both; a file with both forms is refused by name. */
static vsd_status normalise_volumes(parser *p, cJSON *root)
{
    static const char *const keys[] = {"volumes", "volume", "medium"};
    for (size_t k = 0; k < sizeof keys / sizeof keys[0]; k++) {
        int seen = 0;
        for (const cJSON *c = root->child; c; c = c->next)
            if (c->string && !strcmp(c->string, keys[k]) && seen++)
                return fail(p, VSD_ERR_INVALID, keys[k], "duplicate key");
    }
    cJSON *list = cJSON_GetObjectItemCaseSensitive(root, "volumes");
    cJSON *vol = cJSON_GetObjectItemCaseSensitive(root, "volume");
    cJSON *med = cJSON_GetObjectItemCaseSensitive(root, "medium");
    if (list && (vol || med))
        return fail(p, VSD_ERR_INVALID, "volumes",
                    "the scene also has `%s`: write either the list `volumes` (each entry with its own "
                    "`medium`) or one `volume` with `medium`, not both", vol ? "volume" : "medium");
    if (list || (!vol && !med))
        return VSD_OK;
    if (vol && !cJSON_IsObject(vol))
        return fail(p, VSD_ERR_TYPE, "volume", "expected object");
    if (vol && cJSON_GetObjectItemCaseSensitive(vol, "medium"))
        return fail(p, VSD_ERR_INVALID, "volume.medium",
                    "unknown key (a single volume's material is the top-level `medium`)");
    cJSON *entry = vol ? cJSON_DetachItemViaPointer(root, vol) : cJSON_CreateObject();
    cJSON *arr = cJSON_CreateArray();
    if (!entry || !arr) {
        cJSON_Delete(entry);
        cJSON_Delete(arr);
        return fail(p, VSD_ERR_NOMEM, "volume", "out of memory");
    }
    if (med)
        cJSON_AddItemToObject(entry, "medium", cJSON_DetachItemViaPointer(root, med));
    cJSON_AddItemToArray(arr, entry);
    cJSON_AddItemToObject(root, "volumes", arr);
    p->single_volume = 1;
    return VSD_OK;
}

/* `volume[.K]` and `medium[.K]` overrides name the only volume of a one-volume scene
 * ("medium.density=3" keeps working); with several they must say which one. Returns ov
 * itself or a malloc'd rewrite in *owned (free it). */
static vsd_status rewrite_single_volume_key(parser *p, const cJSON *root, const char *ov, const char **out,
                                            char **owned)
{
    static const struct { const char *from, *to; } forms[] = {
        {"volume.", "volumes.0."}, {"volume=", "volumes.0="},
        {"medium.", "volumes.0.medium."}, {"medium=", "volumes.0.medium="}};
    *out = ov;
    *owned = NULL;
    for (size_t i = 0; i < sizeof forms / sizeof forms[0]; i++) {
        size_t len = strlen(forms[i].from);
        if (strncmp(ov, forms[i].from, len))
            continue;
        int count = cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(root, "volumes"));
        if (count > 1)
            return vsd_fail(VSD_ERR_INVALID, p->err, p->errlen,
                            "override \"%s\": the scene has %d volumes; say which, e.g. %.*s%s",
                            ov, count, (int)strlen(forms[i].to) - 1, forms[i].to, ov + len - 1);
        size_t n = strlen(forms[i].to) + strlen(ov + len) + 1;
        if (!(*owned = malloc(n)))
            return vsd_fail(VSD_ERR_NOMEM, p->err, p->errlen, "override \"%s\": out of memory", ov);
        snprintf(*owned, n, "%s%s", forms[i].to, ov + len);
        *out = *owned;
        break;
    }
    return VSD_OK;
}

/* ---- entry points --------------------------------------------------------------------- */

/* 1-based line and column (in characters, not bytes) of `at` in `text`. */
static void text_position(const char *text, const char *at, int *line, int *col)
{
    *line = 1;
    *col = 1;
    for (const char *c = text; c < at; c++) {
        if (*c == '\n') {
            ++*line;
            *col = 1;
        } else if (((unsigned char)*c & 0xC0) != 0x80) { /* not a UTF-8 continuation byte */
            ++*col;
        }
    }
}

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

/* cJSON reports where parsing stopped; turn it into line:column and an excerpt, so a
 * hand-edited file can be fixed at once. cJSON's position is only roughly where the
 * mistake is (often one character past it), so the excerpt shows a few characters on
 * both sides, within the line. The position comes from ParseWithLengthOpts'
 * return_parse_end, the same as cJSON_GetErrorPtr() but without its global (the daemon
 * parses from several threads). */
static vsd_status syntax_error(parser *p, const char *text, size_t len, const char *at)
{
    const char *end = text + len;
    if (!at || at < text || at > end)
        at = end;
    const char *rest = at;
    while (rest < end && is_space(*rest))
        rest++;
    /* cJSON often stops just past the offending character; when it stopped on white
     * space, point at the last character before it instead. */
    if (rest < end)
        while (at > text && is_space(*at))
            at--;
    int line, col;
    text_position(text, at, &line, &col);
    if (rest == end)
        return fail(p, VSD_ERR_FORMAT, "", "line %d, column %d: invalid JSON (unexpected end of text)",
                    line, col);
    if (*at == '\0')
        return fail(p, VSD_ERR_FORMAT, "", "line %d, column %d: invalid JSON (a NUL byte)", line, col);
    const char *a = at, *b = at;
    while (a > text && at - a < 12 && a[-1] != '\n' && a[-1] != '\r')
        a--;
    while (b < end && b - at < 12 && *b != '\n' && *b != '\r')
        b++;
    char near[32];
    size_t n = 0;
    for (const char *c = a; c < b && n + 1 < sizeof near; c++)
        near[n++] = ((unsigned char)*c < 0x20) ? ' ' : *c;
    near[n] = '\0';
    return fail(p, VSD_ERR_FORMAT, "", "line %d, column %d: invalid JSON near '%s'", line, col, near);
}

static vsd_status check_version(parser *p, const cJSON *root)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, "version");
    if (!v)
        return fail(p, VSD_ERR_INVALID, "version", "required (this vsd reads version 1)");
    double d = 0;
    if (read_int(p, v, "version", &d))
        return VSD_ERR_TYPE;
    if (d != 1) {
        char num[32];
        return fail(p, VSD_ERR_UNSUPPORTED, "version", "expected 1, got %s", fmt_num(d, num, sizeof num));
    }
    return VSD_OK;
}

/* text[len] must be '\0' (cJSON's end-of-text check reads it). */
static vsd_status parse_text(parser *p, const char *text, size_t len, const char *base_dir,
                             const char *const *overrides, int override_count, vsd_scene *scene)
{
    scene_ext x;
    memset(&x, 0, sizeof x);
    p->out = &x;
    p->base_dir = base_dir ? base_dir : "";
    if (strlen(p->base_dir) >= sizeof x.s.base_dir)
        return fail(p, VSD_ERR_INVALID, "", "folder name too long (max %zu characters)",
                    sizeof x.s.base_dir - 1);
    snprintf(x.s.base_dir, sizeof x.s.base_dir, "%s", p->base_dir);

    /* A UTF-8 byte-order mark (some Windows editors write one) is not JSON. */
    if (len >= 3 && !memcmp(text, "\xEF\xBB\xBF", 3)) {
        text += 3;
        len -= 3;
    }
    /* JSON text has no NUL; one in a file would otherwise end the text silently there. */
    const char *nul = memchr(text, '\0', len);
    if (nul)
        return syntax_error(p, text, len, nul);
    /* With require_null_terminated, cJSON wants the terminating NUL inside the length. */
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len + 1, &end, 1);
    if (!root)
        return syntax_error(p, text, len, end);
    vsd_status st = VSD_OK;
    if (!cJSON_IsObject(root))
        st = fail(p, VSD_ERR_TYPE, "", "expected a JSON object at the top level");
    if (!st)
        st = normalise_volumes(p, root);
    for (int i = 0; !st && i < override_count; i++) {
        const char *ov = NULL;
        char *owned = NULL;
        st = !overrides[i] ? vsd_fail(VSD_ERR_INVALID, p->err, p->errlen, "override %d is NULL", i)
             : rewrite_single_volume_key(p, root, overrides[i], &ov, &owned);
        if (!st)
            st = apply_override(p, root, ov);
        free(owned);
    }
    if (!st)
        st = check_version(p, root);
    if (!st)
        st = walk(p, &root_table, root, "");
    cJSON_Delete(root);
    if (!st)
        *scene = x.s;
    return st;
}

void vsd_scene_defaults(vsd_scene *scene)
{
    scene_ext x;
    memset(&x, 0, sizeof x);
    parser p = {.out = &x, .base_dir = "", .prefix = "", .defaults_only = 1};
    walk(&p, &root_table, NULL, ""); /* defaults cannot fail */
    *scene = x.s;
}

vsd_status vsd_scene_parse(const char *json, const char *base_dir, const char *const *overrides,
                           int override_count, vsd_scene *scene, char *err, size_t errlen)
{
    parser p = {.prefix = "", .err = err, .errlen = errlen};
    if (!json || !scene || override_count < 0 || (override_count > 0 && !overrides))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "vsd_scene_parse: invalid arguments");
    return parse_text(&p, json, strlen(json), base_dir, overrides, override_count, scene);
}

/* Whole file into memory; scene files are small, the cap only stops a wrong path (a VDB
 * given as the scene) from reading gigabytes. */
static vsd_status read_file(parser *p, const char *path, char **text, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return fail(p, VSD_ERR_IO, "", "cannot open: %s", strerror(errno));
    size_t cap = 0, n = 0;
    char *buf = NULL;
    vsd_status st = VSD_OK;
    for (;;) {
        if (n + 1 >= cap) { /* + 1: the terminating NUL parse_text relies on */
            char *bigger = cap < MAX_SCENE_BYTES ? realloc(buf, cap ? cap * 2 : 65536) : NULL;
            if (!bigger) {
                st = cap < MAX_SCENE_BYTES ? fail(p, VSD_ERR_NOMEM, "", "out of memory")
                                           : fail(p, VSD_ERR_FORMAT, "", "too large for a scene file (over %u MiB)",
                                                  MAX_SCENE_BYTES >> 20);
                break;
            }
            buf = bigger;
            cap = cap ? cap * 2 : 65536;
        }
        size_t got = fread(buf + n, 1, cap - n - 1, f);
        n += got;
        if (got == 0) {
            if (ferror(f))
                st = fail(p, VSD_ERR_IO, "", "cannot read: %s", strerror(errno));
            break;
        }
    }
    fclose(f);
    if (st) {
        free(buf);
        return st;
    }
    buf[n] = '\0';
    *text = buf;
    *len = n;
    return VSD_OK;
}

vsd_status vsd_scene_load(const char *path, const char *const *overrides, int override_count,
                          vsd_scene *scene, char *err, size_t errlen)
{
    if (!path || !scene || override_count < 0 || (override_count > 0 && !overrides))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "vsd_scene_load: invalid arguments");
    parser p = {.prefix = path, .err = err, .errlen = errlen};
    char base[VSD_PATH_LEN];
    const char *slash = strrchr(path, '/');
    size_t blen = !slash ? 0 : slash == path ? 1 : (size_t)(slash - path);
    if (blen >= sizeof base)
        return fail(&p, VSD_ERR_INVALID, "", "folder name too long (max %zu characters)", sizeof base - 1);
    memcpy(base, path, blen);
    base[blen] = '\0';

    char *text = NULL;
    size_t len = 0;
    vsd_status st = read_file(&p, path, &text, &len);
    if (st)
        return st;
    st = parse_text(&p, text, len, base, overrides, override_count, scene);
    free(text);
    return st;
}

const char *vsd_scene_env_conversion(const vsd_scene *s, char *buf, size_t len)
{
    vsd_env_conversion(s->environment.colorspace, s->environment.working_space, buf, len);
    return buf;
}

const char *vsd_scene_ior_grid(const vsd_scene_volume *v)
{
    if (v->ior_grid[0]) return v->ior_grid;
    return strcmp(v->medium.ior_from, "temperature") == 0 ? "temperature" : "";
}

int vsd_scene_volume_refracts(const vsd_scene_volume *v)
{
    return v->medium.ior != 1.0f || vsd_scene_ior_grid(v)[0] != '\0';
}

int vsd_scene_refracting_volume(const vsd_scene *sc)
{
    for (int i = 0; i < sc->volume_count; i++)
        if (vsd_scene_volume_refracts(&sc->volumes[i])) return i;
    return -1;
}

int vsd_scene_volume_frame(const vsd_scene_volume *v, int frame)
{
    long f = (long)frame + v->frame_offset;
    return f < MIN_FRAME ? MIN_FRAME : f > MAX_FRAME ? MAX_FRAME : (int)f;
}
