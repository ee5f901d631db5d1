#include "env_importance_lights.h"
#include "kernel/kernel_env.h"

void vsd_env_importance_lights(const vsd_kenv *env, int count, float *out)
{
    /* rows stratified by k, columns by the golden-ratio sequence (a rank-1 lattice) */
    const double golden = 0.6180339887498949;
    int k;
    for (k = 0; k < count; k++) {
        float u1 = ((float)k + 0.5f) / (float)count;
        double g = (k + 0.5) * golden;
        float u2 = (float)(g - (double)(long long)g);
        vsd_f3 rad;
        float pdf;
        vsd_f3 d = vsd_env_sample(env, u1, u2, &rad, &pdf);
        float w = pdf > 0.0f ? 1.0f / ((float)count * pdf) : 0.0f;
        float *l = out + 8 * k;
        l[0] = d.x; l[1] = d.y; l[2] = d.z; l[3] = 0.0f;
        l[4] = rad.x * w; l[5] = rad.y * w; l[6] = rad.z * w; l[7] = 0.0f;
    }
}
