/* Per-brick value ranges: the majorant grid and empty-space structure of docs/architecture.md §9.
 *
 * A point p in brick cell b ([8b, 8b+8) relative to origin) is interpolated from voxels
 * floor(p) .. floor(p)+1, i.e. from the cell's own 8^3 voxels plus the +1 layer on the +x, +y
 * and +z sides, which belongs to up to 7 neighbouring bricks. Trilinear weights are a convex
 * combination, so min/max over those 9^3 voxels bound the field over the whole cell (and are
 * attained at the voxels themselves, so the bound is tight). Voxels of absent bricks are 0. */
#include "vsd/volume.h"

#include <float.h>
#include <stddef.h>

typedef struct range {
    float lo, hi;
} range;

static void range_add(range *r, float v)
{
    if (v < r->lo) r->lo = v;
    if (v > r->hi) r->hi = v;
}

/* Slot of brick cell (x,y,z), or -1 when it is absent or outside the grid. */
static int32_t slot_at(const vsd_volume *vol, int32_t x, int32_t y, int32_t z)
{
    const int32_t *d = vol->brick_dims;
    if (x < 0 || y < 0 || z < 0 || x >= d[0] || y >= d[1] || z >= d[2])
        return -1;
    return vol->brick_slots[(size_t)x + (size_t)d[0] * ((size_t)y + (size_t)d[1] * (size_t)z)];
}

/* Fold the local box [x0,x1]x[y0,y1]x[z0,z1] of brick cell (bx,by,bz) into r. */
static void range_box(const vsd_volume *vol, int32_t bx, int32_t by, int32_t bz, int x0, int x1,
                      int y0, int y1, int z0, int z1, range *r)
{
    const int32_t slot = slot_at(vol, bx, by, bz);
    if (slot < 0) {
        range_add(r, 0.0f);
        return;
    }
    const float *v = vol->voxels + (size_t)slot * VSD_BRICK_VOXELS;
    for (int z = z0; z <= z1; ++z)
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x)
                range_add(r, v[z * 64 + y * 8 + x]);
}

/* The own brick plus the 7 neighbour pieces of the +1 layer: 3 faces, 3 edges, 1 corner.
 * Bit a of n set = step +1 along axis a; that axis then contributes only local index 0. */
static range cell_range(const vsd_volume *vol, int32_t bx, int32_t by, int32_t bz)
{
    range r = {FLT_MAX, -FLT_MAX};
    for (int n = 0; n < 8; ++n) {
        const int sx = n & 1, sy = (n >> 1) & 1, sz = (n >> 2) & 1;
        range_box(vol, bx + sx, by + sy, bz + sz, 0, sx ? 0 : 7, 0, sy ? 0 : 7, 0, sz ? 0 : 7, &r);
    }
    return r;
}

void vsd_volume_update_ranges(vsd_volume *vol)
{
    if (!vol)
        return;
    vol->value_min = vol->value_max = 0.0f;
    if (!vol->brick_slots || !vol->brick_min || !vol->brick_max)
        return;
    size_t cell = 0;
    for (int32_t z = 0; z < vol->brick_dims[2]; ++z)
        for (int32_t y = 0; y < vol->brick_dims[1]; ++y)
            for (int32_t x = 0; x < vol->brick_dims[0]; ++x, ++cell) {
                const range r = cell_range(vol, x, y, z);
                vol->brick_min[cell] = r.lo;
                vol->brick_max[cell] = r.hi;
            }
    if (vol->brick_count > 0 && vol->voxels) {
        range all = {vol->voxels[0], vol->voxels[0]};
        const size_t n = (size_t)vol->brick_count * VSD_BRICK_VOXELS;
        for (size_t i = 1; i < n; ++i)
            range_add(&all, vol->voxels[i]);
        vol->value_min = all.lo;
        vol->value_max = all.hi;
    }
}
