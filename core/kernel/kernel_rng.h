/* kernel_rng.h — counter-based random numbers: the stream of a pixel sample depends only
 * on (seed, pixel, sample index), so images are identical whatever the thread count, tile
 * order or device. PCG32 (O'Neill) seeded by a 64-bit mix of the three counters. */
#ifndef VSD_KERNEL_RNG_H
#define VSD_KERNEL_RNG_H
#include "kernel_types.h"

typedef struct vsd_rng { uint64_t state; uint64_t inc; } vsd_rng;

VSD_DEVICE uint64_t vsd_mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

VSD_DEVICE uint32_t vsd_rng_u32(vsd_rng *r)
{
    uint64_t old = r->state;
    uint32_t xorshifted, rot;
    r->state = old * 6364136223846793005ull + r->inc;
    xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

VSD_DEVICE vsd_rng vsd_rng_init(uint32_t seed, uint32_t pixel, uint32_t sample)
{
    vsd_rng r;
    r.state = vsd_mix64(((uint64_t)seed << 32) ^ pixel ^ vsd_mix64((uint64_t)sample + 0x9e3779b97f4a7c15ull));
    r.inc = (vsd_mix64((uint64_t)pixel * 0x632be59bd9b4e019ull + seed) << 1) | 1u;
    vsd_rng_u32(&r);
    return r;
}

/* Uniform in [0, 1): 24 random bits so the result is never rounded up to 1. */
VSD_DEVICE float vsd_rng_float(vsd_rng *r) { return (float)(vsd_rng_u32(r) >> 8) * (1.0f / 16777216.0f); }

#endif
