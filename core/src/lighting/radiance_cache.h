/* radiance_cache.h — a fast method's multiple-scattered light as `reference`'s cache
 * (issue 33): the host side of kernel/kernel_radiance_cache.h, built from a record grid's
 * per-record light after the method's lighting stage. */
#ifndef VSD_RADIANCE_CACHE_H
#define VSD_RADIANCE_CACHE_H
#include "kernel/kernel_radiance_cache.h"
#include "src/grids/record_grid.h"

typedef struct vsd_radiance_cache {
    vsd_kradiance_cache k;   /* k.p1 owned here; NULL = none */
} vsd_radiance_cache;

/* From D3Q6 cone radiances (cones: [records][6][3], the cones of the grid's axes +x, -x,
 * +y, -y, +z, -z, each the light moving into it, constant over the cube face of
 * directions whose largest component is that axis; lbl_readout.h), or from an isotropic
 * radiance (cones NULL, iso: [records][3]). The P1 fit keeps the cones' mean radiance and
 * their first moment: F = K sum_axes (L+ - L-) e_axis with K = the integral of w_x over
 * the +x face, 1.7408; B = 3 F / 4pi, carried to world axes along each grid axis's world
 * direction. Cells without a record read 0. */
vsd_status vsd_radiance_cache_from_records(const vsd_record_grid *rg, const float *cones, const float *iso,
                                           vsd_radiance_cache *out, char *err, size_t errlen);
/* From radiance in SH bands 0-1 on a grid of nodes (crm's): sh [nodes][3][4], per node
 * (x fastest) and colour channel the coefficients of the radiance as a function of the
 * direction the light travels, in kernel_sh.h's real basis; node (i, j, k) sits at world
 * node_to_world(i, j, k), and the cache reads the nodes trilinearly between them. The
 * radiance arriving from w travels along -w, so a = L_00 y_0 and B = sqrt(3 / 4pi)
 * (-L_11, -L_1-1, L_10). */
vsd_status vsd_radiance_cache_from_sh(const int32_t res[3], const vsd_affine *node_to_world, const float *sh,
                                      vsd_radiance_cache *out, char *err, size_t errlen);
void vsd_radiance_cache_free(vsd_radiance_cache *c);

#endif
