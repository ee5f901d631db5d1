#include "lbl_escape.h"
#include "lbl_directions.h"
#include "lbl_exp.h"
#include "device/cpu/cpu_tiles.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct escape_job {
    const int32_t *res;
    const float *sigma;
    double cell_world;
    vsd_lbl_directions dirs;
    int v, classes;
    float *tau, *sphere, *axes; /* [cells]: the optical depth out along the vector; the sums */
} escape_job;

/* Cell (x, y, z)'s optical depth to the box along vector v when the step leaves it: the
 * share of the step up to the box's face. */
static float to_face(const escape_job *j, int32_t x, int32_t y, int32_t z, size_t here)
{
    const int *d = j->dirs.d[j->v];
    const int32_t p[3] = {x, y, z};
    double frac = 1.0;
    int a;
    for (a = 0; a < 3; a++)
        if (d[a]) {
            double face = d[a] > 0 ? j->res[a] - 0.5 - p[a] : p[a] + 0.5;
            frac = fmin(frac, face / abs(d[a]));
        }
    return (float)(frac * j->sigma[here] * j->dirs.len[j->v] * j->cell_world);
}

/* Row (y, z) of vector v's sweep: each cell's optical depth out along v (from the next
 * cell's, the trapezoid of sigma between their centres) and its T into the sums. */
static void escape_row(escape_job *j, int32_t y, int32_t z)
{
    const int32_t *res = j->res, nx = res[0];
    const int *d = j->dirs.d[j->v];
    const double step = j->dirs.len[j->v] * j->cell_world;
    const int axis = abs(d[0]) + abs(d[1]) + abs(d[2]) == 1;
    const float share = (float)j->dirs.share[j->v];
    const int32_t ny = y + d[1], nz = z + d[2];
    const size_t r0 = ((size_t)z * res[1] + y) * nx;
    const int next_row = ny >= 0 && ny < res[1] && nz >= 0 && nz < res[2];
    const size_t n0 = next_row ? ((size_t)nz * res[1] + ny) * nx : 0;
    float *restrict tau = j->tau + r0, *restrict sphere = j->sphere + r0, *restrict axes = j->axes + r0;
    int32_t x, k;
    if (d[1] == 0 && d[2] == 0) {
        /* along x: each cell after the one d0 beyond it, cell by cell */
        for (k = 0; k < nx; k++) {
            x = d[0] > 0 ? nx - 1 - k : k;
            tau[x] = x + d[0] < 0 || x + d[0] >= nx
                         ? to_face(j, x, y, z, r0 + x)
                         : tau[x + d[0]] + (float)(0.5 * ((double)j->sigma[r0 + x] + j->sigma[r0 + x + d[0]]) * step);
        }
    } else {
        /* the next row's cells x + d0, where the step stays in the box (the others leave) */
        const int32_t lo = d[0] < 0 ? -d[0] : 0, hi = d[0] > 0 ? nx - d[0] : nx;
        const float *restrict tn = j->tau + n0 + d[0], *restrict sh = j->sigma + r0, *restrict sn = j->sigma + n0 + d[0];
        for (x = 0; x < nx; x++)
            if (!next_row || x < lo || x >= hi) tau[x] = to_face(j, x, y, z, r0 + x);
        if (next_row)
            for (x = lo; x < hi; x++) tau[x] = tn[x] + (float)(0.5 * ((double)sh[x] + sn[x]) * step);
    }
    /* (two loops, not a test per cell: each vectorises) */
    if (axis)
        for (x = 0; x < nx; x++) {
            const float t = vsd_lbl_exp_nonpositive(-tau[x]);
            sphere[x] += share * t;
            axes[x] += t * (1.0f / 6.0f);
        }
    else
        for (x = 0; x < nx; x++) sphere[x] += share * vsd_lbl_exp_nonpositive(-tau[x]);
}

static void class_row(void *user, int32_t y, int32_t z) { escape_row(user, y, z); }

/* Classes [x0, x1) of vector v's rows, each in its sweep's order: a row after the row its
 * step reaches (cell c + d before cell c). */
static void escape_classes(void *user, int x0, int y0, int x1, int y1)
{
    escape_job *j = user;
    const int *d = j->dirs.d[j->v];
    const int out[3] = {-d[0], -d[1], -d[2]};
    int c;
    (void)y0, (void)y1;
    for (c = x0; c < x1; c++) vsd_lbl_class_rows(j->res, out, j->classes, c, class_row, j);
}

int vsd_lbl_escape_keep(const int32_t res[3], const float *sigma, double cell_world, const double *shape, int threads,
                        float *keep)
{
    const size_t n = (size_t)res[0] * res[1] * res[2];
    escape_job j;
    size_t c;
    int ok = 1;
    memset(&j, 0, sizeof j);
    j.res = res, j.sigma = sigma, j.cell_world = cell_world;
    j.tau = malloc(n * sizeof *j.tau), j.sphere = calloc(n, sizeof *j.sphere), j.axes = calloc(n, sizeof *j.axes);
    if (!j.tau || !j.sphere || !j.axes) ok = 0;
    vsd_lbl_directions_make(shape, &j.dirs);
    j.classes = vsd_lbl_row_classes(vsd_cpu_thread_count(threads));
    for (j.v = 0; ok && j.v < VSD_LBL_VECTORS; j.v++)
        /* (the pool fails only when cancelled, which this stage is not) */
        (void)vsd_cpu_run_each(j.classes, threads, escape_classes, &j, "lbl surface escape");
    for (c = 0; ok && c < n; c++) keep[c] = 1.0f - fmaxf(0.0f, j.sphere[c] - j.axes[c]);
    free(j.tau), free(j.sphere), free(j.axes);
    return ok;
}
