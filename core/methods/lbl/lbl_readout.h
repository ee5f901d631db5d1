/* lbl_readout.h — the medium's phase function on the D3Q6 lattice's six direction cones
 * (an extension of the paper, whose lattice scatters and whose view pass reads the fluence
 * as if scattering were isotropic): the diffused light toward the eye from the six
 * populations, and the shares a collision sends forward, backward and sideways.
 *
 * Population f_i moves along axis direction c_i and stands for the light in its cone, the
 * directions whose largest component is along c_i (a cube face, 4pi/6 sr); taken as
 * constant radiance over the cone, L_i = 6 f_i / (4pi lambda^2). Light scattered toward
 * the eye (view direction d, from the eye) is then, per unit sigma_s,
 *     sum_i L_i W_i(d),   W_i(d) = integral over cone i of HG(w . -d) dw,
 * and sum_i W_i = 1, so isotropic populations give phi / 4pi, the paper's readout. In a
 * forward-scattering cloud (g 0.7) the light flowing toward the eye weighs far more than
 * the light flowing away, which the isotropic readout averages out.
 *
 * W depends on d through the cones' cube geometry, so it is tabulated once per g on a cube
 * map of d (16 x 16 per face, nearest; 32 x 32 changed cloud256's VolumeInd by 0.02%),
 * each cone's mean phase over 4096 Fibonacci directions times its solid angle, normalised
 * to sum to 1 (g = 0: 1/6 each). d is in the lattice's (grid) axes. */
#ifndef VSD_LBL_READOUT_H
#define VSD_LBL_READOUT_H
#include "kernel/kernel_types.h"

#define VSD_LBL_READOUT_FACE 16

typedef struct vsd_lbl_readout {
    float g;                 /* the anisotropy the table is for (NAN: none yet) */
    float w[6][VSD_LBL_READOUT_FACE][VSD_LBL_READOUT_FACE][6];
} vsd_lbl_readout;

/* Fills t for anisotropy g unless it already holds it. */
void vsd_lbl_readout_build(vsd_lbl_readout *t, float g);

/* W_i(d), i in the lattice's order (+x, -x, +y, -y, +z, -z); d need not be unit. */
void vsd_lbl_readout_weights(const vsd_lbl_readout *t, vsd_f3 d, float w[6]);

/* The same cones for the lattice's collisions: of light moving along an axis, the share a
 * collision scatters into its own cone (forward), the opposite one (backward) and each of
 * the four others (side); forward + backward + 4 side = 1. For vsd_lbl_lattice_set_phase. */
void vsd_lbl_readout_lattice_phase(float g, float *forward, float *backward, float *side);

#endif
