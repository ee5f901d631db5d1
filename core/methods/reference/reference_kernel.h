/* reference_kernel.h — one sample of the ground-truth volumetric path tracer.
 *
 * Free paths by delta tracking over brick majorants; at every real collision the path
 * scatters with weight albedo (sigma_s / sigma_t, since the medium's extinction is grey);
 * next-event estimation samples the environment by importance and weighs it against HG
 * phase sampling with the power heuristic (MIS); unoccluded phase-sampled escapes add the
 * other half; the scene's lights (sun, point, spot: kernel_lights.h) by NEE alone.
 * Transmittance of shadow rays uses ratio tracking. Emission uses the
 * track-length estimator: the integral of L_e over each free-flight segment, which is
 * unbiased for the integral of T * L_e because P(segment longer than t) = T(t).
 *
 * Passes follow Cycles: light that reaches the camera after exactly one scatter is Direct
 * (VolumeDir) — the environment's light and the emission collected on the segment after
 * the first scatter alike (Cycles writes any light reached at bounce 1 to Volume Direct) —
 * everything that scattered more often is Indirect (VolumeInd); emission seen straight
 * from the camera is Emit. */
#ifndef VSD_REFERENCE_KERNEL_H
#define VSD_REFERENCE_KERNEL_H
#include "kernel/kernel_types.h"
#include "kernel/kernel_rng.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_volumes.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_camera.h"
#include "kernel/kernel_refract.h"
#include "kernel/kernel_lights.h"

VSD_DEVICE float vsd_power_heuristic(float a, float b)
{
    float a2 = a * a, b2 = b * b;
    return (a2 + b2) > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

VSD_DEVICE void vsd_add_path_light(vsd_sample_result *r, int bounce, vsd_f3 l)
{
    if (bounce <= 1) r->direct = f3_add(r->direct, l);
    else r->indirect = f3_add(r->indirect, l);
}

/* Emission of every volume along the free-flight segment [0, t_end) of ray (o, d). */
VSD_DEVICE vsd_f3 vsd_segment_emission(const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d, float t_end, vsd_rng *rng)
{
    return vsd_kvolumes_emission_integral(kd, o, d, t_end, rng);
}

/* Refraction (r != NULL: medium.ior != 1, kernel_refract.h): every ray — camera,
 * scattered, shadow — follows the bent path in straight steps of r->step, each tracked like
 * a straight ray over its length (delta and ratio tracking are memoryless, so chaining
 * them is unbiased); outside the index grid rays are straight. Directions sampled at a
 * vertex (phase, environment) are the rays' starting directions, so MIS compares the pdfs
 * there, and an escaping ray sees the map along the direction it leaves with. */

/* Delta tracking along the bent ray from *o, *d: on a collision returns the arc length to
 * it and leaves *o, *d there; on escape VSD_INF with *d the exit direction. The emission of
 * each straight piece (track-length estimator) is added to *emit. */
VSD_DEVICE float vsd_bent_delta_track(const vsd_kernel_data *kd, const vsd_krefract *r, vsd_f3 *o, vsd_f3 *d,
                                      vsd_rng *rng, vsd_f3 *emit)
{
    float travelled = 0.0f, t0, t1, t;
    int32_t steps = 0;
    for (;;) {
        if (steps >= r->max_steps || !vsd_refract_clip(r, *o, *d, &t0, &t1)) {
            /* straight from here on: n = 1 (or the ray has bent for long enough) */
            t = vsd_delta_track(&kd->density, *o, *d, VSD_INF, rng);
            *emit = f3_add(*emit, vsd_segment_emission(kd, *o, *d, t, rng));
            if (t >= VSD_INF) return VSD_INF;
            *o = f3_madd(*o, *d, t);
            return travelled + t;
        }
        if (!vsd_refract_inside(r, *o)) { /* straight up to the grid, a hair into it */
            t0 += 1e-3f * r->step;
            t = vsd_delta_track(&kd->density, *o, *d, t0, rng);
            *emit = f3_add(*emit, vsd_segment_emission(kd, *o, *d, vsd_minf(t, t0), rng));
            if (t < t0) {
                *o = f3_madd(*o, *d, t);
                return travelled + t;
            }
            *o = f3_madd(*o, *d, t0);
            travelled += t0;
            steps++;   /* a ray grazing the box cannot loop here for ever */
        }
        { /* in the grid: steps of h until it is left */
            vsd_f3 g, v = f3_scale(*d, vsd_refract_eval(r, *o, &g));
            float h = r->step;
            while (steps < r->max_steps && vsd_refract_inside(r, *o)) {
                t = vsd_delta_track(&kd->density, *o, *d, h, rng);
                *emit = f3_add(*emit, vsd_segment_emission(kd, *o, *d, vsd_minf(t, h), rng));
                if (t < h) {
                    *o = f3_madd(*o, *d, t);
                    return travelled + t;
                }
                travelled += h;
                vsd_refract_step(r, o, &v, d, h);
                steps++;
            }
        }
    }
}

/* Ratio-tracked transmittance along the bent ray from o, d; *exit gets the direction it
 * leaves the grid with (d when it never bends). */
VSD_DEVICE float vsd_bent_ratio_track(const vsd_kernel_data *kd, const vsd_krefract *r, vsd_f3 o, vsd_f3 d,
                                      vsd_rng *rng, vsd_f3 *exit)
{
    float tr = 1.0f, t0, t1;
    int32_t steps = 0;
    while (tr > 0.0f) {
        if (steps >= r->max_steps || !vsd_refract_clip(r, o, d, &t0, &t1)) {
            tr *= vsd_ratio_track(&kd->density, o, d, VSD_INF, rng);
            break;
        }
        if (!vsd_refract_inside(r, o)) {
            t0 += 1e-3f * r->step;
            tr *= vsd_ratio_track(&kd->density, o, d, t0, rng);
            o = f3_madd(o, d, t0);
            steps++;
        }
        {
            vsd_f3 g, v = f3_scale(d, vsd_refract_eval(r, o, &g));
            float h = r->step;
            while (tr > 0.0f && steps < r->max_steps && vsd_refract_inside(r, o)) {
                tr *= vsd_ratio_track(&kd->density, o, d, h, rng);
                vsd_refract_step(r, &o, &v, &d, h);
                steps++;
            }
        }
    }
    *exit = d;
    return tr;
}

VSD_DEVICE vsd_sample_result vsd_reference_sample_bent(const vsd_kernel_data *kd, const vsd_krefract *r, int32_t px,
                                                      int32_t py, uint32_t sample)
{
    vsd_sample_result res;
    vsd_rng rng = vsd_rng_init((uint32_t)kd->seed, (uint32_t)(py * kd->camera.width + px), sample);
    vsd_f3 o, d, throughput = f3s(1.0f);
    float g = kd->medium.anisotropy, last_phase_pdf = 0.0f;
    int bounce = 0;
    int32_t which = 0;   /* the volume of the last collision (kernel_volumes.h) */

    res.direct = res.indirect = res.emit = res.background = f3s(0.0f);
    res.depth = VSD_INF;
    vsd_camera_ray(&kd->camera, px, py, vsd_rng_float(&rng), vsd_rng_float(&rng), &o, &d);
    if (r) {
        vsd_f3 exit;
        res.transmittance = vsd_bent_ratio_track(kd, r, o, d, &rng, &exit);
    } else {
        res.transmittance = vsd_kvolumes_ratio_track(kd, o, d, VSD_INF, &rng);
    }

    for (;;) {
        vsd_f3 d_start = d, e = f3s(0.0f);
        float t;
        if (r) {
            t = vsd_bent_delta_track(kd, r, &o, &d, &rng, &e);
        } else {
            t = vsd_kvolumes_delta_track(kd, o, d, VSD_INF, &rng, &which);
            e = vsd_segment_emission(kd, o, d, t, &rng);
        }
        if (bounce == 0) res.emit = f3_add(res.emit, e);
        else vsd_add_path_light(&res, bounce, f3_mul(throughput, e));

        if (t >= VSD_INF) { /* escaped to the environment */
            vsd_f3 env = vsd_env_eval(&kd->env, d);
            if (bounce == 0) {
                if (!kd->transparent) res.background = env;
            } else {
                /* pdfs over the direction sampled at the vertex: the start of a bent ray */
                float w = vsd_power_heuristic(last_phase_pdf, vsd_env_pdf(&kd->env, d_start));
                vsd_add_path_light(&res, bounce, f3_scale(f3_mul(throughput, env), w));
            }
            break;
        }
        if (bounce == 0) res.depth = t;
        if (!r) o = f3_madd(o, d, t);   /* a bent track leaves o at the collision */
        /* scatter with the collided volume's material (the mixture, in expectation) */
        throughput = f3_mul(throughput, vsd_kvolumes_medium(kd, which)->albedo);
        g = vsd_kvolumes_medium(kd, which)->anisotropy;
        bounce++;

        { /* next-event estimation toward the environment */
            vsd_f3 le;
            float pdf_l;
            vsd_f3 wl = vsd_env_sample(&kd->env, vsd_rng_float(&rng), vsd_rng_float(&rng), &le, &pdf_l);
            if (pdf_l > 0.0f) {
                float ph = vsd_hg_eval(f3_dot(d, wl), g);
                float tr;
                if (r) {
                    vsd_f3 exit;
                    tr = vsd_bent_ratio_track(kd, r, o, wl, &rng, &exit);
                    /* the light arriving along wl left the map at the bent ray's exit */
                    le = vsd_env_eval(&kd->env, exit);
                } else {
                    tr = vsd_kvolumes_ratio_track(kd, o, wl, VSD_INF, &rng);
                }
                /* at the last vertex no phase-sampled path follows, so NEE takes the full weight */
                float w = (bounce >= kd->max_bounces) ? 1.0f : vsd_power_heuristic(pdf_l, ph);
                if (tr > 0.0f)
                    vsd_add_path_light(&res, bounce, f3_scale(f3_mul(throughput, le), ph * tr * w / pdf_l));
            }
        }
        /* next-event estimation toward each of the scene's lights (NEE only: a phase-sampled
         * ray never hits one, so each gets its full weight); the scene refuses lights with
         * refraction (vsd_method_check_lights), so these rays are straight */
        if (!r) {
            int32_t k;
            for (k = 0; k < kd->scene_light_count; k++) {
                vsd_f3 wl, weight;
                float dist, u1 = vsd_rng_float(&rng), u2 = vsd_rng_float(&rng);
                if (vsd_light_sample(kd->scene_lights + (size_t)VSD_KLIGHT_FLOATS * k, o, u1, u2, &wl, &dist, &weight)) {
                    float tr = vsd_kvolumes_ratio_track(kd, o, wl, dist, &rng);
                    if (tr > 0.0f)
                        vsd_add_path_light(&res, bounce,
                                           f3_scale(f3_mul(throughput, weight), vsd_hg_eval(f3_dot(d, wl), g) * tr));
                }
            }
        }
        if (bounce >= kd->max_bounces) break;
        /* phase sampling: weight f/pdf = 1 for exact HG sampling */
        d = vsd_hg_sample(d, g, vsd_rng_float(&rng), vsd_rng_float(&rng), &last_phase_pdf);
        if (bounce >= 3) { /* Russian roulette on the path throughput */
            float q = vsd_minf(f3_max_comp(throughput), 0.95f);
            if (vsd_rng_float(&rng) >= q) break;
            throughput = f3_scale(throughput, 1.0f / q);
        }
    }
    return res;
}

VSD_DEVICE vsd_sample_result vsd_reference_sample(const vsd_kernel_data *kd, int32_t px, int32_t py, uint32_t sample)
{
    return vsd_reference_sample_bent(kd, 0, px, py, sample);
}

/* Sample s of pixel (x, y) as a device pass's per-sample function (device/device_pass.h). */
VSD_DEVICE vsd_sample_result vsd_reference_pass_sample(const vsd_kernel_data *kd, int x, int y, int s, int n)
{
    (void)n;
    return vsd_reference_sample(kd, x, y, (uint32_t)s);
}

#endif
