/* lbl_exchange.h — the light one group of volumes sends a near one, as lights at lbl's
 * lattice faces.
 *
 * lbl lights each group of volumes on lattices over the group's box (src/grids/
 * volume_groups.h), and other groups reach it only as shadows. So a cloud 0.1 m above a
 * smoke darkened it, but its own glow, which in the path tracer lights the smoke's top, was
 * lost (VolumeInd over the smoke's top 20-50 % dark on the issue-30 scene). One lattice over
 * both would carry it, but its six directions carry light across the empty gap as beams along
 * the axes (docs/methods/lbl.md, "Several volumes").
 *
 * Instead the other groups become an environment seen from the receiving grid's faces: for
 * each of VSD_LBL_EXCHANGE_DIRS (48) Fibonacci directions w_k (4 pi / 48 sr each; 96 gave the
 * issue-30 scene 9.5 % against 9.6 % for 1.5 s more), the radiance arriving along -w_k
 * at the face its rays leave the grid by (the face of w_k's largest grid component), per
 * block of 2x2 face cells: the other groups' view march (kernel/kernel_record_grids.h) from
 * the face outward, their emission (L_e) and their records' light (L_s: the lights' term at
 * their own lobe, the diffused light as its isotropic fluence / 4 pi, the per-view readout
 * needing an eye). Directions that see nothing are dropped. lbl then treats each kept
 * direction as a directional light whose radiance varies over the face: its rays march
 * through the grid like the map's lights (lbl_march.h), a record's irradiance from it is
 * 4 pi / 48 L(the point where the ray from the record along w_k leaves the grid) times T; its
 * first scattering is read toward the eye with the volume's own lobe (L_s: VolumeInd; L_e:
 * VolumeDir, emission scattered once, as Cycles counts it) and the power it loses in each
 * cell goes to the lattice's source with the phase's cone shares, as the lights' does.
 *
 * What it leaves out: light that crosses between groups more than once (one exchange, from
 * each group's lighting without the others' light), the sender's diffused light at its lobe
 * (isotropic), and light entering by another face than its direction's (the face's nearest
 * block stands in: a record near a side wall whose ray toward w_k leaves by the side). */
#ifndef VSD_LBL_EXCHANGE_H
#define VSD_LBL_EXCHANGE_H
#include <stdint.h>
#include "vsd/status.h"
#include "kernel/kernel_record_grids.h"

#define VSD_LBL_EXCHANGE_DIRS 48

/* The receiving lattice: its cells in the index space of its record grid. */
typedef struct vsd_lbl_exchange_grid {
    int32_t res[3];
    vsd_affine world_to_grid;
    vsd_affine grid_to_world;
} vsd_lbl_exchange_grid;

/* One kept direction: w (world, unit, toward the senders), the face its rays leave the
 * grid by (2a: low a, 2a + 1: high a), the face's blocks and their radiance along -w. */
typedef struct vsd_lbl_exchange_light {
    vsd_f3 w;
    int face, nb[2];
    float *ls, *le;           /* [nb[1]][nb[0]][3]: scattered, emitted */
} vsd_lbl_exchange_light;

typedef struct vsd_lbl_exchange {
    vsd_lbl_exchange_grid grid;
    int count;
    int emits;                /* some L_e > 0 */
    float domega;             /* 4 pi / VSD_LBL_EXCHANGE_DIRS */
    vsd_lbl_exchange_light light[VSD_LBL_EXCHANGE_DIRS];
} vsd_lbl_exchange;

/* The radiance reaching the faces of g from the volumes in `sources` (bit j: volume j,
 * whose record grid is senders->grid[j]), marched with step `step` (world units), into *x
 * (freed first; empty when nothing is seen). Returns VSD_ERR_NOMEM, or VSD_OK. */
vsd_status vsd_lbl_exchange_gather(const vsd_krecord_grids *senders, uint32_t sources, const vsd_lbl_exchange_grid *g,
                                   float step, int threads, vsd_lbl_exchange *x, char *err, size_t errlen);

/* Light k's radiance at grid point q (cell units) of x's grid: the face's bilinear mean where
 * the ray from q along w leaves the grid by that face (clamped to it), scattered into *ls and
 * emitted into *le. */
void vsd_lbl_exchange_radiance(const vsd_lbl_exchange *x, int k, vsd_f3 q, vsd_f3 *ls, vsd_f3 *le);

void vsd_lbl_exchange_free(vsd_lbl_exchange *x);

#endif
