#include "crm_orders.h"
#include "crm_kernel.h"
#include "crm_phase.h"
#include "crm_sweep.h"
#include "vsd/sh.h"
#include "src/common/clock.h"
#include <math.h>
#include "device/cpu/cpu_tiles.h"
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846

/* Most SH coefficients per channel of a source: order 3 (bands 0-2, `ms_bands` 3) */
enum { NB_MAX = 9 };
/* Most directions swept at once (one per thread): each holds two grids of 3 floats */
enum { SWEEP_BATCH_MAX = 8 };


typedef struct coarse_grid {
    int32_t res[3];
    size_t n;
    int nb;             /* SH coefficients per channel of J: 1 (isotropic), 4 or 9 (bands 0-1 or 0-2) */
    float *sigma;       /* [n] world units */
    float *j;           /* [n * 3 * nb] current order's source: SH of J(w_out), per channel */
    float *emit;        /* [n * 3] emission per unit length (world), or NULL */
    float *albedo;      /* [n * 3] per cell (several volumes: their mixture), or NULL: the job's */
    float *next;        /* [n * 3 * nb] the next order */
    double to_cell[9];  /* world direction -> coarse-grid displacement per world unit */
    /* (sigma, sigma J toward one direction) per cell with a zero border (1 cell below, 2
     * above per axis), rebuilt per order (and direction, when J has bands above 0), so the
     * marches read 8 corners of 4 floats without bounds tests */
    float *pad;
    size_t sx, sy;
} coarse_grid;

typedef struct order_job {
    const coarse_grid *g;
    const double *dirs;
    const float *y_in;  /* [m * nb] the SH basis at -w: the direction the light from w travels */
    float weight[NB_MAX]; /* per coefficient: 4 pi chi_l / m, l its band (Funk-Hecke: the phase's
                             band-l coefficient; HG's is g^l) */
    int m;
    int d0, d1;         /* the directions this pass gathers (the pad holds J toward them) */
    double albedo[3];
    /* the first sweep_orders orders (those on the nodes) gather by sweeps (crm_sweep.h)
     * instead of marches: `batch` directions at a time, each with its scattered source
     * (sigma J toward it) and radiance (3 floats per node); source[0] alone where that is
     * the same toward every direction */
    int sweep_orders, batch, shared_source;
    float *source[SWEEP_BATCH_MAX], *radiance[SWEEP_BATCH_MAX];
} order_job;

/* What a march reads as its source per unit length: sigma J (the orders after the first),
 * sigma J + emission (the first order: the medium's own light scatters too), or the
 * emission alone (its once-scattered part, which Cycles counts as direct). */
typedef enum { SOURCE_J, SOURCE_J_EMISSION, SOURCE_EMISSION } source_kind;

/* Y_0^0: an isotropic radiance L has the coefficient L / Y00 */
#define Y00 0.28209479177387814

/* Where coarse cell n = (k res[1] + j) res[0] + i lies in the pad (4 floats), past the
 * one-cell border below on each axis. */
static float *pad_cell(const coarse_grid *g, size_t n)
{
    size_t i = n % (size_t)g->res[0], j = n / (size_t)g->res[0] % (size_t)g->res[1],
           k = n / ((size_t)g->res[0] * (size_t)g->res[1]);
    return g->pad + 4 * ((k + 1) * g->sy + (j + 1) * g->sx + (i + 1));
}

/* Cell n's light scattered per unit length toward a direction whose light travels along
 * -w: sigma J evaluated there (y: the SH basis at -w, nb values; J's truncated SH rings
 * below zero at a cell, radiance does not); none for the emission alone. */
static void cell_scatter(const coarse_grid *g, source_kind kind, const float *y, size_t n, float out[3])
{
    const int nb = g->nb;
    int c, l;
    for (c = 0; c < 3; c++) {
        float v = 0.0f;
        if (kind != SOURCE_EMISSION)
            for (l = 0; l < nb; l++) v += g->j[(3 * n + c) * nb + l] * y[l];
        out[c] = g->sigma[n] * (v > 0.0f ? v : 0.0f);
    }
}

/* The emission the source kind reads (per cell 3 floats), or NULL. */
static const float *kind_emission(const coarse_grid *g, source_kind kind)
{
    return kind != SOURCE_J ? g->emit : NULL;
}

/* Cell n's source per unit length: cell_scatter plus the emission where kind says. */
static void cell_source(const coarse_grid *g, source_kind kind, const float *y, size_t n, float out[3])
{
    const float *emit = kind_emission(g, kind);
    int c;
    cell_scatter(g, kind, y, n, out);
    if (emit)
        for (c = 0; c < 3; c++) out[c] += emit[3 * n + c];
}

/* The pad for marches toward one direction (or every one, where the source is isotropic):
 * sigma and cell_source per cell. */
static void fill_pad(coarse_grid *g, source_kind kind, const float *y)
{
    for (size_t n = 0; n < g->n; n++) {
        float *p = pad_cell(g, n);
        p[0] = g->sigma[n];
        cell_source(g, kind, y, n, p + 1);
    }
}

/* World direction w in g's cells: v, of length 1, and the world length of one cell's
 * length along it (0 where the transform has no length that way). */
static double cell_direction(const coarse_grid *g, const double *w, double v[3])
{
    double len;
    int ax;
    for (ax = 0; ax < 3; ax++)
        v[ax] = g->to_cell[3 * ax] * w[0] + g->to_cell[3 * ax + 1] * w[1] + g->to_cell[3 * ax + 2] * w[2];
    len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0.0)) return 0.0;
    for (ax = 0; ax < 3; ax++) v[ax] /= len;
    return 1.0 / len;
}

/* The pad with (sigma, sigma times coefficient l of v's SH, RGB; v laid out as g->j) per
 * cell, for carrying v to the fine nodes. */
static void fill_pad_coefficient(coarse_grid *g, const float *v, int l)
{
    const int nb = g->nb;
    int c;
    for (size_t n = 0; n < g->n; n++) {
        float *p = pad_cell(g, n);
        p[0] = g->sigma[n];
        for (c = 0; c < 3; c++) p[1 + c] = g->sigma[n] * v[(3 * n + c) * nb + l];
    }
}

/* Trilinear sigma and source per unit length (sigma J, plus emission on the first order) at
 * coarse-index point (x, y, z) in [-1, res], 0 outside: the march divides by sigma, so empty
 * neighbours (J = 0 there, since J is per unit extinction) do not dim the medium's edge. */
static void sample(const coarse_grid *g, float x, float y, float z, float out[4])
{
    float fx = floorf(x), fy = floorf(y), fz = floorf(z), tx = x - fx, ty = y - fy, tz = z - fz;
    size_t b = (size_t)((int32_t)fz + 1) * g->sy + (size_t)((int32_t)fy + 1) * g->sx + (size_t)((int32_t)fx + 1);
    const float *c000 = g->pad + 4 * b, *c100 = c000 + 4, *c010 = c000 + 4 * g->sx, *c110 = c010 + 4;
    const float *c001 = c000 + 4 * g->sy, *c101 = c001 + 4, *c011 = c001 + 4 * g->sx, *c111 = c011 + 4;
    int q;
    for (q = 0; q < 4; q++) {
        float a0 = c000[q] + (c100[q] - c000[q]) * tx, a1 = c010[q] + (c110[q] - c010[q]) * tx;
        float b0 = c001[q] + (c101[q] - c001[q]) * tx, b1 = c011[q] + (c111[q] - c011[q]) * tx;
        float a = a0 + (a1 - a0) * ty, bb = b0 + (b1 - b0) * ty;
        out[q] = a + (bb - a) * tz;
    }
}

/* Cells [n0, n1) of one order, as the x range of a count x 1 job of the CPU backend's pool. */
static void run_order(void *arg, int n0, int y0, int n1, int y1)
{
    const order_job *job = arg;
    const coarse_grid *g = job->g;
    const int nb = g->nb;
    size_t n;
    (void)y0;
    (void)y1;
    for (n = (size_t)n0; n < (size_t)n1; n++) {
        double x0 = (double)(n % g->res[0]), y0 = (double)((n / g->res[0]) % g->res[1]);
        double z0 = (double)(n / ((size_t)g->res[0] * g->res[1])), acc[3 * NB_MAX] = {0.0};
        int d, c, l;
        if (!(g->sigma[n] > 0.0f)) continue;   /* next stays 0 there */
        for (d = job->d0; d < job->d1; d++) {
            const double *w = job->dirs + 3 * (size_t)d;
            const float *y = job->y_in + (size_t)d * nb;
            double v[3], step = cell_direction(g, w, v);
            if (!(step > 0.0)) continue;
            /* one cell per step, sampled at the step's middle, until the grid or the light ends */
            {
                float ux = (float)v[0], uy = (float)v[1], uz = (float)v[2], inv = (float)step, t = 1.0f, s;
                float px = (float)x0, py = (float)y0, pz = (float)z0, sum[3] = {0.0f, 0.0f, 0.0f};
                for (s = 0.5f; t > 1e-3f; s += 1.0f) {
                    float x = px + s * ux, yy = py + s * uy, z = pz + s * uz, smp[4], *src = smp + 1, a;
                    if (x < -1.0f || yy < -1.0f || z < -1.0f || x > (float)g->res[0] || yy > (float)g->res[1] ||
                        z > (float)g->res[2])
                        break;
                    /* sigma J toward the cell (and emission) */
                    sample(g, x, yy, z, smp);
                    if (!(smp[0] > 0.0f)) {
                        /* an empty stretch: only emission (first order) adds, over its length */
                        for (c = 0; c < 3; c++) sum[c] += t * src[c] * inv;
                        continue;
                    }
                    a = 1.0f - expf(-smp[0] * inv);
                    /* the source per unit length over the step's optical path a / sigma */
                    for (c = 0; c < 3; c++) sum[c] += t * a * (src[c] / smp[0]);
                    t *= 1.0f - a;
                }
                /* scattered toward w_out with HG: band l of the result gains g^l Y_l(-w) */
                for (c = 0; c < 3; c++)
                    for (l = 0; l < nb; l++) acc[c * nb + l] += sum[c] * y[l] * job->weight[l];
            }
        }
        for (c = 0; c < 3; c++)
            for (l = 0; l < nb; l++)
                g->next[(3 * n + c) * nb + l] += (float)((g->albedo ? g->albedo[3 * n + c] : job->albedo[c]) * acc[c * nb + l]);
    }
}

/* The pad sampled at fine node i (coarse cell coordinates i / coarse); 0 where no medium. */
static int fine_sample(const coarse_grid *g, const int32_t node_res[3], int coarse, size_t i, float smp[4])
{
    double x = (double)(i % node_res[0]) / coarse, y = (double)((i / node_res[0]) % node_res[1]) / coarse;
    double z = (double)(i / ((size_t)node_res[0] * node_res[1])) / coarse;
    sample(g, (float)x, (float)y, (float)z, smp);
    return smp[0] > 0.0f;
}

/* Whether the pad of the source kind is the same toward every direction: it depends on the
 * direction only through J's band 1, so it is with band 0 alone, and for the emission
 * alone (isotropic: it reads no J at all). */
static int pad_isotropic(const coarse_grid *g, source_kind kind)
{
    return g->nb == 1 || kind == SOURCE_EMISSION;
}

/* Directions [d0 + t0, d0 + t1) of a sweep batch (vsd_cpu_run_each: one per call), each
 * swept into its radiance grid; the batch holds directions d0 .. d0 + count - 1. */
typedef struct sweep_batch {
    const order_job *job;
    source_kind kind;
    int d0, count;
} sweep_batch;

static void sweep_directions(void *arg, int t0, int y0, int t1, int y1)
{
    const sweep_batch *b = arg;
    const order_job *job = b->job;
    const coarse_grid *g = job->g;
    int t;
    (void)y0;
    (void)y1;
    for (t = t0; t < t1; t++) {
        int d = b->d0 + t;
        double v[3], step = cell_direction(g, job->dirs + 3 * (size_t)d, v);
        float *source = job->shared_source ? job->source[0] : job->source[t];
        size_t n;
        if (!job->shared_source)
            for (n = 0; n < g->n; n++) cell_scatter(g, b->kind, job->y_in + (size_t)d * g->nb, n, source + 3 * n);
        if (step > 0.0) vsd_crm_sweep(g->res, g->sigma, source, kind_emission(g, b->kind), v, step, job->radiance[t]);
        else memset(job->radiance[t], 0, sizeof(float) * 3 * g->n);
    }
}

/* Cells [n0, n1): the batch's radiance scattered toward every w_out, as run_order does. One
 * direction at a time into next, in the directions' order: the batch is as large as the
 * thread count, and sums in batches would make the image's last bits depend on it (the CPU
 * backend's promise: the same image whatever the threads, cpu_tiles.h). */
static void sweep_accumulate(void *arg, int n0, int y0, int n1, int y1)
{
    const sweep_batch *b = arg;
    const order_job *job = b->job;
    const coarse_grid *g = job->g;
    const int nb = g->nb;
    size_t n;
    (void)y0;
    (void)y1;
    for (n = (size_t)n0; n < (size_t)n1; n++) {
        int c, t, l;
        if (!(g->sigma[n] > 0.0f)) continue;
        for (c = 0; c < 3; c++) {
            double albedo = g->albedo ? g->albedo[3 * n + c] : job->albedo[c];
            for (t = 0; t < b->count; t++) {
                const float *y = job->y_in + (size_t)(b->d0 + t) * nb;
                double light = albedo * job->radiance[t][3 * n + c];
                for (l = 0; l < nb; l++) g->next[(3 * n + c) * nb + l] += (float)(light * y[l] * job->weight[l]);
            }
        }
    }
}

/* One gather by sweeps: `batch` directions swept at once (a thread each), then every cell
 * takes their light. */
static vsd_status gather_sweep(order_job *job, const vsd_tile_job *tiles, source_kind kind)
{
    sweep_batch b;
    vsd_status st = VSD_OK;
    const coarse_grid *g = job->g;
    b.job = job;
    b.kind = kind;
    job->shared_source = pad_isotropic(g, kind);
    if (job->shared_source)
        for (size_t n = 0; n < g->n; n++) cell_scatter(g, kind, job->y_in, n, job->source[0] + 3 * n);
    for (b.d0 = 0; b.d0 < job->m && !st; b.d0 += job->batch) {
        b.count = b.d0 + job->batch <= job->m ? job->batch : job->m - b.d0;
        st = vsd_cpu_run_each(b.count, tiles->threads, sweep_directions, &b, tiles->stage);
        if (!st) st = vsd_cpu_run_items((int)g->n, tiles->threads, sweep_accumulate, &b, tiles->stage);
    }
    return st;
}

/* One gather of every cell into g->next (zeroed first) from the source kind: by sweeps
 * where `sweep` says (gather_sweep); else by marches: where the pad is isotropic one pad
 * and one pass serve all directions; else (J with bands above 0) one pad and one pass per
 * direction. Either way every coefficient of next is gathered (the emission
 * scattered once has a band 1 too: the phase gives it one). */
static vsd_status gather(coarse_grid *g, order_job *job, vsd_tile_job *tiles, source_kind kind, int sweep)
{
    vsd_status st = VSD_OK;
    int d;
    memset(g->next, 0, sizeof(float) * 3 * (size_t)g->nb * g->n);
    if (sweep) return gather_sweep(job, tiles, kind);
    if (pad_isotropic(g, kind)) {
        fill_pad(g, kind, job->y_in);
        job->d0 = 0;
        job->d1 = job->m;
        return vsd_cpu_run_tiles(tiles);
    }
    for (d = 0; d < job->m && !st; d++) {
        fill_pad(g, kind, job->y_in + (size_t)d * g->nb);
        job->d0 = d;
        job->d1 = d + 1;
        st = vsd_cpu_run_tiles(tiles);
    }
    return st;
}

/* The orders after the last, as a multiple of it, when each is r times the one before
 * (|r| < 1): r + r^2 + ... */
static double tail_factor(double r)
{
    return r / (1.0 - r);
}

/* Band 1's ratio from the last order to the one before (both laid out as g->j), given band
 * 0's r0: the r that best fits last = r prev over every band-1 coefficient (least squares:
 * they are signed, so a ratio of sums as band 0's would cancel), within [-r0, r0].
 * Why its own: the band 1 an order carries over is multiplied by about g r0 per scatter
 * (Funk-Hecke), while band 0's gradients make new band 1 at band 0's rate, so the ratio
 * climbs from near g r0 to r0 over the orders (measured, cloud256 g 0.7: 0.53 against r0
 * 0.80 at the second order, 0.83 against 0.89 at the sixth, 0.907 against 0.899 at the
 * twelfth): band 0's ratio overestimates band 1's tail when the series stops early
 * (cloud256 with `orders` 6: Combined 17.9% with it, 14.0% with this; at the default 12,
 * this clamps to r0 and the image is the same).
 * Why at most r0: the common slowest mode sets both bands' rate in the end (band 1 nears it
 * from above, as the faster part it lost fades), and a band 1 outliving band 0 would break
 * |b1| <= sqrt(3) b0 (bound_band1). Where prev has no band 1 the fit is undefined: g r0, the
 * rate of the band 1 the phase carries over, the low end, so an unknown band 1 is not
 * overestimated (a g < 0 flips its sign each order, as r < 0 does: the tail then shrinks it).
 * Band 2 (`ms_bands` 3) the same way with its own ratio, chi_2 r0 where undefined. */
static double band_ratio(const coarse_grid *g, const float *last, const float *prev, double r0, double chi, int band)
{
    double lp = 0.0, pp = 0.0, r;
    size_t q;
    int l;
    for (q = 0; q < 3 * g->n; q++)
        for (l = band * band; l < (band + 1) * (band + 1) && l < g->nb; l++) {
            lp += (double)last[q * g->nb + l] * prev[q * g->nb + l];
            pp += (double)prev[q * g->nb + l] * prev[q * g->nb + l];
        }
    if (!(pp > 0.0)) return chi * r0;
    r = lp / pp;
    return r > r0 ? r0 : r < -r0 ? -r0 : r;
}

/* The series of orders closed with each band's geometric tail: ms gains, per band, its
 * tail factor times the last order (g->j; g->next holds the one before). Returns the share
 * of the tail in band 0 (stats->tail). */
static double close_series(const coarse_grid *g, float *ms, double last_sum, double prev_sum, double tail_sum,
                           const vsd_crm_phase *phase)
{
    double r0 = last_sum / prev_sum, f[NB_MAX], fb[3] = {0.0, 0.0, 0.0};
    size_t q;
    int l;
    if (r0 > 0.95) r0 = 0.95;
    f[0] = tail_factor(r0);
    for (l = 1; l < 3 && l * l < g->nb; l++) fb[l] = tail_factor(band_ratio(g, g->j, g->next, r0, phase->chi[l], l));
    for (l = 1; l < g->nb; l++) f[l] = fb[vsd_crm_sh_band(l)];
    for (q = 0; q < 3 * g->n; q++)
        for (l = 0; l < g->nb; l++) ms[q * g->nb + l] += (float)(f[l] * g->j[q * g->nb + l]);
    return tail_sum > 0.0 ? f[0] * last_sum / (tail_sum + f[0] * last_sum) : 0.0;
}

/* The SH of any non-negative function has |b_l| <= sqrt(2 l + 1) b0 per band (the norm of
 * band l of a single direction, which reaches it): scales bands 1 (b[1..3]) and 2 (b[4..8],
 * where nb is 9) into that bound, so a band 0 of zero leaves no higher band, which the view
 * would turn into light toward half the directions (it clamps the SH's negative half to
 * 0). The looser bound: the SH's own non-negativity, |b1| <= b0 / sqrt(3), would cut a g
 * 0.7 lobe's b1 (sqrt(3) g b0). */
static void bound_bands(float *b, int nb)
{
    int band, l;
    for (band = 1; band * band < nb; band++) {
        int lo = band * band, hi = (band + 1) * (band + 1);
        double n = 0.0, cap = sqrt(2.0 * band + 1.0) * b[0];
        for (l = lo; l < hi; l++) n += (double)b[l] * b[l];
        n = sqrt(n);
        if (n > cap)
            for (l = lo; l < hi; l++) b[l] = cap > 0.0 ? (float)(b[l] * (cap / n)) : 0.0f;
    }
}

/* J_ms less the emission scattered once (je, laid out as g->j), per cell and channel: band 0
 * is the light, which cannot go below zero; band 1, its direction, is kept within what the
 * remaining band 0 allows. */
static void subtract_emission(const coarse_grid *g, float *ms, const float *je)
{
    size_t q;
    int l;
    for (q = 0; q < 3 * g->n; q++) {
        float *b = ms + q * g->nb;
        const float *e = je + q * g->nb;
        b[0] = b[0] > e[0] ? b[0] - e[0] : 0.0f;
        for (l = 1; l < g->nb; l++) b[l] -= e[l];
        if (g->nb > 1) bound_bands(b, g->nb);
    }
}

/* Delta-M (Wiscombe 1977) for the orders' truncated phase: HG with bands 0..B-1 kept is
 * scaled as f delta(forward) + (1 - f) p', f = g^B (the first band dropped), p' with chi'_l
 * = (g^l - f) / (1 - f) (crm_phase.h; B = 2: HG(g / (1 + g))). The forward part is light
 * that goes on unscattered, so the orders march sigma_t' = sigma_t (1 - a f) and scatter a'
 * = a (1 - f) / (1 - a f) with p' (a: the mean of the albedo's channels, the extinction
 * being one number). J_1 is the scaled problem's already (its single scattering with
 * sigma_t', a' and p': crm.c). job_albedo gets a' (the uniform albedo's), g->albedo and
 * g->sigma the cells'. */
static void delta_m(coarse_grid *g, const double albedo[3], double anisotropy, int bands, double job_albedo[3])
{
    double f = vsd_crm_delta_m_fraction(anisotropy, bands), uniform = (albedo[0] + albedo[1] + albedo[2]) / 3.0;
    size_t n;
    int c;
    for (c = 0; c < 3; c++) job_albedo[c] = albedo[c] * (1.0 - f) / (1.0 - uniform * f);
    for (n = 0; n < g->n; n++) {
        const float *a = g->albedo ? g->albedo + 3 * n : NULL;
        double mean = a ? ((double)a[0] + a[1] + a[2]) / 3.0 : uniform, s = 1.0 - mean * f;
        g->sigma[n] = (float)(g->sigma[n] * s);
        if (a)
            for (c = 0; c < 3; c++) g->albedo[3 * n + c] = (float)(a[c] * (1.0 - f) / s);
    }
}

/* The scaled problem's sources (laid out as g->j) back to the true phase's, for the view:
 * the same radiance scattered with a g^l in place of a' chi'_l. */
static void delta_m_back(const coarse_grid *g, float *b, const double albedo[3], double anisotropy, int bands,
                         const vsd_crm_phase *scaled)
{
    double f = vsd_crm_delta_m_fraction(anisotropy, bands), to_true[NB_MAX];
    const vsd_crm_phase hg = vsd_crm_phase_hg(anisotropy);
    size_t n;
    int c, l;
    for (l = 0; l < g->nb; l++) to_true[l] = l ? hg.chi[vsd_crm_sh_band(l)] / scaled->chi[vsd_crm_sh_band(l)] : 1.0;
    for (n = 0; n < g->n; n++) {
        double mean;
        if (g->albedo) {
            /* the cell's a' mean back to a: a = a' / (1 - f + a' f) */
            double ms = ((double)g->albedo[3 * n] + g->albedo[3 * n + 1] + g->albedo[3 * n + 2]) / 3.0;
            mean = ms / (1.0 - f + ms * f);
        } else {
            mean = (albedo[0] + albedo[1] + albedo[2]) / 3.0;
        }
        for (c = 0; c < 3; c++)
            for (l = 0; l < g->nb; l++)
                b[(3 * n + c) * g->nb + l] *= (float)((1.0 - mean * f) / (1.0 - f) * to_true[l]);
    }
}

/* A grid of cells `coarse` points of a finer grid (fine_res) apart per axis: res, to_cell and
 * the arrays; emission and albedo only where has_emit / has_albedo. */
static int grid_alloc(coarse_grid *g, const int32_t fine_res[3], const double to_fine[9], int coarse, int nb,
                      int has_emit, int has_albedo)
{
    int a;
    memset(g, 0, sizeof *g);
    for (a = 0; a < 3; a++) g->res[a] = (fine_res[a] - 1 + coarse - 1) / coarse + 1;
    g->n = (size_t)g->res[0] * g->res[1] * g->res[2];
    g->nb = nb;
    for (a = 0; a < 9; a++) g->to_cell[a] = to_fine[a] / coarse;
    g->sigma = calloc(g->n, sizeof *g->sigma);
    g->j = calloc(g->n * 3 * nb, sizeof *g->j);
    g->next = calloc(g->n * 3 * nb, sizeof *g->next);
    g->emit = has_emit ? calloc(g->n * 3, sizeof *g->emit) : NULL;
    g->albedo = has_albedo ? calloc(g->n * 3, sizeof *g->albedo) : NULL;
    g->sx = (size_t)g->res[0] + 3;
    g->sy = g->sx * ((size_t)g->res[1] + 3);
    g->pad = calloc(4 * g->sy * ((size_t)g->res[2] + 3), sizeof *g->pad);
    return g->sigma && g->j && g->next && g->pad && (!has_emit || g->emit) && (!has_albedo || g->albedo) &&
           g->n <= 0x7fffffff;
}

static void grid_free(coarse_grid *g)
{
    free(g->sigma);
    free(g->j);
    free(g->next);
    free(g->emit);
    free(g->albedo);
    free(g->pad);
}

/* g's cells from the points of a finer grid (fine_res; sigma, and emit, albedo, j laid out as
 * g's, emit and albedo NULL where g has none), `coarse` points per cell: mean sigma, J
 * weighted by sigma (J is per unit extinction, so empty points must not dilute it), the
 * albedo weighted by sigma (it scatters sigma_s = albedo sigma), the mean emission. The means
 * are tent-weighted around the cell, whose centre is point `coarse` * its index (weight
 * 1 - |offset| / coarse per axis): the transpose of the trilinear interpolation that brings
 * J back, so neither moves the light. (A box of the points nearest each cell, as before,
 * centred the cell's inputs half a point below where the marches and the interpolation put
 * it: VolumeInd shifted by about one node spacing, docs/methods/crm.md.) With coarse 1 it
 * is a copy. Returns 0 where its scratch (a double per cell) cannot be had. */
static int restrict_grid(coarse_grid *g, const int32_t fine_res[3], int coarse, const float *sigma,
                         const float *emit, const float *albedo, const float *j)
{
    const int nb = g->nb;
    size_t fine = (size_t)fine_res[0] * fine_res[1] * fine_res[2], i;
    int a, c;
    double *wsum = calloc(g->n, sizeof *wsum);
    if (!wsum) return 0;
    for (i = 0; i < fine; i++) {
        int32_t q[3] = {(int32_t)(i % fine_res[0]), (int32_t)((i / fine_res[0]) % fine_res[1]),
                        (int32_t)(i / ((size_t)fine_res[0] * fine_res[1]))}, lo[3], cx, cy, cz;
        double s = sigma[i];
        for (a = 0; a < 3; a++) lo[a] = q[a] / coarse;
        for (cz = lo[2]; cz <= lo[2] + 1; cz++)
            for (cy = lo[1]; cy <= lo[1] + 1; cy++)
                for (cx = lo[0]; cx <= lo[0] + 1; cx++) {
                    double w = (1.0 - fabs((double)(q[0] - cx * coarse)) / coarse) *
                               (1.0 - fabs((double)(q[1] - cy * coarse)) / coarse) *
                               (1.0 - fabs((double)(q[2] - cz * coarse)) / coarse);
                    size_t n;
                    if (!(w > 0.0) || cx >= g->res[0] || cy >= g->res[1] || cz >= g->res[2]) continue;
                    n = ((size_t)cz * g->res[1] + (size_t)cy) * g->res[0] + (size_t)cx;
                    g->sigma[n] += (float)(w * s);
                    wsum[n] += w;
                    if (g->emit)
                        for (c = 0; c < 3; c++) g->emit[3 * n + c] += (float)(w * emit[3 * i + c]);
                    if (g->albedo)
                        for (c = 0; c < 3; c++) g->albedo[3 * n + c] += (float)(w * s * albedo[3 * i + c]);
                    if (s > 0.0)
                        for (c = 0; c < 3 * nb; c++) g->j[3 * nb * n + c] += (float)(w * s * j[3 * nb * i + c]);
                }
    }
    for (i = 0; i < g->n; i++) {
        for (c = 0; c < 3 * nb; c++) g->j[3 * nb * i + c] = g->sigma[i] > 0.0f ? g->j[3 * nb * i + c] / g->sigma[i] : 0.0f;
        if (g->albedo)
            for (c = 0; c < 3; c++) g->albedo[3 * i + c] = g->sigma[i] > 0.0f ? g->albedo[3 * i + c] / g->sigma[i] : 0.0f;
        g->sigma[i] = wsum[i] > 0.0 ? (float)(g->sigma[i] / wsum[i]) : 0.0f;
        if (g->emit)
            for (c = 0; c < 3; c++) g->emit[3 * i + c] = wsum[i] > 0.0 ? (float)(g->emit[3 * i + c] / wsum[i]) : 0.0f;
    }
    free(wsum);
    return 1;
}

/* Where the series stands: the band-0 sums of the last two orders (each cell weighted by the
 * nodes it spans, so sums on the two grids compare) and of all so far. */
typedef struct series {
    double prev_sum, last_sum, tail_sum, cell_nodes;
    int orders, converged;
} series;

/* The band-0 sum of v (laid out as g->j) in the series' units. */
static double band0_sum(const coarse_grid *g, const float *v, double cell_nodes)
{
    double sum = 0.0;
    size_t q;
    for (q = 0; q < 3 * g->n; q++) sum += v[q * g->nb];
    return sum * cell_nodes;
}

/* Orders on g, each gathered from g->j into ms, until `until` orders in all or one adds less
 * than `tolerance` of the sum; g->j then holds the last order, g->next the one before. */
static vsd_status follow_orders(coarse_grid *g, order_job *job, vsd_tile_job *tiles, float *ms, series *s, int until,
                                double tolerance)
{
    vsd_status st = VSD_OK;
    job->g = g;
    tiles->width = (int)g->n;
    while (!st && s->orders < until && !s->converged) {
        double sum;
        size_t i;
        float *swap;
        if ((st = gather(g, job, tiles, s->orders == 0 ? SOURCE_J_EMISSION : SOURCE_J, s->orders < job->sweep_orders)))
            break;
        for (i = 0; i < 3 * (size_t)g->nb * g->n; i++) ms[i] += g->next[i];
        sum = band0_sum(g, g->next, s->cell_nodes);
        s->prev_sum = s->last_sum;
        s->last_sum = sum;
        s->orders++;
        swap = g->j;
        g->j = g->next;
        g->next = swap;
        if (s->orders > 1 && sum <= tolerance * (s->tail_sum += sum, s->tail_sum)) s->converged = 1;
        if (s->orders == 1) s->tail_sum = sum;
    }
    return st;
}

/* Adds band l of v (laid out as g's J, g `coarse` fine nodes per cell) to the fine nodes'
 * coefficient l at `offset` of each node's floats, trilinearly and sigma-weighted as the
 * marches read J, where the node has medium (and marks it valid with set_valid). */
static void to_fine_nodes(coarse_grid *g, const int32_t node_res[3], int coarse, const float *sigma_t, const float *v,
                          int l, float *nodes, int offset, int stride, uint8_t *valid, uint8_t set_valid)
{
    size_t fine = (size_t)node_res[0] * node_res[1] * node_res[2], i;
    int c;
    fill_pad_coefficient(g, v, l);
    for (i = 0; i < fine; i++) {
        float *out = nodes + i * CRM_NODE_FLOATS + offset, smp[4];
        if (!(sigma_t[i] > 0.0f) || !fine_sample(g, node_res, coarse, i, smp)) continue;
        for (c = 0; c < 3; c++) out[c * stride + l] += smp[1 + c] / smp[0];
        valid[i] |= set_valid;
    }
}

vsd_status vsd_crm_orders(const int32_t node_res[3], const double to_node[9], const float *sigma_t,
                          const float *emission, const double albedo[3], const float *node_albedo, double anisotropy,
                          int bands, const float *j1, int delta, float *nodes, uint8_t *valid, int coarse,
                          int fine_orders, int sweep, int directions, int max_orders, double tolerance, int threads,
                          vsd_crm_orders_stats *stats, char *err, size_t errlen)
{
    double t0 = vsd_clock_seconds(), *dirs = NULL;
    float *y_in = NULL, *j_nodes = NULL;
    int nb, l;
    vsd_crm_phase phase; /* what the orders scatter with: HG, or delta-M's scaled phase */
    long nside = vsd_sh_healpix_nside(directions);
    /* a: the grid the orders start on (the nodes themselves for the first fine_orders, else
     * the coarse grid); b: the coarse grid the rest go on to, where a is the nodes */
    float *ms_a = NULL, *ms_b = NULL, *je = NULL; /* je: the emission scattered once, on a */
    coarse_grid ga, gb;
    int coarse_a = fine_orders > 0 ? 1 : coarse, two_grids;
    order_job job;
    series ser;
    vsd_tile_job tiles;
    size_t fine = (size_t)node_res[0] * node_res[1] * node_res[2], i;
    vsd_status st = VSD_OK;
    int k, c, scaled;
    memset(stats, 0, sizeof *stats);
    memset(&ga, 0, sizeof ga);
    memset(&gb, 0, sizeof gb);
    memset(&ser, 0, sizeof ser);
    memset(&job, 0, sizeof job);
    if (!j1) j1 = nodes;
    if (!(anisotropy > 0.0)) delta = 0;
    if (coarse < 1 || fine_orders < 0 || !nside || max_orders < 1 || !(tolerance >= 0.0) || bands < 2 || bands > 3)
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "crm orders: coarse %d, %d fine orders, %d directions (12 nside^2), %d orders, tolerance %g or "
                        "%d bands (2..3) out of range",
                        coarse, fine_orders, directions, max_orders, tolerance, bands);
    /* g = 0: every order's J is isotropic (band 0); else bands 0..bands-1 carry the phase */
    nb = anisotropy != 0.0 ? bands * bands : 1;
    two_grids = coarse_a < coarse && fine_orders < max_orders;
    dirs = malloc(sizeof *dirs * 3 * (size_t)directions);
    y_in = malloc(sizeof *y_in * (size_t)nb * (size_t)directions);
    j_nodes = calloc(fine * 3 * nb, sizeof *j_nodes);
    if (!dirs || !y_in || !j_nodes || !grid_alloc(&ga, node_res, to_node, coarse_a, nb, emission != NULL, node_albedo != NULL) ||
        !(ms_a = calloc(ga.n * 3 * nb, sizeof *ms_a)) ||
        (emission && !(je = calloc(ga.n * 3 * nb, sizeof *je)))) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm orders: no memory for a %dx%dx%d grid (or over 2^31 cells)",
                      ga.res[0], ga.res[1], ga.res[2]);
        goto done;
    }
    if (sweep && fine_orders > 0) {
        /* the sweeps' grids, for the orders on the nodes */
        job.sweep_orders = fine_orders;
        job.batch = vsd_cpu_thread_count(threads);
        if (job.batch > SWEEP_BATCH_MAX) job.batch = SWEEP_BATCH_MAX;
        if (job.batch > directions) job.batch = directions;
        for (k = 0; k < job.batch; k++)
            if (!(job.source[k] = malloc(sizeof(float) * 3 * ga.n)) || !(job.radiance[k] = malloc(sizeof(float) * 3 * ga.n))) {
                st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm orders: no memory to sweep %d directions over %zu cells",
                              job.batch, ga.n);
                goto done;
            }
    }
    if ((st = vsd_sh_healpix_dirs(nside, dirs, err, errlen))) goto done;
    for (k = 0; k < directions; k++) {
        double back[3] = {-dirs[3 * k], -dirs[3 * k + 1], -dirs[3 * k + 2]}, y[NB_MAX];
        if (nb > 1) vsd_sh_eval(bands, back, y);
        else y[0] = Y00;
        for (l = 0; l < nb; l++) y_in[(size_t)k * nb + l] = (float)y[l];
    }
    /* J_1 per node laid out as the grids' J: with per-node albedos, J_1, which the single
     * scattering gave with `albedo`, is rescaled to the node's (the first scattering of the
     * mixture there) */
    for (i = 0; i < fine; i++)
        if (valid[i] & CRM_NODE_SINGLE)
            for (c = 0; c < 3; c++) {
                double to_node_albedo = !node_albedo ? 1.0 : albedo[c] > 0.0 ? node_albedo[3 * i + c] / albedo[c] : 0.0;
                for (l = 0; l < nb; l++)
                    j_nodes[(3 * i + c) * nb + l] = (float)(to_node_albedo * j1[i * CRM_NODE_FLOATS + c * CRM_SS_N + l]);
            }
    if (!restrict_grid(&ga, node_res, coarse_a, sigma_t, emission, node_albedo, j_nodes)) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm orders: no memory to restrict onto %zu cells", ga.n);
        goto done;
    }
    free(j_nodes);
    j_nodes = NULL;
    /* delta-M needs band 1 (g > 0): else the orders run the medium as it is */
    scaled = delta && nb > 1;
    phase = scaled ? vsd_crm_phase_delta_m(anisotropy, bands) : vsd_crm_phase_hg(anisotropy);
    if (scaled) delta_m(&ga, albedo, anisotropy, bands, job.albedo);
    job.dirs = dirs;
    job.y_in = y_in;
    for (l = 0; l < nb; l++) job.weight[l] = (float)(4.0 * PI_D * (l == 0 ? 1.0 : phase.chi[vsd_crm_sh_band(l)]) / directions);
    job.m = directions;
    if (!scaled)
        for (c = 0; c < 3; c++) job.albedo[c] = albedo[c];
    memset(&tiles, 0, sizeof tiles);
    tiles.height = 1;
    tiles.threads = threads;
    tiles.fn = run_order;
    tiles.user = &job;
    tiles.stage = "crm multiple scattering";
    job.g = &ga;
    tiles.width = (int)ga.n;
    if (ga.emit) {
        /* The emission scattered once: one gather with the emission alone as the source.
         * It is in J_2 (the first order gathers sigma J_1 + emission), but Cycles counts it
         * as direct light (docs/design-notes.md, "Passes"): it is taken out of J_ms below
         * and written into the single-scattering bands 0 (and 1, with the phase on the
         * orders), so the view puts it in VolumeDir. */
        if ((st = gather(&ga, &job, &tiles, SOURCE_EMISSION, job.sweep_orders > 0))) goto done;
        memcpy(je, ga.next, sizeof(float) * 3 * nb * ga.n);
    }
    ser.cell_nodes = (double)coarse_a * coarse_a * coarse_a;
    if ((st = follow_orders(&ga, &job, &tiles, ms_a, &ser, two_grids ? fine_orders : max_orders, tolerance))) goto done;
    stats->fine_orders = coarse_a == 1 ? ser.orders : 0;
    if (two_grids && !ser.converged) {
        /* The later orders are smooth (each a sum over many paths): on to the coarse grid,
         * from the nodes' (delta-M scaled) medium and the last order's J there. The series'
         * sums go on in the coarse grid's terms, so the last order is summed again there. */
        double last_on_a = ser.last_sum;
        if (!grid_alloc(&gb, ga.res, to_node, coarse, nb, 0, ga.albedo != NULL) ||
            !(ms_b = calloc(gb.n * 3 * nb, sizeof *ms_b))) {
            st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm orders: no memory for a %dx%dx%d grid", gb.res[0],
                          gb.res[1], gb.res[2]);
            goto done;
        }
        if (!restrict_grid(&gb, ga.res, coarse, ga.sigma, NULL, ga.albedo, ga.j)) {
            st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm orders: no memory to restrict onto %zu cells", gb.n);
            goto done;
        }
        ser.cell_nodes = (double)coarse * coarse * coarse;
        ser.last_sum = band0_sum(&gb, gb.j, ser.cell_nodes);
        if (last_on_a > 0.0) ser.tail_sum *= ser.last_sum / last_on_a;
        if ((st = follow_orders(&gb, &job, &tiles, ms_b, &ser, max_orders, tolerance))) goto done;
    }
    stats->orders = ser.orders;
    /* close the series with each band's geometric tail from the last two orders (on the
     * grid the last order ran on; after the switch, the one before is the nodes' last,
     * carried over in gb.next) */
    if (ser.orders >= 2 && ser.prev_sum > 0.0)
        stats->tail = close_series(ms_b ? &gb : &ga, ms_b ? ms_b : ms_a, ser.last_sum, ser.prev_sum, ser.tail_sum, &phase);
    if (je) subtract_emission(&ga, ms_a, je);
    if (scaled) {
        delta_m_back(&ga, ms_a, albedo, anisotropy, bands, &phase);
        if (je) delta_m_back(&ga, je, albedo, anisotropy, bands, &phase);
        if (ms_b) delta_m_back(&gb, ms_b, albedo, anisotropy, bands, &phase);
    }
    /* back to the fine nodes, trilinearly (sigma-weighted, as the marches read J), each of
     * the bands' coefficients in turn: the emission scattered once onto the single
     * scattering, J_ms onto the multiple */
    for (i = 0; i < fine; i++) {
        memset(nodes + i * CRM_NODE_FLOATS + 3 * CRM_SS_N, 0, sizeof(float) * 3 * CRM_MS_N);
        if (sigma_t[i] > 0.0f) valid[i] |= CRM_NODE_MULTIPLE;
        else valid[i] &= (uint8_t)~CRM_NODE_MULTIPLE;
    }
    for (l = 0; l < nb; l++) {
        if (je) to_fine_nodes(&ga, node_res, coarse_a, sigma_t, je, l, nodes, 0, CRM_SS_N, valid, CRM_NODE_SINGLE);
        to_fine_nodes(&ga, node_res, coarse_a, sigma_t, ms_a, l, nodes, 3 * CRM_SS_N, CRM_MS_N, valid, 0);
        if (ms_b) to_fine_nodes(&gb, node_res, coarse, sigma_t, ms_b, l, nodes, 3 * CRM_SS_N, CRM_MS_N, valid, 0);
    }
    for (k = 0; k < 3; k++) stats->res[k] = ms_b ? gb.res[k] : ga.res[k];
done:
    grid_free(&ga);
    grid_free(&gb);
    free(ms_a);
    free(ms_b);
    free(je);
    free(dirs);
    free(y_in);
    free(j_nodes);
    for (k = 0; k < SWEEP_BATCH_MAX; k++) {
        free(job.source[k]);
        free(job.radiance[k]);
    }
    stats->seconds = vsd_clock_seconds() - t0;
    return st;
}
