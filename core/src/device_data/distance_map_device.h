/* distance_map_device.h — the distance map of distance_map.h built on the frame's CUDA
 * device (the paper's per-frame GPU pass): the same map in the same struct, its array
 * copied back to the host so the CPU backend and the host-side statistics can read it. */
#ifndef VSD_DISTANCE_MAP_DEVICE_H
#define VSD_DISTANCE_MAP_DEVICE_H
#include "src/grids/distance_map.h"
#include "src/method/method.h"

/* vol is ctx->density (emission = 0) or ctx->emission (emission = 1). */
vsd_status vsd_distance_map_build_device(const vsd_frame_ctx *ctx, const vsd_volume *vol, int emission,
                                         float threshold, vsd_distance_map *dm, char *err, size_t errlen);

#endif
