/* kernel_refract.h — rays through a medium of varying refractive index n(x) (issue 14):
 * the ray equation of gradient-index optics, d/ds (n dx/ds) = grad n, integrated as
 * Bernabei et al. 2012 eq. 2-3 (after Ihrke et al. 2007) with a fixed arc-length step h:
 *     x += h v / n,    v += h grad n,    v renormalised to |v| = n(x) at the new point
 * (v = n dx/ds; the renormalisation keeps the first-order integrator from drifting in |v|).
 * n and grad n come from a cell grid built per frame (src/refraction/refraction.h): n and
 * its world-space gradient per cell centre, trilinear between them; outside the grid n = 1
 * and grad n = 0, so rays are straight there. CPU and CUDA share these functions. */
#ifndef VSD_KERNEL_REFRACT_H
#define VSD_KERNEL_REFRACT_H
#include <stddef.h>
#include "kernel_types.h"

typedef struct VSD_ALIGN16 vsd_krefract {
    const float *ng;              /* [dims x*y*z * 4]: n, dn/dx, dn/dy, dn/dz (world) per cell centre */
    vsd_affine world_to_grid;     /* cell (i,j,k) spans [i, i+1) x ..., centre at +0.5 */
    int32_t dims[3];
    float step;                   /* h, world units */
    int32_t max_steps;            /* a ray gives up bending after this many steps (then goes straight) */
    float pad_[3];
} vsd_krefract;

/* n and grad n at world point p (trilinear; 1 and 0 outside the grid). */
VSD_DEVICE float vsd_refract_eval(const vsd_krefract *r, vsd_f3 p, vsd_f3 *grad)
{
    vsd_f3 q = vsd_affine_point(&r->world_to_grid, p);
    float fx = q.x - 0.5f, fy = q.y - 0.5f, fz = q.z - 0.5f, acc[4] = {0.0f, 0.0f, 0.0f, 0.0f}, wsum = 0.0f;
    int32_t i0 = (int32_t)floorf(fx), j0 = (int32_t)floorf(fy), k0 = (int32_t)floorf(fz), a, c;
    float tx = fx - (float)i0, ty = fy - (float)j0, tz = fz - (float)k0;
    for (a = 0; a < 8; a++) {
        int32_t i = i0 + (a & 1), j = j0 + ((a >> 1) & 1), k = k0 + ((a >> 2) & 1);
        float w = ((a & 1) ? tx : 1.0f - tx) * (((a >> 1) & 1) ? ty : 1.0f - ty) * (((a >> 2) & 1) ? tz : 1.0f - tz);
        const float *v;
        if (i < 0 || j < 0 || k < 0 || i >= r->dims[0] || j >= r->dims[1] || k >= r->dims[2]) {
            acc[0] += w;   /* n = 1, grad 0 outside */
            wsum += w;
            continue;
        }
        v = r->ng + 4 * (((size_t)k * r->dims[1] + j) * r->dims[0] + i);
        for (c = 0; c < 4; c++) acc[c] += w * v[c];
        wsum += w;
    }
    *grad = f3(acc[1], acc[2], acc[3]);
    return wsum > 0.0f ? acc[0] : 1.0f;
}

/* The grid's box along the ray o + t d (world t): 0 when the ray misses it. */
VSD_DEVICE int vsd_refract_clip(const vsd_krefract *r, vsd_f3 o, vsd_f3 d, float *t0, float *t1)
{
    vsd_f3 q = vsd_affine_point(&r->world_to_grid, o), dq = vsd_affine_vector(&r->world_to_grid, d);
    float lo = 0.0f, hi = VSD_INF, qa[3] = {q.x, q.y, q.z}, da[3] = {dq.x, dq.y, dq.z};
    int32_t a;
    for (a = 0; a < 3; a++) {
        if (fabsf(da[a]) < 1e-20f) {
            if (qa[a] < 0.0f || qa[a] > (float)r->dims[a]) return 0;
            continue;
        }
        {
            float ta = (0.0f - qa[a]) / da[a], tb = ((float)r->dims[a] - qa[a]) / da[a];
            if (ta > tb) { float s = ta; ta = tb; tb = s; }
            lo = vsd_maxf(lo, ta);
            hi = vsd_minf(hi, tb);
        }
    }
    *t0 = lo;
    *t1 = hi;
    return hi > lo;
}

/* Whether world point p is inside the grid's box. */
VSD_DEVICE int vsd_refract_inside(const vsd_krefract *r, vsd_f3 p)
{
    vsd_f3 q = vsd_affine_point(&r->world_to_grid, p);
    return q.x >= 0.0f && q.y >= 0.0f && q.z >= 0.0f && q.x <= (float)r->dims[0] && q.y <= (float)r->dims[1] &&
           q.z <= (float)r->dims[2];
}

/* One step of length h from x with v = n dx/ds: the new x, v, and the unit direction. */
VSD_DEVICE void vsd_refract_step(const vsd_krefract *r, vsd_f3 *x, vsd_f3 *v, vsd_f3 *d, float h)
{
    vsd_f3 g;
    float n = vsd_refract_eval(r, *x, &g), n2;
    *x = f3_madd(*x, *v, h / n);
    *v = f3_madd(*v, g, h);
    *d = f3_normalize(*v);
    n2 = vsd_refract_eval(r, *x, &g);
    *v = f3_scale(*d, n2);
}

#endif
