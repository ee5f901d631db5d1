/* crm_sky.h — the sky's single scattering summed per view over its HEALPix pixels (option
 * `sky_view: "sum"`, default path `single: "grid"`), beside the paper's order-4 SH.
 *
 * Why: the node grid's single scattering projects the shadowed sky L_in tau on order-4 SH
 * and convolves it with HG's bands 0-3. At g 0.65-0.7 HG keeps a third of its lobe in
 * bands 4 and up, so a view that sees the forward lobe loses it: crm's VolumeDir was 0.81x
 * the reference's on cloud256 and 0.75x on a dense cumulus (30% and 44% off, where no other
 * suspect moved it: docs/methods/crm.md, "VolumeDir on sunlit clouds"). Each node already
 * keeps its optical depth toward the 108 pixel centres (crm_node_single.h), so the view's
 * node pass can sum
 *     sum_j albedo L_j Omega T_j Pbar(-w_j . w_o)
 * with L_j the sky's remainder (the map less the bright texels of crm_lights.h) averaged
 * over pixel j, Omega = 4 pi / N, and Pbar HG averaged over a cap of the pixel's solid angle
 * around its centre (a table in the angle: the point phase at the centres would flicker as
 * a view turns between them, HG at g 0.7 being narrower than a pixel). The successive
 * orders keep reading the SH J_1 (bands 0-2); its sky part is taken out of the nodes'
 * single-scattering SH after them, as the lights' bands are. */
#ifndef VSD_CRM_SKY_H
#define VSD_CRM_SKY_H
#include <stdint.h>
#include "vsd/status.h"
#include "crm_node_single.h"
#include "crm_kernel.h" /* CRM_SKY_PHASE_N, read by vsd_crm_sky_phase */

typedef struct vsd_crm_sky {
    int count;                /* pixels (12 nside^2), 0 = off */
    float *pixels;            /* [8 * count] world direction of the centre xyz, 0, albedo L Omega rgb, 0 */
    size_t rows;              /* nodes with density: rows of tr */
    float *tr;                /* [rows * count] exp(-scale od) */
    int32_t *row;             /* [nodes] the node's row in tr, -1 without density */
    size_t row_nodes;
    long long tr_marches;     /* the depths' march count and the scale tr was made for */
    float tr_scale;
    int phase_ready;          /* the table holds phase_g's (and count's) */
    double phase_g;
    float phase[CRM_SKY_PHASE_N];
} vsd_crm_sky;

/* Sets the pixels' directions (the depths' HEALPix ones) and albedo L Omega from
 * `radiance` (4 floats per pixel: the sky's remainder averaged over it, world frame,
 * src/lighting/env_healpix.h), the transmittance rows from the depths at `scale` unless they
 * were made from the same march (`marches`: the caller's count of the depths' marches) at
 * the same scale, and the phase table when g changed. */
vsd_status vsd_crm_sky_update(vsd_crm_sky *sky, const vsd_crm_node_depths *depths, long long marches, float scale,
                              const float *radiance, const double albedo[3], double g, char *err, size_t errlen);

void vsd_crm_sky_free(vsd_crm_sky *sky);

#endif
