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

/* One view ray through pixel (px, py) at sub-pixel position (jx, jy) in [0,1). */
VSD_DEVICE vsd_sample_result vsd_raymarch_pixel(const vsd_kernel_data *kd, int32_t px, int32_t py, float jx, float jy)
{
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
