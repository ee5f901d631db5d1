#include "lbl_first_flight.h"
#include "lbl_directions.h"
#include "device/cpu/cpu_tiles.h"
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

enum { CONES = 6, CH = 3 };

typedef struct flight_job {
    const vsd_lbl_first_flight *in;
    vsd_lbl_directions dirs;
    /* each vector's share of a birth: for births with a direction, the part of each cone's
     * births it carries (its solid angle in the cone over the cone's); for isotropic births,
     * held as cone 0 (the one source array), its solid angle over 4pi */
    double birth[VSD_LBL_VECTORS][CONES];
    size_t cells;
    float *hit;               /* [6][3][cells] collisions after the first flight, per arrival cone
                                 (NULL when no births are asked for) */
    float *paths;
    int failed;
} flight_job;

/* tr = e^-x, e = (1 - e^-x) / x and h = (1 - e) / x, with their limits at x -> 0 (float:
 * the sweep's exp is most of its time) */
static void segment(float x, float *tr, float *e, float *h)
{
    if (x < 1e-3f) {
        *tr = 1.0f - x;
        *e = 1.0f - x * (0.5f - x * (1.0f / 6.0f));
        *h = 0.5f - x * (1.0f / 6.0f);
    } else {
        *tr = expf(-x);
        *e = (1.0f - *tr) / x;
        *h = (1.0f - *e) / x;
    }
}

/* The cones a vector carries births from: their count, indices and its part of each. */
typedef struct vector_births {
    int count, cone[CONES];
    float part[CONES];
} vector_births;

static void vector_births_of(const flight_job *j, int v, vector_births *vb)
{
    int i;
    vb->count = 0;
    for (i = 0; i < CONES; i++)
        if (j->birth[v][i] > 0.0) vb->cone[vb->count] = i, vb->part[vb->count++] = (float)j->birth[v][i];
}

/* One sweep of vector v: the first flight's collisions and paths that arrive in cone i,
 * weighted by the vector's part in it. pout: [3][cells] scratch. */
static void sweep(const flight_job *j, int v, int i, float *pout)
{
    const vsd_lbl_first_flight *in = j->in;
    const int32_t *res = in->res;
    const size_t n = j->cells;
    const int *d = j->dirs.d[v];
    const float len = (float)j->dirs.len[v], step = (float)(j->dirs.len[v] * in->cell_world),
                w = (float)j->dirs.cone[v][i], wl = w * len;
    const size_t src_stride = (size_t)CH * n; /* between one cone's births and the next's */
    float *hit = j->hit ? j->hit + (size_t)i * CH * n : NULL, *paths = j->paths + (size_t)i * CH * n;
    vector_births vb;
    int32_t start[3], dir[3], x, y, z;
    int ch, b;
    const ptrdiff_t back = ((ptrdiff_t)d[2] * res[1] + d[1]) * res[0] + d[0];
    vector_births_of(j, v, &vb);
    /* cell c - d before cell c */
    vsd_lbl_sweep_order(res, d, start, dir);
    for (z = start[2]; z >= 0 && z < res[2]; z += dir[2]) {
        for (y = start[1]; y >= 0 && y < res[1]; y += dir[1])
            for (x = start[0]; x >= 0 && x < res[0]; x += dir[0]) {
                const int32_t ux = x - d[0], uy = y - d[1], uz = z - d[2];
                const size_t here = ((size_t)z * res[1] + y) * res[0] + x;
                const int inside = ux >= 0 && uy >= 0 && uz >= 0 && ux < res[0] && uy < res[1] && uz < res[2];
                float s[CH] = {0.0f, 0.0f, 0.0f}, p_in[CH] = {0.0f, 0.0f, 0.0f}, tr, e, h;
                const float *src = in->source + here;
                if (inside)
                    for (ch = 0; ch < CH; ch++) p_in[ch] = pout[(size_t)ch * n + (size_t)((ptrdiff_t)here - back)];
                for (b = 0; b < vb.count; b++)
                    for (ch = 0; ch < CH; ch++) s[ch] += src[vb.cone[b] * src_stride + (size_t)ch * n] * vb.part[b];
                if (s[0] == 0.0f && s[1] == 0.0f && s[2] == 0.0f && p_in[0] == 0.0f && p_in[1] == 0.0f &&
                    p_in[2] == 0.0f) {
                    for (ch = 0; ch < CH; ch++) pout[(size_t)ch * n + here] = 0.0f;
                    continue;
                }
                if (in->sigma[here] == 0.0f) {
                    /* empty space: the light passes without a collision (a record at a cell whose
                     * samples all missed the density still reads its path) */
                    for (ch = 0; ch < CH; ch++) {
                        pout[(size_t)ch * n + here] = p_in[ch] + s[ch];
                        paths[(size_t)ch * n + here] += wl * (p_in[ch] + 0.5f * s[ch]);
                    }
                    continue;
                }
                segment(in->sigma[here] * step, &tr, &e, &h);
                for (ch = 0; ch < CH; ch++) {
                    pout[(size_t)ch * n + here] = p_in[ch] * tr + s[ch] * e;
                    paths[(size_t)ch * n + here] += wl * (p_in[ch] * e + s[ch] * h);
                    if (hit) hit[(size_t)ch * n + here] += w * (p_in[ch] * (1.0f - tr) + s[ch] * (1.0f - e));
                }
            }
    }
}

/* Cones [x0, x1): every vector with a part in the cone swept (a vector on a cone's edge
 * once per cone it touches), so each cone's arrays have one writer. */
static void flight_cones(void *user, int x0, int y0, int x1, int y1)
{
    flight_job *j = user;
    float *pout = malloc((size_t)CH * j->cells * sizeof *pout);
    int i, v;
    (void)y0, (void)y1;
    if (!pout) {
        j->failed = 1;
        return;
    }
    for (i = x0; i < x1; i++)
        for (v = 0; v < VSD_LBL_VECTORS; v++)
            if (j->dirs.cone[v][i] > 0.0) sweep(j, v, i, pout);
    free(pout);
}

/* Cells [x0, x1) of one z slice each (items): the collisions born again with the albedo and
 * the cone phase. */
typedef struct rebirth_job {
    const flight_job *j;
    float *births;
} rebirth_job;

static void rebirth_slices(void *user, int z0, int y0, int z1, int y1)
{
    const rebirth_job *r = user;
    const flight_job *j = r->j;
    const vsd_lbl_first_flight *in = j->in;
    const size_t n = j->cells, slice = (size_t)in->res[0] * in->res[1];
    size_t c;
    int ch, i;
    (void)y0, (void)y1;
    for (ch = 0; ch < CH; ch++)
        for (c = (size_t)z0 * slice; c < (size_t)z1 * slice; c++) {
            const double a = in->albedo_cells ? in->albedo_cells[(size_t)ch * n + c] : in->albedo[ch];
            double sum = 0.0;
            for (i = 0; i < CONES; i++) sum += j->hit[((size_t)i * CH + ch) * n + c];
            if (!in->per_direction) {
                r->births[(size_t)ch * n + c] = (float)(a * sum);
                continue;
            }
            for (i = 0; i < CONES; i++) {
                const double own = j->hit[((size_t)i * CH + ch) * n + c], back = j->hit[((size_t)(i ^ 1) * CH + ch) * n + c];
                r->births[((size_t)i * CH + ch) * n + c] =
                    (float)(a * (in->side * (sum - own - back) + in->forward * own + in->backward * back));
            }
        }
}

vsd_status vsd_lbl_first_flight_run(const vsd_lbl_first_flight *in, int threads, float *births, float *paths,
                                    char *err, size_t errlen)
{
    flight_job j;
    rebirth_job r;
    double cone_share[CONES] = {0};
    int v, i;
    vsd_status st;
    memset(&j, 0, sizeof j);
    j.in = in;
    j.cells = (size_t)in->res[0] * in->res[1] * in->res[2];
    j.paths = paths;
    vsd_lbl_directions_make(in->shape, &j.dirs);
    for (v = 0; v < VSD_LBL_VECTORS; v++)
        for (i = 0; i < CONES; i++) cone_share[i] += j.dirs.share[v] * j.dirs.cone[v][i];
    for (v = 0; v < VSD_LBL_VECTORS; v++)
        for (i = 0; i < CONES; i++)
            j.birth[v][i] = !in->per_direction ? (i == 0 ? j.dirs.share[v] : 0.0)
                                               : j.dirs.share[v] * j.dirs.cone[v][i] / cone_share[i];
    if (births && !(j.hit = calloc((size_t)CONES * CH * j.cells, sizeof *j.hit)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the first flight of %zu cells", j.cells);
    memset(paths, 0, (size_t)CONES * CH * j.cells * sizeof *paths);
    st = vsd_cpu_run_each(CONES, threads, flight_cones, &j, "lbl first flight");
    r.j = &j;
    r.births = births;
    /* after every sweep has read the source: births may overwrite it */
    if (births && !st && !j.failed) st = vsd_cpu_run_items(in->res[2], threads, rebirth_slices, &r, "lbl first flight");
    free(j.hit);
    if (j.failed) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the first flight of %zu cells", j.cells);
    if (st) return vsd_fail(st, err, errlen, "lbl: the first flight's threads failed");
    return VSD_OK;
}

