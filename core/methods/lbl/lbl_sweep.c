#include "lbl_sweep.h"
#include "lbl_exp.h"
#include "device/cpu/cpu_tiles.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { MEDIA_MAX = 2 };

/* Lights swept per batch: each writes its records' values into a plain array of its own
 * (a sweep reaches the records in layer order, not the records' order), and a batch's are
 * then moved into the [record][light] outputs a whole cache line of lights at a time. */
#define BATCH 16

/* The cells re-laid for sweeps along axis a: layers across a one after another, each a
 * plane of np x nq cells, p the faster of the other two axes (the lower stride in the x
 * fastest grid), so a layer is read as one contiguous run. */
typedef struct axis_layout {
    int a, p, q;
    int32_t na, np, nq;
    float *sigma[MEDIA_MAX];
    int32_t *rec;
} axis_layout;

typedef struct sweep_job {
    const vsd_lbl_grid *g;
    const float *lights;
    int light_count, media;
    axis_layout axes[3];           /* sigma NULL: no light sweeps along that axis */
    int32_t record_count;
    int k0, batch;                 /* this batch: lights [k0, k0 + batch) */
    float *vals;                   /* [BATCH][2 * media][record_count]: T, then lost (where that
                                      medium's output wants it), per medium */
    const vsd_lbl_march_out *out;
    int failed;
} sweep_job;

/* Light k's travel in the grid (vsd_lbl_light_travel) and the world length of a grid unit
 * along it; 0 for a light with no direction. */
static int light_travel(const sweep_job *j, int k, float u[3], float *world_per_grid)
{
    double len;
    if (!vsd_lbl_light_travel(j->g, j->lights + 8 * (size_t)k, u, &len)) return 0;
    *world_per_grid = (float)(1.0 / len);
    return 1;
}

static int dominant_axis(const float u[3])
{
    return fabsf(u[0]) >= fabsf(u[1]) && fabsf(u[0]) >= fabsf(u[2]) ? 0 : fabsf(u[1]) >= fabsf(u[2]) ? 1 : 2;
}

static void layout_free(axis_layout *x)
{
    free(x->sigma[0]), free(x->sigma[1]), free(x->rec);
    memset(x, 0, sizeof *x);
}

/* The cells of g, sigma and their records (cell_record), re-laid along axis a; 0 when out of
 * memory. */
static int layout_build(const vsd_lbl_grid *g, const int32_t *cell_record, int media, int a, axis_layout *x)
{
    const size_t n = (size_t)g->res[0] * g->res[1] * g->res[2];
    const int32_t *res = g->res;
    int32_t A, P, Q;
    int m;
    x->a = a;
    x->p = a == 0 ? 1 : 0;
    x->q = a == 2 ? 1 : 2;
    x->na = res[a], x->np = res[x->p], x->nq = res[x->q];
    x->rec = malloc(n * sizeof *x->rec);
    for (m = 0; m < media; m++) x->sigma[m] = malloc(n * sizeof *x->sigma[m]);
    if (!x->rec || !x->sigma[0] || (media > 1 && !x->sigma[1])) return 0;
    for (A = 0; A < x->na; A++)
        for (Q = 0; Q < x->nq; Q++)
            for (P = 0; P < x->np; P++) {
                int32_t c[3];
                size_t from, to = ((size_t)A * x->nq + Q) * x->np + P;
                c[a] = A, c[x->p] = P, c[x->q] = Q;
                from = ((size_t)c[2] * res[1] + c[1]) * res[0] + c[0];
                x->sigma[0][to] = g->sigma[from];
                if (media > 1) x->sigma[1][to] = g->sigma2[from];
                x->rec[to] = cell_record[from];
            }
    return 1;
}

/* The rays of one medium, one per slot of a plane of (np + 3) x (nq + 3) (a border of one
 * slot, T 1 and sigma 0, that stays: the light entering from beside the box), two copies:
 * the layer before and this one. Slot (b, c) of the interior [0, np] x [0, nq] holds the
 * ray at lateral position (b - 1 + fp, c - 1 + fq) in cell-centre coordinates, so cell
 * (P, Q) lies between slots P and P + 1 (and Q, Q + 1). */
typedef struct ray_planes {
    float *t[2], *sigma[2];    /* the rays' T, and sigma where they crossed the layer */
} ray_planes;

/* This layer's rays from the last layer's: each ray moved by (sp, sq) slots (the integer
 * part of the layer's lateral step), its T taken down by the layer's optical depth, the
 * trapezoid of sigma where it crossed the last layer and this one (bilinear, between the
 * four centres around it, in `pad`: the layer's sigma with a zero border of one cell). */
static void rays_row(size_t np, const float w[4], float half_l, const float *restrict t_was, const float *restrict s_was,
                     const float *restrict pad, size_t pad_stride, float *restrict t_now, float *restrict s_now)
{
    const float w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3];
    size_t b;
    for (b = 0; b <= np; b++) {
        const float sg = w0 * pad[b] + w1 * pad[b + 1] + w2 * pad[b + pad_stride] + w3 * pad[b + pad_stride + 1];
        s_now[b] = sg;
        t_now[b] = t_was[b] * vsd_lbl_exp_nonpositive(half_l * (s_was[b] + sg));
    }
}

/* A row of cells from the rays around them (weights r[4] on slots (P, Q), (P + 1, Q),
 * (P, Q + 1), (P + 1, Q + 1)) and, with lost, the loss of a beam through each cell of
 * optical depth x = sigma l over a layer's path l, per unit T at the centre and per world
 * length, e^{x/2} (1 - e^{-x}) / l = 2 sinh(x / 2) / l (sigma, thin; its series below 1e-2,
 * where the difference of exponentials loses digits). */
static void cells_row(size_t np, const float r[4], float l_world, const float *restrict t_ray, size_t ray_stride,
                      const float *restrict sc, float *restrict t_out, float *restrict lost)
{
    const float r0 = r[0], r1 = r[1], r2 = r[2], r3 = r[3], inv_l = 1.0f / l_world;
    size_t P;
    for (P = 0; P < np; P++)
        t_out[P] = r0 * t_ray[P] + r1 * t_ray[P + 1] + r2 * t_ray[P + ray_stride] + r3 * t_ray[P + ray_stride + 1];
    if (!lost) return;
    for (P = 0; P < np; P++) {
        const float x = sc[P] * l_world < 80.0f ? sc[P] * l_world : 80.0f, h = vsd_lbl_exp_nonpositive(-0.5f * x);
        const float thin = sc[P] * (1.0f + x * x * (1.0f / 24.0f)), thick = (1.0f / h - h) * inv_l;
        lost[P] = t_out[P] * (x < 1e-2f ? thin : thick);
    }
}

/* One light's sweep into its batch slot's values. scratch: per medium the two ray planes'
 * T and sigma, then the padded sigma layer, then a row of cells' T and lost power. */
static void sweep_light(const sweep_job *j, int k, float *vals, float *scratch)
{
    const size_t recs = (size_t)j->record_count;
    float u[3], wpg, ep, eq, fp = 0.0f, fq = 0.0f, l_world;
    const axis_layout *x;
    int32_t A, P, Q, step, n;
    size_t plane, pad_plane, rs, ps, m, i;
    int media = j->media, cur = 0;
    float *pad, *row_t, *row_lost;
    ray_planes rp[MEDIA_MAX];
    if (!light_travel(j, k, u, &wpg)) {
        /* no direction: nothing reaches the records (as the march's lights without rays) */
        for (i = 0; i < 2 * (size_t)media; i++) memset(vals + i * recs, 0, recs * sizeof *vals);
        return;
    }
    x = &j->axes[dominant_axis(u)];
    rs = (size_t)x->np + 3, ps = (size_t)x->np + 2;
    plane = rs * ((size_t)x->nq + 3), pad_plane = ps * ((size_t)x->nq + 2);
    for (m = 0; m < (size_t)media; m++) {
        float *base = scratch + m * 4 * plane;
        rp[m].t[0] = base, rp[m].t[1] = base + plane, rp[m].sigma[0] = base + 2 * plane, rp[m].sigma[1] = base + 3 * plane;
        for (i = 0; i < 2 * plane; i++) base[i] = 1.0f, base[2 * plane + i] = 0.0f;
    }
    pad = scratch + (size_t)media * 4 * plane;
    row_t = pad + pad_plane, row_lost = row_t + x->np;
    memset(pad, 0, pad_plane * sizeof *pad);
    /* a layer's path along u, and the rays' lateral step from one layer to the next */
    l_world = wpg / fabsf(u[x->a]);
    ep = u[x->p] / fabsf(u[x->a]), eq = u[x->q] / fabsf(u[x->a]);
    step = u[x->a] > 0.0f ? 1 : -1;
    for (n = 0, A = step > 0 ? 0 : x->na - 1; A >= 0 && A < x->na; A += step, n++) {
        const size_t layer = (size_t)A * x->nq * x->np;
        /* the rays' offsets in this layer, and the slots they moved by (none into the first) */
        int32_t sp = 0, sq = 0;
        float w[4], r[4];
        if (n > 0) {
            sp = (int32_t)floorf(fp + ep), sq = (int32_t)floorf(fq + eq);
            fp = fp + ep - (float)sp, fq = fq + eq - (float)sq;
            /* (float rounding at an edge) */
            if (fp >= 1.0f) fp = 0.0f, sp++;
            if (fq >= 1.0f) fq = 0.0f, sq++;
        }
        /* a ray in slot b sits at b - 1 + fp: between centres b - 1 and b (padded b, b + 1) */
        w[0] = (1.0f - fp) * (1.0f - fq), w[1] = fp * (1.0f - fq), w[2] = (1.0f - fp) * fq, w[3] = fp * fq;
        /* cell P between slot P (at P - 1 + fp) and slot P + 1 (at P + fp) */
        r[0] = fp * fq, r[1] = (1.0f - fp) * fq, r[2] = fp * (1.0f - fq), r[3] = (1.0f - fp) * (1.0f - fq);
        for (m = 0; m < (size_t)media; m++) {
            const float *sg = x->sigma[m] + layer;
            const float *t_was = rp[m].t[cur], *s_was = rp[m].sigma[cur];
            float *t_now = rp[m].t[cur ^ 1], *s_now = rp[m].sigma[cur ^ 1];
            float *v_t = vals + 2 * m * recs, *v_lost = j->out[m].lost ? vals + (2 * m + 1) * recs : NULL;
            for (Q = 0; Q < x->nq; Q++)
                memcpy(pad + (size_t)(Q + 1) * ps + 1, sg + (size_t)Q * x->np, sizeof *sg * (size_t)x->np);
            /* slot (b, c) came from (b - sp, c - sq), in [-1, np + 1] x [-1, nq + 1]: the
             * border, T 1 and sigma 0, where a ray comes in from beside the box */
            for (Q = 0; Q <= x->nq; Q++) {
                const size_t was = (size_t)(Q - sq + 1) * rs + 1 - (size_t)sp, row = (size_t)(Q + 1) * rs + 1;
                rays_row((size_t)x->np, w, -0.5f * l_world, t_was + was, s_was + was, pad + (size_t)Q * ps, ps,
                         t_now + row, s_now + row);
            }
            for (Q = 0; Q < x->nq; Q++) {
                const int32_t *rec = x->rec + layer + (size_t)Q * x->np;
                cells_row((size_t)x->np, r, l_world, t_now + (size_t)(Q + 1) * rs + 1, rs, sg + (size_t)Q * x->np, row_t,
                          v_lost ? row_lost : NULL);
                for (P = 0; P < x->np; P++)
                    if (rec[P] >= 0) {
                        v_t[rec[P]] = row_t[P];
                        if (v_lost) v_lost[rec[P]] = row_lost[P];
                    }
            }
        }
        cur ^= 1;
    }
}

static void sweep_items(void *user, int x0, int y0, int x1, int y1)
{
    sweep_job *j = user;
    const size_t recs = (size_t)j->record_count;
    size_t need = 0;
    float *scratch;
    int b, a;
    (void)y0, (void)y1;
    for (a = 0; a < 3; a++)
        if (j->axes[a].sigma[0]) {
            const axis_layout *x = &j->axes[a];
            size_t n = (size_t)j->media * 4 * ((size_t)x->np + 3) * (x->nq + 3) + ((size_t)x->np + 2) * (x->nq + 2) +
                       2 * (size_t)x->np;
            if (n > need) need = n;
        }
    if (!(scratch = malloc(need * sizeof *scratch))) {
        j->failed = 1;
        return;
    }
    for (b = x0; b < x1; b++) sweep_light(j, j->k0 + b, j->vals + (size_t)b * 2 * j->media * recs, scratch);
    free(scratch);
}

/* Records [r0, r1) (items of 4096) of the batch's values into the outputs. */
static void store_items(void *user, int x0, int y0, int x1, int y1)
{
    const sweep_job *j = user;
    const size_t recs = (size_t)j->record_count, r0 = (size_t)x0 * 4096, r1 = (size_t)x1 * 4096 < recs ? (size_t)x1 * 4096 : recs;
    size_t r;
    int m, b;
    (void)y0, (void)y1;
    for (m = 0; m < j->media; m++)
        for (r = r0; r < r1; r++) {
            float *t = j->out[m].trans + r * (size_t)j->light_count + j->k0;
            float *lost = j->out[m].lost ? j->out[m].lost + r * (size_t)j->light_count + j->k0 : NULL;
            for (b = 0; b < j->batch; b++) {
                const float *v = j->vals + (size_t)b * 2 * j->media * recs + 2 * (size_t)m * recs;
                t[b] = v[r];
                if (lost) lost[b] = v[recs + r];
            }
        }
}

vsd_status vsd_lbl_sweep_lights(const vsd_lbl_grid *g, const float *lights, int light_count, const int32_t *cell_record,
                                int32_t record_count, int threads, const vsd_lbl_march_out *out, char *err,
                                size_t errlen)
{
    sweep_job j;
    vsd_status st = VSD_OK;
    int k, a;
    if (light_count <= 0 || record_count <= 0 || (size_t)g->res[0] * g->res[1] * g->res[2] == 0) return VSD_OK;
    if (g->refract) return vsd_fail(VSD_ERR_INVALID, err, errlen, "lbl sweep: internal: refraction needs the rays");
    memset(&j, 0, sizeof j);
    j.g = g;
    j.lights = lights;
    j.light_count = light_count;
    j.media = g->sigma2 ? 2 : 1;
    j.record_count = record_count;
    j.out = out;
    /* the layouts the lights' dominant axes ask for */
    for (k = 0; k < light_count && !st; k++) {
        float u[3], wpg;
        if (!light_travel(&j, k, u, &wpg)) continue;
        a = dominant_axis(u);
        if (j.axes[a].sigma[0]) continue;
        if (!layout_build(g, cell_record, j.media, a, &j.axes[a])) st = VSD_ERR_NOMEM;
    }
    if (!st && !(j.vals = malloc((size_t)BATCH * 2 * j.media * (size_t)record_count * sizeof *j.vals))) st = VSD_ERR_NOMEM;
    for (j.k0 = 0; j.k0 < light_count && !st; j.k0 += BATCH) {
        j.batch = light_count - j.k0 < BATCH ? light_count - j.k0 : BATCH;
        if ((st = vsd_cpu_run_each(j.batch, threads, sweep_items, &j, "lbl light sweeps"))) break;
        if (j.failed) {
            st = VSD_ERR_NOMEM;
            break;
        }
        st = vsd_cpu_run_each((record_count + 4095) / 4096, threads, store_items, &j, "lbl light sweeps");
    }
    free(j.vals);
    for (a = 0; a < 3; a++) layout_free(&j.axes[a]);
    if (st == VSD_ERR_NOMEM) return vsd_fail(st, err, errlen, "lbl light sweeps: no memory for %d records", (int)record_count);
    if (st) return vsd_fail(st, err, errlen, "lbl light sweeps cancelled");
    return VSD_OK;
}
