#include "lbl_march.h"
#include "device/cpu/cpu_tiles.h"
#include "src/render/padded_grid.h"
#include "kernel/kernel_refract.h"
#include "kernel/kernel_lights.h"
#include "src/render/distance_map.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Rays die below this transmittance: what they would still leave behind is < 1e-4 of the
 * light they brought. */
#define LBL_T_MIN 1e-4f

typedef struct march_job {
    const vsd_lbl_grid *g;
    const float *lights;
    int light_count;
    const float *points;     /* point and spot lights, kernel_lights.h layout */
    int point_count;
    float *point_trans;
    float spacing, step;
    const int32_t *cell_record;
    const vsd_padded_grid *pad;
    float *trans;
    vsd_status st;
} march_job;

/* trilinear sigma at grid point x inside the box (cell centres at +0.5) */
static float sigma_at(const vsd_padded_grid *p, const float x[3])
{
    return vsd_padded_at(p, x[0] - 0.5f, x[1] - 0.5f, x[2] - 0.5f);
}

/* value v with weight 1 onto the eight cell centres around x, into an accumulator with a
 * one-cell border (strides sx, sy; interior cell (i,j,k) at (i+1, j+1, k+1)): acc[2c] += w v,
 * acc[2c+1] += w. Points are inside the box, so the corners are inside the border. */
static void splat(size_t sx, size_t sy, const float x[3], float v, float *acc)
{
    float fx = x[0] - 0.5f, fy = x[1] - 0.5f, fz = x[2] - 0.5f, ix = floorf(fx), iy = floorf(fy), iz = floorf(fz);
    float tx = fx - ix, ty = fy - iy, tz = fz - iz;
    float *a = acc + 2 * ((size_t)((int32_t)iz + 1) * sy + (size_t)((int32_t)iy + 1) * sx + (size_t)((int32_t)ix + 1));
    float w00 = (1.0f - ty) * (1.0f - tz), w10 = ty * (1.0f - tz), w01 = (1.0f - ty) * tz, w11 = ty * tz;
    float w[8] = {(1.0f - tx) * w00, tx * w00, (1.0f - tx) * w10, tx * w10,
                  (1.0f - tx) * w01, tx * w01, (1.0f - tx) * w11, tx * w11};
    size_t off[8] = {0, 2, 2 * sx, 2 * sx + 2, 2 * sy, 2 * sy + 2, 2 * (sy + sx), 2 * (sy + sx) + 2};
    int q;
    for (q = 0; q < 8; q++) {
        a[off[q]] += w[q] * v;
        a[off[q] + 1] += w[q];
    }
}

/* The ray o + t u (grid units) clipped to the box [0, res]: 0 when it misses. */
static int clip(const int32_t res[3], const float o[3], const float u[3], float *t0, float *t1)
{
    int a;
    *t0 = -1e30f;
    *t1 = 1e30f;
    for (a = 0; a < 3; a++) {
        if (fabsf(u[a]) < 1e-12f) {
            if (o[a] < 0.0f || o[a] > (float)res[a]) return 0;
            continue;
        }
        {
            float ta = (0.0f - o[a]) / u[a], tb = ((float)res[a] - o[a]) / u[a];
            if (ta > tb) { float s = ta; ta = tb; tb = s; }
            if (ta > *t0) *t0 = ta;
            if (tb < *t1) *t1 = tb;
        }
    }
    return *t1 > *t0;
}

/* A light ray through a refracting medium (g->refract): from its entry into the box at
 * grid point o + t0 u, world-space steps of h (the grid step `step` cells along u) bent by
 * the n field (eq. 2-3), each step's middle mapped into the grid for sigma and the deposit,
 * until it leaves the box or dies. */
static void march_bent(const vsd_lbl_grid *g, const vsd_padded_grid *pad, const float o[3], const float u[3], float t0,
                       float h, size_t sx, size_t sy, float *acc)
{
    const vsd_krefract *r = g->refract;
    float q[3], tr = 1.0f;
    vsd_f3 x, d, v, gr;
    int32_t ax, steps = 0;
    /* the bending integrates at the field's own step at most (its smoothed interface is a
     * few of them wide) */
    h = fminf(h, r->step);
    for (ax = 0; ax < 3; ax++) q[ax] = o[ax] + t0 * u[ax];
    x = vsd_affine_point(&g->grid_to_world, f3(q[0], q[1], q[2]));
    d = f3_normalize(vsd_affine_vector(&g->grid_to_world, f3(u[0], u[1], u[2])));
    v = f3_scale(d, vsd_refract_eval(r, x, &gr));
    while (tr > LBL_T_MIN && steps++ < r->max_steps) {
        vsd_f3 m = vsd_affine_point(&g->world_to_grid, f3_madd(x, d, 0.5f * h));
        float xm[3] = {m.x, m.y, m.z}, half;
        if (!(m.x >= 0.0f && m.y >= 0.0f && m.z >= 0.0f && m.x <= (float)g->res[0] && m.y <= (float)g->res[1] &&
              m.z <= (float)g->res[2]))
            break;   /* (also for a NaN position) */
        half = expf(-0.5f * sigma_at(pad, xm) * h);
        tr *= half;
        splat(sx, sy, xm, tr, acc);
        tr *= half;
        vsd_refract_step(r, &x, &v, &d, h);
    }
}

int vsd_lbl_empty_distance(const int32_t res[3], const float *sigma, const int32_t *cell_record, int threads,
                           float *d2)
{
    size_t c, n = (size_t)res[0] * res[1] * res[2];
    uint8_t *occ = malloc(n ? n : 1);
    int ok;
    if (!occ) return 0;
    for (c = 0; c < n; c++) occ[c] = sigma[c] > 0.0f || cell_record[c] >= 0;
    ok = vsd_edt_squared(occ, res, d2, threads);
    free(occ);
    return ok;
}

/* Each record's T: the weighted mean of what the rays left at its cell's centre (0 where
 * nothing reached it), into out[rec * count + k]. */
static void store(const march_job *j, const float *acc, float *out, int count, int k)
{
    const vsd_lbl_grid *g = j->g;
    const size_t sx = (size_t)g->res[0] + 2, sy = sx * ((size_t)g->res[1] + 2);
    int32_t ci, cj, ck;
    for (ck = 0; ck < g->res[2]; ck++)
        for (cj = 0; cj < g->res[1]; cj++)
            for (ci = 0; ci < g->res[0]; ci++) {
                int32_t rec = j->cell_record[((size_t)ck * g->res[1] + cj) * g->res[0] + ci];
                const float *a2 = acc + 2 * ((size_t)(ck + 1) * sy + (size_t)(cj + 1) * sx + (size_t)(ci + 1));
                if (rec >= 0) out[(size_t)rec * count + k] = a2[1] > 0.0f ? a2[0] / a2[1] : 0.0f;
            }
}

/* March one straight ray o + t u (grid units, |u| = 1) over [t0, t1), world_step the world
 * length of a grid step of j->step along u, depositing its transmittance at every step's
 * middle. */
static void march_straight(const march_job *j, const vsd_padded_grid *pad, const float o[3], const float u[3], float t0,
                           float t1, float world_step, size_t sx, size_t sy, float *acc)
{
    const vsd_lbl_grid *g = j->g;
    /* a leap needs sqrt(D^2) - 2.61 - 0.5 step >= step (below): D^2 against this first,
     * so a step that cannot leap takes no square root */
    const float leap2 = (2.61f + 1.5f * j->step) * (2.61f + 1.5f * j->step);
    float t, tr = 1.0f;
    int ax;
    for (t = t0; t < t1 && tr > LBL_T_MIN; t += j->step) {
        float h, x[3], half;
        if (g->empty_d2) {
            /* A step's middle reaches medium or a record only within sqrt(3) cells of a
             * cell centre that has one (the trilinear lookup and the splat read the 8
             * centres around it); from the step's start, D - 0.87 (the start's distance
             * to its cell centre at most) - 0.5 step further on is still that far, so whole
             * steps inside that radius add a factor exp(-0) = 1 and splat only onto empty
             * cells: they are skipped, whole, so the steps after stay where they were. */
            int32_t c[3];
            for (ax = 0; ax < 3; ax++) {
                float p = o[ax] + t * u[ax];
                c[ax] = p <= 0.0f ? 0 : p >= (float)g->res[ax] ? g->res[ax] - 1 : (int32_t)p;
            }
            {
                float d2 = g->empty_d2[((size_t)c[2] * g->res[1] + c[1]) * g->res[0] + c[0]];
                float r = d2 >= leap2 ? sqrtf(d2) - 2.61f - 0.5f * j->step : 0.0f;
                if (r >= j->step) {
                    t += floorf(r / j->step) * j->step;
                    if (!(t < t1)) break;
                }
            }
        }
        h = fminf(j->step, t1 - t);
        for (ax = 0; ax < 3; ax++) x[ax] = o[ax] + (t + 0.5f * h) * u[ax];
        half = expf(-0.5f * sigma_at(pad, x) * world_step * (h / j->step));
        /* the transmittance at the step's middle is what the cells there see */
        tr *= half;
        splat(sx, sy, x, tr, acc);
        tr *= half;
    }
}

/* A point (or spot) light: rays from its position through a cube of directions around it,
 * each face a square lattice of directions whose spacing, at the farthest corner of the
 * box, is j->spacing cells (nearer cells get denser rays); a face's lattice covers only
 * the box's image on it when the whole box lies in front of it. Rays start at the light, or
 * where they enter the box. */
static void march_point(const march_job *j, const vsd_padded_grid *pad, int k, float *acc)
{
    const vsd_lbl_grid *g = j->g;
    const float *l = j->points + (size_t)VSD_KLIGHT_FLOATS * k;
    const size_t sx = (size_t)g->res[0] + 2, sy = sx * ((size_t)g->res[1] + 2);
    vsd_f3 pw = vsd_affine_point(&g->world_to_grid, f3(l[0], l[1], l[2]));
    float o[3] = {pw.x, pw.y, pw.z}, far2 = 0.0f, delta, corner[8][3];
    int face, c, ax;
    memset(acc, 0, 2 * sy * ((size_t)g->res[2] + 2) * sizeof *acc);
    /* the box's corners relative to the light */
    for (c = 0; c < 8; c++) {
        for (ax = 0; ax < 3; ax++) corner[c][ax] = (float)((c >> ax) & 1 ? g->res[ax] : 0) - o[ax];
        far2 = fmaxf(far2, corner[c][0] * corner[c][0] + corner[c][1] * corner[c][1] + corner[c][2] * corner[c][2]);
    }
    if (!(far2 > 0.0f) || !isfinite(far2)) goto done;
    delta = j->spacing / sqrtf(far2);   /* on a face at distance 1: the angle between rays */
    for (face = 0; face < 6; face++) {
        int a = face >> 1, b = (a + 1) % 3, cc = (a + 2) % 3;
        float sgn = (face & 1) ? -1.0f : 1.0f, lo[2] = {-1.0f, -1.0f}, hi[2] = {1.0f, 1.0f}, x, y;
        int in_front = 1;
        float plo[2] = {1e30f, 1e30f}, phi[2] = {-1e30f, -1e30f};
        for (c = 0; c < 8; c++) {
            const float *q = corner[c];
            float depth = sgn * q[a];
            if (depth <= 0.0f) { in_front = 0; break; }
            plo[0] = fminf(plo[0], q[b] / depth);
            phi[0] = fmaxf(phi[0], q[b] / depth);
            plo[1] = fminf(plo[1], q[cc] / depth);
            phi[1] = fmaxf(phi[1], q[cc] / depth);
        }
        if (in_front) {
            int q;
            for (q = 0; q < 2; q++) {
                lo[q] = fmaxf(lo[q], plo[q] - delta);
                hi[q] = fminf(hi[q], phi[q] + delta);
            }
            if (lo[0] > hi[0] || lo[1] > hi[1]) continue;
        }
        for (x = lo[0]; x <= hi[0]; x += delta)
            for (y = lo[1]; y <= hi[1]; y += delta) {
                float u[3], n, t0, t1;
                vsd_f3 uw;
                u[a] = sgn;
                u[b] = x;
                u[cc] = y;
                n = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
                u[0] /= n;
                u[1] /= n;
                u[2] /= n;
                if (!clip(g->res, o, u, &t0, &t1) || t1 <= 0.0f) continue;
                /* a grid step of j->step along u is j->step / |u| in the world's length */
                uw = vsd_affine_vector(&g->grid_to_world, f3(u[0], u[1], u[2]));
                march_straight(j, pad, o, u, fmaxf(t0, 0.0f), t1, j->step * sqrtf(f3_dot(uw, uw)), sx, sy, acc);
            }
    }
done:
    store(j, acc, j->point_trans, j->point_count, k);
}

static void march_light(const march_job *j, const vsd_padded_grid *pad, int k, float *acc)
{
    const vsd_lbl_grid *g = j->g;
    const float *l = j->lights + 8 * (size_t)k;
    const size_t sx = (size_t)g->res[0] + 2, sy = sx * ((size_t)g->res[1] + 2);
    double v[3], len;
    float u[3], e1[3], e2[3], centre[3], radius, a, b;
    int ax;
    /* the rays travel away from the light: -w in the grid */
    for (ax = 0; ax < 3; ax++)
        v[ax] = -(g->to_grid[3 * ax] * l[0] + g->to_grid[3 * ax + 1] * l[1] + g->to_grid[3 * ax + 2] * l[2]);
    len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    memset(acc, 0, 2 * sy * ((size_t)g->res[2] + 2) * sizeof *acc);
    if (len > 0.0) {
        /* a grid step of `step` along u is step / len world units long */
        const float world_step = (float)(j->step / len);
        for (ax = 0; ax < 3; ax++) u[ax] = (float)(v[ax] / len);
        /* e1, e2: an orthonormal frame across u */
        {
            float h[3] = {fabsf(u[0]) < 0.9f ? 1.0f : 0.0f, fabsf(u[0]) < 0.9f ? 0.0f : 1.0f, 0.0f}, d, n;
            d = h[0] * u[0] + h[1] * u[1] + h[2] * u[2];
            for (ax = 0; ax < 3; ax++) e1[ax] = h[ax] - d * u[ax];
            n = sqrtf(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
            for (ax = 0; ax < 3; ax++) e1[ax] /= n;
            e2[0] = u[1] * e1[2] - u[2] * e1[1];
            e2[1] = u[2] * e1[0] - u[0] * e1[2];
            e2[2] = u[0] * e1[1] - u[1] * e1[0];
        }
        for (ax = 0; ax < 3; ax++) centre[ax] = 0.5f * (float)g->res[ax];
        radius = 0.5f * sqrtf((float)g->res[0] * g->res[0] + (float)g->res[1] * g->res[1] + (float)g->res[2] * g->res[2]) + 1.0f;
        for (a = -radius; a <= radius; a += j->spacing)
            for (b = -radius; b <= radius; b += j->spacing) {
                float o[3], t0, t1;
                for (ax = 0; ax < 3; ax++) o[ax] = centre[ax] + a * e1[ax] + b * e2[ax];
                if (!clip(g->res, o, u, &t0, &t1)) continue;
                if (g->refract) {
                    march_bent(g, pad, o, u, t0, (float)(j->step / len), sx, sy, acc);
                    continue;
                }
                march_straight(j, pad, o, u, t0, t1, world_step, sx, sy, acc);
            }
    }
    store(j, acc, j->trans, j->light_count, k);
}

/* Lights [k0, k1) as the x range of a count x 1 job of the CPU pool. */
static void run(void *arg, int k0, int y0, int k1, int y1)
{
    march_job *j = arg;
    size_t cells = ((size_t)j->g->res[0] + 2) * ((size_t)j->g->res[1] + 2) * ((size_t)j->g->res[2] + 2);
    float *acc = malloc(2 * cells * sizeof *acc);
    int k;
    (void)y0;
    (void)y1;
    if (!acc) {
        j->st = VSD_ERR_NOMEM;
    } else {
        for (k = k0; k < k1; k++) {
            if (k < j->light_count) march_light(j, j->pad, k, acc);
            else march_point(j, j->pad, k - j->light_count, acc);
        }
    }
    free(acc);
}

vsd_status vsd_lbl_march_lights(const vsd_lbl_grid *g, const float *lights, int light_count, const float *points,
                                int point_count, float spacing, float step, const int32_t *cell_record, int threads,
                                float *trans, float *point_trans, char *err, size_t errlen)
{
    march_job job;
    vsd_padded_grid pad;
    vsd_status st;
    if (!(spacing > 0.0f && spacing <= 1.0f) || !(step > 0.0f && step <= 1.0f))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "lbl marching: ray spacing %g and step %g must be in (0, 1] cells",
                        (double)spacing, (double)step);
    if (light_count + point_count <= 0 || (size_t)g->res[0] * g->res[1] * g->res[2] == 0) return VSD_OK;
    job.g = g;
    job.lights = lights;
    job.light_count = light_count;
    job.points = points;
    job.point_count = point_count;
    job.point_trans = point_trans;
    job.spacing = spacing;
    job.step = step;
    job.trans = trans;
    job.cell_record = cell_record;
    job.st = VSD_OK;
    if (!vsd_padded_grid_build(&pad, g->res, g->sigma)) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl light marching: no memory");
    job.pad = &pad;
    st = vsd_cpu_run_items(light_count + point_count, threads, run, &job, "lbl light marching");
    vsd_padded_grid_free(&pad);
    if (st) return vsd_fail(st, err, errlen, "lbl light marching cancelled");
    if (job.st) return vsd_fail(job.st, err, errlen, "lbl light marching: no memory for the deposit grids");
    return VSD_OK;
}
