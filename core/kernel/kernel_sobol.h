/* kernel_sobol.h — stratified 2D points for a pixel's samples: the first two dimensions of
 * Sobol's sequence, a (0,2)-sequence (every prefix of 2^k points has one point in each of
 * any 2^k equal dyadic boxes of the square), Owen-scrambled by hashing (Burley 2020,
 * "Practical Hash-based Owen Scrambling": the Laine-Karras permutation), with the sample
 * index itself shuffled by the same scramble. Each (pixel, pair) gets its own seeds, so the
 * pairs of one sample are independent of each other and of the neighbouring pixels', while
 * the samples of one pixel and pair cover the square evenly: the 2D integrals a pixel
 * sample starts with (the lens position, the first light sample, the first scattering
 * direction) converge faster than with independent random numbers, and every point is
 * still uniformly distributed, so nothing is biased. Like kernel_rng.h the points depend
 * only on (seed, pixel, sample index, pair): the same on every thread count and device. */
#ifndef VSD_KERNEL_SOBOL_H
#define VSD_KERNEL_SOBOL_H
#include "kernel_rng.h"

VSD_DEVICE uint32_t vsd_reverse_bits(uint32_t x)
{
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* A random permutation of the bits below each bit (Laine and Karras 2011), on reversed
 * bits: Owen's nested uniform scramble, one per seed. */
VSD_DEVICE uint32_t vsd_owen_scramble(uint32_t x, uint32_t seed)
{
    x = vsd_reverse_bits(x);
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return vsd_reverse_bits(x);
}

/* Sobol's first two dimensions at index i, as 32-bit fractions: the first is i's bits
 * reversed (van der Corput), the second uses the direction numbers of x + 1. */
VSD_DEVICE void vsd_sobol2(uint32_t i, uint32_t *a, uint32_t *b)
{
    uint32_t v = 1u << 31, r = 0;
    *a = vsd_reverse_bits(i);
    for (; i; i >>= 1, v ^= v >> 1)
        if (i & 1u) r ^= v;
    *b = r;
}

/* Point `sample` of pixel `pixel`'s pair `pair` in [0, 1)^2. */
VSD_DEVICE void vsd_sobol_pair(uint32_t seed, uint32_t pixel, uint32_t sample, uint32_t pair, float *u, float *v)
{
    uint64_t h = vsd_mix64(((uint64_t)seed << 32 ^ pixel) * 0x9e3779b97f4a7c15ull + pair);
    uint32_t a, b, i = vsd_owen_scramble(sample, (uint32_t)h);
    vsd_sobol2(i, &a, &b);
    h = vsd_mix64(h);
    a = vsd_owen_scramble(a, (uint32_t)h);
    b = vsd_owen_scramble(b, (uint32_t)(h >> 32));
    /* 24 bits, so that the result is never rounded up to 1 */
    *u = (float)(a >> 8) * (1.0f / 16777216.0f);
    *v = (float)(b >> 8) * (1.0f / 16777216.0f);
}

#endif
