/* kernel_radiance_cache.h — a fast method's multiple-scattered light as `reference`'s
 * control variate (issue 33, `render.options.cache`; docs/methods/reference.md).
 *
 * The cache holds, per cell centre of a grid over the medium, a first-order (P1) fit of
 * the radiance of light that has scattered at least once, as the radiance arriving at x
 * from direction w (w pointing away from x, the way a path continues to fetch it):
 *     c(x, w) = a(x) - B(x) . w      (per colour channel; B is the fit's flux term along
 *                                     the light's travel, hence the minus sign)
 * trilinear between cell centres, 0 outside the grid. For a path that arrived at x moving
 * along d and continues along w drawn from Henyey-Greenstein about d, E[w] = g d exactly,
 * so the cache's phase-weighted mean is known in closed form:
 *     m(x, d) = E_w[c(x, w)] = a(x) - g B(x) . d.
 * The path tracer adds m and subtracts c(x, w) along the w it drew: zero in expectation,
 * whatever a and B hold, so the cache changes the variance and never the mean. */
#ifndef VSD_KERNEL_RADIANCE_CACHE_H
#define VSD_KERNEL_RADIANCE_CACHE_H
#include <stddef.h>
#include "kernel_types.h"

enum { VSD_CACHE_FLOATS = 12 };   /* per cell: a[3], then B's x, y, z components, each [3] (RGB) */

typedef struct VSD_ALIGN16 vsd_kradiance_cache {
    const float *p1;              /* [dims x*y*z][VSD_CACHE_FLOATS], cell (i,j,k) at x-fastest order */
    vsd_affine world_to_grid;     /* cell (i,j,k) spans [i, i+1) x ..., centre at +0.5 */
    int32_t dims[3];
    /* Russian roulette on the difference (reference_kernel.h): from the second scattering
     * on, a path goes on with probability min(1, survival x its largest throughput) */
    float survival;
} vsd_kradiance_cache;

/* The fit at world point p, trilinear between cell centres (cells outside the grid read 0). */
VSD_DEVICE void vsd_cache_eval(const vsd_kradiance_cache *c, vsd_f3 p, float out[VSD_CACHE_FLOATS])
{
    vsd_f3 q = vsd_affine_point(&c->world_to_grid, p);
    float fx = q.x - 0.5f, fy = q.y - 0.5f, fz = q.z - 0.5f;
    int32_t i0 = (int32_t)floorf(fx), j0 = (int32_t)floorf(fy), k0 = (int32_t)floorf(fz), corner, n;
    float tx = fx - (float)i0, ty = fy - (float)j0, tz = fz - (float)k0;
    for (n = 0; n < VSD_CACHE_FLOATS; n++) out[n] = 0.0f;
    if (!(fx > -1.0f && fy > -1.0f && fz > -1.0f && fx < (float)c->dims[0] && fy < (float)c->dims[1] &&
          fz < (float)c->dims[2]))
        return;   /* (also a NaN point) */
    for (corner = 0; corner < 8; corner++) {
        int32_t i = i0 + (corner & 1), j = j0 + ((corner >> 1) & 1), k = k0 + ((corner >> 2) & 1);
        float w = ((corner & 1) ? tx : 1.0f - tx) * (((corner >> 1) & 1) ? ty : 1.0f - ty) *
                  (((corner >> 2) & 1) ? tz : 1.0f - tz);
        const float *v;
        if (i < 0 || j < 0 || k < 0 || i >= c->dims[0] || j >= c->dims[1] || k >= c->dims[2] || w == 0.0f) continue;
        v = c->p1 + (size_t)VSD_CACHE_FLOATS * (((size_t)k * c->dims[1] + j) * c->dims[0] + i);
        for (n = 0; n < VSD_CACHE_FLOATS; n++) out[n] += w * v[n];
    }
}

/* c(x, w): the cached radiance arriving from direction w (unit). */
VSD_DEVICE vsd_f3 vsd_cache_radiance(const float f[VSD_CACHE_FLOATS], vsd_f3 w)
{
    return f3(f[0] - (f[3] * w.x + f[6] * w.y + f[9] * w.z), f[1] - (f[4] * w.x + f[7] * w.y + f[10] * w.z),
              f[2] - (f[5] * w.x + f[8] * w.y + f[11] * w.z));
}

/* m(x, d): its mean over w drawn from HG(g) about the arriving direction d. */
VSD_DEVICE vsd_f3 vsd_cache_phase_mean(const float f[VSD_CACHE_FLOATS], vsd_f3 d, float g)
{
    return vsd_cache_radiance(f, f3_scale(d, g));
}

#endif
