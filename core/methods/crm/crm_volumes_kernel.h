/* crm_volumes_kernel.h — crm's view over several volumes: one node grid per volume (a part,
 * crm_parts.h), read together along one march over every volume (kernel_volumes.h's walk).
 *
 * At a step the medium is the sum of the volumes (sigma = sum sigma_i, emission adds) and
 * the source is the scattering-weighted mixture: sum_i sigma_i J_i / sigma, J_i from volume
 * i's nodes, which already hold its albedo and phase (crm_kernel.h), interpolated as the
 * one-volume march does (vsd_crm_source, a corner cache per volume). With the volumes'
 * media apart this is each volume's own march; where they overlap, Cycles' mixture.
 * On the device each part's nodes sit in slots of their own (crm_device.c). */
#ifndef VSD_CRM_VOLUMES_KERNEL_H
#define VSD_CRM_VOLUMES_KERNEL_H
#include "crm_kernel.h"
#include "kernel/kernel_volumes.h"

typedef struct VSD_ALIGN16 vsd_kcrm_volumes {
    const vsd_kernel_data *kd;    /* the scene's: kd->volumes[i] goes with part[i] */
    const vsd_kcrm *part;         /* [count] each with its per-view node pass done */
    int32_t count;
    int32_t pad[3];
} vsd_kcrm_volumes;

VSD_DEVICE vsd_sample_result vsd_crm_pixel_volumes(const vsd_kcrm_volumes *cv, int32_t px, int32_t py, float jx,
                                                   float jy)
{
    const vsd_kernel_data *kd = cv->kd;
    vsd_march_acc acc;
    vsd_volumes_walk walk;
    vsd_crm_corners corners[VSD_KMAX_VOLUMES];
    vsd_f3 o, d, p;
    float mid, sigma, absorbed, sig[VSD_KMAX_VOLUMES];
    int32_t i, n = cv->count;
    if (!vsd_volumes_view_begin(kd, px, py, jx, jy, &acc, &walk, &o, &d)) return vsd_march_finish(kd, &acc, d);
    for (i = 0; i < n; i++) {
        corners[i].filled = corners[i].valid = 0;
        corners[i].key[0] = corners[i].key[1] = corners[i].key[2] = 0;
    }
    while (vsd_volumes_view_step(&walk, kd, &acc, o, d, &p, &mid, &sigma, &absorbed, sig)) {
        vsd_f3 single = f3s(0.0f), multiple = f3s(0.0f);
        for (i = 0; i < n; i++) {
            const vsd_kcrm *c = &cv->part[i];
            vsd_f3 ix, q, ss, ms;
            if (!(sig[i] > 0.0f) || !c->view_nodes) continue;
            ix = vsd_affine_point(&kd->volumes[i].density.world_to_index, p);
            q = f3(ix.x - (float)c->origin[0] + 0.5f, ix.y - (float)c->origin[1] + 0.5f, ix.z - (float)c->origin[2] + 0.5f);
            vsd_crm_source(c, q, &corners[i], &ss, &ms);
            single = f3_add(single, f3_scale(ss, sig[i] / sigma));
            multiple = f3_add(multiple, f3_scale(ms, sig[i] / sigma));
        }
        vsd_march_source(&acc, single, multiple, mid, absorbed, absorbed);
    }
    return vsd_march_finish(kd, &acc, d);
}

/* Stratum s of the n x n strata of pixel (x, y) (device/device_pass.h). */
VSD_STRATIFIED_SAMPLE(vsd_crm_volumes_sample, vsd_kcrm_volumes, vsd_crm_pixel_volumes)

#endif
