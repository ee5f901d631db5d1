/* lbl_lattice.h — the diffusion pass of Bernabei et al. 2012 (§III-C): lattice-Boltzmann
 * lighting (Geist et al. 2004) on the D3Q6 lattice, one node per cell.
 *
 * Each node holds the photon density f_i arriving along each of the six axis directions
 * c_i (RGB). One step collides every node with eq. 4-5's matrix and streams the result one
 * cell along c_i:
 *     f_i(r + c_i, t + 1) = (1 - p) f_i(r, t) + (albedo p / 6) sum_j f_j(r, t) + S(r) / 6
 * (with an anisotropic phase, vsd_lbl_lattice_set_phase: albedo p sum_j P_ij f_j + S_i(r),
 * P_ij the forward, backward or side share)
 * where p = 1 - exp(-sigma_t lambda) is the node's collision probability per step (the
 * paper's sigma_t, taken as a probability so thick cells stay stable) and the paper's rest
 * population f_0 — the absorbed part, (1 - albedo) p sum_j f_j — is dropped, not re-emitted:
 * with eq. 5 as printed, Theta_i0 = 1/6 would send it back out, which conserves energy for
 * any albedo and turns absorption into delayed scattering. So a step with albedo 1 (or p =
 * 0) conserves the photons inside the lattice, and one with albedo < 1 loses exactly the
 * absorbed part (tests/test_lbl.c). S is the light the marching pass deposited, injected
 * isotropically every step; populations that stream out of the lattice are gone (vacuum).
 *
 * Iterated to the steady state, the photons in a node's cell summed over the directions
 * (the paper's cell light: sum_i f_i; with the path in the cell, the cell means of
 * vsd_lbl_lattice_node_means) are the fluence there times the cell's cross-section: with S
 * in watts (the power the node scatters out of the direct beams, or emits), phi = that sum
 * / lambda^2. Convergence watches, as the paper does, the fluence
 * of a sparse set of probe nodes (every 7th node), every 8 steps — the sum of the probes'
 * absolute changes over their summed fluence, so light moving between probes counts —; it
 * stops when the change still to come — the last window's change plus its geometric continuation at the
 * ratio of the last two windows' changes — is below `tolerance` (relative), or after
 * `max_steps` steps. (The paper's test, the last change alone, stops a warm start long
 * before the new steady state.) The last state warm-starts the next solve (a lighting
 * edit). */
#ifndef VSD_LBL_LATTICE_H
#define VSD_LBL_LATTICE_H
#include <stdint.h>
#include "vsd/status.h"
#include "lbl_blocked.h"
#include "lbl_d3q18.h"

/* Which lattice: the global D3Q6 (all zero), the paper's blocks, or Geist's D3Q18. */
typedef struct vsd_lbl_layout {
    int block_steps;         /* n > 0: 4^3 blocks with interface buffers, n steps per
                                iteration (lbl_blocked.h) */
    int d3q18;               /* 1: 18 directions (lbl_d3q18.h); not with blocks */
} vsd_lbl_layout;

typedef struct vsd_lbl_lattice {
    int32_t res[3];
    size_t cells;
    float *f;                /* [6 directions][3 channels][cells] arriving densities (warm state);
                                NULL when blocked */
    vsd_lbl_layout layout;
    vsd_lbl_blocked blocked; /* when layout.block_steps > 0 */
    vsd_lbl_q18 q18;         /* when layout.d3q18 */
    /* The scattering between directions (global D3Q6 only; vsd_lbl_lattice_set_phase):
     * of the light a collision scatters, the share that keeps its direction, that turns
     * back, and that goes into each of the four sides. Isotropic: 1/6 each (then the
     * source is [3][cells], injected a sixth per direction); else the source is
     * [6][3][cells], per direction. */
    int anisotropic;
    float forward, backward, side;
    int cell_light;          /* VSD_LBL_CELL_*, global D3Q6 only (vsd_lbl_lattice_set_cell_light) */
    double shape[3];         /* each axis's cell edge over the cube-equivalent edge (product 1; path only) */
    const float *keep;       /* [cells] or NULL (vsd_lbl_lattice_set_keep; the caller's array) */
    const float *albedo_cells; /* [3][cells] or NULL (vsd_lbl_lattice_set_albedo_cells) */
    int order;               /* VSD_LBL_ORDER_*, global D3Q6 only (vsd_lbl_lattice_set_order) */
} vsd_lbl_lattice;

/* The light in a cell (global D3Q6 only): the paper's step (FACES: photons counted at the
 * face they arrive at, what is born in the cell — scattered or the source — leaves it
 * whole), or each photon's path through the cell (PATH: vsd_lbl_lattice_node_means). */
enum { VSD_LBL_CELL_FACES = 0, VSD_LBL_CELL_PATH = 1 };

/* The order of a step's nodes (global D3Q6 only): every node from the last step's
 * populations at once (JACOBI, the paper's lattice-Boltzmann step, and the lattice's own
 * until set), or the rows of nodes in turn, each colliding with what the rows before it
 * sent it in the same step (GAUSS_SEIDEL, lbl_lattice.c: the same steady state in
 * a quarter to a third fewer steps). */
enum { VSD_LBL_ORDER_JACOBI = 0, VSD_LBL_ORDER_GAUSS_SEIDEL = 1 };
void vsd_lbl_lattice_set_order(vsd_lbl_lattice *l, int order);

typedef struct vsd_lbl_diffusion_stats {
    int steps;
    int converged;
    double change;           /* estimated relative change still to come at the stop */
    double seconds;
} vsd_lbl_diffusion_stats;

/* Allocates (zero state) or keeps the lattice when res and layout are unchanged; layout
 * NULL = the global D3Q6 lattice. */
vsd_status vsd_lbl_lattice_init(vsd_lbl_lattice *l, const int32_t res[3], const vsd_lbl_layout *layout, char *err,
                                size_t errlen);
void vsd_lbl_lattice_free(vsd_lbl_lattice *l);

/* The phase on the lattice (lbl_readout.h, vsd_lbl_readout_lattice_phase): forward +
 * backward + 4 side = 1. All three 1/6 (or a blocked or D3Q18 lattice) = isotropic, the
 * paper's. Call after vsd_lbl_lattice_init, which resets it. */
void vsd_lbl_lattice_set_phase(vsd_lbl_lattice *l, float forward, float backward, float side);

/* The source per direction, [6][3][cells], whatever the phase (global D3Q6 only): light
 * that enters through the lattice's faces has a direction even where the medium scatters
 * isotropically (lbl_exchange.h). Call after vsd_lbl_lattice_set_phase. */
void vsd_lbl_lattice_set_source_per_direction(vsd_lbl_lattice *l);

/* VSD_LBL_CELL_FACES (the paper's, and what vsd_lbl_lattice_init leaves) or _PATH; call
 * after vsd_lbl_lattice_init. */
void vsd_lbl_lattice_set_cell_light(vsd_lbl_lattice *l, int cell_light);

/* keep[cells] (the caller's, alive while the lattice steps; NULL = all 1): the share of
 * what is born in each cell — scattered or the source — that the lattice keeps, the rest
 * leaving the medium at once (lbl_escape.h; with the path in the cell only). */
void vsd_lbl_lattice_set_keep(vsd_lbl_lattice *l, const float *keep);

/* The cells' shape for the path in the cell: each axis's edge over the cube-equivalent
 * edge V^(1/3) (their product 1; NULL = cubes, what vsd_lbl_lattice_init leaves). The
 * collision probabilities the steps are given are the cube-equivalent cell's, 1 -
 * e^-(sigma V^(1/3)); a photon moving along axis a crosses sigma V^(1/3) shape[a]. */
void vsd_lbl_lattice_set_cell_shape(vsd_lbl_lattice *l, const double shape[3]);

/* Each cell's own albedo, [3][cells] (the caller's array; NULL = the albedo the steps are
 * given, for every cell): where several volumes of different albedo share the lattice's
 * cells, the scattering share of their summed extinction (src/grids/volume_groups.h). Read
 * by the global D3Q6 lattice with cell_light "path" (the default); the paper's faces, the
 * blocked and the D3Q18 lattices keep the one albedo. */
void vsd_lbl_lattice_set_albedo_cells(vsd_lbl_lattice *l, const float *albedo_cells);

/* `steps` collide-and-stream steps on the calling thread (for tests, and the steps while
 * the rays march; a blocked lattice does `steps` iterations): collide[c] = p per node,
 * albedo RGB, source [3][cells] (NULL = none; the global lattice reads it every step, the
 * blocked and D3Q18 lattices copy it once per call: a source still being deposited counts
 * as it grows, per step or per call). */
void vsd_lbl_lattice_steps(vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source,
                           int steps);

/* The same steps in several runs without preparing the material again each time (the
 * cells' exits, the scratch: the steps while the rays march, a run per round): new with
 * the material (l's phase, cell light, shape and keep set before; collide, albedo and
 * source read as by vsd_lbl_lattice_steps and alive until free), then runs of `steps` on
 * `threads` CPU threads (a run's status: cancelled). */
typedef struct vsd_lbl_stepper vsd_lbl_stepper;
vsd_status vsd_lbl_stepper_new(vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source,
                               vsd_lbl_stepper **out, char *err, size_t errlen);
vsd_status vsd_lbl_stepper_run(vsd_lbl_stepper *s, int steps, int threads);
void vsd_lbl_stepper_free(vsd_lbl_stepper *s);

/* Sum of all populations of channel ch (the photons in the lattice, with those waiting in
 * a blocked lattice's interface buffers). */
double vsd_lbl_lattice_total(const vsd_lbl_lattice *l, int ch);

/* The photons of global D3Q6 node c, channel ch, per direction i, with the same collide,
 * albedo and source as the steps. FACES: f_i, the population arriving at the face. PATH:
 * the photons' path in the cell toward i, in cube-equivalent cells: its collisions toward i
 * over x = sigma lambda — the arriving photons', the first collision's light that stays,
 * and the later births' (lbl_lattice.c, the comment above cell_axes). */
void vsd_lbl_lattice_node_means(const vsd_lbl_lattice *l, const float *collide, const float albedo[3],
                                const float *source, int ch, size_t c, float mean[6]);

/* Steps from the current state until converged; fluence[3][cells] = the cell means of the
 * photons summed over the directions (vsd_lbl_lattice_node_means; the caller divides by
 * lambda^2; on D3Q18 sum_i |c_i| f_i). stats->steps counts lattice steps
 * (block_steps per iteration of a blocked lattice). */
vsd_status vsd_lbl_diffuse(vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source,
                           double tolerance, int max_steps, int threads, float *fluence, vsd_lbl_diffusion_stats *stats,
                           char *err, size_t errlen);

#endif
