/* distance_map.h — Navarro et al. §4.1: per cell of the volume's brick box, how far a ray
 * may leap without meeting medium, from an exact Euclidean distance transform.
 *
 * Cells, not voxels: cell c is the index-space cube [c, c+1]^3 (c relative to the box
 * origin); the trilinear field inside it reads only its 8 corner voxels, so it is
 * "occupied" when one of them has |value| > threshold, and anywhere outside occupied cells
 * the field is <= threshold (exactly 0 for threshold 0). With D(c) the distance from c's
 * centre to the nearest occupied cell's centre, every point of c is at least
 * D(c) - sqrt(3) from any occupied cell, so `skip` stores floor(D - sqrt(3) - 1e-3) voxels
 * (0..255): a ball of that radius (index units) around any point of the cell holds no
 * medium above the threshold. Per-brick max/min remain the coarse level: bricks whose
 * range is within the threshold are never read while building.
 *
 * The squared EDT is Felzenszwalb & Huttenlocher's lower envelope of parabolas, run
 * separably along x, y and z (exact, O(n) per line), lines spread over threads.
 *
 * Ownership: vsd_distance_map_build fills a caller-owned struct; vsd_distance_map_free
 * releases its array. */
#ifndef VSD_DISTANCE_MAP_H
#define VSD_DISTANCE_MAP_H
#include <stdint.h>
#include "vsd/status.h"
#include "vsd/volume.h"

typedef struct vsd_distance_map {
    uint8_t *skip;          /* [dims x*y*z], x fastest: safe leap radius in voxels */
    int32_t origin[3];      /* index coordinate of cell (0,0,0)'s lower corner (= volume origin) */
    int32_t dims[3];        /* cells per axis = 8 * brick_dims; 0,0,0 for an empty volume */
    int64_t occupied;       /* occupied cells */
    double seconds;         /* wall time of the build */
} vsd_distance_map;

/* Clears dm and lays it over vol's brick box (origin, dims); returns the cell count, 0 for
 * an empty volume. The CPU build and the GPU build (distance_map_device.h) start here. */
size_t vsd_distance_map_layout(const vsd_volume *vol, vsd_distance_map *dm);

/* threads: 0 = all cores. */
vsd_status vsd_distance_map_build(const vsd_volume *vol, float threshold, int threads, vsd_distance_map *dm,
                                  char *err, size_t errlen);
void vsd_distance_map_free(vsd_distance_map *dm);

/* Exact squared Euclidean distance (in cells) from every cell to the nearest cell with
 * occ != 0; 1e30 when there is none. d2 has dims[0]*dims[1]*dims[2] floats. Exposed for
 * tests. Returns 0 when out of memory. */
int vsd_edt_squared(const uint8_t *occ, const int32_t dims[3], float *d2, int threads);

#endif
