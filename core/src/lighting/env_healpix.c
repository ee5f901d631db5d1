#include "env_healpix.h"
#include "kernel/kernel_env.h"
#include <chealpix.h>
#include <math.h>
#include <stdlib.h>

int vsd_env_healpix_radiance(const vsd_env *env, const vsd_kenv *ke, long nside, float *out)
{
    const long n = 12 * nside * nside;
    double *acc = calloc(4 * (size_t)n, sizeof(double));
    long j;
    int row, col;
    if (!acc) return 0;
    for (row = 0; row < env->height; row++) {
        double th0 = VSD_PI * (double)row / env->height, th1 = VSD_PI * (row + 1.0) / env->height;
        double dom = vsd_env_texel_solid_angle(env->width, env->height, row), thc = 0.5 * (th0 + th1);
        for (col = 0; col < env->width; col++) {
            const float *p = env->rgb + 3 * ((size_t)row * env->width + col);
            double u = (col + 0.5) / env->width, phit = (0.5 - u) * 2.0 * VSD_PI;
            double tx = sin(thc) * cos(phit), ty = sin(thc) * sin(phit);
            /* world = Rz(-rotation) texture (kernel_env.h) */
            double wx = ke->cos_rot * tx + ke->sin_rot * ty, wy = -ke->sin_rot * tx + ke->cos_rot * ty;
            double ph = atan2(wy, wx);
            long pix;
            ang2pix_ring(nside, thc, ph < 0 ? ph + 2.0 * VSD_PI : ph, &pix);
            acc[4 * pix + 0] += dom * p[0];
            acc[4 * pix + 1] += dom * p[1];
            acc[4 * pix + 2] += dom * p[2];
            acc[4 * pix + 3] += dom;
        }
    }
    for (j = 0; j < n; j++) {
        int c;
        if (acc[4 * j + 3] > 0.0) {
            for (c = 0; c < 3; c++) out[4 * j + c] = (float)(acc[4 * j + c] / acc[4 * j + 3] * ke->strength);
        } else {
            double th, ph;
            vsd_f3 l;
            pix2ang_ring(nside, j, &th, &ph);
            l = vsd_env_eval(ke, f3((float)(sin(th) * cos(ph)), (float)(sin(th) * sin(ph)), (float)cos(th)));
            out[4 * j] = l.x, out[4 * j + 1] = l.y, out[4 * j + 2] = l.z;
        }
        out[4 * j + 3] = 0.0f;
    }
    free(acc);
    return 1;
}
