/* crm_sweep.h — the light arriving at every cell of a grid from one direction, in one
 * sweep over the cells (short characteristics), for crm's successive orders.
 *
 * Why: a gather that marches from every cell toward each direction reads the grid tens of
 * times per cell and direction (crm's orders: 1.1 s per order on smoke128's 122 k nodes,
 * most of a lighting change). The light a cell receives from direction w is the light its
 * upstream neighbour receives, attenuated over the step between them, plus what the
 * medium on that step adds; taken cell by cell from the far side, each cell reads one
 * step. The step runs from the cell to the plane of the next cells along the direction's
 * dominant axis, where the upstream light, extinction and source are interpolated
 * bilinearly from four cells already swept: exact where the direction is a grid axis, and
 * elsewhere it blurs a beam sideways by about the square root of the steps it has come (a
 * cell after four steps, two after sixteen), less than the 48 directions' own spacing at
 * that distance. */
#ifndef VSD_CRM_SWEEP_H
#define VSD_CRM_SWEEP_H
#include <stdint.h>

/* res: the grid (cell (i, j, k) at (k res[1] + j) res[0] + i); sigma: extinction per
 * world unit per cell; scatter: per cell 3 floats, the light the medium there scatters per
 * world unit toward the cells the sweep ends at (sigma J); emission: per cell 3 floats,
 * the light it emits per world unit, or NULL; v: the direction the
 * light comes from in cell units, of length 1; world_per_cell: the world length of one
 * cell's length along v. Writes radiance: per cell 3 floats, the light arriving there from
 * v (0 from outside the grid). */
void vsd_crm_sweep(const int32_t res[3], const float *sigma, const float *scatter, const float *emission,
                   const double v[3], double world_per_cell, float *radiance);

#endif
