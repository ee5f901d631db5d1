/* The sparse brick volume of docs/architecture.md §9: creation, voxel access, trilinear sampling and
 * bounds. Brick ranges (the majorant grid) live in volume_ranges.c.
 *
 * Coverage rule. The field is trilinear between voxel centres with floor-based cells, so a
 * non-zero voxel v influences the open interval (v-1, v+1) on each axis. Brick cell b covers
 * [origin+8b, origin+8b+8), so the high side of every stored voxel is always inside some cell,
 * but the low side of a voxel at index `origin` would stick out of the grid. Builders therefore
 * place origin at floor8(lowest non-zero index - 1): one (empty, slot -1) margin cell whenever
 * the data starts exactly on a multiple of 8. Then brick_min/brick_max cover every point where
 * vsd_volume_sample_index can be non-zero, and outside the cells the field is exactly 0. */
#include "vsd/volume.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* floor(v / 8) for any sign, without relying on >> of negative values. */
static int64_t floor_div8(int64_t v)
{
    return v >= 0 ? v / 8 : -((-v + 7) / 8);
}

static void identity4(double m[16])
{
    memset(m, 0, 16 * sizeof(double));
    m[0] = m[5] = m[10] = m[15] = 1.0;
}

/* Voxel size = world length of each index axis = length of the matrix's first three columns
 * (column-vector convention), which also holds for rotated or sheared transforms. */
static void voxel_size_from_matrix(const double m[16], double vs[3])
{
    for (int c = 0; c < 3; ++c)
        vs[c] = sqrt(m[c] * m[c] + m[4 + c] * m[4 + c] + m[8 + c] * m[8 + c]);
}

static vsd_volume *alloc_volume(const double index_to_world[16])
{
    vsd_volume *vol = calloc(1, sizeof *vol);
    if (!vol)
        return NULL;
    if (index_to_world)
        memcpy(vol->index_to_world, index_to_world, sizeof vol->index_to_world);
    else
        identity4(vol->index_to_world);
    voxel_size_from_matrix(vol->index_to_world, vol->voxel_size);
    return vol;
}

vsd_status vsd_volume_create_empty(const double index_to_world[16], vsd_volume **out,
                                   char *err, size_t errlen)
{
    if (!out)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "vsd_volume_create_empty: out is NULL");
    *out = alloc_volume(index_to_world);
    if (!*out)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "vsd_volume_create_empty: out of memory");
    return VSD_OK;
}

void vsd_volume_destroy(vsd_volume *vol)
{
    if (!vol)
        return;
    free(vol->brick_slots);
    free(vol->voxels);
    free(vol->brick_min);
    free(vol->brick_max);
    free(vol);
}

/* ---- dense -> bricks ---------------------------------------------------------------- */

/* Bounding box (in dense-array coordinates) of the non-zero values; returns the count. */
static uint64_t nonzero_box(const float *values, const int32_t dims[3], int64_t lo[3],
                            int64_t hi[3])
{
    uint64_t n = 0;
    for (int a = 0; a < 3; ++a) {
        lo[a] = INT64_MAX;
        hi[a] = INT64_MIN;
    }
    size_t idx = 0;
    for (int64_t z = 0; z < dims[2]; ++z)
        for (int64_t y = 0; y < dims[1]; ++y)
            for (int64_t x = 0; x < dims[0]; ++x, ++idx) {
                if (values[idx] == 0.0f)
                    continue;
                const int64_t p[3] = {x, y, z};
                for (int a = 0; a < 3; ++a) {
                    if (p[a] < lo[a]) lo[a] = p[a];
                    if (p[a] > hi[a]) hi[a] = p[a];
                }
                ++n;
            }
    return n;
}

/* Copy brick cell (bx,by,bz) out of the dense array into dst (x fastest, zeros outside the
 * array) and tell whether any value is non-zero. */
static int gather_brick(const float *values, const int32_t dims[3], const int64_t dense_org[3],
                        int64_t bx, int64_t by, int64_t bz, float *dst)
{
    int any = 0;
    for (int z = 0; z < 8; ++z)
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 8; ++x) {
                const int64_t dx = bx * 8 + x - dense_org[0];
                const int64_t dy = by * 8 + y - dense_org[1];
                const int64_t dz = bz * 8 + z - dense_org[2];
                float v = 0.0f;
                if (dx >= 0 && dy >= 0 && dz >= 0 && dx < dims[0] && dy < dims[1] && dz < dims[2])
                    v = values[(size_t)dx + (size_t)dims[0] * ((size_t)dy + (size_t)dims[1] * (size_t)dz)];
                dst[z * 64 + y * 8 + x] = v;
                any |= v != 0.0f;
            }
    return any;
}

/* Allocate the per-cell arrays of a volume whose origin and brick_dims are set. */
static vsd_status alloc_cells(vsd_volume *vol, char *err, size_t errlen, const char *who)
{
    const size_t n = (size_t)vol->brick_dims[0] * (size_t)vol->brick_dims[1] * (size_t)vol->brick_dims[2];
    vol->brick_slots = malloc(n * sizeof *vol->brick_slots);
    vol->brick_min = calloc(n, sizeof *vol->brick_min);
    vol->brick_max = calloc(n, sizeof *vol->brick_max);
    if (!vol->brick_slots || !vol->brick_min || !vol->brick_max)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: out of memory for %zu brick cells", who, n);
    for (size_t i = 0; i < n; ++i)
        vol->brick_slots[i] = -1;
    return VSD_OK;
}

/* Two passes over the bricks: count the non-empty ones to size the pool exactly, then copy. */
static vsd_status fill_from_dense(vsd_volume *vol, const float *values, const int32_t dims[3],
                                  const int64_t dense_org[3], char *err, size_t errlen)
{
    const char *who = "vsd_volume_create_dense";
    vsd_status st = alloc_cells(vol, err, errlen, who);
    if (st != VSD_OK)
        return st;
    float tmp[VSD_BRICK_VOXELS];
    const int32_t *bd = vol->brick_dims;
    const int64_t ob[3] = {vol->origin[0] / 8, vol->origin[1] / 8, vol->origin[2] / 8};
    int64_t count = 0;
    for (int pass = 0; pass < 2; ++pass) {
        size_t cell = 0;
        for (int64_t bz = 0; bz < bd[2]; ++bz)
            for (int64_t by = 0; by < bd[1]; ++by)
                for (int64_t bx = 0; bx < bd[0]; ++bx, ++cell) {
                    if (!gather_brick(values, dims, dense_org, ob[0] + bx, ob[1] + by, ob[2] + bz, tmp))
                        continue;
                    if (pass) {
                        memcpy(vol->voxels + (size_t)count * VSD_BRICK_VOXELS, tmp, sizeof tmp);
                        vol->brick_slots[cell] = (int32_t)count;
                    }
                    ++count;
                }
        if (pass == 0) {
            if (count > INT32_MAX)
                return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: too many bricks (%lld)", who, (long long)count);
            vol->voxels = malloc((size_t)count * VSD_BRICK_VOXELS * sizeof(float));
            if (!vol->voxels)
                return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: out of memory for %lld bricks", who, (long long)count);
            vol->brick_count = (int32_t)count;
            count = 0;
        }
    }
    return VSD_OK;
}

vsd_status vsd_volume_check_finite(const vsd_volume *vol, char *err, size_t errlen)
{
    const int32_t *bd = vol->brick_dims;
    const int64_t cells = (int64_t)bd[0] * bd[1] * bd[2];
    uint64_t bad = 0;
    int32_t first[3] = {0, 0, 0};
    float value = 0.0f;
    for (int64_t c = 0; c < cells; ++c) {
        const int32_t slot = vol->brick_slots[c];
        if (slot < 0) continue;
        const float *v = vol->voxels + (size_t)slot * VSD_BRICK_VOXELS;
        for (int q = 0; q < VSD_BRICK_VOXELS; ++q) {
            if (isfinite(v[q])) continue;
            if (bad++ == 0) {
                const int32_t bx = (int32_t)(c % bd[0]), by = (int32_t)((c / bd[0]) % bd[1]);
                const int32_t bz = (int32_t)(c / ((int64_t)bd[0] * bd[1]));
                first[0] = vol->origin[0] + 8 * bx + (q & 7);
                first[1] = vol->origin[1] + 8 * by + ((q >> 3) & 7);
                first[2] = vol->origin[2] + 8 * bz + (q >> 6);
                value = v[q];
            }
        }
    }
    if (bad == 0) return VSD_OK;
    return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                    "%s: grid '%s' has %llu voxel%s that %s NaN or infinite, the first at index (%d, %d, %d) = %g; "
                    "vsd renders finite densities only (fix the grid where it was written)",
                    vol->file[0] ? vol->file : "(in memory)", vol->grid_name[0] ? vol->grid_name : "(unnamed)",
                    (unsigned long long)bad, bad == 1 ? "" : "s", bad == 1 ? "is" : "are", first[0], first[1], first[2],
                    (double)value);
}

vsd_status vsd_volume_create_dense(const float *values, const int32_t dims[3],
                                   const int32_t index_min[3], const double index_to_world[16],
                                   vsd_volume **out, char *err, size_t errlen)
{
    const char *who = "vsd_volume_create_dense";
    if (!out)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: out is NULL", who);
    *out = NULL;
    if (!dims || !index_min || (!values && (int64_t)dims[0] * dims[1] * dims[2] > 0))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: NULL values, dims or index_min", who);
    for (int a = 0; a < 3; ++a) {
        /* Keep every index (and the +-8 margin) far inside int32 so no cell math overflows. */
        if (dims[a] < 0 || (int64_t)index_min[a] < -(INT32_MAX / 2) ||
            (int64_t)index_min[a] + dims[a] > INT32_MAX / 2)
            return vsd_fail(VSD_ERR_INVALID, err, errlen,
                            "%s: dims %d x %d x %d at index (%d, %d, %d) out of range", who,
                            dims[0], dims[1], dims[2], index_min[0], index_min[1], index_min[2]);
    }
    vsd_volume *vol = alloc_volume(index_to_world);
    if (!vol)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: out of memory", who);

    int64_t lo[3], hi[3];
    const int64_t total = (int64_t)dims[0] * dims[1] * dims[2];
    const uint64_t nonzero = total > 0 ? nonzero_box(values, dims, lo, hi) : 0;
    vol->active_voxels = nonzero;
    if (nonzero == 0) {
        *out = vol;
        return VSD_OK;
    }
    int64_t dense_org[3];
    for (int a = 0; a < 3; ++a) {
        const int64_t first = floor_div8(index_min[a] + lo[a] - 1);   /* margin: see top */
        const int64_t last = floor_div8(index_min[a] + hi[a]);
        vol->origin[a] = (int32_t)(first * 8);
        vol->brick_dims[a] = (int32_t)(last - first + 1);
        dense_org[a] = index_min[a];
    }
    if ((int64_t)vol->brick_dims[0] * vol->brick_dims[1] * vol->brick_dims[2] > INT32_MAX) {
        vsd_volume_destroy(vol);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: brick grid too large", who);
    }
    vsd_status st = fill_from_dense(vol, values, dims, dense_org, err, errlen);
    if (st == VSD_OK) st = vsd_volume_check_finite(vol, err, errlen);
    if (st != VSD_OK) {
        vsd_volume_destroy(vol);
        return st;
    }
    vsd_volume_update_ranges(vol);
    *out = vol;
    return VSD_OK;
}

/* ---- access --------------------------------------------------------------------------- */

float vsd_volume_voxel(const vsd_volume *vol, int32_t i, int32_t j, int32_t k)
{
    if (!vol || !vol->brick_slots)
        return 0.0f;
    const int64_t r[3] = {(int64_t)i - vol->origin[0], (int64_t)j - vol->origin[1],
                          (int64_t)k - vol->origin[2]};
    for (int a = 0; a < 3; ++a)
        if (r[a] < 0 || r[a] >= (int64_t)vol->brick_dims[a] * 8)
            return 0.0f;
    const size_t cell = (size_t)(r[0] >> 3) +
                        (size_t)vol->brick_dims[0] * ((size_t)(r[1] >> 3) + (size_t)vol->brick_dims[1] * (size_t)(r[2] >> 3));
    const int32_t slot = vol->brick_slots[cell];
    if (slot < 0)
        return 0.0f;
    return vol->voxels[(size_t)slot * VSD_BRICK_VOXELS + (size_t)((r[0] & 7) + 8 * (r[1] & 7) + 64 * (r[2] & 7))];
}

/* Trilinear interpolation with floor-based cells, in double so that the result, rounded to
 * float, never exceeds the largest (or undercuts the smallest) of the 8 corner voxels: that
 * keeps brick_min/brick_max exact bounds. Outside the brick grid's support the value is 0. */
float vsd_volume_sample_index(const vsd_volume *vol, const double p[3])
{
    if (!vol || !p || !vol->brick_slots)
        return 0.0f;
    int32_t c[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
        const double lo = (double)vol->origin[a] - 1.0;
        const double hi = (double)vol->origin[a] + 8.0 * vol->brick_dims[a];
        if (!(p[a] > lo && p[a] < hi))   /* also rejects NaN */
            return 0.0f;
        const double f = floor(p[a]);
        c[a] = (int32_t)f;
        t[a] = p[a] - f;
    }
    double v[8];
    for (int n = 0; n < 8; ++n)
        v[n] = vsd_volume_voxel(vol, c[0] + (n & 1), c[1] + ((n >> 1) & 1), c[2] + ((n >> 2) & 1));
    double x[4], y[2];
    for (int n = 0; n < 4; ++n)
        x[n] = v[2 * n] * (1.0 - t[0]) + v[2 * n + 1] * t[0];
    for (int n = 0; n < 2; ++n)
        y[n] = x[2 * n] * (1.0 - t[1]) + x[2 * n + 1] * t[1];
    return (float)(y[0] * (1.0 - t[2]) + y[1] * t[2]);
}

/* ---- bounds --------------------------------------------------------------------------- */

static void mat4_mul(const double a[16], const double b[16], double out[16])
{
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) {
            double s = 0.0;
            for (int k = 0; k < 4; ++k)
                s += a[r * 4 + k] * b[k * 4 + c];
            out[r * 4 + c] = s;
        }
}

/* Index box of the cells whose range is not {0}: the stored bricks plus the margin cells whose
 * +1 layer reaches into a stored brick, i.e. exactly the support of the trilinear field at
 * brick granularity. Returns 0 when there is none. */
static int support_cells(const vsd_volume *vol, int32_t lo[3], int32_t hi[3])
{
    if (!vol->brick_slots || !vol->brick_min || !vol->brick_max)
        return 0;
    int found = 0;
    size_t cell = 0;
    for (int32_t z = 0; z < vol->brick_dims[2]; ++z)
        for (int32_t y = 0; y < vol->brick_dims[1]; ++y)
            for (int32_t x = 0; x < vol->brick_dims[0]; ++x, ++cell) {
                if (vol->brick_min[cell] == 0.0f && vol->brick_max[cell] == 0.0f)
                    continue;
                const int32_t p[3] = {x, y, z};
                for (int a = 0; a < 3; ++a) {
                    if (!found || p[a] < lo[a]) lo[a] = p[a];
                    if (!found || p[a] > hi[a]) hi[a] = p[a];
                }
                found = 1;
            }
    return found;
}

void vsd_volume_world_bounds(const vsd_volume *vol, const double object_matrix[16],
                             double lo[3], double hi[3])
{
    for (int a = 0; a < 3; ++a) {
        lo[a] = DBL_MAX;
        hi[a] = -DBL_MAX;
    }
    int32_t clo[3], chi[3];
    if (!vol || !support_cells(vol, clo, chi))
        return;
    double m[16];
    if (object_matrix)
        mat4_mul(object_matrix, vol->index_to_world, m);
    else
        memcpy(m, vol->index_to_world, sizeof m);
    double box[2][3];
    for (int a = 0; a < 3; ++a) {
        box[0][a] = (double)vol->origin[a] + 8.0 * clo[a];
        box[1][a] = (double)vol->origin[a] + 8.0 * (chi[a] + 1);
    }
    for (int n = 0; n < 8; ++n) {
        const double p[3] = {box[n & 1][0], box[(n >> 1) & 1][1], box[(n >> 2) & 1][2]};
        for (int r = 0; r < 3; ++r) {
            const double w = m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3];
            if (w < lo[r]) lo[r] = w;
            if (w > hi[r]) hi[r] = w;
        }
    }
}
