/* kernel_record_grid.h — a grid of lighting records and the view pass that reads it, shared
 * by every method that caches its lighting (shgrid: Delalandre et al. 2013's record grid;
 * constellation with shadows = "grid": the transmittance toward each light, cached per
 * lighting change). CPU and CUDA run these same functions.
 *
 * Records sit at the centres of the non-empty cells of a grid over the density's box
 * (src/grids/record_grid.h builds it). A record holds what the view pass needs to get
 * the in-scattered radiance per unit sigma_s at its centre, by kind:
 *   SH_SCALAR  SH of the transmittance T(w) (n^2 floats); S = (1/4pi) sum_i R_i L_i with
 *              the environment's SH (isotropic phase)
 *   SH_RGB     SH of T(w) L(w) per channel (3 n^2); S = sum_i w_i R_ci with per-ray weights
 *              w_i = g^l y_i(d): the HG convolution toward the viewer
 *   BAKED      S itself, RGB (isotropic phase: it does not depend on the view direction), so
 *              a camera change reads 8 RGB triples and redoes none of the lighting
 *   LIGHTS     nothing but the directional lights' term below
 * plus, with light_count > 0, the transmittance T_k toward each directional light, whose
 * term sum_k phase(d . w_k) T_k E_k is added (phase times E per ray: d is fixed along it),
 * and optionally (records_ms) each record's multiply-scattered in-scattered radiance per
 * unit sigma_s, RGB, isotropic (lbl's diffused light): it goes to VolumeInd, trilinear.
 *
 * The view pass marches the ray with the shared march (kernel_march.h) and looks the
 * records up at the nearest cell (Delalandre's paper) or trilinearly between the eight
 * surrounding cell centres, renormalised over the non-empty ones, either in radiance or in
 * log radiance (a weighted geometric mean: in-scattered radiance falls about
 * exponentially with depth into a lit surface, so a linear blend of the cell-centre values
 * — the chord of a convex curve — over-brightens the skin, which a blend of logs does not). */
#ifndef VSD_KERNEL_RECORD_GRID_H
#define VSD_KERNEL_RECORD_GRID_H
#include "kernel_types.h"
#include "kernel_volume.h"
#include "kernel_env.h"
#include "kernel_camera.h"
#include "kernel_march.h"
#include "kernel_phase.h"
#include "kernel_lights.h"
#include "kernel_sh.h"
#include "device/device_pass.h"

enum { VSD_RECORDS_SH_SCALAR = 0, VSD_RECORDS_SH_RGB = 1, VSD_RECORDS_BAKED = 2, VSD_RECORDS_LIGHTS = 3 };
enum { VSD_RECORDS_NEAREST = 0, VSD_RECORDS_TRILINEAR = 1, VSD_RECORDS_LOG_TRILINEAR = 2 };
enum { VSD_RECORDS_MAX_LIGHTS = 64 };
/* The per-ray weights (vsd_records_light_weights): 3 x VSD_RECORDS_MAX_LIGHTS, then the
 * ray's direction and g at VSD_RECORDS_PH_DIR (what the local lights' phase needs). */
enum { VSD_RECORDS_PH_DIR = 3 * VSD_RECORDS_MAX_LIGHTS, VSD_RECORDS_PH_FLOATS = 3 * VSD_RECORDS_MAX_LIGHTS + 4 };

/* The record grid as kernels see it; kd is the scene's. Grid coordinates: cell (i,j,k) spans
 * [i, i+1) x ... ; g = world_to_grid(p). */
typedef struct VSD_ALIGN16 vsd_krecord_grid {
    const vsd_kernel_data *kd;
    const int32_t *cell_record;   /* [res x*y*z] record index, -1 for eliminated cells */
    const float *records;         /* [record_count * stride] coefficients */
    const float *record_pos;      /* [record_count * 4] world position of each record */
    const float *dirs;            /* [dir_count * 4] HEALPix directions (xyz, 0) */
    const float *basis;           /* [dir_count * n2] y_i(w_j) * 4pi / M */
    const float *dir_radiance;    /* [dir_count * 4] env averaged per HEALPix pixel (product form) */
    const float *light;           /* [3 * n2] environment SH (factored form) */
    /* [(light_count + sub_count) * 8] directional lights: world dir xyz, 0, E rgb, 0; then,
     * with sub_count > 0, sub-lights whose 8th float is the light they belong to: the phase
     * is weighed over the sub-lights' directions, the shadow (light_trans) stays the light's */
    const float *lights;
    const float *light_trans;     /* [record_count * light_count] T from each record toward each light */
    const float *records_ms;      /* [record_count * 3] multiple scattering (VolumeInd), or NULL */
    /* [record_count * 3] or NULL: light that scattered once and is isotropic there — lbl's
     * emission scattered once, which Cycles counts as direct (VolumeDir); added linearly to
     * the in-scattered radiance the records give */
    const float *records_emission_once;
    /* [local_count * VSD_KLIGHT_FLOATS] the scene's point and spot lights (kernel_lights.h),
     * and [record_count * local_count] each one's transmittance to the record times its
     * falloff there (vsd_light_falloff): their term sum_k phase(d . w_k(x)) I_k t_k, with w_k
     * toward the light from the record's position (record_pos) */
    const float *local_lights;
    const float *local_trans;
    vsd_affine world_to_grid;
    int32_t res[3];
    int32_t order, n2, stride;    /* stride = n2 (scalar) or 3 n2 (RGB) */
    int32_t kind;                 /* VSD_RECORDS_SH_SCALAR, _SH_RGB, _BAKED or _LIGHTS */
    int32_t interp;
    int32_t dir_count;
    int32_t record_count;
    float record_step;            /* quadrature step of the record marches (world) */
    int32_t light_count;          /* 0..VSD_RECORDS_MAX_LIGHTS; 0 = the paper's pure SH form */
    int32_t local_count;          /* 0..VSD_MAX_LIGHTS */
    int32_t records_log;          /* BAKED with LOG_TRILINEAR: the records hold log radiance
                                     (vsd_record_grid_bake_view), so the corners take no logf */
    int32_t sub_count;            /* sub-lights after the lights (0 = none) */
    int32_t records_ms_per_view;  /* records_ms changes with the view (lbl's phase readout):
                                     the device copies it every render */
} vsd_krecord_grid;
VSD_STATIC_ASSERT(sizeof(vsd_krecord_grid) % 16 == 0, "vsd_krecord_grid must stay 16-byte aligned");

/* sum_i a[i] b[i] over n terms in four interleaved partial sums (lane i % 4), added
 * pairwise at the end: a fixed order the compiler can keep in one SIMD register (gcc's SLP
 * vectoriser does; a plain running sum it may not reorder), the same on CPU and CUDA. */
VSD_DEVICE float vsd_records_dot(const float *a, const float *b, int32_t n)
{
    float acc[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    int32_t i, l;
    for (i = 0; i + 4 <= n; i += 4)
        for (l = 0; l < 4; l++) acc[l] += a[i + l] * b[i + l];
    for (l = 0; i < n; i++, l++) acc[l] += a[i] * b[i];
    return (acc[0] + acc[1]) + (acc[2] + acc[3]);
}

/* Per-ray weights of the directional lights: ph[c * VSD_RECORDS_MAX_LIGHTS + k] = phase(d .
 * w_k) E_kc (planar, so the per-record sums are contiguous dot products). The lights are
 * directional and d is fixed along a ray, so this runs once per ray; an isotropic phase
 * (g = 0) makes it independent of d, which is what lets records be baked. d and g go to
 * ph[VSD_RECORDS_PH_DIR..] for the local lights. ph holds VSD_RECORDS_PH_FLOATS. */
VSD_DEVICE void vsd_records_light_weights(const float *lights, int32_t count, int32_t sub_count, vsd_f3 d, float g,
                                          float *ph)
{
    int32_t k;
    ph[VSD_RECORDS_PH_DIR] = d.x;
    ph[VSD_RECORDS_PH_DIR + 1] = d.y;
    ph[VSD_RECORDS_PH_DIR + 2] = d.z;
    ph[VSD_RECORDS_PH_DIR + 3] = g;
    if (sub_count > 0) {
        /* each light's weight summed over its sub-lights: a strongly forward phase (clouds,
         * g 0.7) varies across a light's region far more than its shadow does */
        for (k = 0; k < count; k++) ph[k] = ph[VSD_RECORDS_MAX_LIGHTS + k] = ph[2 * VSD_RECORDS_MAX_LIGHTS + k] = 0.0f;
        for (k = 0; k < sub_count; k++) {
            const float *l = lights + 8 * ((size_t)count + k);
            int32_t j = (int32_t)l[7];
            float pk = vsd_hg_eval(f3_dot(d, f3(l[0], l[1], l[2])), g);
            if (j < 0 || j >= count) continue;
            ph[j] += pk * l[4];
            ph[VSD_RECORDS_MAX_LIGHTS + j] += pk * l[5];
            ph[2 * VSD_RECORDS_MAX_LIGHTS + j] += pk * l[6];
        }
        return;
    }
    for (k = 0; k < count; k++) {
        const float *l = lights + 8 * (size_t)k;
        float pk = vsd_hg_eval(f3_dot(d, f3(l[0], l[1], l[2])), g);
        ph[k] = pk * l[4];
        ph[VSD_RECORDS_MAX_LIGHTS + k] = pk * l[5];
        ph[2 * VSD_RECORDS_MAX_LIGHTS + k] = pk * l[6];
    }
}

/* The RGB kind's SH weights toward a viewer looking along d: the records' T L convolved
 * with HG(g) and evaluated at d, out(d) = sum_lm g^l f_lm y_lm(d). Per ray in the view
 * below, per record and view in the CPU's bake (record_grid.c). */
VSD_DEVICE void vsd_records_sh_view_weights(int32_t order, float g, vsd_f3 d, float *w)
{
    float gl = 1.0f;
    int32_t l, m;
    vsd_sh_eval_f(order, d, w);
    for (l = 0; l < order; l++) {
        for (m = -l; m <= l; m++) w[l * (l + 1) + m] *= gl;
        gl *= g;
    }
}

/* In-scattered radiance per unit sigma_s from record rec; w: per-ray SH weights (RGB
 * kind, vsd_records_sh_view_weights), ph: the lights' per-ray weights
 * (vsd_records_light_weights). */
VSD_DEVICE vsd_f3 vsd_records_radiance(const vsd_krecord_grid *g, int32_t rec, const float *w, const float *ph)
{
    const float *r = g->kind == VSD_RECORDS_LIGHTS ? 0 : g->records + (size_t)rec * g->stride;
    float s[3] = {0.0f, 0.0f, 0.0f};
    int32_t c;
    if (g->kind == VSD_RECORDS_BAKED) return f3(r[0], r[1], r[2]);
    if (g->kind == VSD_RECORDS_LIGHTS) {
        /* no SH term: the lights' term below is all */
    } else if (g->kind == VSD_RECORDS_SH_SCALAR) {
        for (c = 0; c < 3; c++) s[c] = vsd_records_dot(r, g->light + c * g->n2, g->n2) * (1.0f / (4.0f * VSD_PI));
    } else {
        for (c = 0; c < 3; c++) s[c] = vsd_records_dot(w, r + c * g->n2, g->n2);
    }
    /* the truncated SH may ring below zero; the exact light term never does */
    for (c = 0; c < 3; c++) s[c] = fmaxf(s[c], 0.0f);
    if (g->light_count > 0) {
        const float *t = g->light_trans + (size_t)rec * g->light_count;
        for (c = 0; c < 3; c++) s[c] += vsd_records_dot(t, ph + c * VSD_RECORDS_MAX_LIGHTS, g->light_count);
    }
    if (g->local_count > 0) {
        const float *t = g->local_trans + (size_t)rec * g->local_count, *x = g->record_pos + 4 * (size_t)rec;
        vsd_f3 d = f3(ph[VSD_RECORDS_PH_DIR], ph[VSD_RECORDS_PH_DIR + 1], ph[VSD_RECORDS_PH_DIR + 2]);
        int32_t k;
        for (k = 0; k < g->local_count; k++) {
            const float *l = g->local_lights + (size_t)VSD_KLIGHT_FLOATS * k;
            float f;
            if (!(t[k] > 0.0f)) continue;
            f = vsd_hg_eval(f3_dot(d, f3_normalize(f3(l[0] - x[0], l[1] - x[1], l[2] - x[2]))),
                            ph[VSD_RECORDS_PH_DIR + 3]) * t[k];
            for (c = 0; c < 3; c++) s[c] += f * l[4 + c];
        }
    }
    return f3(s[0], s[1], s[2]);
}

/* Below this, in-scattered radiance counts as zero in the log-trilinear mean (a record
 * whose SH term rings to zero must not force its neighbours to black). */
#define VSD_RECORDS_LOG_FLOOR 1e-12f

/* Per-ray cache of the eight corner values around the current sample (logs for the
 * log-trilinear lookup): the view step is a fraction of a cell, so consecutive samples
 * mostly share the same eight records and the SH dot products are done once per cell. */
typedef struct vsd_records_corners {
    int32_t key[3];   /* i0, j0, k0 of the cached corners */
    int32_t filled;   /* 0 until the first lookup */
    int32_t valid;    /* bit a: corner a holds a record */
    vsd_f3 v[8];
    vsd_f3 m[8];      /* records_ms at the corners (linear values) */
    vsd_f3 e[8];      /* records_emission_once at the corners (linear values) */
} vsd_records_corners;

/* A ray moving into a neighbouring cell shares 4 (or 2, or 1) corners with the last one:
 * those are copied, not recomputed (the same values, so the image does not change). */
VSD_DEVICE void vsd_records_fill_corners(const vsd_krecord_grid *g, int32_t i0, int32_t j0, int32_t k0, const float *w,
                                        const float *ph, vsd_records_corners *c)
{
    int32_t a, logi = g->interp == VSD_RECORDS_LOG_TRILINEAR;
    int32_t di = i0 - c->key[0], dj = j0 - c->key[1], dk = k0 - c->key[2], had = c->filled, old_valid = c->valid;
    vsd_f3 old[8], old_m[8], old_e[8];
    for (a = 0; a < 8; a++) {
        old[a] = c->v[a];
        old_m[a] = c->m[a];
        old_e[a] = c->e[a];
    }
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
            c->m[a] = old_m[b];
            c->e[a] = old_e[b];
            if (old_valid & (1 << b)) c->valid |= 1 << a;
            continue;
        }
        if (i < 0 || j < 0 || k < 0 || i >= g->res[0] || j >= g->res[1] || k >= g->res[2]) continue;
        rec = g->cell_record[((size_t)k * g->res[1] + j) * g->res[0] + i];
        if (rec < 0) continue;
        v = vsd_records_radiance(g, rec, w, ph);
        if (logi && !g->records_log) v = f3(logf(fmaxf(v.x, VSD_RECORDS_LOG_FLOOR)), logf(fmaxf(v.y, VSD_RECORDS_LOG_FLOOR)),
                         logf(fmaxf(v.z, VSD_RECORDS_LOG_FLOOR)));
        c->v[a] = v;
        if (g->records_ms) {
            const float *m = g->records_ms + 3 * (size_t)rec;
            c->m[a] = f3(m[0], m[1], m[2]);
        }
        if (g->records_emission_once) {
            const float *e = g->records_emission_once + 3 * (size_t)rec;
            c->e[a] = f3(e[0], e[1], e[2]);
        }
        c->valid |= 1 << a;
    }
}

/* In-scattered radiance at world point p: nearest cell, or trilinear between the records
 * at the eight surrounding cell centres (weights renormalised over non-empty cells); *ms
 * gets the records_ms term the same way (linearly), or 0 without it; records_emission_once, when
 * present, is added to the returned radiance the same way (linearly). */
VSD_DEVICE vsd_f3 vsd_records_inscatter(const vsd_krecord_grid *g, vsd_f3 p, const float *w, const float *ph,
                                       vsd_records_corners *c, vsd_f3 *ms)
{
    vsd_f3 q = vsd_affine_point(&g->world_to_grid, p);
    *ms = f3s(0.0f);
    if (g->interp == VSD_RECORDS_NEAREST) {
        int32_t i = (int32_t)floorf(q.x), j = (int32_t)floorf(q.y), k = (int32_t)floorf(q.z), rec;
        if (i < 0 || j < 0 || k < 0 || i >= g->res[0] || j >= g->res[1] || k >= g->res[2]) return f3s(0.0f);
        rec = g->cell_record[((size_t)k * g->res[1] + j) * g->res[0] + i];
        if (rec < 0) return f3s(0.0f);
        if (g->records_ms) *ms = f3(g->records_ms[3 * rec], g->records_ms[3 * rec + 1], g->records_ms[3 * rec + 2]);
        if (g->records_emission_once)
            return f3_add(vsd_records_radiance(g, rec, w, ph),
                          f3(g->records_emission_once[3 * rec], g->records_emission_once[3 * rec + 1], g->records_emission_once[3 * rec + 2]));
        return vsd_records_radiance(g, rec, w, ph);
    } else {
        float fx = q.x - 0.5f, fy = q.y - 0.5f, fz = q.z - 0.5f;
        int32_t i0 = (int32_t)floorf(fx), j0 = (int32_t)floorf(fy), k0 = (int32_t)floorf(fz), a;
        float tx = fx - (float)i0, ty = fy - (float)j0, tz = fz - (float)k0, wsum = 0.0f;
        vsd_f3 s = f3s(0.0f), m = f3s(0.0f), e = f3s(0.0f);
        if (!c->filled || c->key[0] != i0 || c->key[1] != j0 || c->key[2] != k0)
            vsd_records_fill_corners(g, i0, j0, k0, w, ph, c);
        if (c->valid == 0xff) {
            /* inside the medium every corner holds a record and the weights sum to one: seven
               lerps a term instead of eight weights, their sum and a division (the view
               march's largest cost, docs/methods/lbl.md) */
            s = f3_trilerp(c->v, tx, ty, tz);
            if (g->records_ms) *ms = f3_trilerp(c->m, tx, ty, tz);
            if (g->interp == VSD_RECORDS_LOG_TRILINEAR) s = f3(expf(s.x), expf(s.y), expf(s.z));
            return g->records_emission_once ? f3_add(s, f3_trilerp(c->e, tx, ty, tz)) : s;
        }
        for (a = 0; a < 8; a++) {
            float wt = ((a & 1) ? tx : 1.0f - tx) * (((a >> 1) & 1) ? ty : 1.0f - ty) * (((a >> 2) & 1) ? tz : 1.0f - tz);
            if (!(c->valid & (1 << a)) || wt <= 0.0f) continue;
            s = f3_add(s, f3_scale(c->v[a], wt));
            if (g->records_ms) m = f3_add(m, f3_scale(c->m[a], wt));
            if (g->records_emission_once) e = f3_add(e, f3_scale(c->e[a], wt));
            wsum += wt;
        }
        if (!(wsum > 0.0f)) return f3s(0.0f);
        s = f3_scale(s, 1.0f / wsum);
        if (g->records_ms) *ms = f3_scale(m, 1.0f / wsum);
        /* log-trilinear: the weighted geometric mean, exact where S falls exponentially */
        if (g->interp == VSD_RECORDS_LOG_TRILINEAR) s = f3(expf(s.x), expf(s.y), expf(s.z));
        return g->records_emission_once ? f3_add(s, f3_scale(e, 1.0f / wsum)) : s;
    }
}

/* One view ray through pixel (px, py) at sub-pixel (jx, jy): the shared march
 * (kernel_march.h) with the record lookup in place of shadow rays. */
VSD_DEVICE vsd_sample_result vsd_records_pixel(const vsd_krecord_grid *g, int32_t px, int32_t py, float jx, float jy)
{
    const vsd_kernel_data *kd = g->kd;
    vsd_march_acc acc;
    vsd_f3 o, d;
    float t0 = 0.0f, t1 = 0.0f;
    float w[VSD_SH_MAX_COEFFS], ph[VSD_RECORDS_PH_FLOATS];
    vsd_records_corners corners;
    corners.filled = 0;
    corners.valid = 0;
    corners.key[0] = corners.key[1] = corners.key[2] = 0;
    vsd_march_begin(&acc);
    vsd_camera_ray(&kd->camera, px, py, jx, jy, &o, &d);
    vsd_records_light_weights(g->lights, g->light_count, g->sub_count, d, kd->medium.anisotropy, ph);
    if (g->kind == VSD_RECORDS_SH_RGB) vsd_records_sh_view_weights(g->order, kd->medium.anisotropy, d, w);
    if (vsd_march_extent(kd, o, d, &t0, &t1)) {
        vsd_march_walk walk;
        float tm, hs;
        vsd_march_walk_begin(&walk, kd, o, d, t0, t1);
        while (vsd_march_walk_next(&walk, kd, acc.tr, &tm, &hs)) {
            vsd_f3 p = f3_madd(o, d, tm);
            /* §4.5: emission accumulates along the same march */
            float absorbed = vsd_march_medium(kd, &acc, p, hs);
            if (absorbed > 0.0f) {
                vsd_f3 ms, ss = vsd_records_inscatter(g, p, w, ph, &corners, &ms);
                if (g->records_ms)
                    vsd_march_source(&acc, f3_mul(kd->medium.albedo, ss), f3_mul(kd->medium.albedo, ms), tm, absorbed,
                                     absorbed);
                else
                    vsd_march_scatter(kd, &acc, ss, tm, absorbed);
            }
        }
    }
    return vsd_march_finish(kd, &acc, d);
}

/* Stratum s of the n x n strata of pixel (x, y) (device/device_pass.h). */
VSD_STRATIFIED_SAMPLE(vsd_records_pass_sample, vsd_krecord_grid, vsd_records_pixel)

#endif
