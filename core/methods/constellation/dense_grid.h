/* dense_grid.h — a dense copy of a brick grid over the distance map's cells, the CPU
 * stand-in for the 3D texture the paper samples (Navarro et al. 2009, §4).
 *
 * Why: the shadow rays are the method's hot loop (64 lights x ~100 samples per lit view
 * sample), and inside the smoke the distance map cannot leap; there each sample is one
 * trilinear lookup. Through the brick index that costs a brick-slot load, a boundary test
 * and, one cell in eight per axis, eight separate brick lookups. The dense copy reads the
 * eight corners at fixed strides from one base address, and the kernel shares the cell
 * index it computes with the distance-map lookup (same cells, same origin).
 *
 * Layout: cell c (0 <= c < dims, relative to origin, as in distance_map.h) reads the
 * voxels origin + c + {0,1}^3, so `v` holds (dims+1) voxels per axis, x fastest; voxels
 * outside stored bricks are 0. The values are copies, so a lookup through it returns the
 * same float as vsd_kvolume_field (tested). Rebuilt per volume frame like the distance map.
 *
 * Shadow code, one byte per cell, read before the corners: 0 = sample the cell; c >= 1 =
 * the sample needs no lookup and the ray may leap c - 1 voxels. A cell whose 8 corners
 * all have |v| <= threshold gets at least 1: the distance map's own notion of empty
 * (distance_map.h), applied to the sample itself where the map's radius is 0. At
 * threshold 0 that means all corners exactly 0, the field is +0 there and skipping the
 * sample changes no bit (17% of the shadow samples on smoke64 frame 24 fell in such cells
 * next to the smoke). With a distance map the code is min(255, skip + 1) wherever the map
 * promises a leap (skip >= 1), so one byte serves both.
 *
 * Ownership: vsd_dense_grid_build fills a caller-owned struct; vsd_dense_grid_free
 * releases its array. */
#ifndef VSD_DENSE_GRID_H
#define VSD_DENSE_GRID_H
#include <stdint.h>
#include "vsd/status.h"
#include "vsd/volume.h"
#include "src/grids/distance_map.h"

/* Above this many voxels the copy is not made (v stays NULL) and kernels read the bricks:
 * 2^27 floats = 512 MiB, beyond any volume in ../shared/data. */
#define VSD_DENSE_GRID_MAX_VOXELS (1ull << 27)

typedef struct vsd_dense_grid {
    float *v;               /* [(dims[0]+1) * (dims[1]+1) * (dims[2]+1)], x fastest; NULL = none */
    uint8_t *code;          /* [dims x*y*z], x fastest: the shadow code above; NULL with v */
    int32_t origin[3];      /* index coordinate of cell (0,0,0) = the volume's origin */
    int32_t dims[3];        /* cells per axis = 8 * brick_dims */
    double seconds;         /* wall time of the build */
} vsd_dense_grid;

/* dm: the distance map of the same volume (same origin and dims), or NULL for no leaps;
 * threshold: the map's density threshold (0 without a map: only exact zeros are skipped).
 * An empty volume, or one above VSD_DENSE_GRID_MAX_VOXELS, gives v = code = NULL and
 * VSD_OK; a dm over other cells or a negative threshold is an error. */
vsd_status vsd_dense_grid_build(const vsd_volume *vol, const vsd_distance_map *dm, float threshold, vsd_dense_grid *g,
                                char *err, size_t errlen);
void vsd_dense_grid_free(vsd_dense_grid *g);

#endif
