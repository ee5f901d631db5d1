/* kernel_march.h — the view-ray march every single-scattering method shares (raymarch,
 * constellation, shgrid): which stretch of the ray to march, and what one step adds.
 *
 * Within a step of length h the medium is taken as constant (sampled at the step's
 * midpoint), so its collision probability is a = 1 - exp(-sigma h); in-scattered light
 * adds T * albedo * S * a, emission adds T * L_e * a / sigma (h where sigma is ~0), and T
 * shrinks by 1 - a. This is exact for piecewise-constant media and stable for thick ones.
 * Methods differ only in where they put the steps and how they compute S. */
#ifndef VSD_KERNEL_MARCH_H
#define VSD_KERNEL_MARCH_H
#include "kernel_types.h"
#include "kernel_volume.h"
#include "kernel_env.h"

/* The view ray's extent: the union of the density and emission boxes, so flames where
 * there is no smoke are still marched. Returns 0 when the ray misses both. */
VSD_DEVICE int vsd_march_extent(const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d, float *t0, float *t1)
{
    float a0, a1;
    int hit = vsd_kvolume_clip(&kd->density, o, d, t0, t1);
    if (kd->medium.has_emission && vsd_kvolume_clip(&kd->emission, o, d, &a0, &a1)) {
        if (!hit) { *t0 = a0; *t1 = a1; }
        else { *t0 = vsd_minf(*t0, a0); *t1 = vsd_maxf(*t1, a1); }
        hit = 1;
    }
    return hit;
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
VSD_DEVICE float vsd_march_medium(const vsd_kernel_data *kd, vsd_march_acc *a, vsd_f3 p, float h)
{
    float sigma = vsd_kvolume_at(&kd->density, p);
    float absorbed = 1.0f - expf(-sigma * h);
    if (kd->medium.has_emission) {
        float le = vsd_kvolume_at(&kd->emission, p);
        float path = sigma > 1e-6f ? absorbed / sigma : h;
        a->res.emit = f3_add(a->res.emit, f3_scale(kd->medium.emission, le * a->tr * path));
    }
    return absorbed;
}

/* The scattering part of the step centred at distance t: s is the in-scattered radiance per
 * unit scattering (phase * incident light), `absorbed` what vsd_march_medium returned. */
VSD_DEVICE void vsd_march_scatter(const vsd_kernel_data *kd, vsd_march_acc *a, vsd_f3 s, float t, float absorbed)
{
    a->res.direct = f3_add(a->res.direct, f3_scale(f3_mul(kd->medium.albedo, s), a->tr * absorbed));
    a->depth_num += t * a->tr * absorbed;
    a->tr *= 1.0f - absorbed;
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
