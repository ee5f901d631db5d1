/* vsd/volume.h — a scalar volume in memory: the sparse brick grid of docs/architecture.md §9.
 *
 * Layout. Voxel (i,j,k) of the source grid holds the value at index coordinate (i,j,k);
 * between voxel centres the field is trilinear; outside stored bricks it is 0. Bricks are
 * 8^3 voxels (OpenVDB's leaf size). Brick cell (bx,by,bz) covers index voxels
 * origin + 8*(bx,by,bz) ... +7 on each axis. `brick_slots` maps a brick cell (x fastest) to
 * its slot in `voxels` (512 floats per slot, x fastest inside the brick) or -1 when the
 * brick is empty (all zero). `brick_min`/`brick_max` hold, per brick cell, the range of the
 * trilinear field over the cell's continuous extent [8b, 8b+8) — i.e. over its own voxels
 * plus the +1 neighbour layer — so brick_max is a valid majorant for delta tracking and
 * brick_max == 0 marks skippable empty space.
 *
 * Ownership: a vsd_volume is created by vsd_volume_create_dense() or a loader
 * (vsd/vdbio.h) and freed by vsd_volume_destroy(), which frees every array in it. */
#ifndef VSD_VOLUME_H
#define VSD_VOLUME_H
#include <stdint.h>
#include "vsd/status.h"
#ifdef __cplusplus
extern "C" {
#endif

#define VSD_BRICK_SIZE 8
#define VSD_BRICK_VOXELS 512

typedef struct vsd_volume {
    int32_t origin[3];       /* index coord of voxel 0 of brick cell (0,0,0); multiple of 8 */
    int32_t brick_dims[3];   /* brick cells per axis; all 0 for an empty grid */
    int32_t brick_count;     /* stored (non-empty) bricks */
    int32_t *brick_slots;    /* [dims x*y*z] slot or -1 */
    float *voxels;           /* [brick_count * 512] */
    float *brick_min;        /* [dims x*y*z] */
    float *brick_max;        /* [dims x*y*z] */
    double index_to_world[16]; /* row-major 4x4, column-vector convention: w = M * (i,j,k,1) */
    double voxel_size[3];    /* world length of one index step along each index axis */
    uint64_t active_voxels;  /* as reported by the source grid */
    float value_min, value_max; /* over stored voxels (0,0 when empty) */
    char grid_name[256];
    char file[1024];
} vsd_volume;

/* Build a volume from a dense array dims[0]*dims[1]*dims[2] (x fastest) whose voxel (0,0,0)
 * sits at index coordinate index_min; zero bricks are dropped. index_to_world may be NULL
 * (identity). Used by tests, synthetic scenes and methods that need dense data. */
vsd_status vsd_volume_create_dense(const float *values, const int32_t dims[3],
                                   const int32_t index_min[3], const double index_to_world[16],
                                   vsd_volume **out, char *err, size_t errlen);

/* An empty volume (renders as empty space). */
vsd_status vsd_volume_create_empty(const double index_to_world[16], vsd_volume **out,
                                   char *err, size_t errlen);

/* Recompute brick_min/brick_max/value_min/value_max from the voxels (loaders call this). */
/* VSD_ERR_FORMAT when a stored voxel is NaN or infinite, with a message naming the file, the
 * grid, the count and the first such voxel's index and value. Every loader calls it (a NaN
 * majorant would make delta tracking run without bound or poison the image), and so does
 * vsd_volume_create_dense. */
vsd_status vsd_volume_check_finite(const vsd_volume *vol, char *err, size_t errlen);
void vsd_volume_update_ranges(vsd_volume *vol);

/* Voxel value at integer index coordinate (0 outside stored bricks). */
float vsd_volume_voxel(const vsd_volume *vol, int32_t i, int32_t j, int32_t k);

/* Trilinear value at continuous index coordinate. */
float vsd_volume_sample_index(const vsd_volume *vol, const double p[3]);

/* World-space bounding box of the stored bricks (empty volume: min > max). */
void vsd_volume_world_bounds(const vsd_volume *vol, const double object_matrix[16],
                             double lo[3], double hi[3]);

void vsd_volume_destroy(vsd_volume *vol);

/* 4x4 row-major matrices (volume.matrix, index_to_world, the camera's): c = a * b (c may
 * be a or b); the inverse returns 0 when m is singular. */
void vsd_mat4_mul(const double a[16], const double b[16], double c[16]);
int vsd_mat4_invert(const double m[16], double inv[16]);

#ifdef __cplusplus
}
#endif
#endif
