/* kvolume_boxes.h — where a kernel volume's medium lies: its non-empty bricks' box in its
 * index space, its index <-> world maps in double precision, and boxes carried between
 * frames (the box of a box's eight transformed corners). Shared by the record grid over a
 * group of volumes (record_grid.c) and the volume groups (volume_groups.c). */
#ifndef VSD_KVOLUME_BOXES_H
#define VSD_KVOLUME_BOXES_H
#include "kernel/kernel_types.h"

/* The voxels along the longest and the shortest axis of v's brick box (8 per brick; 0 for
 * an empty volume): what the automatic record grids size their cells by. */
void vsd_kvolume_brick_extent(const vsd_kvolume *v, int *longest, int *shortest);
/* v's non-empty bricks' box in its index space; 0 when it has none. */
int vsd_kvolume_active_index_box(const vsd_kvolume *v, double lo[3], double hi[3]);
/* v's world -> index map as a 4x4, and its inverse (0 when singular). */
void vsd_kvolume_world_to_index_d(const vsd_kvolume *v, double w2i[16]);
int vsd_kvolume_index_to_world(const vsd_kvolume *v, double i2w[16]);
/* m (4x4 affine) applied to point p. */
void vsd_affine_apply_d(const double m[16], const double p[3], double out[3]);
/* Probe i (0 .. k^3 - 1, x fastest) of the k^3 cell centres of [lo, hi]: where the
 * record grid and the volume groups look for medium in a box. */
vsd_f3 vsd_box_probe(const double lo[3], const double hi[3], int k, int i);
/* The axis-aligned box of the eight corners of [lo, hi] under m. */
void vsd_affine_box(const double m[16], const double lo[3], const double hi[3], double out_lo[3], double out_hi[3]);

#endif
