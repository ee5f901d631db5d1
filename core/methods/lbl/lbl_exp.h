/* lbl_exp.h — e^x for x <= 0 in plain float arithmetic that the compiler vectorises along a
 * row of cells, for lbl's sweeps (lbl_sweep.c, lbl_first_flight.c): libm's expf is a call
 * per cell, most of a scalar sweep's time. A file that uses it in a loop it wants
 * vectorised builds with -fno-trapping-math (core/CMakeLists.txt): the clamp and the floor
 * below are selects the vectoriser if-converts only where comparisons may not trap. */
#ifndef VSD_LBL_EXP_H
#define VSD_LBL_EXP_H
#include <stdint.h>

/* 2^(x log2 e) split into an integer power, set in the exponent's bits, and a degree-6
 * polynomial of 2^f on [0, 1) (fitted for the least largest relative error): within 1e-7
 * of e^x; below e^-87 it is 0's neighbour e^-87 (T that small lights nothing). */
static inline float vsd_lbl_exp_nonpositive(float x)
{
    const float t = (x > -87.0f ? x : -87.0f) * 1.44269504f; /* (fmaxf does not vectorise) */
    const int32_t i = (int32_t)t;                              /* toward 0: i >= t */
    const int32_t n = i - (t < (float)i);                      /* floor */
    const float f = t - (float)n;
    const float p = 1.0f + f * (0.693147004f + f * (0.240229398f + f * (0.0554859675f + f * (0.00967222173f +
                                f * (0.00125117775f + f * 0.000214204862f)))));
    union { int32_t i; float f; } scale;
    scale.i = (n + 127) << 23;
    return p * scale.f;
}

#endif
