#include "env_bright.h"
#include "kernel/kernel_types.h"
#include <stdlib.h>
#include <string.h>

vsd_status vsd_env_split_bright(const vsd_env *env, double threshold, int max_lights, vsd_env *rest,
                                vsd_light_constellation *bright, double *fraction, char *err, size_t errlen)
{
    size_t n = (size_t)env->width * env->height, k;
    float *texels;
    double total = 0.0, taken = 0.0, thr;
    int row, col;
    vsd_status st = VSD_OK;
    memset(bright, 0, sizeof *bright);
    *rest = *env;
    *fraction = 0.0;
    rest->rgb = malloc(sizeof(float) * 3 * n);
    texels = calloc(3 * n, sizeof(float));
    if (!rest->rgb || !texels) {
        free(texels);
        free(rest->rgb);
        rest->rgb = NULL;
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory to split the map", env->file);
    }
    memcpy(rest->rgb, env->rgb, sizeof(float) * 3 * n);
    for (row = 0; row < env->height; row++) {
        double dom = vsd_env_texel_solid_angle(env->width, env->height, row);
        for (col = 0; col < env->width; col++) {
            const float *p = env->rgb + 3 * ((size_t)row * env->width + col);
            total += dom * vsd_luminance(f3(p[0], p[1], p[2]));
        }
    }
    thr = threshold * total / (4.0 * VSD_PI);
    for (row = 0; row < env->height; row++) {
        double dom = vsd_env_texel_solid_angle(env->width, env->height, row);
        for (col = 0; col < env->width; col++) {
            float *p;
            double lum;
            k = 3 * ((size_t)row * env->width + col);
            p = rest->rgb + k;
            lum = vsd_luminance(f3(p[0], p[1], p[2]));
            if (!(lum > thr)) continue;
            memcpy(texels + k, p, 3 * sizeof(float));
            p[0] = p[1] = p[2] = 0.0f;
            taken += dom * lum;
        }
    }
    *fraction = total > 0.0 ? taken / total : 0.0;
    if (taken > 0.0 && max_lights > 0) {
        vsd_env benv = *env;
        benv.rgb = texels;
        st = vsd_constellation_build(&benv, max_lights, VSD_LIGHTS_MEDIAN_CUT, bright, err, errlen);
    }
    free(texels);
    if (st) {
        free(rest->rgb);
        rest->rgb = NULL;
        memset(bright, 0, sizeof *bright);
    }
    return st;
}
