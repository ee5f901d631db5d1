#include "crm_lights.h"
#include "crm_kernel.h"
#include "src/lighting/env_bright.h"
#include "vsd/sh.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static void free_split(vsd_crm_lights *l)
{
    free(l->rest.rgb);
    l->rest.rgb = NULL;
    vsd_constellation_free(&l->bright);
    memset(&l->bright, 0, sizeof l->bright);
    l->split_valid = 0;
}

void vsd_crm_lights_free(vsd_crm_lights *l)
{
    free_split(l);
    free(l->dirs);
    free(l->power);
    free(l->tr);
    vsd_crm_node_depths_free(&l->depths);
    memset(l, 0, sizeof *l);
}

vsd_status vsd_crm_lights_update(vsd_crm_lights *l, const vsd_env *env, int max, double threshold, float strength,
                                 float rotation_z, const vsd_env **sky, char *err, size_t errlen)
{
    uint64_t key = vsd_env_content_hash(env);
    float *k;
    int i, c;
    vsd_status st;
    *sky = env;
    if (!l->split_valid || l->key != key || l->max != max || l->threshold != threshold) {
        free_split(l);
        if (max > 0 && (st = vsd_env_split_bright(env, threshold, max, &l->rest, &l->bright, &l->fraction, err, errlen)))
            return st;
        l->key = key;
        l->max = max;
        l->threshold = threshold;
        l->split_valid = 1;
    }
    l->count = max > 0 ? l->bright.count : 0;
    free(l->dirs);
    free(l->power);
    l->dirs = NULL;
    l->power = NULL;
    if (l->count == 0) return VSD_OK;
    l->dirs = malloc(sizeof *l->dirs * 3 * (size_t)l->count);
    l->power = malloc(sizeof *l->power * 3 * (size_t)l->count);
    k = malloc(sizeof *k * 8 * (size_t)l->count);
    if (!l->dirs || !l->power || !k) {
        free(k);
        l->count = 0;
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for %d lights", l->bright.count);
    }
    /* world directions and powers for this strength and rotation (vsd/lighting.h) */
    vsd_constellation_kernel_lights(&l->bright, strength, rotation_z, k);
    for (i = 0; i < l->count; i++)
        for (c = 0; c < 3; c++) {
            l->dirs[3 * i + c] = k[8 * i + c];
            l->power[3 * i + c] = k[8 * i + 4 + c];
        }
    free(k);
    *sky = &l->rest;
    return VSD_OK;
}

vsd_status vsd_crm_lights_march(vsd_crm_lights *l, const int32_t res[3], const double to_node[9], const float *density,
                                float scale, int threads, int *marched, char *err, size_t errlen)
{
    vsd_status st;
    *marched = 0;
    if (l->count == 0) {
        vsd_crm_node_depths_free(&l->depths);
        return VSD_OK;
    }
    st = vsd_crm_node_depths_update(&l->depths, res, to_node, density, scale, l->dirs, l->count, threads, marched, err,
                                    errlen);
    l->marches += *marched;
    return st;
}

vsd_status vsd_crm_lights_transmittance(vsd_crm_lights *l, float scale, char *err, size_t errlen)
{
    const vsd_crm_node_depths *c = &l->depths;
    size_t nodes = (size_t)c->res[0] * c->res[1] * c->res[2], i;
    int k;
    if (l->count == 0) return VSD_OK;
    if (l->tr_nodes != nodes * (size_t)l->count) {
        free(l->tr);
        l->tr_nodes = 0;
        if (!(l->tr = malloc(sizeof *l->tr * (nodes ? nodes : 1) * (size_t)l->count)))
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the transmittance of %zu nodes x %d lights",
                            nodes, l->count);
        l->tr_nodes = nodes * (size_t)l->count;
    }
    memset(l->tr, 0, sizeof *l->tr * nodes * (size_t)l->count);
    for (i = 0; i < c->count; i++)
        for (k = 0; k < l->count; k++)
            l->tr[(size_t)c->which[i] * l->count + k] = expf(-scale * c->od[i * (size_t)l->count + k]);
    return VSD_OK;
}

void vsd_crm_lights_bands(const vsd_crm_lights *l, const double albedo[3], const vsd_crm_phase *phase, int n2,
                          float sign, float *nodes)
{
    const vsd_crm_node_depths *c = &l->depths;
    /* [k][ch][q]: albedo E_k times chi_l Y_lm at -w_k, for every node */
    double y[VSD_CRM_MAX_LIGHTS * 3 * 9];
    size_t i;
    int k, q, ch;
    if (l->count == 0 || l->count > VSD_CRM_MAX_LIGHTS || n2 < 1 || n2 > 9) return;
    for (k = 0; k < l->count; k++) {
        double w[3] = {-l->dirs[3 * k], -l->dirs[3 * k + 1], -l->dirs[3 * k + 2]}, b[9];
        vsd_sh_eval(n2 > 4 ? 3 : 2, w, b);
        for (ch = 0; ch < 3; ch++)
            for (q = 0; q < n2; q++)
                y[(k * 3 + ch) * n2 + q] =
                    albedo[ch] * l->power[3 * k + ch] * (q == 0 ? b[0] : phase->chi[vsd_crm_sh_band(q)] * b[q]);
    }
    for (i = 0; i < c->count; i++) {
        const float *t = l->tr + (size_t)c->which[i] * l->count;
        float *ss = nodes + (size_t)c->which[i] * CRM_NODE_FLOATS;
        double add[3][9] = {{0}};
        for (k = 0; k < l->count; k++)
            for (ch = 0; ch < 3; ch++)
                for (q = 0; q < n2; q++) add[ch][q] += t[k] * y[(k * 3 + ch) * n2 + q];
        for (ch = 0; ch < 3; ch++)
            for (q = 0; q < n2; q++) ss[ch * CRM_SS_N + q] += sign * (float)add[ch][q];
    }
}

void vsd_crm_lights_view(const vsd_crm_lights *l, const double albedo[3], float *out)
{
    int k, c;
    for (k = 0; k < l->count; k++) {
        for (c = 0; c < 3; c++) {
            out[8 * k + c] = (float)l->dirs[3 * k + c];
            out[8 * k + 4 + c] = (float)(albedo[c] * l->power[3 * k + c]);
        }
        out[8 * k + 3] = out[8 * k + 7] = 0.0f;
    }
}
