/* kernel_record_grids.h — the view pass of a record-grid method over several volumes: one
 * record grid per volume (its own lighting, kernel_record_grid.h), read together along one
 * march over every volume (the walk of kernel_volumes.h).
 *
 * At a step the medium is the sum of the volumes (sigma = sum sigma_i, emission adds), and
 * the in-scattered light is the scattering-weighted mixture of what each volume's records
 * give: sum_i sigma_i albedo_i S_i / sigma, S_i from volume i's grid with volume i's phase
 * (its HG lobe toward the eye; baked records already hold it). This is how Cycles combines
 * overlapping volumes; with one volume it is the single-volume march's step. Each volume's
 * grid keeps its own corner cache along the ray. On the device each grid's arrays sit in
 * slots of their own (record_grid_device.c). */
#ifndef VSD_KERNEL_RECORD_GRIDS_H
#define VSD_KERNEL_RECORD_GRIDS_H
#include "kernel_record_grid.h"
#include "kernel_volumes.h"

typedef struct VSD_ALIGN16 vsd_krecord_grids {
    const vsd_kernel_data *kd;            /* the scene's: kd->volumes[i] goes with grid[i] */
    const vsd_krecord_grid *grid;         /* [kd->volume_count] */
    int32_t count;
    int32_t pad[3];
} vsd_krecord_grids;

/* The march along o + t d (walk begun on it) over every volume, into acc: every volume's
 * extinction and emission, and the in-scattered light of the volumes in `sources` (bit i:
 * volume i) — all of them for the view; lbl's parts gather the light of the other groups
 * only (lbl_exchange.h). */
VSD_DEVICE void vsd_records_march_volumes(const vsd_krecord_grids *gs, vsd_march_acc *acc, vsd_volumes_walk *walk,
                                          vsd_f3 o, vsd_f3 d, uint32_t sources)
{
    const vsd_kernel_data *kd = gs->kd;
    vsd_f3 p;
    float mid, sigma, absorbed, sig[VSD_KMAX_VOLUMES];
    /* per volume: the lights' per-ray weights at its phase, its SH weights, its corners */
    float ph[VSD_KMAX_VOLUMES][VSD_RECORDS_PH_FLOATS], w[VSD_KMAX_VOLUMES][VSD_SH_MAX_COEFFS];
    vsd_records_corners corners[VSD_KMAX_VOLUMES];
    int32_t i, n = gs->count;
    for (i = 0; i < n; i++) {
        const vsd_krecord_grid *g = &gs->grid[i];
        float an = kd->volumes[i].medium.anisotropy;
        corners[i].filled = 0;
        corners[i].valid = 0;
        corners[i].key[0] = corners[i].key[1] = corners[i].key[2] = 0;
        if (walk->lo[i] >= VSD_INF || !((sources >> i) & 1u)) continue;   /* missed, or not a source */
        vsd_records_light_weights(g->lights, g->light_count, g->sub_count, d, an, ph[i]);
        if (g->kind == VSD_RECORDS_SH_RGB) vsd_records_sh_view_weights(g->order, an, d, w[i]);
    }
    while (vsd_volumes_view_step(walk, kd, acc, o, d, &p, &mid, &sigma, &absorbed, sig)) {
        vsd_f3 single = f3s(0.0f), multiple = f3s(0.0f);
        for (i = 0; i < n; i++) {
            vsd_f3 ms, ss, a;
            if (!(sig[i] > 0.0f) || !((sources >> i) & 1u)) continue;
            ss = vsd_records_inscatter(&gs->grid[i], p, w[i], ph[i], &corners[i], &ms);
            a = f3_scale(kd->volumes[i].medium.albedo, sig[i] / sigma);
            single = f3_add(single, f3_mul(a, ss));
            multiple = f3_add(multiple, f3_mul(a, ms));
        }
        vsd_march_source(acc, single, multiple, mid, absorbed, absorbed);
    }
}

VSD_DEVICE vsd_sample_result vsd_records_pixel_volumes(const vsd_krecord_grids *gs, int32_t px, int32_t py, float jx,
                                                       float jy)
{
    const vsd_kernel_data *kd = gs->kd;
    vsd_march_acc acc;
    vsd_volumes_walk walk;
    vsd_f3 o, d;
    if (vsd_volumes_view_begin(kd, px, py, jx, jy, &acc, &walk, &o, &d))
        vsd_records_march_volumes(gs, &acc, &walk, o, d, ~0u);
    return vsd_march_finish(kd, &acc, d);
}

/* Stratum s of the n x n strata of pixel (x, y) (device/device_pass.h). */
VSD_STRATIFIED_SAMPLE(vsd_records_volumes_sample, vsd_krecord_grids, vsd_records_pixel_volumes)

#endif
