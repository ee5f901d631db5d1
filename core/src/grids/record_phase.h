/* The phase weights of many directions toward one, in a loop the compiler vectorises:
 * the per-view bake's inner loop (record_grid.c). */
#ifndef VSD_GRIDS_RECORD_PHASE_H
#define VSD_GRIDS_RECORD_PHASE_H
#include "kernel/kernel_types.h"
#include <stdint.h>

/* pk[s] = vsd_hg_eval(d . (dx[s], dy[s], dz[s]), g) for s < n: the same operations in the
 * same order as the scalar function, so the same bits (record_phase.c). */
void vsd_hg_eval_many(const float *dx, const float *dy, const float *dz, int32_t n, vsd_f3 d, float g, float *pk);
#endif
