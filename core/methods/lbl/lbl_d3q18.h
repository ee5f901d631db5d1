/* lbl_d3q18.h — Geist et al.'s original lattice for the diffusion pass: 18 directions per
 * node, the 6 axis neighbours and the 12 in-plane diagonals (the paper keeps only the 6 to
 * fit an SM's shared memory; `lattice: "d3q18"` restores the 18 on the CPU).
 *
 * The update is lbl_lattice.h's with direction-dependent weights and path lengths:
 *     f_i(r + c_i, t + 1) = (1 - p_i) f_i + w_i (albedo sum_j p_j f_j + S)
 * p_i = 1 - (1 - p)^|c_i| is the collision probability over the link's length (λ on an
 * axis, √2 λ on a diagonal), and w_i the share of the scattered and emitted light each
 * direction gets: 1/12 per axis and 1/24 per diagonal (D3Q19's weights without the rest
 * particle, the ratio that makes lattice diffusion isotropic), summing to 1. A step with
 * albedo 1 conserves sum_i f_i. Populations move |c_i| λ per step, so the fluence is
 * phi = sum_i |c_i| f_i / λ^2 (D3Q6's sum_i f_i / λ^2 when every |c_i| = 1); in an infinite
 * medium the steady state is phi λ^2 = S / (1 - albedo) · sum_i w_i |c_i| / p_i, which is
 * S / (σa λ) for small p as on D3Q6 (tests/test_lbl_lattice.c). */
#ifndef VSD_LBL_D3Q18_H
#define VSD_LBL_D3Q18_H
#include <stddef.h>
#include <stdint.h>
#include "vsd/status.h"

typedef struct vsd_lbl_q18 {
    int32_t res[3];
    size_t cells;
    float *f;                /* [18 dirs][3 ch][cells] arriving populations (warm state) */
    float *post;             /* [18][3][cells] scratch: after collision */
    float *pd;               /* [cells] collision probability over a diagonal link */
    const float *p, *source; /* the caller's material for the current solve */
} vsd_lbl_q18;

vsd_status vsd_lbl_q18_init(vsd_lbl_q18 *q, const int32_t res[3], char *err, size_t errlen);
void vsd_lbl_q18_free(vsd_lbl_q18 *q);
/* collide[c] = p over an axis link, source [3][cells] or NULL; kept by pointer */
void vsd_lbl_q18_set_material(vsd_lbl_q18 *q, const float *collide, const float *source);
vsd_status vsd_lbl_q18_step(vsd_lbl_q18 *q, const float albedo[3], int threads);
/* sum_i |c_i| f_i at node c: the fluence times λ^2 */
float vsd_lbl_q18_node_fluence(const vsd_lbl_q18 *q, int ch, size_t c);
/* sum of all populations of channel ch (the photons) */
double vsd_lbl_q18_total(const vsd_lbl_q18 *q, int ch);

#endif
