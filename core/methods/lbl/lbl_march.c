#include "lbl_march.h"
#include "device/cpu/cpu_tiles.h"
#include "src/grids/padded_grid.h"
#include "kernel/kernel_refract.h"
#include "kernel/kernel_lights.h"
#include "src/grids/distance_map.h"
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

/* Rays die below this transmittance: what they would still leave behind is < 1e-4 of the
 * light they brought. */
#define LBL_T_MIN 1e-4f


/* An accumulator's floats per cell and medium: sum w T, sum w (the weighted mean T), the
 * lost power; a cell's media side by side, so one splat touches the same cache lines. */
enum { ACC_WT = 0, ACC_W = 1, ACC_LOST = 2, ACC = 3 };

/* The media marched along the same rays: sigma, and delta-M's scaled sigma2 (lbl_march.h). */
#define MEDIA_MAX 2

/* A step's middle x and the eight cell centres around it: their trilinear weights, the
 * sigma at each (pad: the sigma grid, whose trilinear value at x is the step's sigma) and
 * the first corner's place in an accumulator with a one-cell border (strides sx, sy;
 * interior cell (i,j,k) at (i+1, j+1, k+1)). Points are inside the box, so the corners are
 * inside the border. */
typedef struct step_corners {
    float *acc;                  /* the accumulator at the first corner (medium 0) */
    float w[8];                  /* trilinear weights */
    float sw[MEDIA_MAX][8];      /* per medium: sigma times weight */
    float sigma[MEDIA_MAX];      /* per medium: the step's sigma, sum of sw */
    size_t sx, sy;               /* the accumulator's strides, in cells */
    int media;                   /* its media per cell */
} step_corners;

/* The corners of x for `media` sigma grids pad[0..media) (the same cells, the weights once) */
static void corners_at(const vsd_padded_grid *pad, int media, size_t sx, size_t sy, const float x[3], float *acc,
                       step_corners *k)
{
    float fx = x[0] - 0.5f, fy = x[1] - 0.5f, fz = x[2] - 0.5f, ix = floorf(fx), iy = floorf(fy), iz = floorf(fz);
    float tx = fx - ix, ty = fy - iy, tz = fz - iz;
    const size_t first = (size_t)((int32_t)iz + 1) * pad->sy + (size_t)((int32_t)iy + 1) * pad->sx + (size_t)((int32_t)ix + 1);
    const size_t poff[8] = {0, 1, pad->sx, pad->sx + 1, pad->sy, pad->sy + 1, pad->sy + pad->sx, pad->sy + pad->sx + 1};
    float w00 = (1.0f - ty) * (1.0f - tz), w10 = ty * (1.0f - tz), w01 = (1.0f - ty) * tz, w11 = ty * tz;
    int q, m;
    k->w[0] = (1.0f - tx) * w00, k->w[1] = tx * w00, k->w[2] = (1.0f - tx) * w10, k->w[3] = tx * w10;
    k->w[4] = (1.0f - tx) * w01, k->w[5] = tx * w01, k->w[6] = (1.0f - tx) * w11, k->w[7] = tx * w11;
    for (m = 0; m < media; m++) {
        const float *sg = pad[m].v + first;   /* (the pads share their layout) */
        k->sigma[m] = 0.0f;
        for (q = 0; q < 8; q++) k->sigma[m] += k->sw[m][q] = sg[poff[q]] * k->w[q];
    }
    k->acc = acc + (size_t)(ACC * media) *
                       ((size_t)((int32_t)iz + 1) * sy + (size_t)((int32_t)iy + 1) * sx + (size_t)((int32_t)ix + 1));
    k->sx = sx, k->sy = sy;
    k->media = media;
}

/* The step's T at its middle (v) and its lost power onto the corners: += w v, += w (the
 * weighted mean's parts), and the lost power shared as the step's extinction is, the
 * corner's sigma w over sum sigma w, so what is lost lands where the medium took it. */
static void splat(const step_corners *k, int m, float v, float lost)
{
    const size_t sx = k->sx, sy = k->sy, cell = (size_t)(ACC * k->media);
    const size_t off[8] = {0, 1, sx, sx + 1, sy, sy + 1, sy + sx, sy + sx + 1};
    float *acc = k->acc + ACC * m;
    int q;
    for (q = 0; q < 8; q++) {
        acc[cell * off[q] + ACC_WT] += k->w[q] * v;
        acc[cell * off[q] + ACC_W] += k->w[q];
    }
    if (!(lost > 0.0f) || !(k->sigma[m] > 0.0f)) return;   /* (lost 0 also when not wanted) */
    for (q = 0; q < 8; q++) acc[cell * off[q] + ACC_LOST] += lost * (k->sw[m][q] / k->sigma[m]);
}

/* Any medium's T still worth marching */
static int any_alive(const float *tr, int media)
{
    int m;
    for (m = 0; m < media; m++)
        if (tr[m] > LBL_T_MIN) return 1;
    return 0;
}

/* A step of straight or bent rays, world length len x part (part: the share of a whole
 * step, as the single march multiplied them): the media whose T is still worth it lose
 * exp(-sigma_m len part) each, T at its middle and the lost power splatted (lost_scale[m]:
 * 0 when not wanted). */
static void step_media(const step_corners *k, float len, float part, const float *lost_scale, float *tr)
{
    int m;
    for (m = 0; m < k->media; m++) {
        float half;
        if (!(tr[m] > LBL_T_MIN)) continue;
        half = expf(-0.5f * k->sigma[m] * len * part);
        /* the transmittance at the step's middle is what the cells there see; what the
         * step loses, tr (1 - half^2), is the light the medium takes out of the ray */
        splat(k, m, tr[m] * half, tr[m] * (1.0f - half * half) * lost_scale[m]);
        tr[m] *= half * half;
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
static void march_bent(const vsd_lbl_grid *g, const vsd_padded_grid *pad, int media, const float o[3], const float u[3],
                       float t0, float h, const float *lost_scale, size_t sx, size_t sy, float *acc)
{
    const vsd_krefract *r = g->refract;
    float q[3], tr[MEDIA_MAX] = {1.0f, 1.0f};
    vsd_f3 x, d, v, gr;
    int32_t ax, steps = 0;
    /* the bending integrates at the field's own step at most (its smoothed interface is a
     * few of them wide) */
    h = fminf(h, r->step);
    for (ax = 0; ax < 3; ax++) q[ax] = o[ax] + t0 * u[ax];
    x = vsd_affine_point(&g->grid_to_world, f3(q[0], q[1], q[2]));
    d = f3_normalize(vsd_affine_vector(&g->grid_to_world, f3(u[0], u[1], u[2])));
    v = f3_scale(d, vsd_refract_eval(r, x, &gr));
    while (any_alive(tr, media) && steps++ < r->max_steps) {
        vsd_f3 m = vsd_affine_point(&g->world_to_grid, f3_madd(x, d, 0.5f * h));
        float xm[3] = {m.x, m.y, m.z};
        step_corners k;
        if (!(m.x >= 0.0f && m.y >= 0.0f && m.z >= 0.0f && m.x <= (float)g->res[0] && m.y <= (float)g->res[1] &&
              m.z <= (float)g->res[2]))
            break;   /* (also for a NaN position) */
        corners_at(pad, media, sx, sy, xm, acc, &k);
        step_media(&k, h, 1.0f, lost_scale, tr);
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

/* A cell centre is read by a splat at a step's middle m only within one cell of m per
 * axis, so within sqrt(3) of it: once every step still to come starts at t >= front, the
 * cells whose centres lie nearer than front - FRONT_REACH (along the rays' t) are final. */
#define FRONT_REACH 1.75f

/* The rays of one light, enumerable by index in the order the sequential march took them,
 * with their origins rebuilt exactly (the same float accumulation), so a ray resumed in a
 * later round is the same ray. */
typedef struct light_rays {
    int point;                   /* 0: parallel rays of a directional light; 1: from a position */
    int count;
    float u[3], e1[3], e2[3], centre[3], world_step;  /* directional */
    int na;
    float *across;               /* [na] the lattice's offsets across u, on both axes */
    float o[3];                  /* point: the light's position in the grid */
    int face_first[7], face_n[6][2];
    float *face_vals[6][2];      /* point: each face's lattice coordinates */
    int axis[6][3];              /* point: the face's normal axis and its two lattice axes */
    float sign[6];
} light_rays;

/* One light on its way through the rounds. */
typedef struct light_march {
    int index;                   /* 0..light_count-1 directional, then the point lights */
    light_rays rays;
    float *acc;                  /* [ACC x padded cells] sum w T, sum w, lost power (splat) */
    float *ray_t, *ray_tr;       /* per ray: the next step's start (NAN: not started, INF: done), T */
    float t_begin;               /* no step starts before this t */
    float front;                 /* cells with d < front are final and stored */
    int done;
} light_march;

typedef struct march_job {
    const vsd_lbl_grid *g;
    const float *lights;
    int light_count;
    const float *points;     /* point and spot lights, kernel_lights.h layout */
    int point_count;
    float spacing, step;
    const int32_t *cell_record;
    const vsd_padded_grid *pad;   /* [media] the sigma grids, padded */
    int media;
    const vsd_lbl_march_out *out;   /* [media] */
    light_march *batch;
    int batch_count;
    float round_end;         /* this round's steps start before t_begin + round_end; INF: all */
    vsd_lbl_overlap *overlap;
    vsd_status st;
} march_job;

/* A directional light's ray stands for a beam of world cross-section A = V spacing^2 step /
 * world_step (its rays are spacing cells apart across it, and a step of `step` cells
 * sweeps spacing^2 step cells' volume V in world_step of length); a step that lowers its T
 * by dT takes E A dT out of it. The lost power is accumulated divided by E V, so that a
 * cell's sum reads like sigma T (per world length), the thin cell's rate. 0 when the march
 * was not asked for the lost power (the splat then skips it). */
static void lost_per_transmittance(const march_job *j, float world_step, float scale[MEDIA_MAX])
{
    int m;
    for (m = 0; m < j->media; m++)
        scale[m] = j->out[m].lost ? j->spacing * j->spacing * j->step / world_step : 0.0f;   /* 0: not wanted */
}

static void rays_free(light_rays *r)
{
    int f;
    free(r->across);
    for (f = 0; f < 6; f++) free(r->face_vals[f][0]), free(r->face_vals[f][1]);
    memset(r, 0, sizeof *r);
}

/* v[0..n) = lo, lo + d, ... while <= hi, accumulated as the sequential loops did; NULL when
 * out of memory (n = 0 gives a 1-element array) */
static float *lattice_values(float lo, float hi, float d, int *n)
{
    float x, *v;
    int c = 0;
    for (x = lo; x <= hi; x += d) c++;
    v = malloc(sizeof *v * (size_t)(c ? c : 1));
    if (!v) return NULL;
    *n = c;
    c = 0;
    for (x = lo; x <= hi; x += d) v[c++] = x;
    return v;
}

int vsd_lbl_light_travel(const vsd_lbl_grid *g, const float *light, float u[3], double *len)
{
    double v[3];
    int ax;
    /* away from the light: -w in the grid */
    for (ax = 0; ax < 3; ax++)
        v[ax] = -(g->to_grid[3 * ax] * light[0] + g->to_grid[3 * ax + 1] * light[1] + g->to_grid[3 * ax + 2] * light[2]);
    *len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(*len > 0.0) || !isfinite(*len)) return 0;
    for (ax = 0; ax < 3; ax++) u[ax] = (float)(v[ax] / *len);
    return 1;
}

/* The parallel rays of directional light k: a square lattice `spacing` apart across -w_k
 * over the grid's bounding sphere. */
static int rays_directional(const march_job *j, int k, light_rays *r, float *t_begin)
{
    const vsd_lbl_grid *g = j->g;
    double len;
    float radius;
    int ax;
    memset(r, 0, sizeof *r);
    *t_begin = 0.0f;
    if (!vsd_lbl_light_travel(g, j->lights + 8 * (size_t)k, r->u, &len)) return 1;   /* no rays */
    /* a grid step of `step` along u is step / len world units long */
    r->world_step = (float)(j->step / len);
    {
        const float *u = r->u;
        float h[3] = {fabsf(u[0]) < 0.9f ? 1.0f : 0.0f, fabsf(u[0]) < 0.9f ? 0.0f : 1.0f, 0.0f}, d, n;
        d = h[0] * u[0] + h[1] * u[1] + h[2] * u[2];
        for (ax = 0; ax < 3; ax++) r->e1[ax] = h[ax] - d * u[ax];
        n = sqrtf(r->e1[0] * r->e1[0] + r->e1[1] * r->e1[1] + r->e1[2] * r->e1[2]);
        for (ax = 0; ax < 3; ax++) r->e1[ax] /= n;
        r->e2[0] = u[1] * r->e1[2] - u[2] * r->e1[1];
        r->e2[1] = u[2] * r->e1[0] - u[0] * r->e1[2];
        r->e2[2] = u[0] * r->e1[1] - u[1] * r->e1[0];
    }
    for (ax = 0; ax < 3; ax++) r->centre[ax] = 0.5f * (float)g->res[ax];
    radius = 0.5f * sqrtf((float)g->res[0] * g->res[0] + (float)g->res[1] * g->res[1] + (float)g->res[2] * g->res[2]) + 1.0f;
    if (!(r->across = lattice_values(-radius, radius, j->spacing, &r->na))) return 0;
    r->count = r->na * r->na;
    /* t is measured from the plane across u through the centre: no ray starts before -radius */
    *t_begin = -radius;
    return 1;
}

/* A point (or spot) light: rays from its position through a cube of directions around it,
 * each face a square lattice of directions whose spacing, at the farthest corner of the
 * box, is j->spacing cells (nearer cells get denser rays); a face's lattice covers only
 * the box's image on it when the whole box lies in front of it. */
static int rays_point(const march_job *j, int k, light_rays *r, float *t_begin)
{
    const vsd_lbl_grid *g = j->g;
    const float *l = j->points + (size_t)VSD_KLIGHT_FLOATS * k;
    vsd_f3 pw = vsd_affine_point(&g->world_to_grid, f3(l[0], l[1], l[2]));
    float far2 = 0.0f, near2 = 0.0f, delta, corner[8][3];
    int face, c, ax;
    memset(r, 0, sizeof *r);
    r->point = 1;
    r->o[0] = pw.x, r->o[1] = pw.y, r->o[2] = pw.z;
    *t_begin = 0.0f;
    /* the box's corners relative to the light */
    for (c = 0; c < 8; c++) {
        for (ax = 0; ax < 3; ax++) corner[c][ax] = (float)((c >> ax) & 1 ? g->res[ax] : 0) - r->o[ax];
        far2 = fmaxf(far2, corner[c][0] * corner[c][0] + corner[c][1] * corner[c][1] + corner[c][2] * corner[c][2]);
    }
    if (!(far2 > 0.0f) || !isfinite(far2)) return 1;   /* no rays */
    /* rays start at the light or where they enter the box: not before the box's distance */
    for (ax = 0; ax < 3; ax++) {
        float e = fmaxf(fmaxf(-r->o[ax], r->o[ax] - (float)g->res[ax]), 0.0f);
        near2 += e * e;
    }
    *t_begin = sqrtf(near2);
    delta = j->spacing / sqrtf(far2);   /* on a face at distance 1: the angle between rays */
    for (face = 0; face < 6; face++) {
        int a = face >> 1, b = (a + 1) % 3, cc = (a + 2) % 3, in_front = 1, q;
        float sgn = (face & 1) ? -1.0f : 1.0f, lo[2] = {-1.0f, -1.0f}, hi[2] = {1.0f, 1.0f};
        float plo[2] = {1e30f, 1e30f}, phi[2] = {-1e30f, -1e30f};
        r->axis[face][0] = a, r->axis[face][1] = b, r->axis[face][2] = cc;
        r->sign[face] = sgn;
        r->face_first[face] = r->count;
        for (c = 0; c < 8; c++) {
            const float *p = corner[c];
            float depth = sgn * p[a];
            if (depth <= 0.0f) { in_front = 0; break; }
            plo[0] = fminf(plo[0], p[b] / depth);
            phi[0] = fmaxf(phi[0], p[b] / depth);
            plo[1] = fminf(plo[1], p[cc] / depth);
            phi[1] = fmaxf(phi[1], p[cc] / depth);
        }
        if (in_front) {
            for (q = 0; q < 2; q++) {
                lo[q] = fmaxf(lo[q], plo[q] - delta);
                hi[q] = fminf(hi[q], phi[q] + delta);
            }
            if (lo[0] > hi[0] || lo[1] > hi[1]) continue;
        }
        for (q = 0; q < 2; q++)
            if (!(r->face_vals[face][q] = lattice_values(lo[q], hi[q], delta, &r->face_n[face][q]))) return 0;
        r->count += r->face_n[face][0] * r->face_n[face][1];
    }
    r->face_first[6] = r->count;
    return 1;
}

/* Ray i of r: origin o, unit direction u (grid units), the span [*t0, *t1) inside the box
 * and the world length of a grid step; 0 when it misses the box. */
static int ray_at(const march_job *j, const light_rays *r, int i, float o[3], float u[3], float *t0, float *t1,
                  float *world_step)
{
    int ax;
    if (!r->point) {
        float a = r->across[i / r->na], b = r->across[i % r->na];
        for (ax = 0; ax < 3; ax++) o[ax] = r->centre[ax] + a * r->e1[ax] + b * r->e2[ax];
        memcpy(u, r->u, sizeof r->u);
        *world_step = r->world_step;
        return clip(j->g->res, o, u, t0, t1);
    }
    {
        int face = 0, q;
        float n;
        vsd_f3 uw;
        while (i >= r->face_first[face + 1]) face++;
        q = i - r->face_first[face];
        u[r->axis[face][0]] = r->sign[face];
        u[r->axis[face][1]] = r->face_vals[face][0][q / r->face_n[face][1]];
        u[r->axis[face][2]] = r->face_vals[face][1][q % r->face_n[face][1]];
        n = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (ax = 0; ax < 3; ax++) u[ax] /= n, o[ax] = r->o[ax];
        if (!clip(j->g->res, o, u, t0, t1) || *t1 <= 0.0f) return 0;
        *t0 = fmaxf(*t0, 0.0f);
        /* a grid step of j->step along u is j->step / |u| in the world's length */
        uw = vsd_affine_vector(&j->g->grid_to_world, f3(u[0], u[1], u[2]));
        *world_step = j->step * sqrtf(f3_dot(uw, uw));
        return 1;
    }
}

/* March one straight ray o + t u (grid units, |u| = 1) from *t while t < t1 and the step
 * starts before t_end, depositing its transmittance *tr at every step's middle; *t and *tr
 * are left where it stopped (a round's end, or t >= t1, or T < LBL_T_MIN). world_step is
 * the world length of a grid step of j->step along u. */
static void march_straight(const march_job *j, const float o[3], const float u[3], float *tp, float t1, float t_end,
                           float world_step, float *tr, size_t sx, size_t sy, float *acc)
{
    const vsd_lbl_grid *g = j->g;
    float lost_scale[MEDIA_MAX];
    /* a leap needs sqrt(D^2) - 2.61 - 0.5 step >= step (below): D^2 against this first,
     * so a step that cannot leap takes no square root */
    const float leap2 = (2.61f + 1.5f * j->step) * (2.61f + 1.5f * j->step);
    float t = *tp;
    int ax;
    lost_per_transmittance(j, world_step, lost_scale);
    for (; t < t1 && t < t_end && any_alive(tr, j->media); t += j->step) {
        float h, x[3];
        step_corners k;
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
                    if (!(t < t1) || !(t < t_end)) break;
                }
            }
        }
        h = fminf(j->step, t1 - t);
        for (ax = 0; ax < 3; ax++) x[ax] = o[ax] + (t + 0.5f * h) * u[ax];
        corners_at(j->pad, j->media, sx, sy, x, acc, &k);
        step_media(&k, world_step, h / j->step, lost_scale, tr);
    }
    *tp = t;
}

/* Advances every ray of light m whose next step starts before t_begin + j->round_end.
 * Bent rays (refraction) have no front: they march to the end in the first round. */
static void advance(const march_job *j, light_march *m)
{
    const vsd_lbl_grid *g = j->g;
    const size_t sx = (size_t)g->res[0] + 2, sy = sx * ((size_t)g->res[1] + 2);
    const float t_end = m->t_begin + j->round_end;
    int i, q, live = 0;
    for (i = 0; i < m->rays.count; i++) {
        float o[3], u[3], t0, t1, ws, t = m->ray_t ? m->ray_t[i] : NAN, tr[MEDIA_MAX];
        for (q = 0; q < j->media; q++) tr[q] = m->ray_tr ? m->ray_tr[(size_t)j->media * i + q] : 1.0f;
        if (isinf(t)) continue;
        if (!ray_at(j, &m->rays, i, o, u, &t0, &t1, &ws)) {
            t = INFINITY;
        } else if (g->refract && !m->rays.point) {
            float lost_scale[MEDIA_MAX];
            lost_per_transmittance(j, ws, lost_scale);
            march_bent(g, j->pad, j->media, o, u, t0, ws, lost_scale, sx, sy, m->acc);
            t = INFINITY;
        } else {
            if (isnan(t)) t = t0;
            march_straight(j, o, u, &t, t1, t_end, ws, tr, sx, sy, m->acc);
            if (!(t < t1) || !any_alive(tr, j->media)) t = INFINITY;
        }
        if (m->ray_t) {
            m->ray_t[i] = t;
            for (q = 0; q < j->media; q++) m->ray_tr[(size_t)j->media * i + q] = tr[q];
        }
        live += !isinf(t);
    }
    m->done = live == 0;
}

/* The distance of cell (x, y, z)'s centre along light m's rays' t. */
static float cell_t(const light_march *m, int32_t x, int32_t y, int32_t z)
{
    const light_rays *r = &m->rays;
    float p[3] = {(float)x + 0.5f, (float)y + 0.5f, (float)z + 0.5f};
    if (r->point) {
        float dx = p[0] - r->o[0], dy = p[1] - r->o[1], dz = p[2] - r->o[2];
        return sqrtf(dx * dx + dy * dy + dz * dz);
    }
    return (p[0] - r->centre[0]) * r->u[0] + (p[1] - r->centre[1]) * r->u[1] + (p[2] - r->centre[2]) * r->u[2];
}

/* Stores light m's T at the records of the cells whose t lies in [lo, hi) — the weighted
 * mean of what the rays left at the cell's centre, 0 where nothing reached it — and hands
 * each to the overlap's deposit. */
static void transfer(const march_job *j, const light_march *m, float lo, float hi)
{
    const vsd_lbl_grid *g = j->g;
    const size_t sx = (size_t)g->res[0] + 2, sy = sx * ((size_t)g->res[1] + 2);
    const int point = m->index >= j->light_count, k = point ? m->index - j->light_count : m->index;
    const int count = point ? j->point_count : j->light_count;
    const int window = isfinite(lo) || isfinite(hi);   /* else every cell: no test */
    int32_t ci, cj, ck;
    for (ck = 0; ck < g->res[2]; ck++)
        for (cj = 0; cj < g->res[1]; cj++) {
            /* the row's cells in the window: t is linear in x (parallel rays) or, from a
             * point, within hi where (x - o)^2 <= hi^2 - (row's distance)^2; one cell of
             * margin each side, then the exact test */
            int32_t x0 = 0, x1 = g->res[0] - 1;
            if (window) {
                const light_rays *r = &m->rays;
                if (r->point) {
                    float dy = (float)cj + 0.5f - r->o[1], dz = (float)ck + 0.5f - r->o[2], r2 = dy * dy + dz * dz;
                    if (isfinite(hi)) {
                        float half;
                        if (hi * hi <= r2) continue;
                        half = sqrtf(hi * hi - r2);
                        x0 = (int32_t)fmaxf(0.0f, floorf(r->o[0] - 0.5f - half) - 1.0f);
                        x1 = (int32_t)fminf((float)(g->res[0] - 1), ceilf(r->o[0] - 0.5f + half) + 1.0f);
                    }
                } else if (fabsf(r->u[0]) > 1e-6f) {
                    float d0 = cell_t(m, 0, cj, ck), a = (lo - d0) / r->u[0], b = (hi - d0) / r->u[0], s;
                    if (a > b) s = a, a = b, b = s;
                    a = fmaxf(a - 1.0f, 0.0f);
                    b = fminf(b + 1.0f, (float)(g->res[0] - 1));
                    if (a > b) continue;
                    x0 = (int32_t)a, x1 = (int32_t)ceilf(b);
                }
            }
            for (ci = x0; ci <= x1; ci++) {
                size_t c = ((size_t)ck * g->res[1] + cj) * g->res[0] + ci;
                int32_t rec = j->cell_record[c];
                const float *a2;
                float t = 0.0f, d, lost = 0.0f;
                int q;
                if (rec < 0) continue;
                if (window) {
                    d = cell_t(m, ci, cj, ck);
                    if (!(d >= lo && d < hi)) continue;
                }
                a2 = m->acc + (size_t)(ACC * j->media) * ((size_t)(ck + 1) * sy + (size_t)(cj + 1) * sx + (size_t)(ci + 1));
                for (q = 0; q < j->media; q++, a2 += ACC) {
                    const vsd_lbl_march_out *o = &j->out[q];
                    t = a2[ACC_W] > 0.0f ? a2[ACC_WT] / a2[ACC_W] : 0.0f;
                    (point ? o->point_trans : o->trans)[(size_t)rec * count + k] = t;
                    lost = point ? NAN : a2[ACC_LOST];
                    if (!point && o->lost) o->lost[(size_t)rec * count + k] = lost;
                }
                /* (an overlap marches one medium: vsd_lbl_march_lights) */
                if (j->overlap && j->overlap->deposit) j->overlap->deposit(j->overlap->user, m->index, c, rec, t, lost);
            }
        }
}

/* Lights [k0, k1) of the batch as the x range of a count x 1 job of the CPU pool. */
static void advance_items(void *arg, int k0, int y0, int k1, int y1)
{
    march_job *j = arg;
    int k;
    (void)y0;
    (void)y1;
    for (k = k0; k < k1; k++)
        if (!j->batch[k].done) advance(j, &j->batch[k]);
}

static void light_free(light_march *m)
{
    rays_free(&m->rays);
    free(m->acc);
    free(m->ray_t);
    free(m->ray_tr);
    memset(m, 0, sizeof *m);
}

/* Light `index` ready to march: its rays, its zeroed accumulator, and (in rounds) each
 * ray's state. 0 when out of memory. */
static int light_begin(const march_job *j, int index, int rounds, light_march *m)
{
    const vsd_lbl_grid *g = j->g;
    size_t cells = ((size_t)g->res[0] + 2) * ((size_t)g->res[1] + 2) * ((size_t)g->res[2] + 2);
    int ok, i;
    memset(m, 0, sizeof *m);
    m->index = index;
    m->front = -INFINITY;
    ok = index < j->light_count ? rays_directional(j, index, &m->rays, &m->t_begin)
                                : rays_point(j, index - j->light_count, &m->rays, &m->t_begin);
    m->acc = calloc((size_t)(ACC * j->media) * cells, sizeof *m->acc);
    if (!ok || !m->acc) return 0;
    if (rounds && m->rays.count > 0) {
        const size_t n = (size_t)m->rays.count;
        m->ray_t = malloc(sizeof *m->ray_t * n);
        m->ray_tr = malloc(sizeof *m->ray_tr * n * (size_t)j->media);
        if (!m->ray_t || !m->ray_tr) return 0;
        for (i = 0; i < m->rays.count; i++) m->ray_t[i] = NAN;
        for (size_t q = 0; q < n * (size_t)j->media; q++) m->ray_tr[q] = 1.0f;
    }
    return 1;
}

/* Sequential: each item marches whole lights, one accumulator at a time. */
static void whole_lights(void *arg, int k0, int y0, int k1, int y1)
{
    march_job *j = arg;
    int k;
    (void)y0;
    (void)y1;
    for (k = k0; k < k1; k++) {
        light_march m;
        if (!light_begin(j, k, 0, &m)) {
            j->st = VSD_ERR_NOMEM;
        } else {
            advance(j, &m);
            transfer(j, &m, -INFINITY, INFINITY);
        }
        light_free(&m);
    }
}

typedef struct during_thread {
    vsd_lbl_overlap *ov;
    pthread_t thread;
    int started;
} during_thread;

static void *during_main(void *arg)
{
    during_thread *d = arg;
    d->ov->during(d->ov->user);
    return NULL;
}

/* Batches of lights advanced in rounds of `history` steps; after every round each light's
 * newly final cells are transferred, and the overlap's `during` runs on a thread of its
 * own while a round marches. */
static vsd_status march_rounds(march_job *j, int threads)
{
    const vsd_lbl_grid *g = j->g;
    const int total = j->light_count + j->point_count, history = j->overlap->history;
    const size_t cells = ((size_t)g->res[0] + 2) * ((size_t)g->res[1] + 2) * ((size_t)g->res[2] + 2);
    const size_t per_light = (size_t)(ACC * j->media) * cells * sizeof(float) + ((size_t)2 << 20);   /* + ray state, roughly */
    int batch = (int)fmin((double)total, fmax(1.0, floor((double)VSD_LBL_OVERLAP_BYTES / (double)per_light)));
    int first, k, march_threads = vsd_cpu_thread_count(threads);
    vsd_status st = VSD_OK;
    if (march_threads > 1 && j->overlap->during) march_threads--;   /* one thread diffuses */
    j->batch = calloc((size_t)batch, sizeof *j->batch);
    if (!j->batch) return VSD_ERR_NOMEM;
    j->overlap->rounds = 0;
    for (first = 0; first < total && st == VSD_OK; first += batch) {
        int n = total - first < batch ? total - first : batch, round, left;
        j->batch_count = n;
        for (k = 0; k < n; k++)
            if (!light_begin(j, first + k, 1, &j->batch[k])) st = VSD_ERR_NOMEM;
        for (round = 0, left = n; st == VSD_OK && left > 0; round++) {
            during_thread d = {j->overlap, 0, 0};
            if (j->overlap->during) d.started = pthread_create(&d.thread, NULL, during_main, &d) == 0;
            j->round_end = (float)(round + 1) * (float)history * j->step;
            st = vsd_cpu_run_items(n, march_threads, advance_items, j, "lbl light marching");
            if (j->overlap->during) {
                if (d.started) pthread_join(d.thread, NULL);
                else j->overlap->during(j->overlap->user);   /* no thread to spare: in turn */
            }
            j->overlap->rounds++;
            /* the transfer: what no step still to come can touch */
            for (k = 0, left = 0; k < n; k++) {
                light_march *m = &j->batch[k];
                float front = m->done ? INFINITY : m->t_begin + j->round_end - FRONT_REACH;
                if (g->refract && !m->rays.point && !m->done) front = -INFINITY;
                if (front > m->front) transfer(j, m, m->front, front), m->front = front;
                left += !m->done;
            }
        }
        for (k = 0; k < n; k++) light_free(&j->batch[k]);
    }
    free(j->batch);
    j->batch = NULL;
    return st ? st : j->st;
}

vsd_status vsd_lbl_march_lights(const vsd_lbl_grid *g, const float *lights, int light_count, const float *points,
                                int point_count, float spacing, float step, const int32_t *cell_record, int threads,
                                const vsd_lbl_march_out *out, vsd_lbl_overlap *overlap, char *err, size_t errlen)
{
    march_job job;
    vsd_padded_grid pad[MEDIA_MAX];
    vsd_status st;
    int m, media = g->sigma2 ? 2 : 1;
    if (!(spacing > 0.0f && spacing <= 1.0f) || !(step > 0.0f && step <= 1.0f))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "lbl marching: ray spacing %g and step %g must be in (0, 1] cells",
                        (double)spacing, (double)step);
    if (overlap && overlap->history < 1)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "lbl marching: a ray history of %d steps (at least 1)",
                        overlap->history);
    if (overlap && media > 1)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "lbl marching: internal: a ray history marches one medium");
    if (light_count + point_count <= 0 || (size_t)g->res[0] * g->res[1] * g->res[2] == 0) return VSD_OK;
    memset(&job, 0, sizeof job);
    job.g = g;
    job.lights = lights;
    job.light_count = light_count;
    job.points = points;
    job.point_count = point_count;
    job.spacing = spacing;
    job.step = step;
    job.media = media;
    job.out = out;
    job.cell_record = cell_record;
    job.overlap = overlap;
    job.round_end = INFINITY;
    job.st = VSD_OK;
    memset(pad, 0, sizeof pad);
    for (m = 0; m < media; m++)
        if (!vsd_padded_grid_build(&pad[m], g->res, m ? g->sigma2 : g->sigma)) {
            while (m-- > 0) vsd_padded_grid_free(&pad[m]);
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl light marching: no memory");
        }
    job.pad = pad;
    st = overlap ? march_rounds(&job, threads)
                 : vsd_cpu_run_items(light_count + point_count, threads, whole_lights, &job, "lbl light marching");
    for (m = 0; m < media; m++) vsd_padded_grid_free(&pad[m]);
    if (st == VSD_ERR_NOMEM || job.st) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl light marching: no memory for the deposit grids");
    if (st) return vsd_fail(st, err, errlen, "lbl light marching cancelled");
    return VSD_OK;
}
