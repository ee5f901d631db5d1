/* kernel_env.h — environment lookup and importance sampling, mapped exactly as Cycles'
 * Environment Texture (equirectangular) behind a Mapping node rotating about Z:
 *   d' = Rz(rotation) d,  u = 0.5 - atan2(d'.y, d'.x) / (2 pi),  v = 1 - acos(d'.z) / pi.
 * Image row 0 is v = 1 (straight up). Lookup is bilinear between texel centres (Blender's
 * default "Linear": wrapping in u, clamped at the poles) or nearest-texel ("Closest").
 *
 * Sampling: texel (col,row) is chosen with probability w / W, w = sin(theta at the row
 * centre) times the texel's luminance (Closest) or the integral of the interpolated
 * luminance over the texel (Linear, kernel_setup.h); inside the texel (c, r) is uniform, so
 * the solid-angle pdf is p = (w / W) * width * height / (2 pi^2 sin theta). That is the
 * density the directions are drawn from in both modes, and a sample's radiance is the map
 * evaluated at its direction, so L / p and the MIS weights stay exact. */
#ifndef VSD_KERNEL_ENV_H
#define VSD_KERNEL_ENV_H
#include "kernel_types.h"

/* World direction -> texture coordinates: u in [0,1) across, r in [0,1] down from the top
 * row (the rotation applied). */
VSD_DEVICE void vsd_env_uv(const vsd_kenv *e, vsd_f3 d, float *u, float *r, float *sin_theta)
{
    float x = e->cos_rot * d.x - e->sin_rot * d.y;
    float y = e->sin_rot * d.x + e->cos_rot * d.y;
    float z = vsd_clampf(d.z, -1.0f, 1.0f);
    float uu = 0.5f - atan2f(y, x) * (1.0f / (2.0f * VSD_PI));
    *u = uu - floorf(uu);
    *r = acosf(z) * (1.0f / VSD_PI); /* 0 at the top row */
    if (sin_theta) *sin_theta = sqrtf(vsd_maxf(0.0f, 1.0f - z * z));
}

/* Texture coordinates -> the texel they fall in. */
VSD_DEVICE int32_t vsd_env_texel_at(const vsd_kenv *e, float u, float r)
{
    int32_t col = (int32_t)(u * (float)e->width), row = (int32_t)(r * (float)e->height);
    if (col >= e->width) col = e->width - 1;
    if (col < 0) col = 0;
    if (row >= e->height) row = e->height - 1;
    if (row < 0) row = 0;
    return row * e->width + col;
}

/* Texture-space direction (rotation applied) -> texel index. */
VSD_DEVICE int32_t vsd_env_texel(const vsd_kenv *e, vsd_f3 d, float *sin_theta)
{
    float u, r;
    vsd_env_uv(e, d, &u, &r, sin_theta);
    return vsd_env_texel_at(e, u, r);
}

VSD_DEVICE vsd_f3 vsd_env_texel_rgb(const vsd_kenv *e, int32_t idx)
{
    const float *p = e->rgb + 3 * (size_t)idx;
    return f3(p[0] * e->strength, p[1] * e->strength, p[2] * e->strength);
}

/* The map at texture coordinates (u, r), interpolated as e->linear says. */
VSD_DEVICE vsd_f3 vsd_env_lookup(const vsd_kenv *e, float u, float r)
{
    float x, y, fx, fy;
    int32_t x0, x1, y0, y1;
    vsd_f3 a, b, c, d;
    if (!e->linear) return vsd_env_texel_rgb(e, vsd_env_texel_at(e, u, r));
    /* texel centres sit at half-integers */
    x = u * (float)e->width - 0.5f;
    y = r * (float)e->height - 0.5f;
    x0 = (int32_t)floorf(x);
    y0 = (int32_t)floorf(y);
    fx = x - (float)x0;
    fy = y - (float)y0;
    x0 = ((x0 % e->width) + e->width) % e->width;
    x1 = x0 + 1 == e->width ? 0 : x0 + 1;
    y1 = y0 + 1;
    if (y0 < 0) y0 = 0;
    if (y1 < 0) y1 = 0;
    if (y0 > e->height - 1) y0 = e->height - 1;
    if (y1 > e->height - 1) y1 = e->height - 1;
    a = vsd_env_texel_rgb(e, y0 * e->width + x0);
    b = vsd_env_texel_rgb(e, y0 * e->width + x1);
    c = vsd_env_texel_rgb(e, y1 * e->width + x0);
    d = vsd_env_texel_rgb(e, y1 * e->width + x1);
    return f3_add(f3_scale(f3_add(f3_scale(a, 1.0f - fx), f3_scale(b, fx)), 1.0f - fy),
                  f3_scale(f3_add(f3_scale(c, 1.0f - fx), f3_scale(d, fx)), fy));
}

VSD_DEVICE vsd_f3 vsd_env_eval(const vsd_kenv *e, vsd_f3 d)
{
    float u, r;
    vsd_env_uv(e, d, &u, &r, 0);
    return vsd_env_lookup(e, u, r);
}

/* Probability of texel idx under the sampling tables. */
VSD_DEVICE float vsd_env_texel_prob(const vsd_kenv *e, int32_t idx)
{
    int32_t row = idx / e->width, col = idx - row * e->width;
    const float *cc = e->cdf_cols + (size_t)row * (e->width + 1);
    return (e->cdf_rows[row + 1] - e->cdf_rows[row]) * (cc[col + 1] - cc[col]);
}

/* Solid-angle pdf of sampling world direction d. */
VSD_DEVICE float vsd_env_pdf(const vsd_kenv *e, vsd_f3 d)
{
    float sin_t;
    int32_t idx = vsd_env_texel(e, d, &sin_t);
    if (sin_t < 1e-6f) return 0.0f;
    return vsd_env_texel_prob(e, idx) * (float)e->width * (float)e->height /
           (2.0f * VSD_PI * VSD_PI * sin_t);
}

/* First index i in [0, n) with cdf[i+1] > u (cdf has n+1 entries, cdf[0] = 0, cdf[n] = 1). */
VSD_DEVICE int32_t vsd_cdf_find(const float *cdf, int32_t n, float u)
{
    int32_t lo = 0, hi = n - 1;
    while (lo < hi) {
        int32_t mid = (lo + hi) >> 1;
        if (cdf[mid + 1] <= u) lo = mid + 1; else hi = mid;
    }
    return lo;
}

/* Sample a world direction; returns it with its radiance and solid-angle pdf. */
VSD_DEVICE vsd_f3 vsd_env_sample(const vsd_kenv *e, float u1, float u2, vsd_f3 *radiance, float *pdf)
{
    int32_t row = vsd_cdf_find(e->cdf_rows, e->height, u1);
    const float *cc = e->cdf_cols + (size_t)row * (e->width + 1);
    float r0 = e->cdf_rows[row], r1 = e->cdf_rows[row + 1];
    float fr = (r1 > r0) ? (u1 - r0) / (r1 - r0) : 0.5f;
    int32_t col = vsd_cdf_find(cc, e->width, u2);
    float c0 = cc[col], c1 = cc[col + 1];
    float fc = (c1 > c0) ? (u2 - c0) / (c1 - c0) : 0.5f;
    float u = ((float)col + vsd_clampf(fc, 0.0f, 0.999f)) / (float)e->width;
    float r = ((float)row + vsd_clampf(fr, 0.0f, 0.999f)) / (float)e->height;
    float theta = r * VSD_PI, phi = (0.5f - u) * 2.0f * VSD_PI;
    float st = sinf(theta);
    float tx = st * cosf(phi), ty = st * sinf(phi);
    /* undo the Z rotation: world = Rz(-rotation) texture */
    vsd_f3 d = f3(e->cos_rot * tx + e->sin_rot * ty, -e->sin_rot * tx + e->cos_rot * ty, cosf(theta));
    *radiance = vsd_env_lookup(e, u, r);
    *pdf = (st < 1e-6f) ? 0.0f
         : (r1 - r0) * (c1 - c0) * (float)e->width * (float)e->height / (2.0f * VSD_PI * VSD_PI * st);
    return d;
}

#endif
