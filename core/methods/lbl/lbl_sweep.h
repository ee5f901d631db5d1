/* lbl_sweep.h — the directional lights' transmittance to every cell centre by one sweep of
 * the cells per light (lbl's `light_march: "sweep"`, the default), in place of the paper's
 * parallel rays (lbl_march.h) whose cost is their steps, about one per cell and light, each
 * a trilinear splat of three sums onto eight cells through several megabytes of
 * accumulator.
 *
 * A light travelling along u (grid units) crosses the cells' layers across its dominant
 * axis a, one layer per 1/|u_a| of its path. The sweep keeps a ray in every slot of a
 * layer's plane (a cell apart on the other two axes) and carries it to the next layer,
 * where it lies u/|u_a| further across: the rays' lattice shifts by the fraction, and by a
 * whole slot when that passes 1, a ray coming in from beside the box with T 1. A ray's T
 * drops by the layer's optical depth, the segment's world length times the mean of sigma
 * where it crossed the two layers (sigma bilinear between the four centres around it, 0
 * beyond the box: the rays' march's taper). A cell's T is read from the four rays around
 * its centre, bilinearly, the weights the same for the whole layer: once, so a shadow is
 * as wide as the march's splat makes it at any depth (interpolating T itself from the last
 * layer, the first form, widened it by n f (1 - f) cells^2 after n layers; docs/methods/
 * lbl.md "The lights' march by sweeps" has both measured).
 *
 * The lost power (light_deposit "lost") of a cell is the loss of a beam through it at the
 * cell's own sigma, T e^{x/2} (1 - e^{-x}) / l = T 2 sinh(x / 2) / l with x = sigma l over
 * a layer's path l (world units), T at the centre: per E V, like sigma T in a thin cell, as
 * the march's. Point and spot lights, refraction and the ray history stay with the march. */
#ifndef VSD_LBL_SWEEP_H
#define VSD_LBL_SWEEP_H
#include "lbl_march.h"

/* The directional lights (kernel layout, 8 floats each) swept through g's cells (sigma, and
 * sigma2 as the second medium where it is set; g->refract must be NULL): out[m].trans[r *
 * light_count + k] and, where out[m].lost is set, out[m].lost[...] for each record r of
 * cell_record. VSD_OK, VSD_ERR_NOMEM or the CPU pool's cancellation, with err filled. */
vsd_status vsd_lbl_sweep_lights(const vsd_lbl_grid *g, const float *lights, int light_count, const int32_t *cell_record,
                                int32_t record_count, int threads, const vsd_lbl_march_out *out, char *err,
                                size_t errlen);

#endif
