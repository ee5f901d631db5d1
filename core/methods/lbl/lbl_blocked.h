/* lbl_blocked.h — the paper's blocked diffusion lattice (Bernabei et al. 2012, §III-C, Fig. 5):
 * the same D3Q6 collide-and-stream as lbl_lattice.h, but the lattice is cut into blocks of
 * 4x4x4 nodes, each block stepped on its own, and the populations that leave a block go
 * through an interface buffer (6 faces x 4 x 4 nodes x RGB per block) that the neighbour
 * block reads at its next iteration. Two interface buffers alternate (written in one
 * iteration, read in the next), so blocks never read what another block is writing: the
 * GPU's one-block-per-SM scheme, here one block per CPU task with the block's 4.6 KB of
 * populations in L1.
 *
 * One iteration runs `block_steps` lattice steps inside every block. Populations crossing a
 * face wait in the buffer until the neighbour's next iteration: every face crossing takes
 * one extra step, and with more steps per iteration the buffer delivers a whole
 * iteration's outflow at once. The fluence is averaged over an iteration's steps (the
 * paper's irradiance volume accumulates it), and that average obeys the global lattice's
 * balance: the steady state is the global one to the convergence tolerance (tests/
 * test_lbl_lattice.c part 6, the paper's Fig. 6); what blocking costs is 1.2-1.7x the steps
 * (docs/methods/lbl.md). Nodes of the last blocks beyond the lattice's size are vacuum, as
 * outside the global lattice. */
#ifndef VSD_LBL_BLOCKED_H
#define VSD_LBL_BLOCKED_H
#include <stddef.h>
#include <stdint.h>
#include "vsd/status.h"

#define VSD_LBL_BLOCK 4

typedef struct vsd_lbl_blocked {
    int32_t res[3];          /* lattice nodes per axis */
    int32_t nb[3];           /* blocks per axis */
    size_t blocks;
    int block_steps;
    float *f;                /* [blocks][6 dirs][3 ch][64 nodes] arriving populations */
    float *iface[2];         /* [blocks][6 dirs][3 ch][16]: what left each face, per iteration */
    int parity;              /* iface[parity] was written by the last iteration */
    /* the material in block order, gathered from the caller's node order per solve */
    float *collide_b;        /* [blocks][64] */
    float *source_b;         /* [blocks][3][64], or NULL */
    float *fluence_b;        /* [blocks][3][64]: sum_i f_i averaged over the last iteration's steps */
} vsd_lbl_blocked;

/* Allocates (zero state) or keeps the lattice when res and block_steps are unchanged. */
vsd_status vsd_lbl_blocked_init(vsd_lbl_blocked *b, const int32_t res[3], int block_steps, char *err, size_t errlen);
void vsd_lbl_blocked_free(vsd_lbl_blocked *b);

/* The material for the next iterations, in the caller's node order (x fastest): collide[c]
 * = p per node, source [3][cells] or NULL (as vsd_lbl_lattice_steps). */
vsd_status vsd_lbl_blocked_set_material(vsd_lbl_blocked *b, const float *collide, const float *source, char *err,
                                        size_t errlen);

/* One iteration (block_steps steps in every block) over `threads` CPU threads. */
vsd_status vsd_lbl_blocked_iterate(vsd_lbl_blocked *b, const float albedo[3], int threads);

/* The photons at node c (caller's order) in channel ch: the sum of its arriving
 * populations, averaged over the last iteration's steps (the same as now for one step). */
float vsd_lbl_blocked_node_sum(const vsd_lbl_blocked *b, int ch, size_t c);

/* All photons of channel ch: in the nodes and waiting in the interface buffers. */
double vsd_lbl_blocked_total(const vsd_lbl_blocked *b, int ch);

#endif
