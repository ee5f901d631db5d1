/* The in-memory render passes: one interleaved float array per pass, row 0 = top. */
#include "vsd/image.h"
#include <stdint.h>
#include <stdlib.h>

/* Largest image we agree to allocate: keeps w*h*4*sizeof(float) far from size_t overflow
 * and turns an absurd request (a typo of 1e6 x 1e6) into an error rather than a swap storm. */
#define VSD_FB_MAX_PIXELS ((size_t)1 << 28)

vsd_status vsd_framebuffer_create(int width, int height, vsd_framebuffer **out,
                                  char *err, size_t errlen)
{
    if (!out)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "framebuffer: no output pointer");
    *out = NULL;
    if (width <= 0 || height <= 0 || (size_t)width * (size_t)height > VSD_FB_MAX_PIXELS)
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "framebuffer: invalid size %d x %d (each side > 0, at most %zu pixels)",
                        width, height, VSD_FB_MAX_PIXELS);
    vsd_framebuffer *fb = calloc(1, sizeof *fb);
    if (!fb)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "framebuffer: out of memory");
    fb->width = width;
    fb->height = height;
    size_t npix = (size_t)width * (size_t)height;
    for (int p = 0; p < VSD_PASS_COUNT; p++) {
        fb->pass[p] = malloc(npix * (size_t)vsd_pass_channels((vsd_pass)p) * sizeof(float));
        if (!fb->pass[p]) {
            vsd_framebuffer_destroy(fb);
            return vsd_fail(VSD_ERR_NOMEM, err, errlen,
                            "framebuffer: out of memory for %d x %d", width, height);
        }
    }
    vsd_framebuffer_clear(fb);
    *out = fb;
    return VSD_OK;
}

/* Zero everything except Depth, which starts "empty" (VSD_DEPTH_EMPTY) like Blender's Z
 * pass where no surface was hit, so a pixel nothing touched reads as infinitely far. */
void vsd_framebuffer_clear(vsd_framebuffer *fb)
{
    if (!fb)
        return;
    size_t npix = (size_t)fb->width * (size_t)fb->height;
    for (int p = 0; p < VSD_PASS_COUNT; p++) {
        float *d = fb->pass[p];
        size_t n = npix * (size_t)vsd_pass_channels((vsd_pass)p);
        float v = p == VSD_PASS_DEPTH ? VSD_DEPTH_EMPTY : 0.0f;
        for (size_t i = 0; d && i < n; i++)
            d[i] = v;
    }
}

void vsd_framebuffer_destroy(vsd_framebuffer *fb)
{
    if (!fb)
        return;
    for (int p = 0; p < VSD_PASS_COUNT; p++)
        free(fb->pass[p]);
    free(fb);
}
