/* kernel_march.h — the view-ray march every single-scattering method shares (raymarch,
 * constellation, shgrid): which stretch of the ray to march, and what one step adds.
 *
 * Within a step of length h the medium is taken as constant (sampled at the step's
 * midpoint), so its collision probability is a = 1 - exp(-sigma h); in-scattered light
 * adds T * albedo * S * a, emission adds T * L_e * a / sigma (h where sigma is ~0), and T
 * shrinks by 1 - a. This is exact for piecewise-constant media and stable for thick ones.
 * Methods differ only in where they put the steps and how they compute S.
 *
 * Where the steps go (vsd_march_walk, shared by raymarch and the record-grid view of
 * kernel_record_grid.h: shgrid, constellation's cached shadows): t_k = t0 + k h,
 * k = 0, 1, ... while t_k < t1, the last step cut at t1, each sampled at its midpoint.
 * Two accelerations, neither of which moves a step:
 *  - empty bricks: a 3D DDA over the density's 8^3 brick cells runs alongside, and steps
 *    whose midpoint lies in a cell whose majorant is <= 0 are skipped. Such a step adds
 *    nothing (the field is 0 over the whole cell: brick_max bounds the trilinear field
 *    there, kernel_volume.h), so the image is the unaccelerated one up to a midpoint that
 *    float rounding puts on the wrong side of a cell face, where the field is ~0 anyway.
 *    Off where the medium emits: the emission grid has bricks of its own.
 *  - early termination: the walk ends once the transmittance T is below kd->march_stop
 *    (default 1e-3, 0 = never). The rest of the ray could add at most T * (albedo * S_max
 *    + L_e,max * l_rest) to the radiance: the steps left have collision probabilities that
 *    sum, weighted by the transmittance, to at most T, and emission adds at most
 *    T * L_e over the remaining length l_rest. For in-scattering lit by a map of radiance
 *    at most L, S_max <= L, so VolumeDir loses at most march_stop * albedo * L (tested on
 *    a slab, test_render.c); the Transmittance pass keeps T at the stop (at most
 *    march_stop above the exact value). */
#ifndef VSD_KERNEL_MARCH_H
#define VSD_KERNEL_MARCH_H
#include "kernel_types.h"
#include "kernel_volume.h"
#include "kernel_env.h"

/* A ray's extent in one volume: the union of its density and emission boxes, so flames
 * where there is no smoke are still marched. Returns 0 when the ray misses both. */
VSD_DEVICE int vsd_march_volume_extent(const vsd_kvolume *density, const vsd_kvolume *emission, int32_t has_emission,
                                       vsd_f3 o, vsd_f3 d, float *t0, float *t1)
{
    float a0, a1;
    int hit = vsd_kvolume_clip(density, o, d, t0, t1);
    if (has_emission && vsd_kvolume_clip(emission, o, d, &a0, &a1)) {
        if (!hit) { *t0 = a0; *t1 = a1; }
        else { *t0 = vsd_minf(*t0, a0); *t1 = vsd_maxf(*t1, a1); }
        hit = 1;
    }
    return hit;
}

/* The view ray's extent in the scene's volume (volume 0). */
VSD_DEVICE int vsd_march_extent(const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d, float *t0, float *t1)
{
    return vsd_march_volume_extent(&kd->density, &kd->emission, kd->medium.has_emission, o, d, t0, t1);
}

/* The steps of a view ray (see the top of this file). */
typedef struct vsd_march_walk {
    float t0, t1, h;
    int32_t k;
    int32_t skip;            /* the brick DDA is on */
    vsd_dda dda;
    float seg0, seg1;        /* the DDA's current cell segment */
    int32_t seg_empty;
} vsd_march_walk;

VSD_DEVICE void vsd_march_walk_begin(vsd_march_walk *w, const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d, float t0,
                                     float t1)
{
    w->t0 = t0;
    w->t1 = t1;
    w->h = kd->march_step;
    w->k = 0;
    w->seg0 = w->seg1 = -VSD_INF;
    w->seg_empty = 0;
    w->skip = !kd->medium.has_emission && kd->density.brick_max != 0;
    /* (read only when skip and the DDA started; set so a caller inlined whole is seen to
       read nothing undefined) */
    w->dda.t = w->dda.t_end = 0.0f;
    /* no emission: the density box is the whole extent, and a ray missing it is empty */
    if (w->skip && !vsd_dda_init(&w->dda, &kd->density, o, d, t0, t1)) w->k = 0x7fffffff;
}

/* The next step: its midpoint *tm and length *hs; 0 when the ray is done (past t1, past
 * the last non-empty brick, or with transmittance tr below kd->march_stop). */
VSD_DEVICE int vsd_march_walk_next(vsd_march_walk *w, const vsd_kernel_data *kd, float tr, float *tm, float *hs)
{
    if (tr < kd->march_stop) return 0;
    for (;;) {
        float t, len, mid;
        int32_t cell;
        if (w->k == 0x7fffffff) return 0;
        t = w->t0 + (float)w->k * w->h;
        if (!(t < w->t1)) return 0;
        len = vsd_minf(w->h, w->t1 - t);
        mid = t + 0.5f * len;
        if (w->skip) {
            while (mid >= w->seg1) {
                if (!vsd_dda_next(&w->dda, &kd->density, &w->seg0, &w->seg1, &cell)) return 0;
                w->seg_empty = !(kd->density.brick_max[cell] > 0.0f);
            }
            if (mid < w->seg0 || w->seg_empty) {
                /* the first step whose midpoint is at or past the segment's end (or start) */
                float edge = mid < w->seg0 ? w->seg0 : w->seg1;
                int32_t next = (int32_t)ceilf((edge - w->t0) / w->h - 0.5f);
                w->k = next > w->k ? next : w->k + 1;
                continue;
            }
        }
        w->k++;
        *tm = mid;
        *hs = len;
        return 1;
    }
}

typedef struct vsd_march_acc {
    vsd_sample_result res;
    float tr;          /* transmittance from the eye to the current step */
    float depth_num;   /* sum of t * collision probability, for the Depth pass */
} vsd_march_acc;

VSD_DEVICE void vsd_march_begin(vsd_march_acc *a)
{
    a->res.direct = a->res.indirect = a->res.emit = a->res.background = f3s(0.0f);
    a->res.depth = VSD_INF;
    a->res.transmittance = 1.0f;
    a->tr = 1.0f;
    a->depth_num = 0.0f;
}

/* The medium part of a step of length h at point p: adds emission and returns the step's
 * collision probability (0 = nothing to scatter, the caller may skip its lighting). */
VSD_DEVICE float vsd_march_medium_sigma(const vsd_kernel_data *kd, vsd_march_acc *a, vsd_f3 p, float h, float sigma)
{
    float absorbed = 1.0f - expf(-sigma * h);
    if (kd->medium.has_emission) {
        float le = vsd_kvolume_at(&kd->emission, p);
        float path = sigma > 1e-6f ? absorbed / sigma : h;
        a->res.emit = f3_add(a->res.emit, f3_scale(kd->medium.emission, le * a->tr * path));
    }
    return absorbed;
}

/* The same with sigma_t taken from the scene's density grid at p. Methods that model the
 * density themselves (crm's RBFs plus residual) call vsd_march_medium_sigma. */
VSD_DEVICE float vsd_march_medium(const vsd_kernel_data *kd, vsd_march_acc *a, vsd_f3 p, float h)
{
    return vsd_march_medium_sigma(kd, a, p, h, vsd_kvolume_at(&kd->density, p));
}

/* The scattering part of the step centred at distance t: s is the in-scattered radiance per
 * unit scattering (phase * incident light), `absorbed` what vsd_march_medium returned. */
VSD_DEVICE void vsd_march_scatter(const vsd_kernel_data *kd, vsd_march_acc *a, vsd_f3 s, float t, float absorbed)
{
    a->res.direct = f3_add(a->res.direct, f3_scale(f3_mul(kd->medium.albedo, s), a->tr * absorbed));
    a->depth_num += t * a->tr * absorbed;
    a->tr *= 1.0f - absorbed;
}

/* A step whose source radiances already include the albedo and the phase function, split
 * into single (VolumeDir) and multiple (VolumeInd) scattering; `shrink` is the step's own
 * collision probability for the transmittance (equal to `absorbed` unless a method
 * attenuates with another density than it scatters from, as crm's residual option does). */
VSD_DEVICE void vsd_march_source(vsd_march_acc *a, vsd_f3 single, vsd_f3 multiple, float t, float absorbed, float shrink)
{
    a->res.direct = f3_add(a->res.direct, f3_scale(single, a->tr * absorbed));
    a->res.indirect = f3_add(a->res.indirect, f3_scale(multiple, a->tr * absorbed));
    a->depth_num += t * a->tr * shrink;
    a->tr *= 1.0f - shrink;
}

/* Transmittance, Depth (mean collision distance) and, on an opaque film, the background. */
VSD_DEVICE vsd_sample_result vsd_march_finish(const vsd_kernel_data *kd, vsd_march_acc *a, vsd_f3 d)
{
    a->res.transmittance = a->tr;
    if (a->tr < 1.0f) a->res.depth = a->depth_num / (1.0f - a->tr);
    if (!kd->transparent) a->res.background = f3_scale(vsd_env_eval(&kd->env, d), a->tr);
    return a->res;
}

#endif
