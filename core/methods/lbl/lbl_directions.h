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

/* Light along d (or against it) reaches the row of cells along x at (y, z) from row
 * (y - d1, z - d2) alone (or y + d1, z + d2), shifted by d0 along it: the rows of one key
 * y d2 - z d1 form chains that no light leaves, so a sweep may deal whole chains to its
 * threads, each row then needing nothing from another thread. A vector along x (d1 = d2 = 0)
 * chains each row to itself. The row's class of `classes`: its key modulo them. */
static inline int vsd_lbl_row_class(const int d[3], int32_t y, int32_t z, int32_t ny, int classes)
{
    const int32_t key = d[1] == 0 && d[2] == 0 ? z * ny + y : y * d[2] - z * d[1];
    /* classes a power of two (vsd_lbl_row_classes): the key's low bits, negative keys too,
     * with no division per row */
    return (int)((uint32_t)key & (uint32_t)(classes - 1));
}

/* The rows of chain class c of `classes` of a sweep along `order` (the light's d, or -d for a
 * sweep that needs cell c + d first), in that sweep's order: row(user, y, z) for each. */
static inline void vsd_lbl_class_rows(const int32_t res[3], const int order[3], int classes, int c,
                                      void (*row)(void *user, int32_t y, int32_t z), void *user)
{
    int32_t start[3], step[3], y, z;
    vsd_lbl_sweep_order(res, order, start, step);
    for (z = start[2]; z >= 0 && z < res[2]; z += step[2])
        for (y = start[1]; y >= 0 && y < res[1]; y += step[1])
            if (vsd_lbl_row_class(order, y, z, res[1], classes) == c) row(user, y, z);
}

/* The classes a sweep on `threads` (resolved) deals out: a power of two, four or more a
 * thread, so a thread that finishes early takes another. */
static inline int vsd_lbl_row_classes(int threads)
{
    int c = 1;
    while (c < 4 * threads) c *= 2;
    return c;
}

#endif
