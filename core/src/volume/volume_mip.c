/* The half-resolution volume of volume_mip.h, brick by brick: a coarse brick (8^3 coarse
 * voxels) covers exactly 2x2x2 fine bricks, because both origins are multiples of 8 and a
 * coarse brick spans 16 fine voxels; coarse bricks over 8 absent fine bricks are absent. */
#include "volume_mip.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int64_t floor_div(int64_t v, int64_t d)
{
    return v >= 0 ? v / d : -((-v + d - 1) / d);
}

/* Slot of fine brick cell (x,y,z), or -1 when absent or outside the grid. */
static int32_t fine_slot(const vsd_volume *v, int64_t x, int64_t y, int64_t z)
{
    const int32_t *d = v->brick_dims;
    if (x < 0 || y < 0 || z < 0 || x >= d[0] || y >= d[1] || z >= d[2]) return -1;
    return v->brick_slots[(size_t)x + (size_t)d[0] * ((size_t)y + (size_t)d[1] * (size_t)z)];
}

/* The coarse brick whose fine bricks start at fine brick cell (fx,fy,fz) into dst; returns
 * the count of non-zero coarse voxels (0: every fine brick absent or all zero). */
static int coarse_brick(const vsd_volume *src, int64_t fx, int64_t fy, int64_t fz, float *dst)
{
    const float *b[8];
    int n, any = 0, nonzero = 0, x, y, z;
    for (n = 0; n < 8; n++) {
        int32_t s = fine_slot(src, fx + (n & 1), fy + ((n >> 1) & 1), fz + ((n >> 2) & 1));
        b[n] = s < 0 ? NULL : src->voxels + (size_t)s * VSD_BRICK_VOXELS;
        any |= s >= 0;
    }
    if (!any) return 0;
    for (z = 0; z < 8; z++)
        for (y = 0; y < 8; y++)
            for (x = 0; x < 8; x++) {
                /* fine voxels 2x, 2x+1 (etc.) lie in one fine brick: (2x) >> 3 = x >> 2 */
                const float *f = b[(x >> 2) | ((y >> 2) << 1) | ((z >> 2) << 2)];
                float s = 0.0f;
                if (f) {
                    const int lx = (2 * x) & 7, ly = (2 * y) & 7, lz = (2 * z) & 7;
                    const float *p = f + lz * 64 + ly * 8 + lx;
                    s = (p[0] + p[1] + p[8] + p[9] + p[64] + p[65] + p[72] + p[73]) * 0.125f;
                }
                dst[z * 64 + y * 8 + x] = s;
                nonzero += s != 0.0f;
            }
    return nonzero;
}

vsd_status vsd_volume_mip_half(const vsd_volume *src, vsd_volume **out, char *err, size_t errlen)
{
    double half[16] = {2, 0, 0, 0.5, 0, 2, 0, 0.5, 0, 0, 2, 0.5, 0, 0, 0, 1}, m[16];
    vsd_volume *v;
    vsd_status st;
    int64_t lo[3], hi[3], cap = 0, count = 0, nonzero = 0;
    size_t cells, cell = 0;
    int a;
    *out = NULL;
    /* coarse index I sits at fine index 2I + 1/2 */
    vsd_mat4_mul(src->index_to_world, half, m);
    if ((st = vsd_volume_create_empty(m, &v, err, errlen))) return st;
    snprintf(v->grid_name, sizeof v->grid_name, "%s", src->grid_name);
    snprintf(v->file, sizeof v->file, "%s", src->file);
    if (src->brick_dims[0] == 0 || src->brick_count == 0) {
        *out = v;
        return VSD_OK;
    }
    for (a = 0; a < 3; a++) {
        /* the coarse voxels the fine box reaches, with the coverage rule's margin below */
        lo[a] = floor_div(floor_div(src->origin[a], 2) - 1, 8) * 8;
        hi[a] = floor_div(src->origin[a] + 8 * (int64_t)src->brick_dims[a] - 1, 2);
        v->origin[a] = (int32_t)lo[a];
        v->brick_dims[a] = (int32_t)((hi[a] + 1 - lo[a] + 7) / 8);
    }
    cells = (size_t)v->brick_dims[0] * v->brick_dims[1] * v->brick_dims[2];
    v->brick_slots = malloc(cells * sizeof *v->brick_slots);
    v->brick_min = calloc(cells, sizeof *v->brick_min);
    v->brick_max = calloc(cells, sizeof *v->brick_max);
    if (!v->brick_slots || !v->brick_min || !v->brick_max) goto nomem;
    for (int32_t bz = 0; bz < v->brick_dims[2]; bz++)
        for (int32_t by = 0; by < v->brick_dims[1]; by++)
            for (int32_t bx = 0; bx < v->brick_dims[0]; bx++, cell++) {
                /* fine brick cell of the coarse brick's first fine voxel: 2 (origin + 8b) */
                const int64_t f[3] = {(2 * (lo[0] + 8 * bx) - src->origin[0]) / 8,
                                      (2 * (lo[1] + 8 * by) - src->origin[1]) / 8,
                                      (2 * (lo[2] + 8 * bz) - src->origin[2]) / 8};
                int nz;
                v->brick_slots[cell] = -1;
                if (count == cap) {
                    int64_t ncap = cap ? 2 * cap : 64;
                    float *nv = realloc(v->voxels, (size_t)ncap * VSD_BRICK_VOXELS * sizeof(float));
                    if (!nv) goto nomem;
                    v->voxels = nv;
                    cap = ncap;
                }
                nz = coarse_brick(src, f[0], f[1], f[2], v->voxels + (size_t)count * VSD_BRICK_VOXELS);
                if (nz <= 0) continue;
                v->brick_slots[cell] = (int32_t)count++;
                nonzero += nz;
            }
    v->brick_count = (int32_t)count;
    v->active_voxels = (uint64_t)nonzero;
    vsd_volume_update_ranges(v);
    *out = v;
    return VSD_OK;
nomem:
    vsd_volume_destroy(v);
    return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory for the half-resolution copy of grid '%s'",
                    src->file[0] ? src->file : "(in memory)", src->grid_name);
}

double vsd_volume_mip_loss(const vsd_volume *src, const vsd_volume *coarse, int levels_between)
{
    /* fine index p sits at coarse index (p - (2^L - 1)/2) / 2^L after L halvings */
    const double scale = 1.0 / (double)(1 << levels_between), shift = 0.5 * ((double)(1 << levels_between) - 1.0);
    const int32_t *d = src->brick_dims;
    double num = 0, den = 0;
    size_t cell = 0;
    for (int32_t bz = 0; bz < d[2]; bz++)
        for (int32_t by = 0; by < d[1]; by++)
            for (int32_t bx = 0; bx < d[0]; bx++, cell++) {
                const int32_t slot = src->brick_slots[cell];
                const float *v;
                if (slot < 0) continue;
                v = src->voxels + (size_t)slot * VSD_BRICK_VOXELS;
                /* every 7th voxel of each brick: 7 is prime to 8, so the sample walks through
                   every parity of x, y and z (an upsampled grid's even and odd voxels alike) */
                for (int q = (int)(cell % 7); q < VSD_BRICK_VOXELS; q += 7) {
                    const double p[3] = {(src->origin[0] + 8 * bx + (q & 7) - shift) * scale,
                                         (src->origin[1] + 8 * by + ((q >> 3) & 7) - shift) * scale,
                                         (src->origin[2] + 8 * bz + (q >> 6) - shift) * scale};
                    const double e = (double)v[q] - (double)vsd_volume_sample_index(coarse, p);
                    num += e * e;
                    den += (double)v[q] * v[q];
                }
            }
    return den > 0 ? num / den : 0.0;
}
