/* shgrid_kernel.h — Delalandre et al. 2013 (../shared/papers/003_…txt): single scattering
 * from a coarse grid of reduced-intensity records, shared by the CPU backend (shgrid.c)
 * and CUDA (shgrid_cuda.cu).
 *
 * Record pass (§4.2), one record per non-empty cell: from the cell centre, march toward
 * each of M HEALPix directions to the volume's box, T_j = exp(-optical depth), and project
 * into SH with equal weights 4pi/M:
 *   factored form (§4.2-4.3, isotropic): R_i = sum_j T_j y_i(w_j) 4pi/M   (volume only)
 *   product form (§4.4, static media):   R_ci = sum_j T_j L_c(w_j) y_i(w_j) 4pi/M  (RGB)
 * where L_c(w_j) is the environment averaged over HEALPix pixel j (not point-sampled, so a
 * small bright sun is neither missed nor over-weighted).
 *
 * View pass (§4.3): march the view ray like the raymarch baseline (same quadrature, so the
 * two differ only in how in-scattering is computed); at each sample the in-scattered
 * radiance per unit sigma_s is a dot product:
 *   factored: S_c = (1/4pi) sum_i R_i L_ci               (isotropic phase)
 *   RGB records (TL, from the product form or the triple product): S_c = sum_i w_i R_ci,
 *     w_i = g^l y_i(d) — the HG convolution evaluated toward the viewer; per ray, since d
 *     is fixed along it.
 * Records are looked up at the nearest cell (the paper) or trilinearly between the eight
 * surrounding cell centres, renormalised over the non-empty ones, either in radiance or in
 * log radiance (a weighted geometric mean). The log form is an extension: in-scattered
 * radiance falls about exponentially with depth into a lit surface, so a linear blend of
 * the cell-centre values (the chord of a convex curve) over-brightens the skin, which a
 * blend of logs does not.
 *
 * Extension beyond the paper (option `lights`, 0 = the paper's pure form): the map's
 * brightest texels (a sun, studio lamps, windows) are taken out of the SH projection and
 * stood for by K directional lights (a median cut of those texels only). Each record also
 * stores the exact transmittance T_k from its cell centre toward each light, and the view
 * pass adds sum_k phase(d . w_k) T_k E_k to the SH term, which then carries only the
 * smooth remainder of the map. A small source is the one thing a low-order SH cannot hold:
 * its product with the truncated T(w) is T's truncation error evaluated at one direction. */
#ifndef VSD_SHGRID_KERNEL_H
#define VSD_SHGRID_KERNEL_H
#include "kernel/kernel_types.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_camera.h"
#include "kernel/kernel_march.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_sh.h"
#include "kernel/kernel_record_grid.h"
#include "kernel/kernel_volumes.h"

/* Reduced-intensity record of one cell (the record pass), written to out[stride]. */
VSD_DEVICE void vsd_shgrid_record(const vsd_krecord_grid *g, int32_t rec, float *out)
{
    const float *pp = g->record_pos + 4 * (size_t)rec;
    vsd_f3 p = f3(pp[0], pp[1], pp[2]);
    int32_t j, i, c;
    for (i = 0; i < g->stride; i++) out[i] = 0.0f;
    for (j = 0; j < g->dir_count; j++) {
        const float *dj = g->dirs + 4 * (size_t)j;
        const float *yj = g->basis + (size_t)j * g->n2;
        float tr = expf(-vsd_kvolumes_optical_depth(g->kd, p, f3(dj[0], dj[1], dj[2]), g->record_step, 0.5f));
        if (g->kind == VSD_RECORDS_SH_SCALAR) {
            for (i = 0; i < g->n2; i++) out[i] += tr * yj[i];
        } else {
            const float *lj = g->dir_radiance + 4 * (size_t)j;
            for (c = 0; c < 3; c++) {
                float v = tr * lj[c];
                for (i = 0; i < g->n2; i++) out[c * g->n2 + i] += v * yj[i];
            }
        }
    }
}

/* Transmittance from record rec's position toward each extracted light, out[light_count]:
 * the same march as the record pass, K more directions. */
VSD_DEVICE void vsd_shgrid_light_record(const vsd_krecord_grid *g, int32_t rec, float *out)
{
    const float *pp = g->record_pos + 4 * (size_t)rec;
    vsd_f3 p = f3(pp[0], pp[1], pp[2]);
    int32_t k;
    for (k = 0; k < g->light_count; k++) {
        const float *l = g->lights + 8 * (size_t)k;
        out[k] = expf(-vsd_kvolumes_optical_depth(g->kd, p, f3(l[0], l[1], l[2]), g->record_step, 0.5f));
    }
}

/* Record i of the record pass (device/device_pass.h): its SH record into out[stride * i],
 * or with lights != 0 its transmittance toward each light into out[light_count * i]. */
VSD_DEVICE void vsd_shgrid_record_item(const vsd_krecord_grid *g, int i, int lights, void *out)
{
    float *o = (float *)out;
    if (lights) vsd_shgrid_light_record(g, i, o + (size_t)i * g->light_count);
    else vsd_shgrid_record(g, i, o + (size_t)i * g->stride);
}

#endif
