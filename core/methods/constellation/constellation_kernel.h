/* constellation_kernel.h — Navarro, Gutierrez & Serón 2009: single scattering with
 * self-shadowing from a light constellation, accelerated by a distance map (§4.1) and a
 * validity mask (§4.2), sampling on spherical shells about the eye (§4.2).
 *
 * Shells: view sample i sits at t = i * slice along the unit view ray (for an
 * orthographic camera t is measured from the ray's origin on the image plane, so shells
 * become planes). iNear = ceil(t0 / slice), iFar = floor(t1 / slice) over the union of the
 * density and emission boxes. Each sample stands for a segment of length `slice` of
 * constant medium (eq. 4-5 in the stable form of kernel/kernel_march.h):
 * direct += T * albedo * (1 - exp(-sigma slice)) * sum_n phase * L_n * T_shadow,n.
 * Shadow rays sample t = ta + (k + 1/2) * shadow_step to the density box's exit.
 *
 * Exactness of the accelerations: every sample position is computed from its integer
 * index, never by accumulation, and a sample whose medium is exactly 0 changes nothing
 * (it adds +0 and multiplies T by 1). The distance map only leaps over samples inside
 * balls where the field is <= threshold, and the mask only skips shells before the first
 * sample with |field| > threshold, so with threshold 0 the accelerated image is bit-for-bit
 * the unaccelerated one (tested). Early termination happens at the same sample either way.
 *
 * All positions go through the volume's affine world_to_index map; a leap of r voxels
 * along world direction w is r / |A w| world units, exact for any affine transform. */
#ifndef VSD_CONSTELLATION_KERNEL_H
#define VSD_CONSTELLATION_KERNEL_H
#include "kernel/kernel_types.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_camera.h"
#include "kernel/kernel_march.h"

/* A distance map as kernels see it (see src/grids/distance_map.h). */
typedef struct VSD_ALIGN16 vsd_kdistmap {
    const uint8_t *skip;      /* NULL = no map: never leap */
    const float *field;       /* dense copy of the grid over the same cells (dense_grid.h); NULL = read bricks */
    const uint8_t *shadow_code; /* with field: per cell 0 = sample, c >= 1 = no lookup, leap c - 1 voxels */
    int32_t origin[3];
    int32_t dims[3];
} vsd_kdistmap;

/* The method's kernel data: the shared scene data plus what only this method needs. */
typedef struct VSD_ALIGN16 vsd_kconstellation {
    const vsd_kernel_data *kd;   /* lights = the rotated constellation */
    const int32_t *first;        /* validity mask: iFirst per view ray, -1 = empty; NULL = off */
    vsd_kdistmap dm_density;
    vsd_kdistmap dm_emission;
    float slice;                 /* shell spacing, world units */
    float shadow_step;           /* shadow-ray step, world units */
    float threshold;             /* |grid value| above which medium counts as present */
    float early_termination;     /* stop a ray once its transmittance is below this */
    int32_t use_distance_map;
    int32_t pixel_samples;       /* n: n x n stratified view rays per pixel */
    int32_t pad_[2];
} vsd_kconstellation;

VSD_STATIC_ASSERT(sizeof(vsd_kdistmap) % 16 == 0, "vsd_kdistmap must stay 16-byte aligned");
VSD_STATIC_ASSERT(sizeof(vsd_kconstellation) % 16 == 0, "vsd_kconstellation must stay 16-byte aligned");

/* Leap radius in voxels at world point p (0 outside the map: no promise there). */
VSD_DEVICE float vsd_dm_skip(const vsd_kdistmap *m, const vsd_kvolume *v, vsd_f3 p)
{
    vsd_f3 q;
    int32_t i, j, k;
    if (!m->skip) return 0.0f;
    q = vsd_affine_point(&v->world_to_index, p);
    i = (int32_t)floorf(q.x) - m->origin[0];
    j = (int32_t)floorf(q.y) - m->origin[1];
    k = (int32_t)floorf(q.z) - m->origin[2];
    if (i < 0 || j < 0 || k < 0 || i >= m->dims[0] || j >= m->dims[1] || k >= m->dims[2]) return 0.0f;
    return (float)m->skip[((size_t)k * m->dims[1] + j) * m->dims[0] + i];
}

/* World units per voxel of leap along world direction d (1 / |A d|); 0 when degenerate. */
VSD_DEVICE float vsd_dm_world_per_voxel(const vsd_kvolume *v, vsd_f3 d)
{
    vsd_f3 di = vsd_affine_vector(&v->world_to_index, d);
    float l = sqrtf(f3_dot(di, di));
    return l > 0.0f ? 1.0f / l : 0.0f;
}

/* Number of steps of length h to advance from a sample whose leap radius is r world
 * units: every sample strictly inside the ball is skipped, at least 1. */
VSD_DEVICE int32_t vsd_dm_steps(float r, float h)
{
    float s = ceilf(r / h);
    if (!(s >= 1.0f)) return 1;
    if (s > 1e8f) return 100000000;
    return (int32_t)s;
}

/* The ray q + t dq (index space) clipped to the density volume's brick box for t >= 0,
 * once per shadow ray on the index-space origin the caller already has (the DDA's slab
 * test). Returns 0 when it misses. */
VSD_DEVICE int vsd_cst_clip_index(const vsd_kvolume *v, vsd_f3 q, vsd_f3 dq, float *t0, float *t1)
{
    *t0 = 0.0f;
    *t1 = VSD_INF;
    return vsd_kvolume_clip_index(v, q, dq, t0, t1);
}

/* Trilinear interpolation of the dense grid's cell whose corner (0,0,0) is b (x stride 1,
 * y stride sy, z stride sz), at fractions (tx, ty, tz). The arithmetic is exactly that of
 * vsd_kvolume_field, so both give the same float for the same point (tested): the
 * accelerations stay bit-exact whichever lookup a sample takes. */
VSD_DEVICE float vsd_cst_trilinear(const float *b, size_t sy, size_t sz, float tx, float ty, float tz)
{
    float c000 = b[0], c100 = b[1], c010 = b[sy], c110 = b[sy + 1];
    float c001 = b[sz], c101 = b[sz + 1], c011 = b[sz + sy], c111 = b[sz + sy + 1];
    float c00 = c000 + (c100 - c000) * tx, c10 = c010 + (c110 - c010) * tx;
    float c01 = c001 + (c101 - c001) * tx, c11 = c011 + (c111 - c011) * tx;
    float c0 = c00 + (c10 - c00) * ty, c1 = c01 + (c11 - c01) * ty;
    return c0 + (c1 - c0) * tz;
}

/* Sum of unscaled density samples beyond which a ray's transmittance exp(-scale * sum * h)
 * is below the early-termination threshold (infinite when termination is off). */
VSD_DEVICE float vsd_cst_sum_stop(const vsd_kconstellation *kc)
{
    float s = kc->kd->density.scale * kc->shadow_step;
    return (kc->early_termination > 0.0f && s > 0.0f) ? -logf(kc->early_termination) / s : VSD_INF;
}

/* Transmittance from index-space point qa along the index-space light direction da (A wl)
 * to the density box's exit, by midpoint samples on the lattice ta + (k + 1/2) h, leaping
 * with the distance map (wpv = world units per voxel of leap along wl). The hot loop of the
 * method: one madd and one floor per axis per sample; the cell index found there reads
 * the shadow code (all-zero cell or distance-map leap, dense_grid.h) and then the dense
 * grid's corners. Without a dense grid (huge volumes) it reads the distance map and the
 * bricks. Outside the cells (rounding at the box faces) it reads the bricks, which hold
 * the same values. Stops
 * once the sum passes sum_stop (vsd_cst_sum_stop) and returns that tiny transmittance. */
VSD_DEVICE float vsd_cst_shadow(const vsd_kconstellation *kc, vsd_f3 qa, vsd_f3 da, float wpv, float sum_stop)
{
    const vsd_kvolume *v = &kc->kd->density;
    const vsd_kdistmap *m = &kc->dm_density;
    const uint8_t *skip = kc->use_distance_map ? m->skip : 0;
    const float *g = m->field;
    const int32_t nx = m->dims[0], ny = m->dims[1], nz = m->dims[2];
    const size_t sy = (size_t)nx + 1, sz = sy * (size_t)(ny + 1);
    float ta, tb, h = kc->shadow_step, sum = 0.0f;
    int32_t k = 0;
    if (!vsd_cst_clip_index(v, qa, da, &ta, &tb)) return 1.0f;
    for (;;) {
        float t = ta + ((float)k + 0.5f) * h, f, fx, fy, fz;
        int32_t i, j, l;
        vsd_f3 q;
        if (!(t < tb)) break;
        q = f3_madd(qa, da, t);
        fx = floorf(q.x);
        fy = floorf(q.y);
        fz = floorf(q.z);
        i = (int32_t)fx - m->origin[0];
        j = (int32_t)fy - m->origin[1];
        l = (int32_t)fz - m->origin[2];
        if (i >= 0 && j >= 0 && l >= 0 && i < nx && j < ny && l < nz) {
            size_t cell = ((size_t)l * ny + j) * nx + i;
            if (g) {
                uint8_t c = m->shadow_code[cell];
                if (c) {
                    k += c > 1 ? vsd_dm_steps((float)(c - 1) * wpv, h) : 1;
                    continue;
                }
                f = vsd_cst_trilinear(g + (size_t)l * sz + (size_t)j * sy + i, sy, sz, q.x - fx, q.y - fy, q.z - fz);
            } else {
                if (skip && skip[cell]) {
                    k += vsd_dm_steps((float)skip[cell] * wpv, h);
                    continue;
                }
                f = vsd_kvolume_field(v, q);
            }
        } else {
            f = vsd_kvolume_field(v, q);
        }
        sum += f;
        if (sum > sum_stop) break;
        k++;
    }
    return expf(-v->scale * sum * h);
}

/* In-scattered radiance per unit sigma_s at p toward -d: phase * L * T over the lights.
 * The index-space point is computed once for all N shadow rays. */
VSD_DEVICE vsd_f3 vsd_cst_inscatter(const vsd_kconstellation *kc, vsd_f3 p, vsd_f3 d, float sum_stop)
{
    const vsd_kernel_data *kd = kc->kd;
    const vsd_affine *a = &kd->density.world_to_index;
    vsd_f3 s = f3s(0.0f), qa = vsd_affine_point(a, p);
    int32_t n;
    for (n = 0; n < kd->light_count; n++) {
        const float *l = kd->lights + 8 * n;
        vsd_f3 wl = f3(l[0], l[1], l[2]), da = vsd_affine_vector(a, wl);
        float wpv = 0.0f, w;
        if (kc->use_distance_map) {
            float len = sqrtf(f3_dot(da, da));
            wpv = len > 0.0f ? 1.0f / len : 0.0f;
        }
        w = vsd_hg_eval(f3_dot(d, wl), kd->medium.anisotropy) * vsd_cst_shadow(kc, qa, da, wpv, sum_stop);
        s = f3_add(s, f3_scale(f3(l[4], l[5], l[6]), w));
    }
    return s;
}

/* Cached shadows (shadows = "grid"): the transmittance from world point p toward each
 * light, out[light_count], by the same shadow rays the per-sample mode sends (distance-map
 * leaps, dense grid, early termination). Run once per record per lighting change. */
VSD_DEVICE void vsd_cst_light_record(const vsd_kconstellation *kc, vsd_f3 p, float *out)
{
    const vsd_kernel_data *kd = kc->kd;
    const vsd_affine *a = &kd->density.world_to_index;
    vsd_f3 qa = vsd_affine_point(a, p);
    float sum_stop = vsd_cst_sum_stop(kc);
    int32_t n;
    for (n = 0; n < kd->light_count; n++) {
        const float *l = kd->lights + 8 * n;
        vsd_f3 da = vsd_affine_vector(a, f3(l[0], l[1], l[2]));
        float wpv = 0.0f;
        if (kc->use_distance_map) {
            float len = sqrtf(f3_dot(da, da));
            wpv = len > 0.0f ? 1.0f / len : 0.0f;
        }
        out[n] = vsd_cst_shadow(kc, qa, da, wpv, sum_stop);
    }
}

/* View ray of sub-sample s (0..n*n-1) of pixel (px, py): the centre of stratum s. */
VSD_DEVICE void vsd_cst_view_ray(const vsd_kconstellation *kc, int32_t px, int32_t py, int32_t s, vsd_f3 *o, vsd_f3 *d)
{
    int32_t n = kc->pixel_samples;
    float inv = 1.0f / (float)n;
    vsd_camera_ray(&kc->kd->camera, px, py, ((float)(s % n) + 0.5f) * inv, ((float)(s / n) + 0.5f) * inv, o, d);
}

/* Shell range [*i0, *i1] of the view ray; returns 0 when it misses both boxes. */
VSD_DEVICE int vsd_cst_shells(const vsd_kconstellation *kc, vsd_f3 o, vsd_f3 d, int32_t *i0, int32_t *i1)
{
    float t0, t1;
    if (!vsd_march_extent(kc->kd, o, d, &t0, &t1)) return 0;
    *i0 = (int32_t)ceilf(t0 / kc->slice);
    *i1 = (int32_t)floorf(t1 / kc->slice);
    return *i0 <= *i1;
}

/* Leap radius (world units) for a view sample: the smaller of the density and emission
 * maps' promises, since both fields contribute along view rays. */
VSD_DEVICE float vsd_cst_view_leap(const vsd_kconstellation *kc, vsd_f3 p, float wpv_d, float wpv_e)
{
    float r = vsd_dm_skip(&kc->dm_density, &kc->kd->density, p) * wpv_d;
    if (kc->kd->medium.has_emission && r > 0.0f)
        r = fminf(r, vsd_dm_skip(&kc->dm_emission, &kc->kd->emission, p) * wpv_e);
    return r;
}

/* Validity-mask pass (§4.2): the first shell whose medium exceeds the threshold, or -1.
 * No lighting, so it is cheap; the distance map accelerates it too. */
VSD_DEVICE int32_t vsd_cst_first_shell(const vsd_kconstellation *kc, int32_t px, int32_t py, int32_t s)
{
    const vsd_kernel_data *kd = kc->kd;
    vsd_f3 o, d;
    int32_t i, i0, i1;
    float wpv_d = 0.0f, wpv_e = 0.0f, thr_d = kc->threshold * kd->density.scale;
    vsd_cst_view_ray(kc, px, py, s, &o, &d);
    if (!vsd_cst_shells(kc, o, d, &i0, &i1)) return -1;
    if (kc->use_distance_map) {
        wpv_d = vsd_dm_world_per_voxel(&kd->density, d);
        wpv_e = kd->medium.has_emission ? vsd_dm_world_per_voxel(&kd->emission, d) : 0.0f;
    }
    for (i = i0; i <= i1;) {
        vsd_f3 p = f3_madd(o, d, (float)i * kc->slice);
        float r = kc->use_distance_map ? vsd_cst_view_leap(kc, p, wpv_d, wpv_e) : 0.0f;
        if (r > 0.0f) {
            i += vsd_dm_steps(r, kc->slice);
            continue;
        }
        if (fabsf(vsd_kvolume_at(&kd->density, p)) > thr_d) return i;
        if (kd->medium.has_emission && fabsf(vsd_kvolume_field(&kd->emission, vsd_affine_point(&kd->emission.world_to_index, p))) > kc->threshold)
            return i;
        i++;
    }
    return -1;
}

/* Lighting pass for one view ray from shell `start` (iNear, or iFirst from the mask). */
VSD_DEVICE vsd_sample_result vsd_cst_shade(const vsd_kconstellation *kc, vsd_f3 o, vsd_f3 d, int32_t start, int32_t i1)
{
    const vsd_kernel_data *kd = kc->kd;
    vsd_march_acc acc;
    float h = kc->slice, wpv_d = 0.0f, wpv_e = 0.0f, sum_stop = vsd_cst_sum_stop(kc);
    int32_t i;
    vsd_march_begin(&acc);
    if (kc->use_distance_map) {
        wpv_d = vsd_dm_world_per_voxel(&kd->density, d);
        wpv_e = kd->medium.has_emission ? vsd_dm_world_per_voxel(&kd->emission, d) : 0.0f;
    }
    for (i = start; i >= 0 && i <= i1;) {
        float t = (float)i * h;
        vsd_f3 p = f3_madd(o, d, t);
        float r = kc->use_distance_map ? vsd_cst_view_leap(kc, p, wpv_d, wpv_e) : 0.0f;
        float absorbed;
        if (r > 0.0f) {
            i += vsd_dm_steps(r, h);
            continue;
        }
        absorbed = vsd_march_medium(kd, &acc, p, h);
        if (absorbed > 0.0f) {
            vsd_march_scatter(kd, &acc, vsd_cst_inscatter(kc, p, d, sum_stop), t, absorbed);
            if (acc.tr < kc->early_termination) break;
        }
        i++;
    }
    return vsd_march_finish(kd, &acc, d);
}

/* One view ray: sub-sample s of pixel (px, py), using the mask when there is one. */
VSD_DEVICE vsd_sample_result vsd_cst_sample(const vsd_kconstellation *kc, int32_t px, int32_t py, int32_t s)
{
    vsd_f3 o, d;
    int32_t i0 = 0, i1 = -1, n2 = kc->pixel_samples * kc->pixel_samples;
    vsd_cst_view_ray(kc, px, py, s, &o, &d);
    if (vsd_cst_shells(kc, o, d, &i0, &i1) && kc->first)
        i0 = kc->first[((size_t)py * kc->kd->camera.width + px) * n2 + s];
    if (i0 < 0 || i1 < i0) i1 = -1; /* empty: the loop below does nothing */
    return vsd_cst_shade(kc, o, d, i0 < 0 ? 0 : i0, i1);
}

/* Validity mask as an item pass (device/device_pass.h): item i is sub-sample i mod n2 of
 * pixel i div n2 in row-major order, its first shell into ((int32_t *)out)[i]. */
VSD_DEVICE void vsd_cst_mask_item(const vsd_kconstellation *kc, int i, int n, void *out)
{
    int32_t n2 = kc->pixel_samples * kc->pixel_samples, pixel = i / n2;
    (void)n;
    ((int32_t *)out)[i] = vsd_cst_first_shell(kc, pixel % kc->kd->camera.width, pixel / kc->kd->camera.width, i % n2);
}

/* The lighting pass's per-sample function (device/device_pass.h). */
VSD_DEVICE vsd_sample_result vsd_cst_pass_sample(const vsd_kconstellation *kc, int x, int y, int s, int n)
{
    (void)n;
    return vsd_cst_sample(kc, x, y, s);
}

#endif
