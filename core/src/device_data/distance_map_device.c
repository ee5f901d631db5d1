#include "distance_map_device.h"
#include "device_frame.h"
#include <stdlib.h>
#include <string.h>
#include "src/common/clock.h"

vsd_status vsd_distance_map_build_device(const vsd_frame_ctx *ctx, const vsd_volume *vol, int emission,
                                         float threshold, vsd_distance_map *dm, char *err, size_t errlen)
{
    double t0 = vsd_clock_seconds();
    vsd_kvolume kv = emission ? ctx->kd.emission : ctx->kd.density;
    long long occupied = 0;
    size_t n = vsd_distance_map_layout(vol, dm);
    vsd_status st;
    if (n == 0) return VSD_OK;
    if (!(dm->skip = malloc(n)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a %dx%dx%d distance map", dm->dims[0], dm->dims[1],
                        dm->dims[2]);
    st = vsd_device_volume(ctx, vol, &kv, emission, err, errlen);
    if (!st) st = vsd_cuda_distance_map(ctx->cuda, &kv, threshold, dm->skip, &occupied, err, errlen);
    if (st) {
        vsd_distance_map_free(dm);
        return st;
    }
    dm->occupied = occupied;
    dm->seconds = vsd_clock_seconds() - t0;
    return VSD_OK;
}
