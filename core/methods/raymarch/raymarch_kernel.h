/* raymarch_kernel.h — the papers' brute-force single-scattering baseline (Navarro et al.
 * 2009, eq. 3-5), with no acceleration: march the view ray with a fixed step; at each step
 * send a shadow ray, itself marched with the same fixed step, to each of the K directional
 * lights (kd->lights: fixed per frame, importance-sampled from the environment, weights
 * already divided by K * pdf) and add T_view * sigma_s * phase * L * T_shadow.
 *
 * Each step's contribution (emission, in-scattering, transmittance) is the shared step of
 * kernel/kernel_march.h. */
#ifndef VSD_RAYMARCH_KERNEL_H
#define VSD_RAYMARCH_KERNEL_H
#include "kernel/kernel_types.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_camera.h"
#include "kernel/kernel_march.h"
#include "kernel/kernel_volumes.h"
#include "device/device_pass.h"

/* Transmittance from p along d to the volume's exit by fixed-step midpoint marching. */
VSD_DEVICE float vsd_march_transmittance(const vsd_kernel_data *kd, vsd_f3 p, vsd_f3 d)
{
    float t0, t1, t, h = kd->march_step, tau = 0.0f;
    if (!vsd_kvolume_clip(&kd->density, p, d, &t0, &t1)) return 1.0f;
    for (t = t0 + 0.5f * h; t < t1; t += h) tau += vsd_kvolume_at(&kd->density, f3_madd(p, d, t));
    return expf(-tau * h);
}

/* In-scattered radiance per unit sigma_s at p toward -d (phase * L * T summed over lights). */
VSD_DEVICE vsd_f3 vsd_march_inscatter(const vsd_kernel_data *kd, vsd_f3 p, vsd_f3 d)
{
    vsd_f3 s = f3s(0.0f);
    int32_t k;
    for (k = 0; k < kd->light_count; k++) {
        const float *l = kd->lights + 8 * k;
        vsd_f3 wl = f3(l[0], l[1], l[2]);
        float w = vsd_hg_eval(f3_dot(d, wl), kd->medium.anisotropy) * vsd_march_transmittance(kd, p, wl);
        s = f3_add(s, f3_scale(f3(l[4], l[5], l[6]), w));
    }
    return s;
}

/* ---- several volumes (kernel_volumes.h's rules) ----------------------------------------
 * The same fixed-step march over every volume: at a step sigma = sum of the volumes'
 * sigma_i, emission adds, and the in-scattered light is sum_i sigma_i albedo_i S_i / sigma
 * with S_i = sum over lights of phase_i * L * T(all volumes), on the walk of
 * kernel_volumes.h (the space between distant volumes costs nothing). */

VSD_DEVICE vsd_sample_result vsd_raymarch_pixel_volumes(const vsd_kernel_data *kd, int32_t px, int32_t py, float jx,
                                                       float jy)
{
    vsd_march_acc acc;
    vsd_volumes_walk walk;
    vsd_f3 o, d, p;
    float mid, sigma, absorbed, sig[VSD_KMAX_VOLUMES];
    int32_t i, n = kd->volume_count;
    if (!vsd_volumes_view_begin(kd, px, py, jx, jy, &acc, &walk, &o, &d)) return vsd_march_finish(kd, &acc, d);
    while (vsd_volumes_view_step(&walk, kd, &acc, o, d, &p, &mid, &sigma, &absorbed, sig)) {
        vsd_f3 scatter = f3s(0.0f);
        int32_t l;
        for (l = 0; l < kd->light_count; l++) {
            const float *lt = kd->lights + 8 * l;
            vsd_f3 wl = f3(lt[0], lt[1], lt[2]);
            float tr = vsd_kvolumes_march_transmittance(kd, p, wl, VSD_INF, 0u, kd->march_step), c = f3_dot(d, wl);
            vsd_f3 mix = f3s(0.0f);   /* sum_i sigma_i albedo_i phase_i */
            for (i = 0; i < n; i++)
                if (sig[i] > 0.0f)
                    mix = f3_madd(mix, kd->volumes[i].medium.albedo, sig[i] * vsd_hg_eval(c, kd->volumes[i].medium.anisotropy));
            scatter = f3_madd(scatter, f3_mul(mix, f3(lt[4], lt[5], lt[6])), tr / sigma);
        }
        acc.res.direct = f3_add(acc.res.direct, f3_scale(scatter, acc.tr * absorbed));
        acc.depth_num += mid * acc.tr * absorbed;
        acc.tr *= 1.0f - absorbed;
    }
    return vsd_march_finish(kd, &acc, d);
}

/* One view ray through pixel (px, py) at sub-pixel position (jx, jy) in [0,1). */
VSD_DEVICE vsd_sample_result vsd_raymarch_pixel(const vsd_kernel_data *kd, int32_t px, int32_t py, float jx, float jy)
{
    if (kd->volume_count > 1) return vsd_raymarch_pixel_volumes(kd, px, py, jx, jy);
    vsd_march_acc acc;
    vsd_march_walk walk;
    vsd_f3 o, d;
    float t0, t1, tm, hs;
    vsd_march_begin(&acc);
    vsd_camera_ray(&kd->camera, px, py, jx, jy, &o, &d);
    if (vsd_march_extent(kd, o, d, &t0, &t1)) {
        vsd_march_walk_begin(&walk, kd, o, d, t0, t1);
        while (vsd_march_walk_next(&walk, kd, acc.tr, &tm, &hs)) {
            vsd_f3 p = f3_madd(o, d, tm);
            float absorbed = vsd_march_medium(kd, &acc, p, hs);
            if (absorbed > 0.0f) vsd_march_scatter(kd, &acc, vsd_march_inscatter(kd, p, d), tm, absorbed);
        }
    }
    return vsd_march_finish(kd, &acc, d);
}

/* Stratum s of the n x n strata of pixel (x, y) (device/device_pass.h). */
VSD_STRATIFIED_SAMPLE(vsd_raymarch_pass_sample, vsd_kernel_data, vsd_raymarch_pixel)

#endif
