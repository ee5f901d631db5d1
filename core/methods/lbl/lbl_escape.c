#include "lbl_escape.h"
#include "lbl_directions.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

int vsd_lbl_escape_keep(const int32_t res[3], const float *sigma, double cell_world, const double *shape, float *keep)
{
    const size_t n = (size_t)res[0] * res[1] * res[2];
    vsd_lbl_directions dirs;
    const int(*d)[3] = dirs.d;
    int v;
    float *tau = malloc(n * sizeof *tau), *sphere = calloc(n, sizeof *sphere), *axes = calloc(n, sizeof *axes);
    size_t c;
    if (!tau || !sphere || !axes) {
        free(tau), free(sphere), free(axes);
        return 0;
    }
    vsd_lbl_directions_make(shape, &dirs);
    for (v = 0; v < VSD_LBL_VECTORS; v++) {
        const double step = dirs.len[v] * cell_world;
        const int axis = abs(d[v][0]) + abs(d[v][1]) + abs(d[v][2]) == 1;
        const int out[3] = {-d[v][0], -d[v][1], -d[v][2]};
        int32_t start[3], dir[3], x, y, z;
        /* cell c + d before cell c */
        vsd_lbl_sweep_order(res, out, start, dir);
        for (z = start[2]; z >= 0 && z < res[2]; z += dir[2]) {
            for (y = start[1]; y >= 0 && y < res[1]; y += dir[1])
                for (x = start[0]; x >= 0 && x < res[0]; x += dir[0]) {
                    const int32_t nx = x + d[v][0], ny = y + d[v][1], nz = z + d[v][2];
                    const size_t here = ((size_t)z * res[1] + y) * res[0] + x;
                    float t;
                    if (nx < 0 || ny < 0 || nz < 0 || nx >= res[0] || ny >= res[1] || nz >= res[2]) {
                        /* the step leaves the box: the share of it up to the box's face */
                        const int32_t p[3] = {x, y, z};
                        double frac = 1.0;
                        int a;
                        for (a = 0; a < 3; a++)
                            if (d[v][a]) {
                                double to_face = d[v][a] > 0 ? res[a] - 0.5 - p[a] : p[a] + 0.5;
                                frac = fmin(frac, to_face / abs(d[v][a]));
                            }
                        tau[here] = (float)(frac * sigma[here] * step);
                    } else {
                        const size_t next = ((size_t)nz * res[1] + ny) * res[0] + nx;
                        tau[here] = tau[next] + (float)(0.5 * ((double)sigma[here] + sigma[next]) * step);
                    }
                    t = expf(-tau[here]);
                    sphere[here] += (float)dirs.share[v] * t;
                    if (axis) axes[here] += t * (1.0f / 6.0f);
                }
        }
    }
    for (c = 0; c < n; c++) keep[c] = 1.0f - fmaxf(0.0f, sphere[c] - axes[c]);
    free(tau), free(sphere), free(axes);
    return 1;
}
