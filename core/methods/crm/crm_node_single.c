#include "crm_node_single.h"
#include "crm_single_direct.h"
#include "crm_kernel.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct node_depth {
    int32_t res[3];
    double to_node[9];      /* world direction -> node-grid displacement per world unit */
    const float *sigma;
} node_depth;

static double sigma_at(const node_depth *g, double x, double y, double z)
{
    double fx = floor(x), fy = floor(y), fz = floor(z), tx = x - fx, ty = y - fy, tz = z - fz, s = 0.0;
    int32_t i = (int32_t)fx, j = (int32_t)fy, k = (int32_t)fz, a;
    for (a = 0; a < 8; a++) {
        int32_t ii = i + (a & 1), jj = j + ((a >> 1) & 1), kk = k + ((a >> 2) & 1);
        double w = ((a & 1) ? tx : 1.0 - tx) * (((a >> 1) & 1) ? ty : 1.0 - ty) * (((a >> 2) & 1) ? tz : 1.0 - tz);
        if (ii < 0 || jj < 0 || kk < 0 || ii >= g->res[0] || jj >= g->res[1] || kk >= g->res[2]) continue;
        s += w * g->sigma[((size_t)kk * g->res[1] + jj) * g->res[0] + ii];
    }
    return s;
}

/* One node per step from p (node coordinates) toward world direction w, midpoints, until
 * the grid ends or the light is gone (optical depth 7: transmittance below 1e-3). The
 * direction is carried into the grid by the volume's transform, so rotated or stretched
 * volumes see the map the right way round; a node step is 1/|v| world units long. */
static double march(const void *user, const double p[3], const double w[3])
{
    const node_depth *g = user;
    double v[3], len, od = 0.0, s;
    int a;
    for (a = 0; a < 3; a++) v[a] = g->to_node[3 * a] * w[0] + g->to_node[3 * a + 1] * w[1] + g->to_node[3 * a + 2] * w[2];
    len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0.0)) return 0.0;
    for (a = 0; a < 3; a++) v[a] /= len;
    for (s = 0.5; od < 7.0; s += 1.0) {
        double x = p[0] + s * v[0], y = p[1] + s * v[1], z = p[2] + s * v[2];
        if (x < -1.0 || y < -1.0 || z < -1.0 || x > g->res[0] || y > g->res[1] || z > g->res[2]) break;
        od += sigma_at(g, x, y, z) / len;
    }
    return od;
}

vsd_status vsd_crm_node_single(const int32_t res[3], const double to_node[9], const float *sigma_t, const double albedo[3], double g,
                               int order, const double *env_sh, int directions, float *nodes, uint8_t *valid,
                               char *err, size_t errlen)
{
    node_depth depth;
    size_t n = (size_t)res[0] * res[1] * res[2], i, m = 0;
    int32_t *which = NULL;
    double *points = NULL, *j = NULL;
    int n2 = order * order, c, q;
    vsd_status st;
    memcpy(depth.res, res, sizeof depth.res);
    memcpy(depth.to_node, to_node, sizeof depth.to_node);
    depth.sigma = sigma_t;
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
    if ((st = vsd_crm_single_scatter_points((int)m, points, march, &depth, albedo, g, order, env_sh, directions, j, err,
                                            errlen)))
        goto done;
    for (i = 0; i < m; i++) {
        float *ss = nodes + (size_t)which[i] * CRM_NODE_FLOATS;
        for (c = 0; c < 3; c++) {
            for (q = 0; q < CRM_SS_N; q++) ss[c * CRM_SS_N + q] = q < n2 ? (float)j[(i * 3 + c) * (size_t)n2 + q] : 0.0f;
        }
        valid[which[i]] |= CRM_NODE_SINGLE;
    }
done:
    free(which);
    free(points);
    free(j);
    return st;
}
