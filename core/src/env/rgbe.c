/* Radiance RGBE (.hdr/.pic) reader: text header, "-Y H +X W" resolution line, then flat or
 * new-style run-length-encoded scanlines. Small enough to own, and no Debian library reads it
 * without pulling in a whole image toolkit. The whole file is read into memory first, so
 * every error can name the byte offset where the data ran out or went wrong. */
#define _POSIX_C_SOURCE 200809L
#include "src/env/env_internal.h"
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RGBE_MAX_PIXELS ((size_t)1 << 28)

typedef struct cursor {
    const unsigned char *p;
    size_t n, pos;
    const char *path;
} cursor;

static vsd_status slurp(const char *path, unsigned char **data, size_t *size, char *err,
                        size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot open '%s': %s", path, strerror(errno));
    size_t cap = 1 << 20, n = 0;
    unsigned char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        unsigned char *bigger = realloc(buf, cap * 2);
        if (!bigger)
            free(buf);
        buf = bigger;
        cap *= 2;
    }
    int failed = ferror(f);
    fclose(f);
    if (!buf)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "'%s': out of memory", path);
    if (failed) {
        free(buf);
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot read '%s'", path);
    }
    *data = buf;
    *size = n;
    return VSD_OK;
}

/* One header line without its newline (truncated to len-1 characters, but consumed whole).
 * Returns 0 when the file ends before the newline. */
static int read_line(cursor *c, char *line, size_t len)
{
    size_t k = 0;
    while (c->pos < c->n && c->p[c->pos] != '\n') {
        if (k + 1 < len)
            line[k++] = (char)c->p[c->pos];
        c->pos++;
    }
    line[k] = '\0';
    if (c->pos >= c->n)
        return 0;
    c->pos++;
    return 1;
}

/* Header lines up to the blank line. Only FORMAT matters for decoding; EXPOSURE is ignored,
 * as Blender's reader does, so that vsd sees the same radiance as Cycles. */
static vsd_status parse_header(cursor *c, char *err, size_t errlen)
{
    char line[512];
    if (!read_line(c, line, sizeof line) ||
        (strncmp(line, "#?RADIANCE", 10) != 0 && strncmp(line, "#?RGBE", 6) != 0))
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "'%s' is not a Radiance HDR file", c->path);
    for (;;) {
        if (!read_line(c, line, sizeof line))
            return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                            "'%s' is truncated: the header never ends (%zu bytes)", c->path, c->n);
        if (line[0] == '\0')
            return VSD_OK;
        if (strncmp(line, "FORMAT=", 7) == 0 && strcmp(line + 7, "32-bit_rle_rgbe") != 0)
            return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                            "'%s': pixel format '%s' is not supported (only 32-bit_rle_rgbe)",
                            c->path, line + 7);
    }
}

/* "-Y H +X W": rows top to bottom, pixels left to right, the orientation every common
 * writer uses. The seven others (flipped or transposed) are refused rather than guessed. */
static vsd_status parse_resolution(cursor *c, int *w, int *h, char *err, size_t errlen)
{
    char line[128], ya[3], xa[3];
    int hh = 0, ww = 0;
    if (!read_line(c, line, sizeof line) ||
        sscanf(line, "%2s %d %2s %d", ya, &hh, xa, &ww) != 4)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                        "'%s': bad or missing resolution line at byte offset %zu", c->path, c->pos);
    if (strcmp(ya, "-Y") != 0 || strcmp(xa, "+X") != 0)
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                        "'%s': image orientation '%s' is not supported (only '-Y H +X W')",
                        c->path, line);
    if (ww <= 0 || hh <= 0 || (size_t)ww * (size_t)hh > RGBE_MAX_PIXELS)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "'%s': bad image size %d x %d", c->path,
                        ww, hh);
    *w = ww;
    *h = hh;
    return VSD_OK;
}

static vsd_status truncated(const cursor *c, int y, int h, char *err, size_t errlen)
{
    return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                    "'%s' is truncated: scanline %d of %d runs past the end of the file "
                    "(%zu bytes)", c->path, y, h, c->n);
}

/* One component of a new-style RLE scanline: runs (count > 128: one byte repeated
 * count-128 times) and literals (count <= 128 bytes copied). */
static vsd_status rle_component(cursor *c, unsigned char *row, int w, int comp, int y, int h,
                                char *err, size_t errlen)
{
    for (int x = 0; x < w;) {
        if (c->pos >= c->n)
            return truncated(c, y, h, err, errlen);
        size_t at = c->pos;
        int count = c->p[c->pos++];
        int run = count > 128;
        if (run)
            count -= 128;
        if (count == 0 || x + count > w)
            return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                            "'%s': corrupt run-length data at byte offset %zu (scanline %d)",
                            c->path, at, y);
        if (c->n - c->pos < (size_t)(run ? 1 : count))
            return truncated(c, y, h, err, errlen);
        for (int k = 0; k < count; k++, x++)
            row[4 * x + comp] = run ? c->p[c->pos] : c->p[c->pos + (size_t)k];
        c->pos += run ? 1 : (size_t)count;
    }
    return VSD_OK;
}

/* One scanline into `row` (w RGBE quadruples). New-style RLE is announced by the bytes
 * 2, 2, then the width as big-endian 15 bits; anything else is a flat scanline. (Old-style
 * RLE, repeat markers 1,1,1,n from the 1980s, is not supported.) */
static vsd_status read_scanline(cursor *c, unsigned char *row, int w, int y, int h, char *err,
                                size_t errlen)
{
    const unsigned char *q = c->p + c->pos;
    int rle = w >= 8 && w <= 0x7fff && c->n - c->pos >= 4 && q[0] == 2 && q[1] == 2 &&
              !(q[2] & 0x80);
    if (!rle) {
        if (c->n - c->pos < 4 * (size_t)w)
            return truncated(c, y, h, err, errlen);
        memcpy(row, q, 4 * (size_t)w);
        c->pos += 4 * (size_t)w;
        return VSD_OK;
    }
    if (((q[2] << 8) | q[3]) != w)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                        "'%s': scanline %d at byte offset %zu says width %d, image is %d wide",
                        c->path, y, c->pos, (q[2] << 8) | q[3], w);
    c->pos += 4;
    vsd_status s = VSD_OK;
    for (int comp = 0; comp < 4 && s == VSD_OK; comp++)
        s = rle_component(c, row, w, comp, y, h, err, errlen);
    return s;
}

/* Radiance's own decoding (and Blender's): mantissa + 0.5 scaled by 2^(e-128-8), so a
 * stored value stands for the middle of its quantisation bin. OpenImageIO omits the 0.5;
 * vsd follows Blender because its images are compared with Cycles'. */
static void decode_row(const unsigned char *row, int w, float *rgb)
{
    for (int x = 0; x < w; x++) {
        const unsigned char *q = row + 4 * x;
        float f = q[3] ? ldexpf(1.0f, (int)q[3] - 136) : 0.0f;
        for (int k = 0; k < 3; k++)
            rgb[3 * x + k] = q[3] ? ((float)q[k] + 0.5f) * f : 0.0f;
    }
}

static vsd_status decode_pixels(cursor *c, int w, int h, float **out, char *err, size_t errlen)
{
    float *rgb = malloc((size_t)w * (size_t)h * 3 * sizeof(float));
    unsigned char *row = malloc(4 * (size_t)w);
    vsd_status s = rgb && row ? VSD_OK
                              : vsd_fail(VSD_ERR_NOMEM, err, errlen, "'%s': out of memory",
                                         c->path);
    for (int y = 0; y < h && s == VSD_OK; y++) {
        s = read_scanline(c, row, w, y, h, err, errlen);
        if (s == VSD_OK)
            decode_row(row, w, rgb + (size_t)y * (size_t)w * 3);
    }
    free(row);
    if (s != VSD_OK) {
        free(rgb);
        return s;
    }
    *out = rgb;
    return VSD_OK;
}

vsd_status vsd_rgbe_read(const char *path, int *w, int *h, float **rgb, char *err, size_t errlen)
{
    *rgb = NULL;
    unsigned char *data = NULL;
    size_t size = 0;
    vsd_status s = slurp(path, &data, &size, err, errlen);
    if (s != VSD_OK)
        return s;
    cursor c = {data, size, 0, path};
    s = parse_header(&c, err, errlen);
    if (s == VSD_OK)
        s = parse_resolution(&c, w, h, err, errlen);
    if (s == VSD_OK)
        s = decode_pixels(&c, *w, *h, rgb, err, errlen);
    free(data);
    return s;
}
