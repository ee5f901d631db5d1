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
#include "kernel/kernel_sobol.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_volumes.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_camera.h"
#include "kernel/kernel_refract.h"
#include "kernel/kernel_lights.h"
#include "kernel/kernel_radiance_cache.h"

VSD_DEVICE float vsd_power_heuristic(float a, float b)
{
    float a2 = a * a, b2 = b * b;
    return (a2 + b2) > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* Russian roulette's probability that a path goes on: the square root of its largest
 * throughput (times scale), at most 1, as Cycles does. The root keeps paths alive longer
 * than the throughput itself would (a path of throughput 0.25 goes on with 0.5): in a
 * cloud of albedo 0.98 most of the light comes after tens of scatterings, and a path cut
 * early is noise. Measured for issue 33 against min(throughput, 0.95) (docs/methods/
 * reference.md): cloud256 at 320x180, Combined's noise 7.40 -> 5.79% per 64 samples for 6%
 * more time; fire96 5.59 -> 5.32% for 2%. */
VSD_DEVICE float vsd_continuation(vsd_f3 throughput, float scale)
{
    return vsd_minf(sqrtf(scale * f3_max_comp(throughput)), 1.0f);
}

/* The path's 2D sample `pair` at vertex `bounce` (0: the camera): at the camera and the
 * first scattering vertex a stratified point over the pixel's samples (kernel_sobol.h;
 * pairs: 0 the position in the pixel, 1 the environment's light sample, 2 the phase,
 * 3 + k scene light k), later from the path's own stream (from there on, how many numbers
 * a path has drawn varies). Measured for issue 33 against the stream alone (320x180, 16
 * spp, one render's noise from two seeds): VolumeDir 17.2 -> 14.9% on cloud256, 15.2 ->
 * 14.0% on smoke128, 16.9 -> 16.1% on fire96; Combined 1-3% lower; no cost. */
typedef struct vsd_path_samples {
    uint32_t seed, pixel, sample;
} vsd_path_samples;

VSD_DEVICE void vsd_path_2d(const vsd_path_samples *ps, vsd_rng *rng, int bounce, uint32_t pair, float *u, float *v)
{
    if (bounce <= 1) {
        vsd_sobol_pair(ps->seed, ps->pixel, ps->sample, pair, u, v);
        return;
    }
    *u = vsd_rng_float(rng);
    *v = vsd_rng_float(rng);
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
 * each straight piece (track-length estimator) is added to *emit; *which gets the volume
 * collided with (kernel_volumes.h: every volume's medium is tracked along the bent path,
 * the index field is the one refracting volume's). */
VSD_DEVICE float vsd_bent_delta_track(const vsd_kernel_data *kd, const vsd_krefract *r, vsd_f3 *o, vsd_f3 *d,
                                      vsd_rng *rng, vsd_f3 *emit, int32_t *which)
{
    float travelled = 0.0f, t0, t1, t;
    int32_t steps = 0;
    for (;;) {
        if (steps >= r->max_steps || !vsd_refract_clip(r, *o, *d, &t0, &t1)) {
            /* straight from here on: n = 1 (or the ray has bent for long enough) */
            t = vsd_kvolumes_delta_track(kd, *o, *d, VSD_INF, rng, which);
            *emit = f3_add(*emit, vsd_segment_emission(kd, *o, *d, t, rng));
            if (t >= VSD_INF) return VSD_INF;
            *o = f3_madd(*o, *d, t);
            return travelled + t;
        }
        if (!vsd_refract_inside(r, *o)) { /* straight up to the grid, a hair into it */
            t0 += 1e-3f * r->step;
            t = vsd_kvolumes_delta_track(kd, *o, *d, t0, rng, which);
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
                t = vsd_kvolumes_delta_track(kd, *o, *d, h, rng, which);
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
            tr *= vsd_kvolumes_ratio_track(kd, o, d, VSD_INF, rng);
            break;
        }
        if (!vsd_refract_inside(r, o)) {
            t0 += 1e-3f * r->step;
            tr *= vsd_kvolumes_ratio_track(kd, o, d, t0, rng);
            o = f3_madd(o, d, t0);
            steps++;
        }
        {
            vsd_f3 g, v = f3_scale(d, vsd_refract_eval(r, o, &g));
            float h = r->step;
            while (tr > 0.0f && steps < r->max_steps && vsd_refract_inside(r, o)) {
                tr *= vsd_kvolumes_ratio_track(kd, o, d, h, rng);
                vsd_refract_step(r, &o, &v, &d, h);
                steps++;
            }
        }
    }
    *exit = d;
    return tr;
}

/* With a radiance cache (cache != NULL, kernel_radiance_cache.h; docs/methods/reference.md),
 * at every scattering vertex x_k: once the next direction w is drawn, the path adds
 * throughput x m(x_k, d) (the cache's light scattered here, in closed form) and subtracts
 * throughput x c(x_k, w) (the cache's light arriving along the w it drew), so what it
 * carries on from x_k is the difference between the true light arriving along w and the
 * cache's. The two terms cancel in expectation given x_k and d, so the estimate stays
 * unbiased whatever the cache holds. From the second vertex on, the Russian roulette (with
 * `survival` scaling the throughput) comes between them: a path that stops keeps m, one
 * that goes on is reweighted by 1/q before it subtracts c. The cache's terms are light
 * scattered at least twice (VolumeInd), and nothing before the second vertex's roulette
 * draws a random number differently, so VolumeDir is the plain path tracer's, bit for bit
 * with the same seed. */
VSD_DEVICE vsd_sample_result vsd_reference_sample_bent(const vsd_kernel_data *kd, const vsd_krefract *r,
                                                      const vsd_kradiance_cache *cache, int32_t px, int32_t py,
                                                      uint32_t sample)
{
    vsd_sample_result res;
    vsd_rng rng = vsd_rng_init((uint32_t)kd->seed, (uint32_t)(py * kd->camera.width + px), sample);
    vsd_f3 o, d, throughput = f3s(1.0f);
    float g = kd->medium.anisotropy, last_phase_pdf = 0.0f;
    int bounce = 0;
    int32_t which = 0;   /* the volume of the last collision (kernel_volumes.h) */

    res.direct = res.indirect = res.emit = res.background = f3s(0.0f);
    res.depth = VSD_INF;
    vsd_path_samples ps;
    float u, v;
    ps.seed = (uint32_t)kd->seed;
    ps.pixel = (uint32_t)(py * kd->camera.width + px);
    ps.sample = sample;
    vsd_path_2d(&ps, &rng, 0, 0, &u, &v);
    vsd_camera_ray(&kd->camera, px, py, u, v, &o, &d);
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
            t = vsd_bent_delta_track(kd, r, &o, &d, &rng, &e, &which);
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
            vsd_f3 wl;
            vsd_path_2d(&ps, &rng, bounce, 1, &u, &v);
            wl = vsd_env_sample(&kd->env, u, v, &le, &pdf_l);
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
                float dist, u1, u2;
                vsd_path_2d(&ps, &rng, bounce, 3u + (uint32_t)k, &u1, &u2);
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
        {
            const vsd_f3 d_in = d;
            vsd_path_2d(&ps, &rng, bounce, 2, &u, &v);
            d = vsd_hg_sample(d, g, u, v, &last_phase_pdf);
            if (cache) { /* the control variate and its roulette (above) */
                float c[VSD_CACHE_FLOATS];
                vsd_cache_eval(cache, o, c);
                res.indirect = f3_add(res.indirect, f3_mul(throughput, vsd_cache_phase_mean(c, d_in, g)));
                if (bounce >= 2) {
                    float q = vsd_continuation(throughput, cache->survival);
                    if (vsd_rng_float(&rng) >= q) break;
                    throughput = f3_scale(throughput, 1.0f / q);
                }
                res.indirect = f3_sub(res.indirect, f3_mul(throughput, vsd_cache_radiance(c, d)));
                continue;
            }
        }
        if (bounce >= 3) { /* Russian roulette on the path throughput (without a cache) */
            float q = vsd_continuation(throughput, 1.0f);
            if (vsd_rng_float(&rng) >= q) break;
            throughput = f3_scale(throughput, 1.0f / q);
        }
    }
    return res;
}

VSD_DEVICE vsd_sample_result vsd_reference_sample(const vsd_kernel_data *kd, int32_t px, int32_t py, uint32_t sample)
{
    return vsd_reference_sample_bent(kd, 0, 0, px, py, sample);
}

/* Sample s of pixel (x, y) as a device pass's per-sample function (device/device_pass.h). */
VSD_DEVICE vsd_sample_result vsd_reference_pass_sample(const vsd_kernel_data *kd, int x, int y, int s, int n)
{
    (void)n;
    return vsd_reference_sample(kd, x, y, (uint32_t)s);
}

#endif
