/* vsd/vdbio.h — OpenVDB files into vsd_volume (implemented in vdbio/, C++ behind this C API).
 * Ownership: vsd_vdb_load returns a volume the caller frees with vsd_volume_destroy;
 * vsd_vdb_list returns an array the caller frees with vsd_vdb_list_free. */
#ifndef VSD_VDBIO_H
#define VSD_VDBIO_H
#include <stdint.h>
#include "vsd/status.h"
#include "vsd/volume.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef struct vsd_grid_info {
    char name[256];
    char type[64];            /* OpenVDB value type: "float", "vec3s", "int32", ... */
    uint64_t active_voxels;
    int32_t index_bbox_min[3], index_bbox_max[3]; /* inclusive; min > max when empty */
    double world_bbox_min[3], world_bbox_max[3];
    double voxel_size[3];
    int half_float;           /* stored as 16-bit floats on disk */
    char compression[32];     /* "none", "zip", "blosc", ... as far as the file says */
} vsd_grid_info;

/* Which grid to load: by name (first match), or by index among all grids when
 * `index` >= 0 (for files whose grids share a name); name == NULL/"" and index < 0 picks the
 * first float grid. */
typedef struct vsd_grid_select {
    const char *name;  /* 0 = default */
    int index;         /* -1 = use name; set explicitly (0 is a valid index) */
} vsd_grid_select;

vsd_status vsd_vdb_list(const char *path, vsd_grid_info **grids, int *count,
                        char *err, size_t errlen);
void vsd_vdb_list_free(vsd_grid_info *grids);

/* What vsd_vdb_list says of the one grid `sel` picks, picked as vsd_vdb_load picks it (its
 * errors too), without reading the grid's voxels: for limits checked before loading (the
 * active voxel count the file states). */
vsd_status vsd_vdb_select_info(const char *path, vsd_grid_select sel, vsd_grid_info *out, char *err, size_t errlen);

/* Load one float (or half/double, converted) grid. Errors name the file and the problem:
 * missing file, not a VDB, truncated, no such grid (listing the grids present), not float. */
vsd_status vsd_vdb_load(const char *path, vsd_grid_select sel, vsd_volume **out,
                        char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
