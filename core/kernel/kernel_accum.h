/* kernel_accum.h — how one sample result is added into a pixel's sums: the layout of the
 * per-pixel accumulation buffer (doubles, so thousands of samples add up without drift)
 * and the one add that the CPU tiles (src/render/accum.c) and the CUDA kernels both call,
 * so both backends sum the same values in the same order. */
#ifndef VSD_KERNEL_ACCUM_H
#define VSD_KERNEL_ACCUM_H
#include "kernel_types.h"

enum { VSD_ACC_DIR = 0, VSD_ACC_IND = 3, VSD_ACC_EMIT = 6, VSD_ACC_BG = 9, VSD_ACC_T = 12,
       VSD_ACC_DEPTH = 13, VSD_ACC_DEPTH_N = 14, VSD_ACC_N = 15 };

VSD_DEVICE void vsd_accum_add3(double *d, vsd_f3 v)
{
    d[0] += v.x;
    d[1] += v.y;
    d[2] += v.z;
}

/* p: the VSD_ACC_N sums of one pixel. */
VSD_DEVICE void vsd_accum_sample(double *p, const vsd_sample_result *r)
{
    vsd_accum_add3(p + VSD_ACC_DIR, r->direct);
    vsd_accum_add3(p + VSD_ACC_IND, r->indirect);
    vsd_accum_add3(p + VSD_ACC_EMIT, r->emit);
    vsd_accum_add3(p + VSD_ACC_BG, r->background);
    p[VSD_ACC_T] += r->transmittance;
    if (r->depth < VSD_INF) {
        p[VSD_ACC_DEPTH] += r->depth;
        p[VSD_ACC_DEPTH_N] += 1.0;
    }
}

#endif
