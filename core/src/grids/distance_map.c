/* The distance map of distance_map.h: occupancy from the bricks, a separable exact EDT
 * (Felzenszwalb & Huttenlocher 2012), then conservative leap radii in voxels. */
#include "distance_map.h"
#include "device/cpu/cpu_tiles.h"
#include "kernel/kernel_edt.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "src/common/clock.h"

#define EDT_INF VSD_EDT_INF

typedef struct edt_pass {
    float *d2;
    int32_t dims[3];
    int axis;            /* the axis the lines run along */
} edt_pass;

/* One tile of lines of an axis pass: lines are addressed by the two other axes (a, b),
 * gathered into a contiguous buffer, transformed and scattered back. */
static void edt_lines(void *user, int a0, int b0, int a1, int b1)
{
    const edt_pass *p = user;
    int n = p->dims[p->axis], a, b, q;
    size_t stride = p->axis == 0 ? 1 : (p->axis == 1 ? (size_t)p->dims[0] : (size_t)p->dims[0] * p->dims[1]);
    float *f = malloc(sizeof(float) * 2 * (size_t)n);
    int32_t *v = malloc(sizeof(int32_t) * (size_t)n);
    double *z = malloc(sizeof(double) * (size_t)(n + 1));
    if (!f || !v || !z) { /* cannot happen for sane sizes; the caller checked a big block */
        free(f); free(v); free(z);
        return;
    }
    for (b = b0; b < b1; b++)
        for (a = a0; a < a1; a++) {
            size_t base;
            if (p->axis == 0) base = ((size_t)b * p->dims[1] + a) * p->dims[0];
            else if (p->axis == 1) base = (size_t)b * p->dims[0] * p->dims[1] + a;
            else base = (size_t)b * p->dims[0] + a;
            for (q = 0; q < n; q++) f[q] = p->d2[base + q * stride];
            vsd_edt_line(f, n, f + n, v, z);
            for (q = 0; q < n; q++) p->d2[base + q * stride] = f[n + q];
        }
    free(f); free(v); free(z);
}

/* Run one axis pass with the tile pool: the 2D domain of lines is (other axis 1) x
 * (other axis 2), so 16x16-line tiles balance over threads. */
static void edt_axis(float *d2, const int32_t dims[3], int axis, int threads)
{
    edt_pass p;
    vsd_tile_job job;
    memset(&job, 0, sizeof job);
    p.d2 = d2;
    memcpy(p.dims, dims, sizeof p.dims);
    p.axis = axis;
    job.width = axis == 0 ? dims[1] : dims[0];
    job.height = axis == 2 ? dims[1] : dims[2];
    job.threads = threads;
    job.fn = edt_lines;
    job.user = &p;
    job.stage = "distance map";
    vsd_cpu_run_tiles(&job);
}

int vsd_edt_squared(const uint8_t *occ, const int32_t dims[3], float *d2, int threads)
{
    size_t i, n = (size_t)dims[0] * dims[1] * dims[2];
    int axis;
    for (i = 0; i < n; i++) d2[i] = occ[i] ? 0.0f : EDT_INF;
    for (axis = 0; axis < 3; axis++) edt_axis(d2, dims, axis, threads);
    return 1;
}

typedef struct skip_pass {
    const float *d2;
    uint8_t *skip;
    size_t slab;         /* cells per z slice */
} skip_pass;

/* Leap radii from the squared distances (kernel/kernel_edt.h, shared with the GPU pass). */
static void skip_rows(void *user, int x0, int z0, int x1, int z1)
{
    const skip_pass *p = user;
    int z;
    (void)x0; (void)x1;
    for (z = z0; z < z1; z++) {
        size_t i, base = (size_t)z * p->slab;
        for (i = base; i < base + p->slab; i++) p->skip[i] = vsd_edt_skip(p->d2[i]);
    }
}

/* Voxel occupancy (|v| > threshold) read brick by brick, skipping bricks whose range is
 * within the threshold, then dilated into cell occupancy: cell c is occupied when any
 * voxel c + {0,1}^3 is (three in-place OR passes, each reading the not-yet-updated next
 * element). */
static int64_t cell_occupancy(const vsd_volume *vol, float threshold, const int32_t dims[3], uint8_t *occ)
{
    int32_t bx, by, bz, x, y, z;
    int64_t count = 0;
    size_t i, n = (size_t)dims[0] * dims[1] * dims[2];
    const int32_t *bd = vol->brick_dims;
    for (bz = 0; bz < bd[2]; bz++)
        for (by = 0; by < bd[1]; by++)
            for (bx = 0; bx < bd[0]; bx++) {
                size_t cell = ((size_t)bz * bd[1] + by) * bd[0] + bx;
                int32_t slot = vol->brick_slots[cell];
                const float *b;
                if (slot < 0 || fmaxf(fabsf(vol->brick_max[cell]), fabsf(vol->brick_min[cell])) <= threshold) continue;
                b = vol->voxels + (size_t)slot * VSD_BRICK_VOXELS;
                for (z = 0; z < 8; z++)
                    for (y = 0; y < 8; y++) {
                        uint8_t *row = occ + ((size_t)(bz * 8 + z) * dims[1] + (by * 8 + y)) * dims[0] + bx * 8;
                        const float *src = b + (z * 8 + y) * 8;
                        for (x = 0; x < 8; x++) row[x] = fabsf(src[x]) > threshold;
                    }
            }
    for (z = 0; z < dims[2]; z++)
        for (y = 0; y < dims[1]; y++) {
            uint8_t *row = occ + ((size_t)z * dims[1] + y) * dims[0];
            for (x = 0; x + 1 < dims[0]; x++) row[x] |= row[x + 1];
        }
    for (z = 0; z < dims[2]; z++)
        for (y = 0; y + 1 < dims[1]; y++) {
            uint8_t *row = occ + ((size_t)z * dims[1] + y) * dims[0];
            for (x = 0; x < dims[0]; x++) row[x] |= row[x + dims[0]];
        }
    for (z = 0; z + 1 < dims[2]; z++) {
        uint8_t *sl = occ + (size_t)z * dims[1] * dims[0];
        size_t s = (size_t)dims[1] * dims[0];
        for (i = 0; i < s; i++) sl[i] |= sl[i + s];
    }
    for (i = 0; i < n; i++) count += occ[i];
    return count;
}

size_t vsd_distance_map_layout(const vsd_volume *vol, vsd_distance_map *dm)
{
    int a;
    memset(dm, 0, sizeof *dm);
    if (!vol || vol->brick_dims[0] == 0) return 0;
    for (a = 0; a < 3; a++) {
        dm->origin[a] = vol->origin[a];
        dm->dims[a] = 8 * vol->brick_dims[a];
    }
    return (size_t)dm->dims[0] * dm->dims[1] * dm->dims[2];
}

vsd_status vsd_distance_map_build(const vsd_volume *vol, float threshold, int threads, vsd_distance_map *dm,
                                  char *err, size_t errlen)
{
    double t0 = vsd_clock_seconds();
    size_t n = vsd_distance_map_layout(vol, dm);
    uint8_t *occ;
    float *d2;
    if (n == 0) return VSD_OK;
    occ = calloc(n, 1);
    d2 = malloc(sizeof(float) * n);
    dm->skip = malloc(n);
    if (!occ || !d2 || !dm->skip) {
        free(occ);
        free(d2);
        vsd_distance_map_free(dm);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory for a %dx%dx%d distance map", vol->file,
                        8 * vol->brick_dims[0], 8 * vol->brick_dims[1], 8 * vol->brick_dims[2]);
    }
    dm->occupied = cell_occupancy(vol, threshold, dm->dims, occ);
    vsd_edt_squared(occ, dm->dims, d2, threads);
    {
        skip_pass sp;
        vsd_tile_job job;
        memset(&job, 0, sizeof job);
        sp.d2 = d2;
        sp.skip = dm->skip;
        sp.slab = (size_t)dm->dims[0] * dm->dims[1];
        job.width = 1;
        job.height = dm->dims[2];
        job.threads = threads;
        job.fn = skip_rows;
        job.user = &sp;
        job.stage = "distance map";
        vsd_cpu_run_tiles(&job);
    }
    free(occ);
    free(d2);
    dm->seconds = vsd_clock_seconds() - t0;
    return VSD_OK;
}

void vsd_distance_map_free(vsd_distance_map *dm)
{
    if (!dm) return;
    free(dm->skip);
    memset(dm, 0, sizeof *dm);
}
