/* shgrid_kernel.h — Delalandre et al. 2013 (../shared/papers/003_…txt): single scattering
 * from a coarse grid of reduced-intensity records, shared by the CPU backend (shgrid.c)
 * and CUDA (device/cuda/shgrid_kernels.cu).
 *
 * Record pass (§4.2), one record per non-empty cell: from the cell centre, march toward
 * each of M HEALPix directions to the volume's box, T_j = exp(-optical depth), and project
 * into SH with equal weights 4pi/M:
 *   factored form (§4.2-4.3, isotropic): R_i = sum_j T_j y_i(w_j) 4pi/M   (volume only)
 *   product form (§4.4, static media):   R_ci = sum_j T_j L_c(w_j) y_i(w_j) 4pi/M  (RGB)
 * where L_c(w_j) is the environment averaged over HEALPix pixel j (not point-sampled, so a
 * small bright sun is neither missed nor over-weighted).
 *
 * View pass (§4.3): march the view ray like the raymarch baseline (same quadrature, so the
 * two differ only in how in-scattering is computed); at each sample the in-scattered
 * radiance per unit sigma_s is a dot product:
 *   factored: S_c = (1/4pi) sum_i R_i L_ci               (isotropic phase)
 *   RGB records (TL, from the product form or the triple product): S_c = sum_i w_i R_ci,
 *     w_i = g^l y_i(d) — the HG convolution evaluated toward the viewer; per ray, since d
 *     is fixed along it.
 * Records are looked up at the nearest cell (the paper) or trilinearly between the eight
 * surrounding cell centres, renormalised over the non-empty ones. */
#ifndef VSD_SHGRID_KERNEL_H
#define VSD_SHGRID_KERNEL_H
#include "kernel/kernel_types.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_camera.h"
#include "kernel/kernel_march.h"
#include "src/sh/sh_kernel.h"

enum { VSD_SHGRID_SCALAR = 0, VSD_SHGRID_RGB = 1 };
enum { VSD_SHGRID_NEAREST = 0, VSD_SHGRID_TRILINEAR = 1 };

/* The method's own kernel data; kd is the scene's. Grid coordinates: cell (i,j,k) spans
 * [i, i+1) x ... ; g = world_to_grid(p). */
typedef struct VSD_ALIGN16 vsd_kshgrid {
    const vsd_kernel_data *kd;
    const int32_t *cell_record;   /* [res x*y*z] record index, -1 for eliminated cells */
    const float *records;         /* [record_count * stride] coefficients */
    const float *record_pos;      /* [record_count * 4] world position of each record */
    const float *dirs;            /* [dir_count * 4] HEALPix directions (xyz, 0) */
    const float *basis;           /* [dir_count * n2] y_i(w_j) * 4pi / M */
    const float *dir_radiance;    /* [dir_count * 4] env averaged per HEALPix pixel (product form) */
    const float *light;           /* [3 * n2] environment SH (factored form) */
    vsd_affine world_to_grid;
    int32_t res[3];
    int32_t order, n2, stride;    /* stride = n2 (scalar) or 3 n2 (RGB) */
    int32_t kind;                 /* VSD_SHGRID_SCALAR or VSD_SHGRID_RGB */
    int32_t interp;
    int32_t dir_count;
    int32_t record_count;
    float record_step;            /* quadrature step of the record marches (world) */
    float pad_[3];
} vsd_kshgrid;

/* Reduced-intensity record of one cell (the record pass), written to out[stride]. */
VSD_DEVICE void vsd_shgrid_record(const vsd_kshgrid *g, int32_t rec, float *out)
{
    vsd_kvolume kv = g->kd->density;
    const float *pp = g->record_pos + 4 * (size_t)rec;
    vsd_f3 p = f3(pp[0], pp[1], pp[2]);
    int32_t j, i, c;
    kv.step = g->record_step;
    for (i = 0; i < g->stride; i++) out[i] = 0.0f;
    for (j = 0; j < g->dir_count; j++) {
        const float *dj = g->dirs + 4 * (size_t)j;
        const float *yj = g->basis + (size_t)j * g->n2;
        float tr = expf(-vsd_field_integral(&kv, p, f3(dj[0], dj[1], dj[2]), 0.0f, VSD_INF, 0.5f));
        if (g->kind == VSD_SHGRID_SCALAR) {
            for (i = 0; i < g->n2; i++) out[i] += tr * yj[i];
        } else {
            const float *lj = g->dir_radiance + 4 * (size_t)j;
            for (c = 0; c < 3; c++) {
                float v = tr * lj[c];
                for (i = 0; i < g->n2; i++) out[c * g->n2 + i] += v * yj[i];
            }
        }
    }
}

/* In-scattered radiance per unit sigma_s from record rec; w: per-ray weights (RGB kind). */
VSD_DEVICE vsd_f3 vsd_shgrid_record_radiance(const vsd_kshgrid *g, int32_t rec, const float *w)
{
    const float *r = g->records + (size_t)rec * g->stride;
    float s[3] = {0.0f, 0.0f, 0.0f};
    int32_t i, c;
    if (g->kind == VSD_SHGRID_SCALAR) {
        for (c = 0; c < 3; c++) {
            const float *l = g->light + c * g->n2;
            for (i = 0; i < g->n2; i++) s[c] += r[i] * l[i];
            s[c] *= 1.0f / (4.0f * VSD_PI);
        }
    } else {
        for (c = 0; c < 3; c++)
            for (i = 0; i < g->n2; i++) s[c] += w[i] * r[c * g->n2 + i];
    }
    return f3(fmaxf(s[0], 0.0f), fmaxf(s[1], 0.0f), fmaxf(s[2], 0.0f));
}

/* In-scattered radiance at world point p: nearest cell, or trilinear between the records
 * at the eight surrounding cell centres (weights renormalised over non-empty cells). */
VSD_DEVICE vsd_f3 vsd_shgrid_inscatter(const vsd_kshgrid *g, vsd_f3 p, const float *w)
{
    vsd_f3 q = vsd_affine_point(&g->world_to_grid, p);
    if (g->interp == VSD_SHGRID_NEAREST) {
        int32_t i = (int32_t)floorf(q.x), j = (int32_t)floorf(q.y), k = (int32_t)floorf(q.z), rec;
        if (i < 0 || j < 0 || k < 0 || i >= g->res[0] || j >= g->res[1] || k >= g->res[2]) return f3s(0.0f);
        rec = g->cell_record[((size_t)k * g->res[1] + j) * g->res[0] + i];
        return rec < 0 ? f3s(0.0f) : vsd_shgrid_record_radiance(g, rec, w);
    } else {
        float fx = q.x - 0.5f, fy = q.y - 0.5f, fz = q.z - 0.5f;
        int32_t i0 = (int32_t)floorf(fx), j0 = (int32_t)floorf(fy), k0 = (int32_t)floorf(fz), a;
        float tx = fx - (float)i0, ty = fy - (float)j0, tz = fz - (float)k0, wsum = 0.0f;
        vsd_f3 s = f3s(0.0f);
        for (a = 0; a < 8; a++) {
            int32_t i = i0 + (a & 1), j = j0 + ((a >> 1) & 1), k = k0 + ((a >> 2) & 1), rec;
            float wt = ((a & 1) ? tx : 1.0f - tx) * (((a >> 1) & 1) ? ty : 1.0f - ty) * (((a >> 2) & 1) ? tz : 1.0f - tz);
            if (wt <= 0.0f || i < 0 || j < 0 || k < 0 || i >= g->res[0] || j >= g->res[1] || k >= g->res[2]) continue;
            rec = g->cell_record[((size_t)k * g->res[1] + j) * g->res[0] + i];
            if (rec < 0) continue;
            s = f3_add(s, f3_scale(vsd_shgrid_record_radiance(g, rec, w), wt));
            wsum += wt;
        }
        return wsum > 0.0f ? f3_scale(s, 1.0f / wsum) : s;
    }
}

/* One view ray through pixel (px, py) at sub-pixel (jx, jy): the raymarch baseline's march
 * (raymarch_kernel.h) with the SH lookup in place of the shadow rays. */
VSD_DEVICE vsd_sample_result vsd_shgrid_pixel(const vsd_kshgrid *g, int32_t px, int32_t py, float jx, float jy)
{
    const vsd_kernel_data *kd = g->kd;
    vsd_march_acc acc;
    vsd_f3 o, d;
    float t0 = 0.0f, t1 = 0.0f, t, h = kd->march_step;
    float w[VSD_SH_MAX_COEFFS];
    vsd_march_begin(&acc);
    vsd_camera_ray(&kd->camera, px, py, jx, jy, &o, &d);
    if (g->kind == VSD_SHGRID_RGB) {
        /* convolution with HG toward the viewer: out(d) = sum_lm g^l f_lm y_lm(d) */
        float gl = 1.0f;
        int32_t l, m;
        vsd_sh_eval_f(g->order, d, w);
        for (l = 0; l < g->order; l++) {
            for (m = -l; m <= l; m++) w[l * (l + 1) + m] *= gl;
            gl *= kd->medium.anisotropy;
        }
    }
    if (vsd_march_extent(kd, o, d, &t0, &t1)) {
        for (t = t0; t < t1; t += h) {
            float hs = vsd_minf(h, t1 - t), tm = t + 0.5f * hs;
            vsd_f3 p = f3_madd(o, d, tm);
            /* §4.5: emission accumulates along the same march */
            float absorbed = vsd_march_medium(kd, &acc, p, hs);
            if (absorbed > 0.0f) vsd_march_scatter(kd, &acc, vsd_shgrid_inscatter(g, p, w), tm, absorbed);
        }
    }
    return vsd_march_finish(kd, &acc, d);
}

#endif
