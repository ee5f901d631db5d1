/* kernel_edt.h — the one-dimensional pass of the exact squared Euclidean distance
 * transform (Felzenszwalb & Huttenlocher 2012), shared by the CPU distance map
 * (src/grids/distance_map.c) and its CUDA pass (device/cuda/distance_map_cuda.cu), so
 * both build the same map. */
#ifndef VSD_KERNEL_EDT_H
#define VSD_KERNEL_EDT_H
#include "kernel_types.h"

#define VSD_EDT_INF 1e30f

/* 1D squared distance transform of f (n samples, VSD_EDT_INF = no parabola) into d, by
 * the lower envelope of the parabolas (q - p)^2 + f(p). v and z are scratch of n and
 * n + 1. Parabolas of infinite height are left out, so lines with no site stay at
 * VSD_EDT_INF and no infinity enters the intersection arithmetic. */
VSD_DEVICE void vsd_edt_line(const float *f, int32_t n, float *d, int32_t *v, double *z)
{
    int32_t q, k = -1;
    for (q = 0; q < n; q++) {
        double s;
        if (f[q] >= VSD_EDT_INF) continue;
        if (k < 0) {
            k = 0;
            v[0] = q;
            z[0] = -1e300;
            z[1] = 1e300;
            continue;
        }
        /* pop parabolas hidden by the new one; z[0] = -inf stops the loop at k = 0 */
        for (;;) {
            int32_t p = v[k];
            s = (((double)f[q] + (double)q * q) - ((double)f[p] + (double)p * p)) / (2.0 * (q - p));
            if (s <= z[k]) k--; else break;
        }
        k++;
        v[k] = q;
        z[k] = s;
        z[k + 1] = 1e300;
    }
    if (k < 0) {
        for (q = 0; q < n; q++) d[q] = VSD_EDT_INF;
        return;
    }
    k = 0;
    for (q = 0; q < n; q++) {
        while (z[k + 1] < q) k++;
        d[q] = (float)((double)(q - v[k]) * (q - v[k]) + f[v[k]]);
    }
}

/* Leap radius in voxels from a squared distance between cell centres: floor(D - sqrt(3)
 * - 1e-3), clamped to 0..255 (see src/grids/distance_map.h for why sqrt(3)). */
VSD_DEVICE uint8_t vsd_edt_skip(float d2)
{
    float r = d2 >= VSD_EDT_INF ? 255.0f : floorf(sqrtf(d2) - 1.7320508f - 1e-3f);
    return (uint8_t)(r <= 0.0f ? 0 : (r >= 255.0f ? 255 : (int32_t)r));
}

#endif
