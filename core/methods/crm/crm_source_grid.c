#include "crm_source_grid.h"
#include "crm_kernel.h"
#include "src/common/clock.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

void vsd_crm_source_grid_free(vsd_crm_source_grid *g)
{
    free(g->nodes);
    free(g->valid);
    memset(g, 0, sizeof *g);
}

vsd_status vsd_crm_source_grid_build(const vsd_crm_rbfs *rbfs, const double *j_ss, int ss_n2, const double *j_ms,
                                     const int32_t dims[3], float spacing, vsd_crm_source_grid *g, char *err,
                                     size_t errlen)
{
    double t0 = vsd_clock_seconds(), *acc, *wsum, wmax = 0.0;
    size_t count, n;
    int a;
    memset(g, 0, sizeof *g);
    if (!(spacing > 0.0f) || ss_n2 < 1 || ss_n2 > CRM_SS_N)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm source grid: spacing %g or SH size %d out of range",
                        (double)spacing, ss_n2);
    for (a = 0; a < 3; a++) g->res[a] = (int32_t)ceilf((float)dims[a] / spacing) + 1;
    g->spacing = spacing;
    count = (size_t)g->res[0] * g->res[1] * g->res[2];
    g->nodes = calloc(count * CRM_NODE_FLOATS, sizeof(float));
    g->valid = calloc(count, 1);
    acc = calloc(count * CRM_NODE_FLOATS, sizeof(double));
    wsum = calloc(count, sizeof(double));
    if (!g->nodes || !g->valid || !acc || !wsum) {
        free(acc);
        free(wsum);
        vsd_crm_source_grid_free(g);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm source grid: no memory for %zu nodes", count);
    }
    /* scatter each RBF's weighted coefficients onto the nodes inside its support */
    for (n = 0; n < (size_t)rbfs->count; n++) {
        const vsd_crm_rbf *b = &rbfs->rbf[n];
        const double *ss = j_ss + n * 3 * (size_t)ss_n2, *ms = j_ms + n * 12;
        int32_t lo[3], hi[3], i, j, k;
        if (b->w > wmax) wmax = b->w;
        for (a = 0; a < 3; a++) {
            lo[a] = (int32_t)ceilf((b->c[a] - VSD_CRM_SUPPORT * b->r) / spacing);
            hi[a] = (int32_t)floorf((b->c[a] + VSD_CRM_SUPPORT * b->r) / spacing);
            if (lo[a] < 0) lo[a] = 0;
            if (hi[a] > g->res[a] - 1) hi[a] = g->res[a] - 1;
        }
        for (k = lo[2]; k <= hi[2]; k++)
            for (j = lo[1]; j <= hi[1]; j++)
                for (i = lo[0]; i <= hi[0]; i++) {
                    double w = vsd_crm_rbf_eval(b, (float)i * spacing, (float)j * spacing, (float)k * spacing);
                    size_t node = ((size_t)k * g->res[1] + j) * g->res[0] + i;
                    double *d = acc + node * CRM_NODE_FLOATS;
                    int c, q;
                    if (w <= 0.0) continue;
                    wsum[node] += w;
                    for (c = 0; c < 3; c++) {
                        for (q = 0; q < ss_n2; q++) d[c * CRM_SS_N + q] += w * ss[c * ss_n2 + q];
                        /* the paper's diffusion: order 2 (bands 0-1); band 2 stays 0 */
                        for (q = 0; q < 4; q++) d[3 * CRM_SS_N + c * CRM_MS_N + q] += w * ms[c * 4 + q];
                    }
                }
    }
    for (n = 0; n < count; n++) {
        int q;
        if (!(wsum[n] > VSD_CRM_NODE_EMPTY * wmax)) continue;
        /* the RBFs' multiple scattering (multiple "rbf") shares their coverage */
        g->valid[n] = CRM_NODE_SINGLE | CRM_NODE_MULTIPLE;
        for (q = 0; q < CRM_NODE_FLOATS; q++) g->nodes[n * CRM_NODE_FLOATS + q] = (float)(acc[n * CRM_NODE_FLOATS + q] / wsum[n]);
    }
    free(acc);
    free(wsum);
    g->seconds = vsd_clock_seconds() - t0;
    return VSD_OK;
}
