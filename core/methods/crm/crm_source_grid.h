/* crm_source_grid.h — J~(x) of eq. 7 on a coarse node grid, per lighting change.
 *
 * The paper interpolates the source radiance at every voxel from the RBF centres,
 * J~(x) = sum_l w_l B_l(x) J~(c_l) / D~(x), in a volume pass per frame of the view. The
 * SH coefficients of J~ are linear in the centres' coefficients, so the same weights can
 * be applied once per lighting change on a node grid a few voxels apart (J~ is smooth: it
 * is a blend of RBFs whose radii are 2-11 voxels at 128^3); the view march then reads the
 * nodes trilinearly (crm_kernel.h). Nodes where the RBFs give no density (D~ below
 * VSD_CRM_NODE_EMPTY of the largest weight) carry no radiance and are skipped by the
 * lookup, so the smoke's edge is not darkened by empty neighbours. */
#ifndef VSD_CRM_SOURCE_GRID_H
#define VSD_CRM_SOURCE_GRID_H
#include <stdint.h>
#include "vsd/status.h"
#include "crm_rbf.h"

#define VSD_CRM_NODE_EMPTY 1e-3

typedef struct vsd_crm_source_grid {
    float *nodes;          /* [count * CRM_NODE_FLOATS] (crm_kernel.h layout) */
    uint8_t *valid;        /* [count] */
    int32_t res[3];
    float spacing;         /* voxels between nodes; node (a,b,c) at crm-space (a,b,c) * spacing */
    double seconds;
} vsd_crm_source_grid;

/* Builds the grid over an nx x ny x nz dense grid. j_ss: count * 3 * ss_n2 (order-n SH per
 * centre and channel, crm_single.h), ss_n2 <= 16; j_ms: count * 3 * 4. g is overwritten. */
vsd_status vsd_crm_source_grid_build(const vsd_crm_rbfs *rbfs, const double *j_ss, int ss_n2, const double *j_ms,
                                     const int32_t dims[3], float spacing, vsd_crm_source_grid *g, char *err,
                                     size_t errlen);
void vsd_crm_source_grid_free(vsd_crm_source_grid *g);

#endif
