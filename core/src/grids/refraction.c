#include "refraction.h"
#include "src/method/method.h"
#include "src/render/kernel_setup.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_volumes.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

void vsd_refraction_free(vsd_refraction_field *f)
{
    free((void *)f->k.ng);
    memset(f, 0, sizeof *f);
}

/* In-place Gaussian blur of a scalar grid along one axis (radius 3 sigma, at most 63
 * cells). Outside the grid n is 1, and the blur sees it so: the medium's edge fades
 * toward vacuum, not toward nothing. */
static void blur_axis(float *v, const int32_t dims[3], int axis, float sigma, float *line, float *out)
{
    const size_t sx = 1, sy = (size_t)dims[0], sz = (size_t)dims[0] * dims[1];
    const size_t stride = axis == 0 ? sx : axis == 1 ? sy : sz;
    const int32_t n = dims[axis], rad = (int32_t)fminf(ceilf(3.0f * sigma), 63.0f);
    /* the two axes across the lines, and their strides */
    const int32_t na = dims[axis == 0 ? 1 : 0], nb = dims[axis == 2 ? 1 : 2];
    const size_t ta = axis == 0 ? sy : sx, tb = axis == 2 ? sy : sz;
    float w[64];
    int32_t a, b, i, r;
    for (r = 0; r <= rad; r++) w[r] = expf(-0.5f * (float)(r * r) / (sigma * sigma));
    for (b = 0; b < nb; b++)
        for (a = 0; a < na; a++) {
            const size_t base = (size_t)a * ta + (size_t)b * tb;
            for (i = 0; i < n; i++) line[i] = v[base + (size_t)i * stride];
            for (i = 0; i < n; i++) {
                float sum = 0.0f, ws = 0.0f;
                for (r = -rad; r <= rad; r++) {
                    int32_t j = i + r;
                    float wr = w[r < 0 ? -r : r];
                    sum += wr * (j < 0 || j >= n ? 1.0f : line[j]);
                    ws += wr;
                }
                out[i] = sum / ws;
            }
            for (i = 0; i < n; i++) v[base + (size_t)i * stride] = out[i];
        }
}

/* n from one sample of the source grid, by mode; *bad set for an n grid value in (0, 1) */
static float n_of(int mode, float v, float ior, int *bad)
{
    if (mode == VSD_IOR_GRID) {
        if (v == 0.0f) return 1.0f;   /* background: no index given */
        if (v < 1.0f) *bad = 1;
        return v;
    }
    if (mode == VSD_IOR_TEMPERATURE) {
        float t = 293.0f + 1000.0f * (v > 0.0f ? v : 0.0f);
        return 1.0f - 2.9e-4f * (1.0f - 293.0f / t);
    }
    return v > 0.0f ? ior : 1.0f;   /* the constant inside the medium */
}

vsd_status vsd_refraction_build(const vsd_kvolume *density, const vsd_kvolume *source, const char *name, int mode,
                                float ior, float smooth, int max_cells, vsd_refraction_field *out, char *err,
                                size_t errlen)
{
    const vsd_kvolume *box = mode == VSD_IOR_CONSTANT ? density : source;
    int32_t k, margin, dims[3], a, x, y, z, big;
    size_t cells, c;
    float *n = NULL, *line = NULL, *tmp = NULL, *ng = NULL, cell_world = 1e30f;
    double lo[3];
    vsd_status st = VSD_OK;
    memset(out, 0, sizeof *out);
    if (mode == VSD_IOR_CONSTANT && (!(ior >= 1.0f) || !(ior <= 4.0f)))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "medium.ior: %g is out of range for refraction (1 to 4)", (double)ior);
    if (mode != VSD_IOR_CONSTANT && !source)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "refraction: no grid '%s' loaded", name ? name : "");
    if (!(smooth >= 0.25f && smooth <= 8.0f) || max_cells < 8)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "refraction: smoothing %g cells (0.25-8) or %d cells (>= 8)",
                        (double)smooth, max_cells);
    if (box->dims[0] == 0) return VSD_OK;   /* nothing given: n = 1 everywhere */
    big = 8 * (box->dims[0] > box->dims[1] ? (box->dims[0] > box->dims[2] ? box->dims[0] : box->dims[2])
                                          : (box->dims[1] > box->dims[2] ? box->dims[1] : box->dims[2]));
    k = (big + max_cells - 1) / max_cells;
    if (k < 1) k = 1;
    margin = (int32_t)ceilf(3.0f * smooth) + 1;
    for (a = 0; a < 3; a++) {
        dims[a] = (8 * box->dims[a] + k - 1) / k + 2 * margin;
        lo[a] = box->origin[a] - (double)margin * k;
    }
    cells = (size_t)dims[0] * dims[1] * dims[2];
    n = malloc(cells * sizeof *n);
    ng = malloc(4 * cells * sizeof *ng);
    line = malloc(sizeof(float) * (size_t)(dims[0] + dims[1] + dims[2]));
    tmp = malloc(sizeof(float) * (size_t)(dims[0] + dims[1] + dims[2]));
    if (!n || !ng || !line || !tmp) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "refraction: no memory for a %dx%dx%d grid", dims[0], dims[1], dims[2]);
        goto done;
    }
    /* n per cell: the mean over k^3 samples, the voxels lo + k x + (0..k-1) of the index
     * grid (voxel values sit at integer index coordinates) */
    for (z = 0, c = 0; z < dims[2]; z++)
        for (y = 0; y < dims[1]; y++)
            for (x = 0; x < dims[0]; x++, c++) {
                int32_t i, j, l, bad = 0;
                float sum = 0.0f;
                for (l = 0; l < k; l++)
                    for (j = 0; j < k; j++)
                        for (i = 0; i < k; i++) {
                            vsd_f3 p = f3((float)(lo[0] + (double)x * k + i), (float)(lo[1] + (double)y * k + j),
                                          (float)(lo[2] + (double)z * k + l));
                            sum += n_of(mode, vsd_kvolume_field(box, p), ior, &bad);
                            if (bad) {
                                st = vsd_fail(VSD_ERR_INVALID, err, errlen,
                                              "volume.ior_grid '%s': n = %g below 1 at index (%d, %d, %d); n >= 1 "
                                              "(0 = background)", name ? name : "", (double)vsd_kvolume_field(box, p),
                                              (int)p.x, (int)p.y, (int)p.z);
                                goto done;
                            }
                        }
                /* the constant's occupancy, or the mean n of the grid's samples */
                n[c] = sum / (float)(k * k * k);
            }
    for (a = 0; a < 3; a++) blur_axis(n, dims, a, smooth, line, tmp);
    /* world -> grid: cell x's samples are centred on index lo + k x + (k - 1) / 2, which
     * must land on grid x + 0.5: grid = (index - lo) / k + 0.5 - (k - 1) / (2k) */
    for (a = 0; a < 3; a++) {
        int q;
        for (q = 0; q < 4; q++) out->k.world_to_grid.m[4 * a + q] = box->world_to_index.m[4 * a + q] / (float)k;
        out->k.world_to_grid.m[4 * a + 3] += (float)(-lo[a] / k + 0.5 - (k - 1) / (2.0 * k));
    }
    /* the world length of a grid step along each axis: 1 / |row a of the linear part|
     * would be the spacing of the planes; the step is half the smallest */
    for (a = 0; a < 3; a++) {
        const float *m = out->k.world_to_grid.m + 4 * a;
        float len = sqrtf(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        if (len > 0.0f && 1.0f / len < cell_world) cell_world = 1.0f / len;
    }
    out->n_max = 1.0f;
    for (z = 0, c = 0; z < dims[2]; z++)
        for (y = 0; y < dims[1]; y++)
            for (x = 0; x < dims[0]; x++, c++) {
                float gg[3];
                const float *m = out->k.world_to_grid.m;
                int32_t p[3] = {x, y, z};
                for (a = 0; a < 3; a++) {
                    size_t s = a == 0 ? 1 : a == 1 ? (size_t)dims[0] : (size_t)dims[0] * dims[1];
                    float up = p[a] + 1 < dims[a] ? n[c + s] : 1.0f, dn = p[a] > 0 ? n[c - s] : 1.0f;
                    gg[a] = 0.5f * (up - dn);   /* per grid unit */
                }
                ng[4 * c] = n[c];
                /* d n / d world_j = sum_a d n / d grid_a * d grid_a / d world_j */
                for (a = 0; a < 3; a++) ng[4 * c + 1 + a] = gg[0] * m[a] + gg[1] * m[4 + a] + gg[2] * m[8 + a];
                if (n[c] > out->n_max) out->n_max = n[c];
            }
    memcpy(out->k.dims, dims, sizeof dims);
    out->k.ng = ng;
    ng = NULL;
    out->k.step = 0.5f * cell_world;
    /* generous: a ray crossing the grid's diagonal 8 times */
    out->k.max_steps = (int32_t)(16.0f * sqrtf((float)dims[0] * dims[0] + (float)dims[1] * dims[1] + (float)dims[2] * dims[2]));
done:
    free(n);
    free(ng);
    free(line);
    free(tmp);
    return st;
}

vsd_status vsd_refraction_for_frame(const vsd_frame_ctx *ctx, vsd_refraction_field *out, char *err, size_t errlen)
{
    const vsd_scene *sc = ctx->scene;
    /* a part's context stands its volume as volume 0 and never refracts (method_parts.c) */
    const int i = ctx->part.active ? -1 : vsd_scene_refracting_volume(sc);
    const vsd_scene_volume *sv = i >= 0 ? &sc->volumes[i] : NULL;
    const char *name = sv ? vsd_scene_ior_grid(sv) : "";
    const vsd_kvolume *density = i >= 0 ? vsd_kvolumes_density(&ctx->kd, i) : NULL;
    const vsd_volume *grid = i >= 0 ? ctx->volume_ior[i] : NULL;
    vsd_kvolume src;
    vsd_status st;
    memset(out, 0, sizeof *out);
    if (!sv) return VSD_OK;
    if (!name[0])
        return vsd_refraction_build(density, NULL, NULL, VSD_IOR_CONSTANT, sv->medium.ior, 1.0f, 128, out, err, errlen);
    if (sv->medium.ior != 1.0f)
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "medium.ior (%g) and the grid '%s' (volume.ior_grid / medium.ior_from) both give the refractive "
                        "index: set one", (double)sv->medium.ior, name);
    if (!grid) return vsd_fail(VSD_ERR_INVALID, err, errlen, "the refractive index's grid '%s' is not loaded", name);
    if ((st = vsd_kvolume_setup(&src, grid, sv->matrix, 1.0f, err, errlen))) return st;
    return vsd_refraction_build(density, &src, name,
                                strcmp(sv->medium.ior_from, "temperature") == 0 ? VSD_IOR_TEMPERATURE : VSD_IOR_GRID, 1.0f,
                                1.0f, 128, out, err, errlen);
}
