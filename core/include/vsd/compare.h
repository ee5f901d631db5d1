/* vsd/compare.h — image error metrics used by tests, the benchmark and `vsd compare`:
 * relative RMSE after a k x k block average (blocks tame Monte Carlo noise so that a
 * tolerance measures bias, not noise). Nothing is allocated for the caller. */
#ifndef VSD_COMPARE_H
#define VSD_COMPARE_H
#include "vsd/status.h"
#ifdef __cplusplus
extern "C" {
#endif

/* Planes a and b (width x height, `channels` interleaved, stride in floats between
 * pixels >= channels) are averaged over block x block tiles (partial edge tiles dropped),
 * then rel_rmse = sqrt(mean over blocks and channels of (A - B)^2) / mean(|B|).
 * Returns VSD_ERR_INVALID when no whole block fits or mean(|B|) is 0. */
vsd_status vsd_block_rel_rmse(const float *a, const float *b, int width, int height, int channels,
                              int stride, int block, double *rel_rmse, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
