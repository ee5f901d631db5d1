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
 * surrounding cell centres, renormalised over the non-empty ones, either in radiance or in
 * log radiance (a weighted geometric mean). The log form is an extension: in-scattered
 * radiance falls about exponentially with depth into a lit surface, so a linear blend of
 * the cell-centre values (the chord of a convex curve) over-brightens the skin, which a
 * blend of logs does not.
 *
 * Extension beyond the paper (option `lights`, 0 = the paper's pure form): the map's
 * brightest texels (a sun, studio lamps, windows) are taken out of the SH projection and
 * stood for by K directional lights (a median cut of those texels only). Each record also
 * stores the exact transmittance T_k from its cell centre toward each light, and the view
 * pass adds sum_k phase(d . w_k) T_k E_k to the SH term, which then carries only the
 * smooth remainder of the map. A small source is the one thing a low-order SH cannot hold:
 * its product with the truncated T(w) is T's truncation error evaluated at one direction. */
#ifndef VSD_SHGRID_KERNEL_H
#define VSD_SHGRID_KERNEL_H
#include "kernel/kernel_types.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_camera.h"
#include "kernel/kernel_march.h"
#include "kernel/kernel_phase.h"
#include "src/sh/sh_kernel.h"

/* BAKED: the lighting stage's in-scattered RGB per record (isotropic phase: it does not
 * depend on the view direction), 3 floats per record, so a camera change redoes none of
 * the lighting and a view lookup reads 8 RGB triples. */
enum { VSD_SHGRID_SCALAR = 0, VSD_SHGRID_RGB = 1, VSD_SHGRID_BAKED = 2 };
enum { VSD_SHGRID_NEAREST = 0, VSD_SHGRID_TRILINEAR = 1, VSD_SHGRID_LOG_TRILINEAR = 2 };
enum { VSD_SHGRID_MAX_LIGHTS = 64 };

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
    const float *lights;          /* [light_count * 8] extracted lights: world dir xyz, 0, E rgb, 0 */
    const float *light_trans;     /* [record_count * light_count] T from each record toward each light */
    vsd_affine world_to_grid;
    int32_t res[3];
    int32_t order, n2, stride;    /* stride = n2 (scalar) or 3 n2 (RGB) */
    int32_t kind;                 /* VSD_SHGRID_SCALAR, _RGB or _BAKED */
    int32_t interp;
    int32_t dir_count;
    int32_t record_count;
    float record_step;            /* quadrature step of the record marches (world) */
    int32_t light_count;          /* 0..VSD_SHGRID_MAX_LIGHTS; 0 = the paper's pure SH form */
    float pad_[2];
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

/* Transmittance from record rec's position toward each extracted light, out[light_count]:
 * the same march as the record pass, K more directions. */
VSD_DEVICE void vsd_shgrid_light_record(const vsd_kshgrid *g, int32_t rec, float *out)
{
    vsd_kvolume kv = g->kd->density;
    const float *pp = g->record_pos + 4 * (size_t)rec;
    vsd_f3 p = f3(pp[0], pp[1], pp[2]);
    int32_t k;
    kv.step = g->record_step;
    for (k = 0; k < g->light_count; k++) {
        const float *l = g->lights + 8 * (size_t)k;
        out[k] = expf(-vsd_field_integral(&kv, p, f3(l[0], l[1], l[2]), 0.0f, VSD_INF, 0.5f));
    }
}

/* In-scattered radiance per unit sigma_s from record rec; w: per-ray SH weights (RGB
 * kind), ph: per-ray phase times irradiance of each extracted light (3 per light). */
VSD_DEVICE vsd_f3 vsd_shgrid_record_radiance(const vsd_kshgrid *g, int32_t rec, const float *w, const float *ph)
{
    const float *r = g->records + (size_t)rec * g->stride;
    float s[3] = {0.0f, 0.0f, 0.0f};
    int32_t i, c;
    if (g->kind == VSD_SHGRID_BAKED) return f3(r[0], r[1], r[2]);
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
    /* the truncated SH may ring below zero; the exact light term never does */
    for (c = 0; c < 3; c++) s[c] = fmaxf(s[c], 0.0f);
    if (g->light_count > 0) {
        const float *t = g->light_trans + (size_t)rec * g->light_count;
        for (i = 0; i < g->light_count; i++)
            for (c = 0; c < 3; c++) s[c] += t[i] * ph[3 * i + c];
    }
    return f3(s[0], s[1], s[2]);
}

/* In-scattered radiance at world point p: nearest cell, or trilinear between the records
 * at the eight surrounding cell centres (weights renormalised over non-empty cells). */
/* Below this, in-scattered radiance counts as zero in the log-trilinear mean (a record
 * whose SH term rings to zero must not force its neighbours to black). */
#define VSD_SHGRID_LOG_FLOOR 1e-12f

/* Per-ray cache of the eight corner values around the current sample (logs for the
 * log-trilinear lookup): the view step is a fraction of a cell, so consecutive samples
 * mostly share the same eight records and the SH dot products are done once per cell. */
typedef struct vsd_shgrid_corners {
    int32_t key[3];   /* i0, j0, k0 of the cached corners */
    int32_t filled;   /* 0 until the first lookup */
    int32_t valid;    /* bit a: corner a holds a record */
    vsd_f3 v[8];
} vsd_shgrid_corners;

/* A ray moving into a neighbouring cell shares 4 (or 2, or 1) corners with the last one:
 * those are copied, not recomputed (the same values, so the image does not change). */
VSD_DEVICE void vsd_shgrid_fill_corners(const vsd_kshgrid *g, int32_t i0, int32_t j0, int32_t k0, const float *w,
                                        const float *ph, vsd_shgrid_corners *c)
{
    int32_t a, logi = g->interp == VSD_SHGRID_LOG_TRILINEAR;
    int32_t di = i0 - c->key[0], dj = j0 - c->key[1], dk = k0 - c->key[2], had = c->filled, old_valid = c->valid;
    vsd_f3 old[8];
    for (a = 0; a < 8; a++) old[a] = c->v[a];
    c->key[0] = i0; c->key[1] = j0; c->key[2] = k0;
    c->filled = 1;
    c->valid = 0;
    for (a = 0; a < 8; a++) {
        int32_t ax = a & 1, ay = (a >> 1) & 1, az = (a >> 2) & 1;
        int32_t i = i0 + ax, j = j0 + ay, k = k0 + az, rec;
        int32_t ox = ax + di, oy = ay + dj, oz = az + dk;   /* this corner in the old cube */
        vsd_f3 v;
        if (had && ox >= 0 && ox <= 1 && oy >= 0 && oy <= 1 && oz >= 0 && oz <= 1) {
            int32_t b = ox | (oy << 1) | (oz << 2);
            c->v[a] = old[b];
            if (old_valid & (1 << b)) c->valid |= 1 << a;
            continue;
        }
        if (i < 0 || j < 0 || k < 0 || i >= g->res[0] || j >= g->res[1] || k >= g->res[2]) continue;
        rec = g->cell_record[((size_t)k * g->res[1] + j) * g->res[0] + i];
        if (rec < 0) continue;
        v = vsd_shgrid_record_radiance(g, rec, w, ph);
        if (logi) v = f3(logf(fmaxf(v.x, VSD_SHGRID_LOG_FLOOR)), logf(fmaxf(v.y, VSD_SHGRID_LOG_FLOOR)),
                         logf(fmaxf(v.z, VSD_SHGRID_LOG_FLOOR)));
        c->v[a] = v;
        c->valid |= 1 << a;
    }
}

VSD_DEVICE vsd_f3 vsd_shgrid_inscatter(const vsd_kshgrid *g, vsd_f3 p, const float *w, const float *ph,
                                       vsd_shgrid_corners *c)
{
    vsd_f3 q = vsd_affine_point(&g->world_to_grid, p);
    if (g->interp == VSD_SHGRID_NEAREST) {
        int32_t i = (int32_t)floorf(q.x), j = (int32_t)floorf(q.y), k = (int32_t)floorf(q.z), rec;
        if (i < 0 || j < 0 || k < 0 || i >= g->res[0] || j >= g->res[1] || k >= g->res[2]) return f3s(0.0f);
        rec = g->cell_record[((size_t)k * g->res[1] + j) * g->res[0] + i];
        return rec < 0 ? f3s(0.0f) : vsd_shgrid_record_radiance(g, rec, w, ph);
    } else {
        float fx = q.x - 0.5f, fy = q.y - 0.5f, fz = q.z - 0.5f;
        int32_t i0 = (int32_t)floorf(fx), j0 = (int32_t)floorf(fy), k0 = (int32_t)floorf(fz), a;
        float tx = fx - (float)i0, ty = fy - (float)j0, tz = fz - (float)k0, wsum = 0.0f;
        vsd_f3 s = f3s(0.0f);
        if (!c->filled || c->key[0] != i0 || c->key[1] != j0 || c->key[2] != k0)
            vsd_shgrid_fill_corners(g, i0, j0, k0, w, ph, c);
        for (a = 0; a < 8; a++) {
            float wt = ((a & 1) ? tx : 1.0f - tx) * (((a >> 1) & 1) ? ty : 1.0f - ty) * (((a >> 2) & 1) ? tz : 1.0f - tz);
            if (!(c->valid & (1 << a)) || wt <= 0.0f) continue;
            s = f3_add(s, f3_scale(c->v[a], wt));
            wsum += wt;
        }
        if (!(wsum > 0.0f)) return f3s(0.0f);
        s = f3_scale(s, 1.0f / wsum);
        /* log-trilinear: the weighted geometric mean, exact where S falls exponentially */
        return g->interp == VSD_SHGRID_LOG_TRILINEAR ? f3(expf(s.x), expf(s.y), expf(s.z)) : s;
    }
}

/* One view ray through pixel (px, py) at sub-pixel (jx, jy): the raymarch baseline's march
 * (raymarch_kernel.h) with the SH lookup in place of the shadow rays. */
VSD_DEVICE vsd_sample_result vsd_shgrid_pixel(const vsd_kshgrid *g, int32_t px, int32_t py, float jx, float jy)
{
    const vsd_kernel_data *kd = g->kd;
    vsd_march_acc acc;
    vsd_f3 o, d;
    float t0 = 0.0f, t1 = 0.0f;
    float w[VSD_SH_MAX_COEFFS], ph[3 * VSD_SHGRID_MAX_LIGHTS];
    vsd_shgrid_corners corners;
    int32_t k;
    corners.filled = 0;
    corners.valid = 0;
    corners.key[0] = corners.key[1] = corners.key[2] = 0;
    vsd_march_begin(&acc);
    vsd_camera_ray(&kd->camera, px, py, jx, jy, &o, &d);
    /* the lights are directional and d is fixed along the ray: phase * E once per ray */
    for (k = 0; k < g->light_count; k++) {
        const float *l = g->lights + 8 * (size_t)k;
        float pk = vsd_hg_eval(f3_dot(d, f3(l[0], l[1], l[2])), kd->medium.anisotropy);
        ph[3 * k] = pk * l[4]; ph[3 * k + 1] = pk * l[5]; ph[3 * k + 2] = pk * l[6];
    }
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
        vsd_march_walk walk;
        float tm, hs;
        vsd_march_walk_begin(&walk, kd, o, d, t0, t1);
        while (vsd_march_walk_next(&walk, kd, acc.tr, &tm, &hs)) {
            vsd_f3 p = f3_madd(o, d, tm);
            /* §4.5: emission accumulates along the same march */
            float absorbed = vsd_march_medium(kd, &acc, p, hs);
            if (absorbed > 0.0f) vsd_march_scatter(kd, &acc, vsd_shgrid_inscatter(g, p, w, ph, &corners), tm, absorbed);
        }
    }
    return vsd_march_finish(kd, &acc, d);
}

#endif
