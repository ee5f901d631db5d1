#include "crm_sweep.h"
#include <math.h>
#include <stddef.h>

/* The upstream point of every cell sits at the same offset (the next plane along the
 * dominant axis, shifted by a fixed amount along the other two), so the four bilinear
 * weights and corner offsets are the direction's, not the cell's. */
typedef struct sweep_step {
    int a, b, c;         /* the dominant axis; the other two, b the one with the smaller stride */
    int da;              /* +1: the light comes from higher indices along a, so those go first */
    int ob, oc;          /* floor of the offsets along b and c */
    float w[4];          /* bilinear weights of corners (ob, oc), (ob+1, oc), (ob, oc+1), (ob+1, oc+1) */
    float length;        /* world length of the step */
} sweep_step;

static sweep_step step_of(const double v[3], double world_per_cell)
{
    sweep_step s;
    double t, fb, fc, pb, pc;
    int k;
    s.a = 0;
    for (k = 1; k < 3; k++)
        if (fabs(v[k]) > fabs(v[s.a])) s.a = k;
    s.b = s.a == 0 ? 1 : 0;
    s.c = s.a == 2 ? 1 : 2;
    s.da = v[s.a] > 0.0 ? 1 : -1;
    t = 1.0 / fabs(v[s.a]);
    pb = v[s.b] * t;
    pc = v[s.c] * t;
    fb = floor(pb);
    fc = floor(pc);
    s.ob = (int)fb;
    s.oc = (int)fc;
    pb -= fb;
    pc -= fc;
    s.w[0] = (float)((1.0 - pb) * (1.0 - pc));
    s.w[1] = (float)(pb * (1.0 - pc));
    s.w[2] = (float)((1.0 - pb) * pc);
    s.w[3] = (float)(pb * pc);
    s.length = (float)(t * world_per_cell);
    return s;
}

/* The light arriving at one end of a step from its far end: extinction s0, s1, scattering
 * source sj0, sj1 (sigma J) and emission e0, e1 (per world unit; NULL: none) at the two
 * ends, lu arriving at the far end, len the step's world length. The step's optical depth
 * tau is that of the mean extinction sm. The emission, linear in length, integrates exactly
 * against the attenuation:
 *     len (E0 a0 + E1 a1),  a1 = (1 - e^-tau (1 + tau)) / tau^2,  a0 = (1 - e^-tau) / tau - a1.
 * The scattered light is (1 - e^-tau) times a mix of the ends' J = sigma J / sigma, the far
 * end's share being
 *     far = (s1 / sm) tau a1 / (1 - e^-tau):
 * with one extinction along the step this is J linear in optical depth integrated exactly;
 * optically thin it is s1 / (s0 + s1), the trapezoid of sigma J that the marches' trilinear
 * samples amount to; optically thick it falls to 0: J at the near end, the light of the
 * first mean free path. (The trapezoid of sigma J at every depth reads the far end as much
 * in a thick step, and J linear in optical depth at every depth dims the edges of a thin
 * one; measured in docs/methods/crm.md.) An end without extinction takes the other's J: J
 * is per unit extinction, and an empty neighbour must not dim the medium's edge. The
 * emission is not J: it does not scale with extinction (a flame's thin hot gas). */
static void emit_step(float s0, const float sj0[3], const float *e0, float s1, const float sj1[3], const float *e1,
                      const float lu[3], float len, float out[3])
{
    float sm = 0.5f * (s0 + s1), tau = sm * len, e, a0, a1;
    int c;
    if (!(sm > 0.0f)) {
        for (c = 0; c < 3; c++) out[c] = (e0 ? 0.5f * (e0[c] + e1[c]) * len : 0.0f) + lu[c];
        return;
    }
    e = expf(-tau);
    /* the series where the closed forms lose digits */
    if (tau < 1e-2f) {
        a1 = 0.5f - tau / 3.0f;
        a0 = 0.5f - tau / 6.0f;
    } else {
        a1 = (1.0f - e * (1.0f + tau)) / (tau * tau);
        a0 = (1.0f - e) / tau - a1;
    }
    {
        /* the far end's share (above); tau a1 / (1 - e^-tau) -> 1/2 - tau/12 as tau -> 0 */
        float far = (s1 / sm) * (tau < 1e-2f ? 0.5f - tau / 12.0f : tau * a1 / (1.0f - e));
        for (c = 0; c < 3; c++) {
            float j0 = s0 > 0.0f ? sj0[c] / s0 : sj1[c] / s1, j1 = s1 > 0.0f ? sj1[c] / s1 : j0;
            out[c] = (1.0f - e) * (j0 + far * (j1 - j0)) + e * lu[c];
            if (e0) out[c] += len * (e0[c] * a0 + e1[c] * a1);
        }
    }
}

/* What the step from cell (ib, ic) of a plane reads on the upstream plane `up`: extinction,
 * sigma J, emission (where given) and arriving light, mixed by the step's bilinear weights
 * over the corners inside the grid (all 0 past its far face). */
typedef struct upstream {
    float sigma, scatter[3], emission[3], light[3];
} upstream;

static upstream upstream_mix(const sweep_step *s, const int32_t res[3], const size_t stride[3], int up, int ib,
                             int ic, const float *sigma, const float *scatter, const float *emission,
                             const float *radiance)
{
    upstream u = {0.0f, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}};
    int q, c;
    if (up < 0 || up >= res[s->a]) return u;
    for (q = 0; q < 4; q++) {
        int jb = ib + s->ob + (q & 1), jc = ic + s->oc + (q >> 1);
        size_t m;
        if (jb < 0 || jb >= res[s->b] || jc < 0 || jc >= res[s->c] || !(s->w[q] > 0.0f)) continue;
        m = up * stride[s->a] + jc * stride[s->c] + jb * stride[s->b];
        u.sigma += s->w[q] * sigma[m];
        for (c = 0; c < 3; c++) {
            u.scatter[c] += s->w[q] * scatter[3 * m + c];
            if (emission) u.emission[c] += s->w[q] * emission[3 * m + c];
            u.light[c] += s->w[q] * radiance[3 * m + c];
        }
    }
    return u;
}

void vsd_crm_sweep(const int32_t res[3], const float *sigma, const float *scatter, const float *emission,
                   const double v[3], double world_per_cell, float *radiance)
{
    const sweep_step s = step_of(v, world_per_cell);
    const size_t stride[3] = {1, (size_t)res[0], (size_t)res[0] * (size_t)res[1]};
    int ia, ib, ic, p;
    for (p = 0; p < res[s.a]; p++) {
        ia = s.da > 0 ? res[s.a] - 1 - p : p;
        for (ic = 0; ic < res[s.c]; ic++)
            for (ib = 0; ib < res[s.b]; ib++) {
                size_t n = ia * stride[s.a] + ic * stride[s.c] + ib * stride[s.b];
                upstream u = upstream_mix(&s, res, stride, ia + s.da, ib, ic, sigma, scatter, emission, radiance);
                emit_step(sigma[n], scatter + 3 * n, emission ? emission + 3 * n : NULL, u.sigma, u.scatter,
                          u.emission, u.light, s.length, radiance + 3 * n);
            }
    }
}
