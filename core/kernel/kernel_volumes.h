/* kernel_volumes.h — the scene's volumes together (vsd_scene.volumes), as Cycles combines
 * overlapping volume objects: extinction and scattering add, emission adds, and the phase
 * at a point is the scattering-weighted mixture of the volumes' HG lobes.
 *
 * Free flights: each volume's real collisions along a ray form an independent process, so
 * the first collision in the sum of the media is the earliest of the per-volume ones; each
 * volume is delta tracked only up to the earliest collision found so far. The collision
 * belongs to volume i with probability sigma_t,i / sigma_t at that point; scattering there
 * with volume i's albedo and lobe is, in expectation, the mixture above (sum over i of
 * sigma_t,i/sigma_t * albedo_i * p_i = (sigma_s/sigma_t) * sum of sigma_s,i p_i / sigma_s).
 * Transmittance is the product of the volumes' ratio-tracking estimates (independent and
 * unbiased, so the product is unbiased for the product of transmittances).
 *
 * With one volume each function is exactly the single-volume call it replaces (same random
 * numbers, same image). */
#ifndef VSD_KERNEL_VOLUMES_H
#define VSD_KERNEL_VOLUMES_H
#include "kernel_types.h"
#include "kernel_volume.h"

VSD_DEVICE int32_t vsd_kvolumes_count(const vsd_kernel_data *kd)
{
    return kd->volume_count > 1 ? kd->volume_count : 1;
}
VSD_DEVICE const vsd_kvolume *vsd_kvolumes_density(const vsd_kernel_data *kd, int32_t i)
{
    return kd->volume_count > 1 ? &kd->volumes[i].density : &kd->density;
}
VSD_DEVICE const vsd_kvolume *vsd_kvolumes_emission(const vsd_kernel_data *kd, int32_t i)
{
    return kd->volume_count > 1 ? &kd->volumes[i].emission : &kd->emission;
}
VSD_DEVICE const vsd_kmedium *vsd_kvolumes_medium(const vsd_kernel_data *kd, int32_t i)
{
    return kd->volume_count > 1 ? &kd->volumes[i].medium : &kd->medium;
}

/* Delta tracking through every volume: distance to the first real collision within
 * [0, tmax) (VSD_INF when there is none) and in *which the volume it belongs to. */
VSD_DEVICE float vsd_kvolumes_delta_track(const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d, float tmax, vsd_rng *rng,
                                          int32_t *which)
{
    int32_t i, n = vsd_kvolumes_count(kd);
    float best = VSD_INF;
    *which = 0;
    for (i = 0; i < n; i++) {
        float t = vsd_delta_track(vsd_kvolumes_density(kd, i), o, d, vsd_minf(tmax, best), rng);
        if (t < best) {
            best = t;
            *which = i;
        }
    }
    return best;
}

/* Ratio-tracked transmittance through every volume over [0, tmax). */
VSD_DEVICE float vsd_kvolumes_ratio_track(const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d, float tmax, vsd_rng *rng)
{
    int32_t i, n = vsd_kvolumes_count(kd);
    float tr = 1.0f;
    for (i = 0; i < n && tr > 0.0f; i++) tr *= vsd_ratio_track(vsd_kvolumes_density(kd, i), o, d, tmax, rng);
    return tr;
}

/* Emission of every volume along [0, t_end) of o + t d (the track-length estimator). */
VSD_DEVICE vsd_f3 vsd_kvolumes_emission_integral(const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d, float t_end,
                                                 vsd_rng *rng)
{
    int32_t i, n = vsd_kvolumes_count(kd);
    vsd_f3 sum = f3s(0.0f);
    for (i = 0; i < n; i++) {
        const vsd_kmedium *m = vsd_kvolumes_medium(kd, i);
        if (!m->has_emission) continue;
        sum = f3_add(sum, f3_scale(m->emission, vsd_field_integral(vsd_kvolumes_emission(kd, i), o, d, 0.0f, t_end,
                                                                   vsd_rng_float(rng))));
    }
    return sum;
}

#endif
