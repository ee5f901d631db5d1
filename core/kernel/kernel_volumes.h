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
#include "kernel_march.h"
#include "kernel_camera.h"

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


/* Optical depth from p along d to infinity through every volume (kd's volume 0 alone when it
 * has one), each volume's field integrated with quadrature step `step` at offset u
 * (vsd_field_integral): the records of shgrid and constellation's shadow grid, whose rays
 * cross whatever volume lies toward the light. */
VSD_DEVICE float vsd_kvolumes_optical_depth(const vsd_kernel_data *kd, vsd_f3 p, vsd_f3 d, float step, float u)
{
    float tau = 0.0f;
    int32_t i;
    if (kd->volume_count <= 1) {
        vsd_kvolume kv = kd->density;
        kv.step = step;
        return vsd_field_integral(&kv, p, d, 0.0f, VSD_INF, u);
    }
    for (i = 0; i < kd->volume_count; i++) {
        vsd_kvolume kv = kd->volumes[i].density;
        kv.step = step;
        tau += vsd_field_integral(&kv, p, d, 0.0f, VSD_INF, u);
    }
    return tau;
}

/* ---- a deterministic march over every volume (raymarch; the record-grid methods' view) ----
 * Steps stay on the lattice t0 + k h from the first box the ray enters (density or
 * emission); stretches inside no volume's box are jumped over, so the space between
 * distant volumes costs nothing. */
typedef struct vsd_volumes_walk {
    float lo[VSD_KMAX_VOLUMES], hi[VSD_KMAX_VOLUMES];   /* each volume's extent (INF, -INF: missed) */
    float start, end, h;
    int32_t k, n;
} vsd_volumes_walk;

/* Returns 0 when the ray misses every volume. */
VSD_DEVICE int vsd_volumes_walk_begin(vsd_volumes_walk *w, const vsd_kernel_data *kd, vsd_f3 o, vsd_f3 d)
{
    int32_t i;
    w->n = kd->volume_count;
    w->h = kd->march_step;
    w->k = 0;
    w->start = VSD_INF;
    w->end = -VSD_INF;
    for (i = 0; i < w->n; i++) {
        const vsd_kobject *v = &kd->volumes[i];
        if (!vsd_march_volume_extent(&v->density, &v->emission, v->medium.has_emission, o, d, &w->lo[i], &w->hi[i])) {
            w->lo[i] = VSD_INF;
            w->hi[i] = -VSD_INF;
            continue;
        }
        w->start = vsd_minf(w->start, w->lo[i]);
        w->end = vsd_maxf(w->end, w->hi[i]);
    }
    return w->start < w->end;
}

/* The next step inside some volume's box: midpoint *mid, length *len; 0 when done (past
 * the last box, or the transmittance tr below kd->march_stop). */
VSD_DEVICE int vsd_volumes_walk_next(vsd_volumes_walk *w, const vsd_kernel_data *kd, float tr, float *mid, float *len)
{
    while (w->start < w->end && tr >= kd->march_stop) {
        float t = w->start + (float)w->k * w->h, next = VSD_INF;
        int32_t i, inside = 0;
        if (!(t < w->end)) return 0;
        *len = vsd_minf(w->h, w->end - t);
        *mid = t + 0.5f * *len;
        for (i = 0; i < w->n; i++) {
            if (*mid >= w->lo[i] && *mid < w->hi[i]) inside = 1;
            else if (w->lo[i] > *mid) next = vsd_minf(next, w->lo[i]);
        }
        if (!inside) { /* jump to the first step whose midpoint reaches the next box */
            int32_t kn;
            if (next >= VSD_INF) return 0;
            kn = (int32_t)ceilf((next - w->start) / w->h - 0.5f);
            w->k = kn > w->k ? kn : w->k + 1;
            continue;
        }
        w->k++;
        return 1;
    }
    return 0;
}

/* The medium at a step of length len around p: each volume's sigma into sig[] (0 outside
 * its box along this ray), their emission added to acc's Emit; returns sigma_t (the sum). */
VSD_DEVICE float vsd_volumes_walk_medium(const vsd_volumes_walk *w, const vsd_kernel_data *kd, vsd_march_acc *acc,
                                         vsd_f3 p, float mid, float len, float *sig)
{
    float sigma = 0.0f;
    vsd_f3 emit = f3s(0.0f);
    int32_t i;
    for (i = 0; i < w->n; i++) {
        const vsd_kobject *v = &kd->volumes[i];
        sig[i] = 0.0f;
        if (!(mid >= w->lo[i] && mid < w->hi[i])) continue;
        sig[i] = vsd_kvolume_at(&v->density, p);
        sigma += sig[i];
        if (v->medium.has_emission) emit = f3_madd(emit, v->medium.emission, vsd_kvolume_at(&v->emission, p));
    }
    {
        float absorbed = 1.0f - expf(-sigma * len);
        float path = sigma > 1e-6f ? absorbed / sigma : len;
        acc->res.emit = f3_add(acc->res.emit, f3_scale(emit, acc->tr * path));
    }
    return sigma;
}

/* A view ray over every volume (raymarch's, the record grids', crm's): the accumulator, the
 * camera ray through pixel (px, py) at (jx, jy) and the walk along it; 0 when the ray misses
 * every volume (finish it at once). */
VSD_DEVICE int vsd_volumes_view_begin(const vsd_kernel_data *kd, int32_t px, int32_t py, float jx, float jy,
                                      vsd_march_acc *acc, vsd_volumes_walk *walk, vsd_f3 *o, vsd_f3 *d)
{
    vsd_march_begin(acc);
    vsd_camera_ray(&kd->camera, px, py, jx, jy, o, d);
    return vsd_volumes_walk_begin(walk, kd, *o, *d);
}

/* The view ray's next step that can scatter: its centre *p at distance *mid, sigma_t
 * (returned in *sigma, each volume's in sig[], emission added to acc) and its collision
 * probability *absorbed > 0; 0 when the walk ends. */
VSD_DEVICE int vsd_volumes_view_step(vsd_volumes_walk *walk, const vsd_kernel_data *kd, vsd_march_acc *acc, vsd_f3 o,
                                     vsd_f3 d, vsd_f3 *p, float *mid, float *sigma, float *absorbed, float *sig)
{
    float len;
    while (vsd_volumes_walk_next(walk, kd, acc->tr, mid, &len)) {
        *p = f3_madd(o, d, *mid);
        *sigma = vsd_volumes_walk_medium(walk, kd, acc, *p, *mid, len, sig);
        *absorbed = 1.0f - expf(-*sigma * len);
        if (*absorbed > 0.0f) return 1;
    }
    return 0;
}

/* Transmittance from p along d over [0, tmax) through the volumes NOT in `skip` (bit i =
 * volume i), each marched over its own box by midpoints of step h (h <= 0: each volume's
 * voxel, twice its quadrature step). raymarch's shadow rays (skip 0, its march step), and
 * the shadow other groups of volumes cast on a lighting grid that does not hold them
 * (src/grids/volume_groups.h). */
VSD_DEVICE float vsd_kvolumes_march_transmittance(const vsd_kernel_data *kd, vsd_f3 p, vsd_f3 d, float tmax,
                                                  uint32_t skip, float step)
{
    float tau = 0.0f;
    int32_t i;
    for (i = 0; i < kd->volume_count; i++) {
        const vsd_kvolume *v = &kd->volumes[i].density;
        float t0 = 0.0f, t1 = tmax, t, part = 0.0f;
        float h = step > 0.0f ? step : v->step > 0.0f ? 2.0f * v->step : 0.01f;
        if ((skip >> i) & 1u) continue;
        if (!vsd_kvolume_clip(v, p, d, &t0, &t1)) continue;
        t1 = vsd_minf(t1, tmax);
        for (t = t0 + 0.5f * h; t < t1; t += h) part += vsd_kvolume_at(v, f3_madd(p, d, t));
        tau += part * h;
    }
    return expf(-tau);
}

#endif
