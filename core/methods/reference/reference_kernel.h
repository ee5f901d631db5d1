/* reference_kernel.h — one sample of the ground-truth volumetric path tracer.
 *
 * Free paths by delta tracking over brick majorants; at every real collision the path
 * scatters with weight albedo (sigma_s / sigma_t, since the medium's extinction is grey);
 * next-event estimation samples the environment by importance and weighs it against HG
 * phase sampling with the power heuristic (MIS); unoccluded phase-sampled escapes add the
 * other half. Transmittance of shadow rays uses ratio tracking. Emission uses the
 * track-length estimator: the integral of L_e over each free-flight segment, which is
 * unbiased for the integral of T * L_e because P(segment longer than t) = T(t).
 *
 * Passes follow Cycles: light that scattered exactly once toward the camera is Direct
 * (VolumeDir), everything that scattered more often — and emission seen after a scatter —
 * is Indirect (VolumeInd); emission seen straight from the camera is Emit. */
#ifndef VSD_REFERENCE_KERNEL_H
#define VSD_REFERENCE_KERNEL_H
#include "kernel/kernel_types.h"
#include "kernel/kernel_rng.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_camera.h"

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

/* Emission along the free-flight segment [0, t_end) of ray (o, d). */
VSD_DEVICE vsd_f3 vsd_segment_emission(const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d, float t_end, vsd_rng *rng)
{
    float integral;
    if (!kd->medium.has_emission) return f3s(0.0f);
    integral = vsd_field_integral(&kd->emission, o, d, 0.0f, t_end, vsd_rng_float(rng));
    return f3_scale(kd->medium.emission, integral);
}

VSD_DEVICE vsd_sample_result vsd_reference_sample(const vsd_kernel_data *kd, int32_t px, int32_t py, uint32_t sample)
{
    vsd_sample_result res;
    vsd_rng rng = vsd_rng_init((uint32_t)kd->seed, (uint32_t)(py * kd->camera.width + px), sample);
    vsd_f3 o, d, throughput = f3s(1.0f);
    float g = kd->medium.anisotropy, last_phase_pdf = 0.0f;
    int bounce = 0;

    res.direct = res.indirect = res.emit = res.background = f3s(0.0f);
    res.depth = VSD_INF;
    vsd_camera_ray(&kd->camera, px, py, vsd_rng_float(&rng), vsd_rng_float(&rng), &o, &d);
    res.transmittance = vsd_ratio_track(&kd->density, o, d, VSD_INF, &rng);

    for (;;) {
        float t = vsd_delta_track(&kd->density, o, d, VSD_INF, &rng);
        vsd_f3 e = vsd_segment_emission(kd, o, d, t, &rng);
        if (bounce == 0) res.emit = f3_add(res.emit, e);
        else res.indirect = f3_add(res.indirect, f3_mul(throughput, e));

        if (t >= VSD_INF) { /* escaped to the environment */
            vsd_f3 env = vsd_env_eval(&kd->env, d);
            if (bounce == 0) {
                if (!kd->transparent) res.background = env;
            } else {
                float w = vsd_power_heuristic(last_phase_pdf, vsd_env_pdf(&kd->env, d));
                vsd_add_path_light(&res, bounce, f3_scale(f3_mul(throughput, env), w));
            }
            break;
        }
        if (bounce == 0) res.depth = t;
        o = f3_madd(o, d, t);
        throughput = f3_mul(throughput, kd->medium.albedo);
        bounce++;

        { /* next-event estimation toward the environment */
            vsd_f3 le;
            float pdf_l;
            vsd_f3 wl = vsd_env_sample(&kd->env, vsd_rng_float(&rng), vsd_rng_float(&rng), &le, &pdf_l);
            if (pdf_l > 0.0f) {
                float ph = vsd_hg_eval(f3_dot(d, wl), g);
                float tr = vsd_ratio_track(&kd->density, o, wl, VSD_INF, &rng);
                /* at the last vertex no phase-sampled path follows, so NEE takes the full weight */
                float w = (bounce >= kd->max_bounces) ? 1.0f : vsd_power_heuristic(pdf_l, ph);
                if (tr > 0.0f)
                    vsd_add_path_light(&res, bounce, f3_scale(f3_mul(throughput, le), ph * tr * w / pdf_l));
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

/* Sample s of pixel (x, y) as a device pass's per-sample function (device/device_pass.h). */
VSD_DEVICE vsd_sample_result vsd_reference_pass_sample(const vsd_kernel_data *kd, int x, int y, int s, int n)
{
    (void)n;
    return vsd_reference_sample(kd, x, y, (uint32_t)s);
}

#endif
