/* vsd grids as POV-Ray df3 files (df3.h). */
#include "df3.h"
#include "pov_file.h"
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Calls fn for every stored voxel with its index coordinate. */
typedef void (*voxel_fn)(void *user, int32_t i, int32_t j, int32_t k, float v);

static void for_each_voxel(const vsd_volume *vol, voxel_fn fn, void *user)
{
    const int32_t *d = vol->brick_dims;
    int32_t bx, by, bz;
    for (bz = 0; bz < d[2]; bz++)
        for (by = 0; by < d[1]; by++)
            for (bx = 0; bx < d[0]; bx++) {
                int32_t slot = vol->brick_slots[((size_t)bz * d[1] + by) * d[0] + bx];
                const float *b;
                int x, y, z;
                if (slot < 0) continue;
                b = vol->voxels + (size_t)slot * VSD_BRICK_VOXELS;
                for (z = 0; z < 8; z++)
                    for (y = 0; y < 8; y++)
                        for (x = 0; x < 8; x++)
                            fn(user, vol->origin[0] + 8 * bx + x, vol->origin[1] + 8 * by + y,
                               vol->origin[2] + 8 * bz + z, b[(z * 8 + y) * 8 + x]);
            }
}

typedef struct bounds_acc {
    int32_t lo[3], hi[3];
    float max;
    uint64_t negative;
} bounds_acc;

static void bounds_fn(void *user, int32_t i, int32_t j, int32_t k, float v)
{
    bounds_acc *a = user;
    const int32_t p[3] = {i, j, k};
    int c;
    if (v < 0) a->negative++;
    if (!(v > 0)) return;
    if (v > a->max) a->max = v;
    for (c = 0; c < 3; c++) {
        if (p[c] < a->lo[c]) a->lo[c] = p[c];
        if (p[c] > a->hi[c]) a->hi[c] = p[c];
    }
}

static void fill_fn(void *user, int32_t i, int32_t j, int32_t k, float v)
{
    vsd_df3 *d = user;
    long x = (long)i - d->index_min[0], y = (long)j - d->index_min[1], z = (long)k - d->index_min[2];
    double q;
    if (!(v > 0)) return;  /* zero, negative (counted by bounds_fn) */
    q = floor(65535.0 * v / d->scale + 0.5);
    if (q > 65535) q = 65535;
    d->data[((size_t)z * d->size[1] + (size_t)y) * d->size[0] + (size_t)x] = (uint16_t)q;
}

vsd_status vsd_df3_from_volume(const vsd_volume *vol, vsd_df3 *out, char *err, size_t errlen)
{
    bounds_acc a;
    size_t n;
    int c;
    memset(out, 0, sizeof *out);
    for (c = 0; c < 3; c++) {
        a.lo[c] = INT32_MAX;
        a.hi[c] = INT32_MIN;
    }
    a.max = 0;
    a.negative = 0;
    if (vol && vol->brick_dims[0] > 0) for_each_voxel(vol, bounds_fn, &a);
    out->negative = a.negative;
    if (a.max <= 0) {
        /* nothing to see: a valid file POV-Ray reads, with zero coefficients */
        for (c = 0; c < 3; c++) out->size[c] = 2;
        out->data = calloc(8, sizeof(uint16_t));
        if (!out->data) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a df3 file");
        return VSD_OK;
    }
    for (c = 0; c < 3; c++) {
        long s = (long)a.hi[c] - a.lo[c] + 3;  /* the non-zero voxels and a zero on each side */
        if (s > 65535)
            return vsd_fail(VSD_ERR_INVALID, err, errlen,
                            "grid '%s' spans %ld voxels along axis %c; a df3 file holds at most 65533",
                            vol->grid_name, s - 2, "xyz"[c]);
        out->size[c] = (int)s;
        out->index_min[c] = a.lo[c] - 1;
    }
    out->scale = a.max;
    n = (size_t)out->size[0] * out->size[1] * out->size[2];
    out->data = calloc(n, sizeof(uint16_t));
    if (!out->data)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a %dx%dx%d df3 grid", out->size[0],
                        out->size[1], out->size[2]);
    for_each_voxel(vol, fill_fn, out);
    return VSD_OK;
}

float vsd_df3_value(const vsd_df3 *d, int x, int y, int z)
{
    return (float)(d->data[((size_t)z * d->size[1] + y) * d->size[0] + x] * (double)d->scale / 65535.0);
}

void vsd_df3_box_to_index(const vsd_df3 *d, double m[16])
{
    int c;
    memset(m, 0, 16 * sizeof(double));
    for (c = 0; c < 3; c++) {
        m[c * 4 + c] = d->size[c];
        m[c * 4 + 3] = d->index_min[c];
    }
    m[15] = 1;
}

static void put_be16(unsigned char *p, unsigned v)
{
    p[0] = (unsigned char)(v >> 8);
    p[1] = (unsigned char)(v & 0xff);
}

vsd_status vsd_df3_write(const char *path, const vsd_df3 *d, char *err, size_t errlen)
{
    vsd_pov_file pf;
    unsigned char buf[2 * 4096];
    size_t n = (size_t)d->size[0] * d->size[1] * d->size[2], i = 0;
    vsd_status st;
    int c;
    if ((st = vsd_pov_file_open(&pf, path, err, errlen))) return st;
    for (c = 0; c < 3; c++) put_be16(buf + 2 * c, (unsigned)d->size[c]);
    fwrite(buf, 1, 6, pf.f);
    while (i < n) {
        size_t k, chunk = n - i < 4096 ? n - i : 4096;
        for (k = 0; k < chunk; k++) put_be16(buf + 2 * k, d->data[i + k]);
        if (fwrite(buf, 2, chunk, pf.f) != chunk) break;
        i += chunk;
    }
    return vsd_pov_file_commit(&pf, err, errlen);
}

vsd_status vsd_df3_read(const char *path, vsd_df3 *out, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    unsigned char h[6], buf[2 * 4096];
    size_t n, i = 0;
    int c;
    memset(out, 0, sizeof *out);
    if (!f) return vsd_fail(VSD_ERR_IO, err, errlen, "%s: cannot open: %s", path, strerror(errno));
    if (fread(h, 1, 6, f) != 6) {
        fclose(f);
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: not a df3 file (shorter than its 6-byte header)", path);
    }
    for (c = 0; c < 3; c++) {
        out->size[c] = h[2 * c] << 8 | h[2 * c + 1];
        if (out->size[c] == 0) {
            fclose(f);
            return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: df3 size along %c is 0", path, "xyz"[c]);
        }
    }
    out->scale = 1;
    n = (size_t)out->size[0] * out->size[1] * out->size[2];
    out->data = malloc(n * sizeof(uint16_t));
    if (!out->data) {
        fclose(f);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory for %zu voxels", path, n);
    }
    while (i < n) {
        size_t k, chunk = n - i < 4096 ? n - i : 4096;
        if (fread(buf, 2, chunk, f) != chunk) {
            fclose(f);
            vsd_df3_free(out);
            return vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: truncated: %zu of %zu voxels", path, i, n);
        }
        for (k = 0; k < chunk; k++) out->data[i + k] = (uint16_t)(buf[2 * k] << 8 | buf[2 * k + 1]);
        i += chunk;
    }
    fclose(f);
    return VSD_OK;
}

void vsd_df3_free(vsd_df3 *d)
{
    if (!d) return;
    free(d->data);
    d->data = NULL;
}
