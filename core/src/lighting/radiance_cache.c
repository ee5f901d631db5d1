/* radiance_cache.c — the P1 fit of a record grid's light (radiance_cache.h). */
#include "radiance_cache.h"
#include "vsd/volume.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* the integral of w_x over the directions through the +x face of the cube [-1, 1]^3:
 * integral over y, z in [-1, 1] of (1 + y^2 + z^2)^-2 */
#define FACE_FIRST_MOMENT 1.7408395
#define PI_D 3.14159265358979323846

/* The 4x4 inverse of affine map a (both row-major), 0 when a is singular. */
static int invert_affine(const vsd_affine *a, double inv[16])
{
    double m[16];
    int i;
    for (i = 0; i < 12; i++) m[i] = a->m[i];
    m[12] = m[13] = m[14] = 0.0;
    m[15] = 1.0;
    return vsd_mat4_invert(m, inv);
}

vsd_status vsd_radiance_cache_from_records(const vsd_record_grid *rg, const float *cones, const float *iso,
                                           vsd_radiance_cache *out, char *err, size_t errlen)
{
    const size_t cells = (size_t)rg->res[0] * rg->res[1] * rg->res[2];
    const double b_scale = 3.0 * FACE_FIRST_MOMENT / (4.0 * PI_D);
    double g2w[16];
    vsd_f3 axis[3];
    size_t c;
    int a;
    memset(out, 0, sizeof *out);
    if (cells == 0) return VSD_OK;   /* an empty volume: a cache of nothing */
    if (!cones && !iso) return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "radiance cache: no light given");
    float *p1 = calloc(cells * VSD_CACHE_FLOATS, sizeof *p1);
    if (!p1) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "radiance cache: no memory for %zu cells", cells);
    /* each grid axis's direction in the world: the columns of grid -> world */
    if (!invert_affine(&rg->world_to_grid, g2w)) {
        free(p1);
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "radiance cache: the grid's transform is singular");
    }
    for (a = 0; a < 3; a++) axis[a] = f3_normalize(f3((float)g2w[a], (float)g2w[4 + a], (float)g2w[8 + a]));
    for (c = 0; c < cells; c++) {
        int32_t rec = rg->cell_record[c];
        float *v = p1 + VSD_CACHE_FLOATS * c;
        int ch;
        if (rec < 0) continue;
        if (!cones) {
            for (ch = 0; ch < 3; ch++) v[ch] = iso[3 * (size_t)rec + ch];
            continue;
        }
        {
            const float *L = cones + 18 * (size_t)rec;
            for (ch = 0; ch < 3; ch++) {
                float mean = 0.0f;
                int i;
                for (i = 0; i < 6; i++) mean += L[3 * i + ch] / 6.0f;
                v[ch] = mean;
                for (a = 0; a < 3; a++) {
                    /* this axis's flux, along its world direction */
                    float f = (float)(b_scale * (L[3 * (2 * a) + ch] - L[3 * (2 * a + 1) + ch]));
                    v[3 + ch] += f * axis[a].x;
                    v[6 + ch] += f * axis[a].y;
                    v[9 + ch] += f * axis[a].z;
                }
            }
        }
    }
    out->k.p1 = p1;
    out->k.world_to_grid = rg->world_to_grid;
    memcpy(out->k.dims, rg->res, sizeof out->k.dims);
    return VSD_OK;
}

vsd_status vsd_radiance_cache_from_sh(const int32_t res[3], const vsd_affine *node_to_world, const float *sh,
                                      vsd_radiance_cache *out, char *err, size_t errlen)
{
    const size_t nodes = (size_t)res[0] * res[1] * res[2];
    const float y0 = (float)(0.5 / sqrt(PI_D)), c1 = (float)sqrt(3.0 / (4.0 * PI_D));
    double w2n[16];
    size_t n;
    int a, ch;
    float *p1;
    memset(out, 0, sizeof *out);
    if (nodes == 0) return VSD_OK;
    if (!invert_affine(node_to_world, w2n))
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "radiance cache: the nodes' transform is singular");
    if (!(p1 = calloc(nodes * VSD_CACHE_FLOATS, sizeof *p1)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "radiance cache: no memory for %zu nodes", nodes);
    for (n = 0; n < nodes; n++)
        for (ch = 0; ch < 3; ch++) {
            const float *L = sh + (n * 3 + (size_t)ch) * 4;
            float *v = p1 + VSD_CACHE_FLOATS * n;
            v[ch] = y0 * L[0];
            v[3 + ch] = -c1 * L[3];
            v[6 + ch] = -c1 * L[1];
            v[9 + ch] = c1 * L[2];
        }
    out->k.p1 = p1;
    /* the cache's cell (i, j, k) has its centre at (i, j, k) + 0.5: node (i, j, k) */
    for (a = 0; a < 12; a++) out->k.world_to_grid.m[a] = (float)w2n[a] + (a % 4 == 3 ? 0.5f : 0.0f);
    memcpy(out->k.dims, res, sizeof out->k.dims);
    return VSD_OK;
}

void vsd_radiance_cache_free(vsd_radiance_cache *c)
{
    free((void *)c->k.p1);
    memset(c, 0, sizeof *c);
}
