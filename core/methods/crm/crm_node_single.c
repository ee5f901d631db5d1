#include "crm_node_single.h"
#include "crm_single_directions.h"
#include "crm_kernel.h"
#include "src/grids/padded_grid.h"
#include "vsd/sh.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct node_depth {
    int32_t res[3];
    double to_node[9];      /* world direction -> node-grid displacement per world unit */
    float stop;             /* optical depth (grid units) past which the light counts as gone */
    vsd_padded_grid pad;    /* the density on the nodes */
} node_depth;

/* One node per step from p (node coordinates) toward world direction w, midpoints, until
 * the grid ends or the optical depth passes g->stop. The direction is carried into the grid
 * by the volume's transform, so rotated or stretched volumes see the map the right way
 * round; a node step is 1/|v| world units long. Returns the optical depth of the density
 * (world units, unscaled). */
static double march(const void *user, const double p[3], const double w[3])
{
    const node_depth *g = user;
    double v[3], len;
    float od = 0.0f, stop, px, py, pz, ux, uy, uz, s;
    int a;
    for (a = 0; a < 3; a++) v[a] = g->to_node[3 * a] * w[0] + g->to_node[3 * a + 1] * w[1] + g->to_node[3 * a + 2] * w[2];
    len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0.0)) return 0.0;
    /* optical depth is summed in node units and scaled once: a node step is 1/len long */
    stop = (float)(g->stop * len);
    px = (float)p[0]; py = (float)p[1]; pz = (float)p[2];
    ux = (float)(v[0] / len); uy = (float)(v[1] / len); uz = (float)(v[2] / len);
    for (s = 0.5f; od < stop; s += 1.0f) {
        float x = px + s * ux, y = py + s * uy, z = pz + s * uz;
        if (x < -1.0f || y < -1.0f || z < -1.0f || x > (float)g->res[0] || y > (float)g->res[1] || z > (float)g->res[2])
            break;
        od += vsd_padded_at(&g->pad, x, y, z);
    }
    return od / len;
}

double *vsd_crm_healpix_directions(int directions)
{
    long nside = vsd_sh_healpix_nside(directions);
    double *dirs = nside ? malloc(sizeof *dirs * 3 * (size_t)directions) : NULL;
    char err[64];
    if (dirs && vsd_sh_healpix_dirs(nside, dirs, err, sizeof err)) {
        free(dirs);
        dirs = NULL;
    }
    return dirs;
}

void vsd_crm_node_depths_free(vsd_crm_node_depths *c)
{
    free(c->dirs);
    free(c->which);
    free(c->od);
    memset(c, 0, sizeof *c);
}

vsd_status vsd_crm_node_depths_update(vsd_crm_node_depths *c, const int32_t res[3], const double to_node[9],
                                      const float *density, float scale, const double *dirs, int directions, int threads,
                                      int *marched, char *err, size_t errlen)
{
    node_depth depth;
    size_t n = (size_t)res[0] * res[1] * res[2], i, m = 0;
    double *points = NULL;
    vsd_status st;
    *marched = 0;
    /* a march stopped at optical depth 7 / c->scale has, at any scale >= c->scale, reached
     * transmittance e^-7 < 1e-3 where it stopped: the cut still means "no light" */
    if (c->od && c->directions == directions && memcmp(c->res, res, sizeof c->res) == 0 &&
        memcmp(c->to_node, to_node, sizeof c->to_node) == 0 &&
        memcmp(c->dirs, dirs, sizeof *dirs * 3 * (size_t)directions) == 0 && scale >= c->scale)
        return VSD_OK;
    vsd_crm_node_depths_free(c);
    memcpy(depth.res, res, sizeof depth.res);
    memcpy(depth.to_node, to_node, sizeof depth.to_node);
    depth.stop = scale > 0.0f ? 7.0f / scale : VSD_INF;
    if (!vsd_padded_grid_build(&depth.pad, res, density))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the padded node grid");
    for (i = 0; i < n; i++) m += density[i] > 0.0f;
    c->which = malloc((m ? m : 1) * sizeof *c->which);
    c->od = malloc((m ? m : 1) * (size_t)(directions ? directions : 1) * sizeof *c->od);
    c->dirs = malloc((directions ? directions : 1) * 3 * sizeof *c->dirs);
    points = malloc((m ? m : 1) * 3 * sizeof *points);
    if (!c->which || !c->od || !c->dirs || !points) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the transmittance of %zu nodes x %d directions", m,
                      directions);
        goto done;
    }
    for (i = 0, m = 0; i < n; i++) {
        if (!(density[i] > 0.0f)) continue;
        c->which[m] = (int32_t)i;
        points[3 * m] = (double)(i % res[0]);
        points[3 * m + 1] = (double)((i / res[0]) % res[1]);
        points[3 * m + 2] = (double)(i / ((size_t)res[0] * res[1]));
        m++;
    }
    memcpy(c->dirs, dirs, sizeof *dirs * 3 * (size_t)directions);
    if ((st = vsd_crm_optical_depths((int)m, points, march, &depth, dirs, directions, threads, c->od, err, errlen)))
        goto done;
    memcpy(c->res, res, sizeof c->res);
    memcpy(c->to_node, to_node, sizeof c->to_node);
    c->directions = directions;
    c->scale = scale;
    c->count = m;
    *marched = 1;
done:
    if (st) vsd_crm_node_depths_free(c);
    vsd_padded_grid_free(&depth.pad);
    free(points);
    return st;
}

vsd_status vsd_crm_node_single(const vsd_crm_node_depths *c, float scale, const double albedo[3],
                               const vsd_crm_phase *phase, int order,
                               const double *env_sh, const float *sky, int threads, float *nodes, uint8_t *valid,
                               char *err, size_t errlen)
{
    size_t n = (size_t)c->res[0] * c->res[1] * c->res[2], i;
    double *j;
    int n2 = order * order, ch, q;
    vsd_status st;
    for (i = 0; i < n; i++) valid[i] &= (uint8_t)~CRM_NODE_SINGLE;
    if (c->count == 0) return VSD_OK;
    if (!(j = malloc(c->count * 3 * (size_t)n2 * sizeof *j)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the single scattering of %zu nodes", c->count);
    if (!(st = vsd_crm_single_from_depths((int)c->count, c->od, scale, albedo, phase, order, env_sh, sky, c->directions, threads,
                                          j, err, errlen)))
        for (i = 0; i < c->count; i++) {
            float *ss = nodes + (size_t)c->which[i] * CRM_NODE_FLOATS;
            for (ch = 0; ch < 3; ch++)
                for (q = 0; q < CRM_SS_N; q++) ss[ch * CRM_SS_N + q] = q < n2 ? (float)j[(i * 3 + ch) * (size_t)n2 + q] : 0.0f;
            valid[c->which[i]] |= CRM_NODE_SINGLE;
        }
    free(j);
    return st;
}
