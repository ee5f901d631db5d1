/* lbl_directions.h — the 98 lattice vectors lbl's sweeps over its cells follow: the surface
 * escape (lbl_escape.h) and the first flight (lbl_first_flight.h).
 *
 * The vectors with components in [-2, 2] whose components share no factor (the 26
 * neighbours and the knight's moves between them), so each direction once. A sweep along a
 * vector steps from a cell to the cell one vector away: the vector's lines of cells
 * partition the grid, and each cell owns one vector's length of its line. Each vector gets
 * the share of the sphere whose directions are nearest it (16384 Fibonacci points, in
 * world directions: cells that are not cubes stretch the vectors), and the share of it that
 * falls in each of the D3Q6 lattice's six cones (+x, -x, +y, -y, +z, -z: the axis with the
 * largest world component, split evenly where two or three tie). */
#ifndef VSD_LBL_DIRECTIONS_H
#define VSD_LBL_DIRECTIONS_H
#include <stdint.h>

enum { VSD_LBL_VECTORS = 98 };

typedef struct vsd_lbl_directions {
    int d[VSD_LBL_VECTORS][3];       /* the vector in cells */
    double len[VSD_LBL_VECTORS];     /* its world length in cube-equivalent cells */
    double share[VSD_LBL_VECTORS];   /* its solid angle over 4pi (the shares sum to 1) */
    double cone[VSD_LBL_VECTORS][6]; /* the lattice cones it falls in (each row sums to 1) */
} vsd_lbl_directions;

/* shape: each axis's cell edge over the cube-equivalent edge, or NULL for cubes. */
void vsd_lbl_directions_make(const double *shape, vsd_lbl_directions *dirs);

/* The order of a sweep that visits cell c - d before cell c (light moving along d): each
 * coordinate starts at the box's far side from d's sign and steps with it. A sweep that
 * needs c + d first (toward the outside along d) passes -d. Loop with
 * `for (z = start[2]; z >= 0 && z < res[2]; z += step[2])`, and the same for y and x. */
static inline void vsd_lbl_sweep_order(const int32_t res[3], const int d[3], int32_t start[3], int32_t step[3])
{
    int a;
    for (a = 0; a < 3; a++) start[a] = d[a] < 0 ? res[a] - 1 : 0, step[a] = d[a] < 0 ? -1 : 1;
}

#endif
