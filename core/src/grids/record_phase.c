/* vsd_hg_eval_many (record_phase.h). lbl's view bakes, per record, the phase toward the eye
 * of every sub-light (64 lights x 8: 512 evaluations a record, 50 M for smoke128's 97k
 * records): 14% of a camera change in perf, each a square root and a division. Written
 * over separate x, y, z arrays with no branch and no reduction, this loop vectorises
 * (4 lanes with SSE2, 8 in the AVX2 clone where the CPU has it: target_clones picks at load
 * time, and the default clone runs anywhere); element-wise IEEE operations in the scalar
 * order give the same bits in every lane width. Built with the dynamic vectoriser cost model
 * (core/CMakeLists.txt; -fno-math-errno, which lets sqrtf become sqrtps, is the project's). */
#include "src/grids/record_phase.h"
#include "kernel/kernel_phase.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
void vsd_hg_eval_many(const float *dx, const float *dy, const float *dz, int32_t n, vsd_f3 d, float g, float *pk)
{
    const float num = 1.0f - g * g, a = 1.0f + g * g, b = 2.0f * g;
    int32_t s;
    if (fabsf(g) < 1e-4f) {
        for (s = 0; s < n; s++) pk[s] = vsd_hg_eval(0.0f, g);
        return;
    }
    for (s = 0; s < n; s++) {
        /* vsd_hg_eval(f3_dot(d, w_s), g), term by term */
        float c = d.x * dx[s] + d.y * dy[s] + d.z * dz[s];
        float den = a - b * c;
        pk[s] = num / (4.0f * VSD_PI * den * sqrtf(den));
    }
}
