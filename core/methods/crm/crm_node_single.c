#include "crm_node_single.h"
#include "crm_single_direct.h"
#include "crm_kernel.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct node_depth {
    int32_t res[3];
    double to_node[9];      /* world direction -> node-grid displacement per world unit */
    /* sigma_t on the nodes with a zero border (1 node below, 2 above per axis), so a march
     * inside [-1, res] reads its 8 corners without bounds tests */
    float *pad;
    size_t sx, sy;          /* strides of pad */
} node_depth;

static vsd_status pad_grid(node_depth *g, const float *sigma, char *err, size_t errlen)
{
    int32_t i, j, k;
    g->sx = (size_t)g->res[0] + 3;
    g->sy = g->sx * ((size_t)g->res[1] + 3);
    if (!(g->pad = calloc(g->sy * ((size_t)g->res[2] + 3), sizeof *g->pad)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the padded node grid");
    for (k = 0; k < g->res[2]; k++)
        for (j = 0; j < g->res[1]; j++)
            for (i = 0; i < g->res[0]; i++)
                g->pad[(size_t)(k + 1) * g->sy + (size_t)(j + 1) * g->sx + (size_t)(i + 1)] =
                    sigma[((size_t)k * g->res[1] + j) * g->res[0] + i];
    return VSD_OK;
}

/* trilinear sigma_t at node coordinates (x, y, z) in [-1, res]: 0 outside the grid */
static float sigma_at(const node_depth *g, float x, float y, float z)
{
    float fx = floorf(x), fy = floorf(y), fz = floorf(z), tx = x - fx, ty = y - fy, tz = z - fz;
    const float *c = g->pad + (size_t)((int32_t)fz + 1) * g->sy + (size_t)((int32_t)fy + 1) * g->sx + (size_t)((int32_t)fx + 1);
    float c00 = c[0] + (c[1] - c[0]) * tx, c10 = c[g->sx] + (c[g->sx + 1] - c[g->sx]) * tx;
    float c01 = c[g->sy] + (c[g->sy + 1] - c[g->sy]) * tx;
    float c11 = c[g->sy + g->sx] + (c[g->sy + g->sx + 1] - c[g->sy + g->sx]) * tx;
    float c0 = c00 + (c10 - c00) * ty, c1 = c01 + (c11 - c01) * ty;
    return c0 + (c1 - c0) * tz;
}

/* One node per step from p (node coordinates) toward world direction w, midpoints, until
 * the grid ends or the light is gone (optical depth 7: transmittance below 1e-3). The
 * direction is carried into the grid by the volume's transform, so rotated or stretched
 * volumes see the map the right way round; a node step is 1/|v| world units long. */
static double march(const void *user, const double p[3], const double w[3])
{
    const node_depth *g = user;
    double v[3], len;
    float od = 0.0f, step, px, py, pz, ux, uy, uz, s;
    int a;
    for (a = 0; a < 3; a++) v[a] = g->to_node[3 * a] * w[0] + g->to_node[3 * a + 1] * w[1] + g->to_node[3 * a + 2] * w[2];
    len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0.0)) return 0.0;
    /* optical depth is summed in node units and scaled once: a node step is 1/len long */
    step = (float)(7.0 * len);
    px = (float)p[0]; py = (float)p[1]; pz = (float)p[2];
    ux = (float)(v[0] / len); uy = (float)(v[1] / len); uz = (float)(v[2] / len);
    for (s = 0.5f; od < step; s += 1.0f) {
        float x = px + s * ux, y = py + s * uy, z = pz + s * uz;
        if (x < -1.0f || y < -1.0f || z < -1.0f || x > (float)g->res[0] || y > (float)g->res[1] || z > (float)g->res[2])
            break;
        od += sigma_at(g, x, y, z);
    }
    return od / len;
}

vsd_status vsd_crm_node_single(const int32_t res[3], const double to_node[9], const float *sigma_t, const double albedo[3], double g,
                               int order, const double *env_sh, int directions, int threads, float *nodes,
                               uint8_t *valid, char *err, size_t errlen)
{
    node_depth depth;
    size_t n = (size_t)res[0] * res[1] * res[2], i, m = 0;
    int32_t *which = NULL;
    double *points = NULL, *j = NULL;
    int n2 = order * order, c, q;
    vsd_status st;
    memcpy(depth.res, res, sizeof depth.res);
    memcpy(depth.to_node, to_node, sizeof depth.to_node);
    depth.pad = NULL;
    if ((st = pad_grid(&depth, sigma_t, err, errlen))) return st;
    for (i = 0; i < n; i++) m += sigma_t[i] > 0.0f;
    which = malloc((m ? m : 1) * sizeof *which);
    points = calloc((m ? m : 1) * 3, sizeof *points);
    j = malloc((m ? m : 1) * 3 * (size_t)n2 * sizeof *j);
    if (!which || !points || !j) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the single scattering of %zu nodes", m);
        goto done;
    }
    for (i = 0, m = 0; i < n; i++) {
        if (!(sigma_t[i] > 0.0f)) {
            valid[i] &= (uint8_t)~CRM_NODE_SINGLE;
            continue;
        }
        which[m] = (int32_t)i;
        points[3 * m] = (double)(i % res[0]);
        points[3 * m + 1] = (double)((i / res[0]) % res[1]);
        points[3 * m + 2] = (double)(i / ((size_t)res[0] * res[1]));
        m++;
    }
    if ((st = vsd_crm_single_scatter_points((int)m, points, march, &depth, albedo, g, order, env_sh, directions, threads,
                                            j, err, errlen)))
        goto done;
    for (i = 0; i < m; i++) {
        float *ss = nodes + (size_t)which[i] * CRM_NODE_FLOATS;
        for (c = 0; c < 3; c++) {
            for (q = 0; q < CRM_SS_N; q++) ss[c * CRM_SS_N + q] = q < n2 ? (float)j[(i * 3 + c) * (size_t)n2 + q] : 0.0f;
        }
        valid[which[i]] |= CRM_NODE_SINGLE;
    }
done:
    free(depth.pad);
    free(which);
    free(points);
    free(j);
    return st;
}
