/* df3.h — POV-Ray density files: a vsd grid as 16-bit normalised voxels.
 *
 * Format (POV-Ray 3.x "df3"): three big-endian uint16 sizes nx, ny, nz, then nx*ny*nz
 * big-endian uint16 values, x fastest, then y, then z. POV-Ray reads value/65535.
 *
 * Placement. With `interpolate 1` POV-Ray 3.7 puts df3 voxel n at u = n/S of the unit box
 * and interpolates linearly from voxel S-1 towards voxel 0 (it wraps; measured with
 * POV-Ray 3.7.0.10, docs/povray.md). vsd's field is trilinear between voxel centres at
 * integer index coordinates and 0 one voxel beyond the last stored one. So the encoder
 * keeps one zero voxel on every side of the grid's non-zero voxels: then u in [0,1] maps
 * to index i = index_min + S*u and POV's field equals vsd's on the whole box (the wrapped
 * last cell interpolates between two zeros). */
#ifndef VSD_PIPELINE_DF3_H
#define VSD_PIPELINE_DF3_H
#include <stddef.h>
#include <stdint.h>
#include "vsd/status.h"
#include "vsd/volume.h"

typedef struct vsd_df3 {
    int size[3];            /* voxels per axis, 2..65535 */
    int32_t index_min[3];   /* vsd index coordinate of df3 voxel (0,0,0) */
    float scale;            /* grid value of 65535 (the grid's maximum; 0 = empty grid) */
    uint16_t *data;         /* [size x*y*z], x fastest, host order in memory */
    uint64_t negative;      /* voxels below 0 written as 0 (vsd's media are never negative) */
} vsd_df3;

/* The non-zero voxels of `vol` plus a zero border, value v stored as
 * round(65535 * v / max). An empty grid gives a 2x2x2 zero file at index 0, scale 0.
 * VSD_ERR_INVALID when the padded extent exceeds 65535 voxels on an axis. */
vsd_status vsd_df3_from_volume(const vsd_volume *vol, vsd_df3 *out, char *err, size_t errlen);

/* Grid value the df3 voxel (x,y,z) stands for: data * scale / 65535. */
float vsd_df3_value(const vsd_df3 *d, int x, int y, int z);

/* Row-major 4x4 (column vectors) from the unit box of POV-Ray's density_file to vsd
 * index space: i = index_min + size * u. */
void vsd_df3_box_to_index(const vsd_df3 *d, double m[16]);

/* Write via a temporary file renamed on success; errors name the path. */
vsd_status vsd_df3_write(const char *path, const vsd_df3 *d, char *err, size_t errlen);
/* Read a df3 (index_min 0, scale 1); errors name the path and what is wrong. */
vsd_status vsd_df3_read(const char *path, vsd_df3 *out, char *err, size_t errlen);
void vsd_df3_free(vsd_df3 *d);

#endif
