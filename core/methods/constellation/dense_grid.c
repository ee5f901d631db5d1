/* The dense copy of dense_grid.h: zero-filled, then each stored brick's 8^3 voxels copied
 * row by row into place; then the shadow code per cell from the corners and the map. */
#include "dense_grid.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "src/common/clock.h"

/* Shadow codes (dense_grid.h): 1 where all 8 corners are within the threshold, raised to
 * skip + 1 where the distance map promises a leap. */
static void shadow_codes(vsd_dense_grid *g, const vsd_distance_map *dm, float thr)
{
    const size_t sy = (size_t)g->dims[0] + 1, sz = sy * ((size_t)g->dims[1] + 1);
    int32_t x, y, z;
    for (z = 0; z < g->dims[2]; z++)
        for (y = 0; y < g->dims[1]; y++) {
            size_t c = ((size_t)z * g->dims[1] + y) * g->dims[0];
            const float *b = g->v + (size_t)z * sz + (size_t)y * sy;
            for (x = 0; x < g->dims[0]; x++, c++, b++) {
                int code = fabsf(b[0]) <= thr && fabsf(b[1]) <= thr && fabsf(b[sy]) <= thr &&
                           fabsf(b[sy + 1]) <= thr && fabsf(b[sz]) <= thr && fabsf(b[sz + 1]) <= thr &&
                           fabsf(b[sz + sy]) <= thr && fabsf(b[sz + sy + 1]) <= thr;
                if (dm && dm->skip[c] > 0) code = dm->skip[c] >= 254 ? 255 : dm->skip[c] + 1;
                g->code[c] = (uint8_t)code;
            }
        }
}

vsd_status vsd_dense_grid_build(const vsd_volume *vol, const vsd_distance_map *dm, float threshold, vsd_dense_grid *g,
                                char *err, size_t errlen)
{
    double t0 = vsd_clock_seconds();
    size_t nx, ny, nz;
    int32_t bx, by, bz, y, z, a;
    const int32_t *bd;
    memset(g, 0, sizeof *g);
    if (!(threshold >= 0.0f))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "dense grid: threshold %g must be >= 0", (double)threshold);
    if (!vol || vol->brick_dims[0] == 0) return VSD_OK;
    bd = vol->brick_dims;
    for (a = 0; a < 3; a++) {
        g->origin[a] = vol->origin[a];
        g->dims[a] = 8 * bd[a];
    }
    nx = (size_t)g->dims[0] + 1;
    ny = (size_t)g->dims[1] + 1;
    nz = (size_t)g->dims[2] + 1;
    if (dm && dm->skip && (memcmp(dm->origin, g->origin, sizeof g->origin) || memcmp(dm->dims, g->dims, sizeof g->dims)))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: the distance map covers other cells than the volume",
                        vol->file);
    if (dm && !dm->skip) dm = NULL;
    if ((unsigned long long)nx * ny * nz > VSD_DENSE_GRID_MAX_VOXELS) return VSD_OK;
    g->v = calloc(nx * ny * nz, sizeof(float));
    g->code = malloc((size_t)g->dims[0] * g->dims[1] * g->dims[2]);
    if (!g->v || !g->code) {
        vsd_dense_grid_free(g);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory for a %zux%zux%zu dense grid", vol->file, nx, ny,
                        nz);
    }
    for (bz = 0; bz < bd[2]; bz++)
        for (by = 0; by < bd[1]; by++)
            for (bx = 0; bx < bd[0]; bx++) {
                int32_t slot = vol->brick_slots[((size_t)bz * bd[1] + by) * bd[0] + bx];
                const float *b;
                if (slot < 0) continue;
                b = vol->voxels + (size_t)slot * VSD_BRICK_VOXELS;
                for (z = 0; z < 8; z++)
                    for (y = 0; y < 8; y++)
                        memcpy(g->v + ((size_t)(bz * 8 + z) * ny + (size_t)(by * 8 + y)) * nx + (size_t)bx * 8,
                               b + (z * 8 + y) * 8, 8 * sizeof(float));
            }
    shadow_codes(g, dm, threshold);
    g->seconds = vsd_clock_seconds() - t0;
    return VSD_OK;
}

void vsd_dense_grid_free(vsd_dense_grid *g)
{
    if (!g) return;
    free(g->v);
    free(g->code);
    memset(g, 0, sizeof *g);
}
