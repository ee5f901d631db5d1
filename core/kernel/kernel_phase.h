/* kernel_phase.h — Henyey–Greenstein phase function, normalised over the sphere
 * (integral = 1), with exact importance sampling. cos_theta is the cosine between the
 * incoming propagation direction and the outgoing one (g > 0 scatters forward), the
 * convention of Cycles and pbrt. */
#ifndef VSD_KERNEL_PHASE_H
#define VSD_KERNEL_PHASE_H
#include "kernel_types.h"

VSD_DEVICE float vsd_hg_eval(float cos_theta, float g)
{
    float denom;
    if (fabsf(g) < 1e-4f) return 1.0f / (4.0f * VSD_PI);
    denom = 1.0f + g * g - 2.0f * g * cos_theta;
    return (1.0f - g * g) / (4.0f * VSD_PI * denom * sqrtf(denom));
}

/* An orthonormal basis around n (Duff et al. 2017, branchless). */
VSD_DEVICE void vsd_basis(vsd_f3 n, vsd_f3 *t, vsd_f3 *b)
{
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = f3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    *b = f3(bb, sign + n.y * n.y * a, -n.y);
}

/* Sample an outgoing direction for propagation direction `dir`; returns it, *pdf = phase. */
VSD_DEVICE vsd_f3 vsd_hg_sample(vsd_f3 dir, float g, float u1, float u2, float *pdf)
{
    float cos_t, sin_t, phi;
    vsd_f3 t, b;
    if (fabsf(g) < 1e-4f) {
        cos_t = 1.0f - 2.0f * u1;
    } else {
        float s = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
        cos_t = (1.0f + g * g - s * s) / (2.0f * g);
    }
    cos_t = vsd_clampf(cos_t, -1.0f, 1.0f);
    sin_t = sqrtf(vsd_maxf(0.0f, 1.0f - cos_t * cos_t));
    phi = 2.0f * VSD_PI * u2;
    vsd_basis(dir, &t, &b);
    *pdf = vsd_hg_eval(cos_t, g);
    return f3_add(f3_add(f3_scale(t, sin_t * cosf(phi)), f3_scale(b, sin_t * sinf(phi))),
                  f3_scale(dir, cos_t));
}

#endif
