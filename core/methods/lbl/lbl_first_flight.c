#include "lbl_first_flight.h"
#include "lbl_directions.h"
#include "lbl_exp.h"
#include "device/cpu/cpu_tiles.h"
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

enum { CONES = 6, CH = 3 };

/* One vector's sweep: its step, the cones its births come from (its part of each: for
 * births with a direction, its solid angle in the cone over the cone's; for isotropic
 * births, held as cone 0, its solid angle over 4pi) and the cones its light arrives in (its
 * weight in each). Its light is the same whichever cone it is counted in, so one sweep
 * serves them all. */
typedef struct vector_plan {
    int d[3];
    float len, step; /* its length in cube-equivalent cells, in world units */
    int births, birth_cone[CONES];
    float birth_part[CONES];
    int arrivals, arrival_cone[CONES];
    float arrival_wl[CONES]; /* its weight in the cone times len */
} vector_plan;

typedef struct flight_job {
    const vsd_lbl_first_flight *in;
    vsd_lbl_directions dirs;
    double birth[VSD_LBL_VECTORS][CONES];
    size_t cells, rows;
    float *paths;     /* [6][3][cells] (lbl_first_flight.h); the collisions after the flight
                         are sigma lambda times them (rebirth_slices) */
    float *pout;      /* [3][cells] the swept vector's light leaving each cell, where lit */
    unsigned char *lit;  /* [rows] the row of cells along x has the vector's light (else 0) */
    unsigned char *born; /* [cones][rows] the row's births in that cone's source are not all 0 */
    vector_plan plan; /* the vector swept now */
    int classes;
    int failed;       /* a thread found no memory for its scratch */
} flight_job;

/* A segment of optical depth x: tr = e^-x, e = (1 - e^-x) / x (what a birth at a uniform
 * point carries out of it) and h = (1 - e) / x. Below x = 1/4 e and h take their series to
 * x^6 (within 2e-9), where the differences lose digits: at x = 1e-3 the last bit of e^-x
 * would be 1e-4 of e and a tenth of h. Selects, not branches: a row of cells vectorises
 * (x = 0, empty space, gives tr = e = 1 and h = 1/2: the light passes, a birth's path is half
 * the segment). */
static inline void segment(float x, float *tr, float *e, float *h)
{
    const int small = x < 0.25f;
    const float xs = small ? 1.0f : x;
    const float ex = vsd_lbl_exp_nonpositive(-x), eb = (1.0f - ex) / xs, hb = (1.0f - eb) / xs;
    const float es = 1.0f - x * (1.0f / 2 - x * (1.0f / 6 - x * (1.0f / 24 - x * (1.0f / 120 - x * (1.0f / 720 -
                                                                                               x * (1.0f / 5040))))));
    const float hs = 1.0f / 2 - x * (1.0f / 6 - x * (1.0f / 24 - x * (1.0f / 120 - x * (1.0f / 720 - x * (1.0f / 5040 -
                                                                                               x * (1.0f / 40320))))));
    *tr = ex;
    *e = small ? es : eb;
    *h = small ? hs : hb;
}

/* One cell's segment, its light p_in arriving and its births s: the light leaving it and
 * the path its photons take in it (over the vector's length):
 *     P_out = P_in e^-x + S e,  path = P_in e + S h.
 * What collides in it, P_in (1 - e^-x) + S (1 - e), is x times the path (x e = 1 - e^-x,
 * x h = 1 - e): no sweep keeps it. */
#define CELL_LIGHT(tr, e, h, p_in, s, out, path) ((out) = (p_in) * (tr) + (s) * (e), (path) = (p_in) * (e) + (s) * (h))

/* Cells [0, nx) of a row that no light crosses along it: arriving light pin and births s
 * ([3][nx] each) into the leaving light out (channel stride n) and the path qp ([3][nx]). */
static void row_cells(int32_t nx, const float *restrict sigma, float step, const float *restrict s,
                      const float *restrict pin, float *restrict out, size_t n, float *restrict qp)
{
    int32_t x;
    for (x = 0; x < nx; x++) {
        float tr, e, h;
        segment(sigma[x] * step, &tr, &e, &h);
        CELL_LIGHT(tr, e, h, pin[x], s[x], out[x], qp[x]);
        CELL_LIGHT(tr, e, h, pin[nx + x], s[nx + x], out[n + x], qp[nx + x]);
        CELL_LIGHT(tr, e, h, pin[2 * nx + x], s[2 * nx + x], out[2 * n + x], qp[2 * nx + x]);
    }
}

/* The same along a row that the light crosses cell by cell (a vector along x, dx = +-1):
 * each cell's arriving light is the leaving light of the one before. */
static void row_cells_along(int32_t nx, int dx, const float *sigma, float step, const float *s, float *out, size_t n,
                            float *qp)
{
    int32_t k;
    for (k = 0; k < nx; k++) {
        const int32_t x = dx > 0 ? k : nx - 1 - k, u = x - dx;
        float tr, e, h;
        int ch;
        segment(sigma[x] * step, &tr, &e, &h);
        for (ch = 0; ch < CH; ch++) {
            const float p_in = u >= 0 && u < nx ? out[(size_t)ch * n + u] : 0.0f;
            CELL_LIGHT(tr, e, h, p_in, s[ch * nx + x], out[(size_t)ch * n + x], qp[ch * nx + x]);
        }
    }
}

/* Row (y, z) of the plan's sweep; scratch: [3][3][nx]. */
static void sweep_row(flight_job *j, int32_t y, int32_t z, float *scratch)
{
    const vsd_lbl_first_flight *in = j->in;
    const vector_plan *p = &j->plan;
    const int32_t *res = in->res, nx = res[0], py = y - p->d[1], pz = z - p->d[2];
    const size_t n = j->cells, row = (size_t)z * res[1] + y, r0 = row * nx, cstride = (size_t)CH * n;
    const int along_x = p->d[1] == 0 && p->d[2] == 0;
    const int arriving = !along_x && py >= 0 && py < res[1] && pz >= 0 && pz < res[2] && j->lit[(size_t)pz * res[1] + py];
    float *s = scratch, *pin = scratch + CH * nx, *qp = scratch + 2 * CH * nx;
    int births = 0, b, ch, i;
    int32_t x;
    for (b = 0; b < p->births; b++) births |= j->born[(size_t)p->birth_cone[b] * j->rows + row];
    j->lit[row] = births || arriving;
    if (!j->lit[row]) return;
    memset(s, 0, (size_t)CH * nx * sizeof *s);
    for (b = 0; b < p->births && births; b++)
        for (ch = 0; ch < CH; ch++) {
            const float *src = in->source + (size_t)p->birth_cone[b] * cstride + (size_t)ch * n + r0, part = p->birth_part[b];
            float *sc = s + ch * nx;
            for (x = 0; x < nx; x++) sc[x] += src[x] * part;
        }
    if (along_x) {
        row_cells_along(nx, p->d[0], in->sigma + r0, p->step, s, j->pout + r0, n, qp);
    } else {
        memset(pin, 0, (size_t)CH * nx * sizeof *pin);
        if (arriving) {
            /* cell x's light comes from cell x - d0 of the row before */
            const int32_t lo = p->d[0] > 0 ? p->d[0] : 0, hi = p->d[0] < 0 ? nx + p->d[0] : nx;
            const size_t prev = ((size_t)pz * res[1] + py) * nx;
            for (ch = 0; ch < CH && hi > lo; ch++)
                memcpy(pin + ch * nx + lo, j->pout + (size_t)ch * n + prev + lo - p->d[0], (size_t)(hi - lo) * sizeof *pin);
        }
        row_cells(nx, in->sigma + r0, p->step, s, pin, j->pout + r0, n, qp);
    }
    for (i = 0; i < p->arrivals; i++) {
        const size_t at = (size_t)p->arrival_cone[i] * cstride + r0;
        const float wl = p->arrival_wl[i];
        for (ch = 0; ch < CH; ch++) {
            float *pa = j->paths + at + (size_t)ch * n;
            const float *qpc = qp + ch * nx;
            for (x = 0; x < nx; x++) pa[x] += wl * qpc[x];
        }
    }
}

/* One thread's rows: the job and its scratch. */
typedef struct row_ctx {
    flight_job *j;
    float *scratch;
} row_ctx;

static void class_row(void *user, int32_t y, int32_t z)
{
    const row_ctx *r = user;
    sweep_row(r->j, y, z, r->scratch);
}

/* Classes [x0, x1) of the plan's rows (vsd_lbl_class_rows: chains no light leaves), each
 * swept in the vector's order: a row after the row its light comes from. */
static void sweep_classes(void *user, int x0, int y0, int x1, int y1)
{
    row_ctx r = {user, NULL};
    const int32_t *res = r.j->in->res;
    int c;
    (void)y0, (void)y1;
    if (!(r.scratch = malloc((size_t)3 * CH * res[0] * sizeof *r.scratch))) {
        r.j->failed = 1;
        return;
    }
    for (c = x0; c < x1; c++) vsd_lbl_class_rows(res, r.j->plan.d, r.j->classes, c, class_row, &r);
    free(r.scratch);
}

static void plan_vector(flight_job *j, int v)
{
    vector_plan *p = &j->plan;
    int i;
    memset(p, 0, sizeof *p);
    memcpy(p->d, j->dirs.d[v], sizeof p->d);
    p->len = (float)j->dirs.len[v];
    p->step = (float)(j->dirs.len[v] * j->in->cell_world);
    for (i = 0; i < CONES; i++) {
        if (j->birth[v][i] > 0.0) p->birth_cone[p->births] = i, p->birth_part[p->births++] = (float)j->birth[v][i];
        if (j->dirs.cone[v][i] > 0.0) {
            const float w = (float)j->dirs.cone[v][i];
            p->arrival_cone[p->arrivals] = i, p->arrival_wl[p->arrivals++] = w * p->len;
        }
    }
}

/* Slices [z0, z1) (items): which rows of each cone's source hold births. */
static void mark_born(void *user, int z0, int y0, int z1, int y1)
{
    flight_job *j = user;
    const vsd_lbl_first_flight *in = j->in;
    const int32_t nx = in->res[0], ny = in->res[1];
    const int cones = in->per_direction ? CONES : 1;
    size_t row;
    int i, ch;
    int32_t x;
    (void)y0, (void)y1;
    for (i = 0; i < cones; i++)
        for (row = (size_t)z0 * ny; row < (size_t)z1 * ny; row++) {
            int any = 0;
            for (ch = 0; ch < CH && !any; ch++) {
                const float *src = in->source + ((size_t)i * CH + ch) * j->cells + row * nx;
                for (x = 0; x < nx && !any; x++) any = src[x] != 0.0f;
            }
            j->born[(size_t)i * j->rows + row] = (unsigned char)any;
        }
}

/* Cells [x0, x1) of one z slice each (items): the collisions after the first flight, per cone
 * they arrived in sigma lambda times its paths there, born again with the albedo and the
 * cone phase. */
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
            const double x = (double)in->sigma[c] * in->cell_world;
            double hit[CONES], sum = 0.0;
            for (i = 0; i < CONES; i++) sum += hit[i] = x * j->paths[((size_t)i * CH + ch) * n + c];
            if (!in->per_direction) {
                r->births[(size_t)ch * n + c] = (float)(a * sum);
                continue;
            }
            for (i = 0; i < CONES; i++) {
                const double own = hit[i], back = hit[i ^ 1];
                r->births[((size_t)i * CH + ch) * n + c] =
                    (float)(a * (in->side * (sum - own - back) + in->forward * own + in->backward * back));
            }
        }
}

/* The 98 sweeps, one vector after another, each on every thread (its rows' chains dealt
 * out, so a cell's arrays have one writer and the result is the same for any thread
 * count). */
static vsd_status sweep_vectors(flight_job *j, int threads)
{
    const int t = vsd_cpu_thread_count(threads);
    int v;
    j->classes = vsd_lbl_row_classes(t);
    for (v = 0; v < VSD_LBL_VECTORS; v++) {
        vsd_status st;
        plan_vector(j, v);
        if (!j->plan.births) continue;
        if ((st = vsd_cpu_run_each(j->classes, t, sweep_classes, j, "lbl first flight"))) return st;
        if (j->failed) return VSD_ERR_NOMEM;
    }
    return VSD_OK;
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
    j.rows = (size_t)in->res[1] * in->res[2];
    j.paths = paths;
    vsd_lbl_directions_make(in->shape, &j.dirs);
    for (v = 0; v < VSD_LBL_VECTORS; v++)
        for (i = 0; i < CONES; i++) cone_share[i] += j.dirs.share[v] * j.dirs.cone[v][i];
    for (v = 0; v < VSD_LBL_VECTORS; v++)
        for (i = 0; i < CONES; i++)
            j.birth[v][i] = !in->per_direction ? (i == 0 ? j.dirs.share[v] : 0.0)
                                               : j.dirs.share[v] * j.dirs.cone[v][i] / cone_share[i];
    j.pout = malloc((size_t)CH * j.cells * sizeof *j.pout);
    j.lit = malloc(j.rows);
    j.born = malloc((size_t)CONES * j.rows);
    if (!j.pout || !j.lit || !j.born) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the first flight of %zu cells", j.cells);
    } else {
        memset(paths, 0, (size_t)CONES * CH * j.cells * sizeof *paths);
        st = vsd_cpu_run_each(in->res[2], threads, mark_born, &j, "lbl first flight");
        if (!st) st = sweep_vectors(&j, threads);
        r.j = &j;
        r.births = births;
        /* after every sweep has read the source: births may overwrite it */
        if (births && !st) st = vsd_cpu_run_each(in->res[2], threads, rebirth_slices, &r, "lbl first flight");
        if (st == VSD_ERR_NOMEM)
            st = vsd_fail(st, err, errlen, "lbl: no memory for the first flight of %zu cells", j.cells);
        else if (st)
            st = vsd_fail(st, err, errlen, "lbl: the first flight's threads failed");
    }
    free(j.pout), free(j.lit), free(j.born);
    return st;
}
