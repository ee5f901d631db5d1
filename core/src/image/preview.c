/* Display preview: the Combined pass through an OpenColorIO display/view transform (as
 * Blender's "View Transform" setting does) into an 8-bit RGBA PNG, written via a temporary
 * name and renamed like the EXR. Without any config, a plain sRGB transfer function. */
#define _POSIX_C_SOURCE 200809L
#include "src/image/imageio_internal.h"
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Straight (un-premultiplied) scene-linear RGBA of the Combined pass, scaled by the
 * exposure. View transforms are defined on colour, not on colour*alpha: transforming
 * premultiplied values would darken every semi-transparent edge of the volume. */
static float *straight_rgba(const vsd_framebuffer *fb, float exposure)
{
    size_t n = (size_t)fb->width * (size_t)fb->height;
    float *rgba = malloc(n * 4 * sizeof(float));
    if (!rgba)
        return NULL;
    float gain = exp2f(exposure);
    const float *src = fb->pass[VSD_PASS_COMBINED];
    for (size_t i = 0; i < n; i++) {
        float a = src[4 * i + 3];
        float k = a > 0.0f ? gain / a : gain;
        for (int c = 0; c < 3; c++)
            rgba[4 * i + c] = src[4 * i + c] * k;
        rgba[4 * i + 3] = a;
    }
    return rgba;
}

static float srgb_oetf(float v)
{
    return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
}

/* The no-config path: only what an sRGB display can honestly show without a config. */
static vsd_status fallback_transform(float *rgba, size_t n, const vsd_preview_options *opt,
                                     char *err, size_t errlen)
{
    const char *view = opt ? opt->view : NULL;
    const char *display = opt ? opt->display : NULL;
    if ((view && *view && strcmp(view, "Standard") != 0) ||
        (display && *display && strcmp(display, "sRGB") != 0))
        return vsd_fail(VSD_ERR_NOT_FOUND, err, errlen,
                        "display '%s' / view '%s' need an OpenColorIO config and none was found "
                        "($OCIO is unset and Blender's config is not installed); without one "
                        "only display sRGB, view Standard is available",
                        display && *display ? display : "sRGB", view && *view ? view : "Standard");
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            rgba[4 * i + c] = srgb_oetf(rgba[4 * i + c]);
    return VSD_OK;
}

static unsigned char to_byte(float v)
{
    if (!(v > 0.0f)) /* also catches NaN */
        return 0;
    return v >= 1.0f ? 255 : (unsigned char)lrintf(v * 255.0f);
}

/* Encode with libpng's simplified API (no setjmp/longjmp error handling needed) onto a
 * duplicate of the temporary file's descriptor, which the commit then fsyncs and closes. */
static vsd_status write_png(vsd_io_tmpfile *t, const unsigned char *px, int w, int h, int srgb,
                            char *err, size_t errlen)
{
    int fd = dup(t->fd);
    FILE *f = fd >= 0 ? fdopen(fd, "wb") : NULL;
    if (!f) {
        if (fd >= 0)
            close(fd);
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot write '%s'", t->path);
    }
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    img.width = (png_uint_32)w;
    img.height = (png_uint_32)h;
    img.format = PNG_FORMAT_RGBA;
    img.flags = srgb ? 0 : PNG_IMAGE_FLAG_COLORSPACE_NOT_sRGB;
    int ok = png_image_write_to_stdio(&img, f, 0, px, 0, NULL);
    int closed = fclose(f) == 0;
    if (!ok || !closed)
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot write PNG '%s': %s", t->path,
                        ok ? "write failed" : img.message);
    return VSD_OK;
}

/* Display-referred floats -> the caller's PNG, via the temporary file. */
static vsd_status save_png(const char *path, const float *rgba, int w, int h, int srgb,
                           char *err, size_t errlen)
{
    size_t n = (size_t)w * (size_t)h;
    unsigned char *px = malloc(n * 4);
    if (!px)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "preview '%s': out of memory", path);
    for (size_t i = 0; i < 4 * n; i++)
        px[i] = to_byte(rgba[i]);
    vsd_io_tmpfile t;
    vsd_status s = vsd_io_tmp_open(&t, path, err, errlen);
    if (s == VSD_OK)
        s = write_png(&t, px, w, h, srgb, err, errlen);
    if (s == VSD_OK)
        s = vsd_io_tmp_commit(&t, err, errlen);
    else
        vsd_io_tmp_abort(&t);
    free(px);
    return s;
}

/* Apply the chosen config's display/view (or the fallback) and describe it in `note`. */
static vsd_status transform(float *rgba, const vsd_framebuffer *fb,
                            const vsd_preview_options *opt, int *srgb, char *note,
                            size_t notelen, char *err, size_t errlen)
{
    char config[4096], display[256] = "sRGB", view[256] = "Standard";
    vsd_ocio_origin origin;
    vsd_status s = vsd_ocio_choose_config(config, sizeof config, &origin, err, errlen);
    if (s != VSD_OK)
        return s;
    if (origin == VSD_OCIO_NONE) {
        s = fallback_transform(rgba, (size_t)fb->width * (size_t)fb->height, opt, err, errlen);
        if (s == VSD_OK && note && notelen)
            snprintf(note, notelen, "no OpenColorIO config found ($OCIO unset, Blender's not "
                                    "installed): plain sRGB transfer function");
    } else {
        s = vsd_ocio_display_view(config, rgba, fb->width, fb->height, opt ? opt->display : NULL,
                                  opt ? opt->view : NULL, display, sizeof display, view,
                                  sizeof view, err, errlen);
        if (s == VSD_OK && note && notelen)
            snprintf(note, notelen, "OCIO config %s (%s), display %s, view %s", config,
                     vsd_ocio_origin_str(origin), display, view);
    }
    *srgb = strcmp(display, "sRGB") == 0;
    return s;
}

vsd_status vsd_preview_write_png(const char *path, const vsd_framebuffer *fb,
                                 const vsd_preview_options *opt, char *note, size_t notelen,
                                 char *err, size_t errlen)
{
    if (note && notelen)
        note[0] = '\0';
    if (!path || !*path)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "preview: no file name given");
    if (!fb || fb->width <= 0 || fb->height <= 0 || !fb->pass[VSD_PASS_COMBINED])
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "preview '%s': empty framebuffer", path);
    float *rgba = straight_rgba(fb, opt ? opt->exposure : 0.0f);
    if (!rgba)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "preview '%s': out of memory", path);
    int srgb = 1;
    vsd_status s = transform(rgba, fb, opt, &srgb, note, notelen, err, errlen);
    if (s == VSD_OK)
        s = save_png(path, rgba, fb->width, fb->height, srgb, err, errlen);
    free(rgba);
    return s;
}
