/* lbl_escape.h — the light the D3Q6 lattice keeps in the medium that should leave it.
 *
 * A photon born in a cell (scattered, or the source) leaves the medium without another
 * collision with probability P = (1/4pi) integral of T(c -> outside, w) dw. On the lattice
 * it can leave only along the six axes: P_lattice = (1/6) sum over the axes of T. Deep in the
 * medium both are 0; at a flat surface P is 1/2 E_2(tau) for a birth at optical depth tau,
 * P_lattice (1/6) e^-tau: over the first optical depth the lattice lets out a third of the
 * light that leaves (docs/methods/lbl.md, "What a cell scatters out of the rays"). The
 * difference is what each birth there should lose to the outside besides what the lattice
 * carries out: keep = 1 - max(0, P - P_lattice), the share of each birth the lattice keeps
 * (lbl_lattice.h, vsd_lbl_lattice_set_keep).
 *
 * P from the 98 lattice vectors with components in [-2, 2] and no common factor, each
 * weighted by the solid angle of the directions nearest it (lbl_directions.h), T along
 * each from a sweep over the cells (optical depth from cell centre to cell centre with sigma
 * averaged, half a step to the box). (The 26 neighbours alone measured 0.12 against the
 * half-space's 0.21 at a face of thin cells: the sideways directions' cells straddle the
 * horizon.) Cells are `shape` (each axis's edge over the cube-equivalent edge; NULL = cubes). */
#ifndef VSD_LBL_ESCAPE_H
#define VSD_LBL_ESCAPE_H
#include <stdint.h>

/* keep[cells] from sigma[cells] (per world unit, x fastest) and the cube-equivalent cell edge
 * (world units), on `threads` (0 = all): each vector's sweep by rows of cells along x, whole
 * chains of them per thread (vsd_lbl_row_class), the same result on any thread count.
 * Returns 0 when out of memory. */
int vsd_lbl_escape_keep(const int32_t res[3], const float *sigma, double cell_world, const double *shape, int threads,
                        float *keep);

#endif
