/* sh_kernel.h — real spherical-harmonics basis evaluation for kernel code (CPU and CUDA),
 * in the convention of Zhou et al. 2008's appendix (and Sloan's PRT papers): index
 * i = l(l+1)+m, order n has n^2 coefficients, Condon-Shortley phase included, so
 *   y0 = sqrt(1/4pi), y1 = -sqrt(3/4pi) y, y2 = sqrt(3/4pi) z, y3 = -sqrt(3/4pi) x.
 * The host library (vsd/sh.h) evaluates the same basis in double precision; a unit test
 * checks the two agree.
 *
 * Why this recurrence: P_l^m(z) = sin^m(theta) Q_l^m(z) with Q a polynomial, and
 * sin^m(theta) e^{i m phi} = (x + i y)^m, so the whole basis is polynomial in (x, y, z) —
 * no acos/atan2, no division by sin(theta), exact at the poles. */
#ifndef VSD_SH_KERNEL_H
#define VSD_SH_KERNEL_H
#include "kernel_types.h"

#define VSD_SH_MAX_ORDER 8
#define VSD_SH_MAX_COEFFS (VSD_SH_MAX_ORDER * VSD_SH_MAX_ORDER)

/* y[0 .. order^2) at unit direction d; order in 1..VSD_SH_MAX_ORDER. */
VSD_DEVICE void vsd_sh_eval_f(int32_t order, vsd_f3 d, float *y)
{
    float cm = 1.0f, sm = 0.0f;   /* Re, Im of (x + i y)^m */
    float qmm = 1.0f;             /* Q_m^m = (-1)^m (2m-1)!! */
    int32_t m, l;
    for (m = 0; m < order; m++) {
        float qlm2 = 0.0f, qlm1 = qmm;
        /* K_l^m^2 = (2l+1)/(4pi) (l-m)!/(l+m)!, built up in l from l = m */
        float fr = 1.0f;          /* (l-m)!/(l+m)! at l = m: 1/(2m)! */
        int32_t k;
        for (k = 2; k <= 2 * m; k++) fr /= (float)k;
        for (l = m; l < order; l++) {
            float q, kn;
            if (l == m) q = qmm;
            else if (l == m + 1) q = d.z * (float)(2 * m + 1) * qmm;
            else q = ((float)(2 * l - 1) * d.z * qlm1 - (float)(l + m - 1) * qlm2) / (float)(l - m);
            if (l > m) fr *= (float)(l - m) / (float)(l + m);
            kn = sqrtf((float)(2 * l + 1) * (1.0f / (4.0f * VSD_PI)) * fr);
            if (m == 0) {
                y[l * (l + 1)] = kn * q;
            } else {
                y[l * (l + 1) + m] = 1.41421356237f * kn * q * cm;
                y[l * (l + 1) - m] = 1.41421356237f * kn * q * sm;
            }
            if (l > m) { qlm2 = qlm1; qlm1 = q; }
        }
        {
            float c = cm * d.x - sm * d.y, s = cm * d.y + sm * d.x;
            cm = c; sm = s;
        }
        qmm *= -(float)(2 * m + 1);
    }
}

#endif
