/* Environment maps: load an equirectangular HDR image (EXR or Radiance RGBE, told apart by
 * content), optionally convert it to scene-linear through OpenColorIO, and keep it as
 * interleaved RGB floats, row 0 = top (docs/architecture.md §3). */
#define _POSIX_C_SOURCE 200809L
#include "vsd/env.h"
#include "src/env/env_internal.h"
#include "src/image/imageio_internal.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ENV_MAX_PIXELS ((size_t)1 << 28)

/* The R, G, B planes of an EXR: plain "R"/"G"/"B" as HDRIs store them, else the Combined
 * pass of a multilayer render ("<layer>.Combined.R"), so a vsd or Blender render can
 * light a scene. Returns 0 when neither exists. */
static int find_rgb(const vsd_exr_image *img, const float *plane[3])
{
    plane[0] = vsd_exr_channel(img, "R");
    plane[1] = vsd_exr_channel(img, "G");
    plane[2] = vsd_exr_channel(img, "B");
    if (plane[0] && plane[1] && plane[2])
        return 1;
    for (int i = 0; i < img->channel_count; i++) {
        const char *name = img->channel_names[i];
        size_t len = strlen(name), sfx = strlen(".Combined.R");
        if (len < sfx || strcmp(name + len - sfx, ".Combined.R") != 0 || len >= 1024)
            continue;
        char other[1024];
        memcpy(other, name, len + 1);
        plane[0] = img->channels[i];
        other[len - 1] = 'G';
        plane[1] = vsd_exr_channel(img, other);
        other[len - 1] = 'B';
        plane[2] = vsd_exr_channel(img, other);
        if (plane[1] && plane[2])
            return 1;
    }
    return 0;
}

static vsd_status load_exr(const char *path, vsd_env *env, char *err, size_t errlen)
{
    vsd_exr_image *img = NULL;
    vsd_status s = vsd_exr_read(path, &img, err, errlen);
    if (s != VSD_OK)
        return s;
    const float *plane[3];
    size_t n = (size_t)img->width * (size_t)img->height;
    if (!find_rgb(img, plane))
        s = vsd_fail(VSD_ERR_FORMAT, err, errlen,
                     "'%s' has no R, G, B channels (nor a Combined pass) to use as an environment",
                     path);
    else if (n == 0 || n > ENV_MAX_PIXELS)
        s = vsd_fail(VSD_ERR_FORMAT, err, errlen, "'%s': bad image size %d x %d", path,
                     img->width, img->height);
    else if (!(env->rgb = malloc(n * 3 * sizeof(float))))
        s = vsd_fail(VSD_ERR_NOMEM, err, errlen, "'%s': out of memory", path);
    for (size_t i = 0; s == VSD_OK && i < n; i++)
        for (int c = 0; c < 3; c++)
            env->rgb[3 * i + (size_t)c] = plane[c][i];
    if (s == VSD_OK) {
        env->width = img->width;
        env->height = img->height;
    }
    vsd_exr_image_destroy(img);
    return s;
}

/* Radiance cannot be negative: lossy DWA compression leaves a few slightly negative texels
 * (down to -0.0016 in forest.exr) and a broken file may hold NaN/Inf. Both would poison
 * importance sampling and SH projection, so they become 0. */
static void sanitise(vsd_env *env)
{
    size_t n = (size_t)env->width * (size_t)env->height * 3;
    for (size_t i = 0; i < n; i++)
        if (!(env->rgb[i] >= 0.0f) || isinf(env->rgb[i]))
            env->rgb[i] = 0.0f;
}

/* `conversion` as vsd_env_conversion writes it: "FROM" or FROM, VSD_ENV_SPACE_SEP, TO. The
 * config in use ($OCIO, else Blender's installed one) is tried first; where it lacks a name
 * (3.4's config has no "Linear Rec.709", "Linear Rec.2020" or "ACEScg"), or where Blender's
 * config cannot be read, vsd's built-in config of Blender's linear spaces is. A config named
 * by $OCIO that cannot be read stays an error: the user asked for it. */
static vsd_status convert_colorspace(vsd_env *env, const char *conversion, const char *path,
                                     char *err, size_t errlen)
{
    char from[VSD_ENV_NAME_LEN], to[VSD_ENV_NAME_LEN] = "";
    const char *sep = strchr(conversion, VSD_ENV_SPACE_SEP);
    snprintf(from, sizeof from, "%.*s", sep ? (int)(sep - conversion) : (int)strlen(conversion), conversion);
    if (sep) snprintf(to, sizeof to, "%s", sep + 1);

    char config[4096], first[1024] = "";
    vsd_ocio_origin origin;
    size_t n = (size_t)env->width * (size_t)env->height;
    vsd_status s = vsd_ocio_choose_config(config, sizeof config, &origin, err, errlen);
    if (s != VSD_OK)
        return s;
    if (origin != VSD_OCIO_NONE) {
        s = vsd_ocio_convert(config, from, to, env->rgb, n, err, errlen);
        if (s == VSD_OK || !(s == VSD_ERR_NOT_FOUND || (s == VSD_ERR_FORMAT && origin == VSD_OCIO_BLENDER)))
            goto done;
        snprintf(first, sizeof first, "%s", err ? err : "");
    }
    s = vsd_ocio_convert(NULL, from, to, env->rgb, n, err, errlen);
done:
    if (s != VSD_OK) {
        /* prefix the map's name: the message alone names only the config */
        char why[1024];
        snprintf(why, sizeof why, "%s", err ? err : "");
        if (first[0] && strcmp(first, why) != 0)
            vsd_fail(s, err, errlen, "'%s': %s; and %s", path, first, why);
        else
            vsd_fail(s, err, errlen, "'%s': %s", path, why);
    }
    return s;
}

/* Pick the decoder by the first bytes, never by the extension: files get renamed. */
static vsd_status decode(const char *path, vsd_env *env, char *err, size_t errlen)
{
    unsigned char head[16];
    size_t got = 0;
    vsd_status s = vsd_io_read_head(path, head, sizeof head, &got, err, errlen);
    if (s != VSD_OK)
        return s;
    if (got == 0)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "'%s' is empty, not an image", path);
    if (got >= 4 && memcmp(head, VSD_EXR_MAGIC, 4) == 0)
        return load_exr(path, env, err, errlen);
    if ((got >= 10 && memcmp(head, "#?RADIANCE", 10) == 0) ||
        (got >= 6 && memcmp(head, "#?RGBE", 6) == 0))
        return vsd_rgbe_read(path, &env->width, &env->height, &env->rgb, err, errlen);
    return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                    "'%s' is not an environment image (neither OpenEXR nor Radiance HDR; "
                    "first bytes %02x %02x %02x %02x)",
                    path, head[0], got > 1 ? head[1] : 0, got > 2 ? head[2] : 0,
                    got > 3 ? head[3] : 0);
}

vsd_status vsd_env_load(const char *path, const char *conversion, vsd_env **out, char *err,
                        size_t errlen)
{
    if (!out)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "environment: no output pointer");
    *out = NULL;
    vsd_env *env = calloc(1, sizeof *env);
    if (!env)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "environment: out of memory");
    vsd_status s = decode(path, env, err, errlen);
    if (s == VSD_OK && conversion && *conversion)
        s = convert_colorspace(env, conversion, path, err, errlen);
    if (s != VSD_OK) {
        vsd_env_destroy(env);
        return s;
    }
    sanitise(env);
    snprintf(env->file, sizeof env->file, "%s", path);
    *out = env;
    return VSD_OK;
}

vsd_status vsd_env_create_uniform(const float rgb[3], int width, int height, vsd_env **out,
                                  char *err, size_t errlen)
{
    if (!out || !rgb)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "uniform environment: bad arguments");
    *out = NULL;
    if (width <= 0 || height <= 0 || (size_t)width * (size_t)height > ENV_MAX_PIXELS)
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "uniform environment: invalid size %d x %d", width, height);
    for (int c = 0; c < 3; c++)
        if (!(rgb[c] >= 0.0f) || isinf(rgb[c]))
            return vsd_fail(VSD_ERR_INVALID, err, errlen,
                            "uniform environment: colour component %d is %g (must be finite, >= 0)",
                            c, (double)rgb[c]);
    vsd_env *env = calloc(1, sizeof *env);
    size_t n = (size_t)width * (size_t)height;
    if (env)
        env->rgb = malloc(n * 3 * sizeof(float));
    if (!env || !env->rgb) {
        vsd_env_destroy(env);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "uniform environment: out of memory");
    }
    env->width = width;
    env->height = height;
    for (size_t i = 0; i < n; i++)
        memcpy(env->rgb + 3 * i, rgb, 3 * sizeof(float));
    snprintf(env->file, sizeof env->file, "(uniform %g %g %g)", (double)rgb[0], (double)rgb[1],
             (double)rgb[2]);
    *out = env;
    return VSD_OK;
}

void vsd_env_destroy(vsd_env *env)
{
    if (!env)
        return;
    free(env->rgb);
    free(env);
}

double vsd_env_texel_solid_angle(int width, int height, int row)
{
    const double pi = 3.14159265358979323846;   /* M_PI, which _POSIX_C_SOURCE hides */
    double t0 = pi * row / height, t1 = pi * (row + 1) / height;
    return 2.0 * pi / width * (cos(t0) - cos(t1));
}
