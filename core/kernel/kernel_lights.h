/* kernel_lights.h — the scene's extra lights (lights[]: sun, point, spot) as the kernels
 * see them, and how a point in the medium samples one. Units and shapes follow Cycles
 * (docs/scene-file.md):
 *   sun    strength S in W/m^2 is the irradiance at normal incidence; with an angular
 *          diameter the sun is a disc of uniform radiance around its direction;
 *   point  power P in watts, intensity I = P / 4pi W/sr; with a radius a sphere of uniform
 *          radiance I / (pi r^2), so at distance d >> r the irradiance is I / d^2;
 *   spot   a point light times Cycles' spot mask: 1 inside the cone, smoothed to 0 over the
 *          last spot_blend of it, times the cosine to the spot's axis where spot_cosine is
 *          set (Cycles 3.x's spot_light_attenuation has the cosine, 4.2's and 5.0's do not:
 *          docs/cycles-crosscheck.md, "Newer Cycles").
 * Scene lights are sampled by next-event estimation only (a phase-sampled ray never hits
 * one), so there is nothing to weigh against: every sample returns radiance / pdf.
 *
 * Kernel layout, VSD_KLIGHT_FLOATS per light:
 *   [0..2]  sun: unit direction toward the light; point, spot: position
 *   [3]     type (vsd_light_type)
 *   [4..6]  sun: S * colour (irradiance); point, spot: I * colour (intensity)
 *   [7]     sun: cos of the angular radius (1 = a delta direction); point, spot: radius
 *   [8..10] spot: unit axis, the direction the light travels
 *   [11]    spot: cos of half the cone angle
 *   [12]    spot: the blend band, (1 - [11]) * spot_blend
 *   [13]    spot: 1 = the mask has the cosine to the axis (spot_cosine), 0 = not
 *   [14..15] 0 */
#ifndef VSD_KERNEL_LIGHTS_H
#define VSD_KERNEL_LIGHTS_H
#include "kernel_types.h"
#include "kernel_phase.h"

#define VSD_KLIGHT_FLOATS 16

/* Cycles' spot mask for light leaving the spot along unit direction `out`. */
VSD_DEVICE float vsd_spot_mask(const float *l, vsd_f3 out)
{
    float c = f3_dot(out, f3(l[8], l[9], l[10])), t, mask;
    if (c <= l[11]) return 0.0f;
    t = c - l[11];
    mask = l[13] != 0.0f ? c : 1.0f;
    if (t < l[12] && l[12] > 0.0f) {
        float s = t / l[12];
        mask *= s * s * (3.0f - 2.0f * s);
    }
    return mask;
}

/* A direction in the cone of cosine cos_max around unit axis a, uniform in solid angle. */
VSD_DEVICE vsd_f3 vsd_cone_sample(vsd_f3 a, float cos_max, float u1, float u2)
{
    vsd_f3 t, b;
    float cos_t = 1.0f - u1 * (1.0f - cos_max), sin_t = sqrtf(vsd_maxf(0.0f, 1.0f - cos_t * cos_t));
    float phi = 2.0f * VSD_PI * u2;
    vsd_basis(a, &t, &b);
    return f3_add(f3_add(f3_scale(t, sin_t * cosf(phi)), f3_scale(b, sin_t * sinf(phi))), f3_scale(a, cos_t));
}

/* A point or spot light's radiance / pdf per unit intensity at p: 1/d^2 for a point; for a
 * sphere of radius r sampled uniformly over its cone of directions 2 / (d^2 (1 + cos_max))
 * (radiance I / (pi r^2) over the solid angle 2pi (1 - cos_max), written without 1 - cos_max,
 * which cancels badly for a small sphere), and 2 / r^2 inside it (the limit d = r); times
 * the spot mask toward p (at the sphere's centre: the mask varies little across a small
 * light). 0 at the light's centre. */
VSD_DEVICE float vsd_light_falloff(const float *l, vsd_f3 p)
{
    vsd_f3 c = f3_sub(p, f3(l[0], l[1], l[2]));
    float d2 = f3_dot(c, c), r = l[7], k;
    if (!(d2 > 0.0f)) return 0.0f;
    if (r > 0.0f && d2 > r * r)
        k = 2.0f / (d2 * (1.0f + sqrtf(vsd_maxf(0.0f, 1.0f - (r * r) / d2))));
    else if (r > 0.0f)
        k = 2.0f / (r * r);
    else
        k = 1.0f / d2;
    if ((int)l[3] == 2) k *= vsd_spot_mask(l, f3_scale(c, 1.0f / sqrtf(d2)));
    return k;
}

/* Sample light l from point p: *w the unit direction toward it, *dist the distance to its
 * surface (VSD_INF for a sun), *weight radiance / pdf (RGB; multiply by phase and
 * transmittance). Returns 0 where the light gives nothing (outside a spot's cone). */
VSD_DEVICE int vsd_light_sample(const float *l, vsd_f3 p, float u1, float u2, vsd_f3 *w, float *dist, vsd_f3 *weight)
{
    vsd_f3 rgb = f3(l[4], l[5], l[6]);
    if ((int)l[3] == 0) { /* sun */
        vsd_f3 a = f3(l[0], l[1], l[2]);
        float cos_a = l[7];
        *dist = VSD_INF;
        if (cos_a >= 1.0f - 1e-7f) {
            *w = a;
            *weight = rgb;
        } else {
            /* uniform radiance S / (pi sin^2 a) over the cone, pdf 1 / (2pi (1 - cos a)) */
            *w = vsd_cone_sample(a, cos_a, u1, u2);
            *weight = f3_scale(rgb, 2.0f / (1.0f + cos_a));
        }
        return 1;
    }
    {
        vsd_f3 c = f3_sub(f3(l[0], l[1], l[2]), p);
        float d2 = f3_dot(c, c), d = sqrtf(d2), r = l[7], k = vsd_light_falloff(l, p);
        if (!(k > 0.0f)) return 0;
        c = f3_scale(c, 1.0f / d);
        *w = c;
        *dist = d;
        if (r > 0.0f && d > r) {
            /* uniform in the sphere's cone of directions; the distance to its near side */
            float cos_max = sqrtf(vsd_maxf(0.0f, 1.0f - (r * r) / d2)), cos_t;
            *w = vsd_cone_sample(c, cos_max, u1, u2);
            cos_t = f3_dot(*w, c);
            *dist = d * cos_t - sqrtf(vsd_maxf(0.0f, r * r - d2 * (1.0f - cos_t * cos_t)));
        } else if (r > 0.0f) {
            *dist = 0.0f;   /* inside the sphere */
        }
        *weight = f3_scale(rgb, k);
        return 1;
    }
}

#endif
