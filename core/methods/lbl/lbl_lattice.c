#include "lbl_lattice.h"
#include "device/cpu/cpu_tiles.h"
#include "src/common/clock.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { DIRS = 6, CH = 3 };

/* the six lattice directions: +x, -x, +y, -y, +z, -z */
static const int32_t dir_axis[DIRS] = {0, 0, 1, 1, 2, 2};
static const int32_t dir_sign[DIRS] = {1, -1, 1, -1, 1, -1};

/* whichever layout's populations exist */
static int allocated(const vsd_lbl_lattice *l) { return l->f || l->blocked.f || l->q18.f; }

vsd_status vsd_lbl_lattice_init(vsd_lbl_lattice *l, const int32_t res[3], const vsd_lbl_layout *layout, char *err,
                                size_t errlen)
{
    static const vsd_lbl_layout global = {0, 0};
    size_t cells = (size_t)res[0] * res[1] * res[2];
    if (!layout) layout = &global;
    if (allocated(l) && memcmp(l->res, res, sizeof l->res) == 0 &&
        memcmp(&l->layout, layout, sizeof *layout) == 0)
        return VSD_OK;
    vsd_lbl_lattice_free(l);
    if (cells == 0) return VSD_OK;
    if (layout->block_steps > 0 && layout->d3q18)
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "lbl: the blocked lattice (block_steps) is D3Q6 only, not with lattice \"d3q18\"");
    if (layout->block_steps > 0 || layout->d3q18) {
        vsd_status st = layout->d3q18 ? vsd_lbl_q18_init(&l->q18, res, err, errlen)
                                      : vsd_lbl_blocked_init(&l->blocked, res, layout->block_steps, err, errlen);
        if (st) return st;
        memcpy(l->res, res, sizeof l->res);
        l->cells = cells;
        l->layout = *layout;
        return VSD_OK;
    }
    if (!(l->f = calloc(cells * DIRS * CH, sizeof *l->f)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for a %dx%dx%d lattice", res[0], res[1], res[2]);
    memcpy(l->res, res, sizeof l->res);
    l->cells = cells;
    return VSD_OK;
}

void vsd_lbl_lattice_set_phase(vsd_lbl_lattice *l, float forward, float backward, float side)
{
    l->forward = forward;
    l->backward = backward;
    l->side = side;
    l->anisotropic = l->f != NULL && !(forward == backward && forward == side);
}

void vsd_lbl_lattice_set_cell_light(vsd_lbl_lattice *l, int cell_light) { l->cell_light = cell_light; }

void vsd_lbl_lattice_free(vsd_lbl_lattice *l)
{
    free(l->f);
    vsd_lbl_blocked_free(&l->blocked);
    vsd_lbl_q18_free(&l->q18);
    memset(l, 0, sizeof *l);
}

typedef struct step_job {
    vsd_lbl_lattice *l;
    const float *collide, *source;
    float albedo[3];
    float *post;             /* [DIRS][CH][cells] */
    float *gain;             /* [cells] scratch: what a node scatters into each direction */
    float *esc;              /* [CH][cells] the share of the light born in a node's cell that leaves it (in_cell) */
} step_job;

/* A photon born at a uniform point of a cell of optical depth x = sigma lambda (the
 * light a collision scatters, or the source) crosses the rest of the cell first: it
 * leaves with probability e = (1 - e^-x) / x, else collides there and, with the albedo,
 * is born again. So of what is born in the cell, esc = e / (1 - albedo (1 - e)) leaves it,
 * and each photon born there spends credit = ((1 - e) / x) / (1 - albedo (1 - e)) cells of
 * path in it; a photon arriving at a face spends e. Thin cells: e -> 1 - x/2, esc -> 1,
 * credit -> 1/2. (The paper's step lets what is born in a cell leave it whole, and counts
 * only the arriving photons; both are off by the order of x, which made VolumeInd darker the
 * coarser the lattice, and emission-lit media brighter: docs/methods/lbl.md, "A photon's
 * path through a cell".) */
static void in_cell(const vsd_lbl_lattice *l, float p, float albedo, float *arriving, float *esc, float *credit)
{
    float x, e, stay;
    if (l->cell_light != VSD_LBL_CELL_PATH) {
        *arriving = *esc = 1.0f;
        *credit = 0.0f;
        return;
    }
    /* p = 1 - e^-x; in float p reaches 1 near x = 17.3 (2^-25), where the cell is opaque
     * all the same: x is capped there so e stays continuous */
    x = p < 1.0f ? fminf(-log1pf(-p), 17.3f) : 17.3f;
    e = x > 1e-4f ? p / x : 1.0f - 0.5f * x;
    stay = 1.0f / (1.0f - albedo * (1.0f - e));
    *arriving = e;
    *esc = e * stay;
    *credit = (x > 1e-4f ? (1.0f - e) / x : 0.5f - x / 6.0f) * stay;
}

/* The anisotropic collision of nodes [c0, c0 + n): post_i = (1 - p) f_i + albedo p
 * (side sum_j f_j + (forward - side) f_i + (backward - side) f_opposite(i)) + S_i, the
 * cube's symmetry making P_ij one of three shares. */
static void collide_anisotropic(step_job *j, size_t c0, size_t n)
{
    const vsd_lbl_lattice *l = j->l;
    const size_t cells = l->cells;
    const float fs = l->forward - l->side, bs = l->backward - l->side;
    float *gain = j->gain + c0;
    const float *p = j->collide + c0;
    size_t c;
    int ch, i;
    for (ch = 0; ch < CH; ch++) {
        const float a = j->albedo[ch];
        for (c = 0; c < n; c++) gain[c] = 0.0f;
        for (i = 0; i < DIRS; i++) {
            const float *f = l->f + ((size_t)i * CH + ch) * cells + c0;
            for (c = 0; c < n; c++) gain[c] += f[c];
        }
        for (c = 0; c < n; c++) gain[c] *= l->side;
        for (i = 0; i < DIRS; i++) {
            const size_t o = ((size_t)i * CH + ch) * cells + c0, opp = ((size_t)(i ^ 1) * CH + ch) * cells + c0;
            const float *f = l->f + o, *fo = l->f + opp;
            const float *src = j->source ? j->source + o : NULL;
            float *q = j->post + o;
            const float *esc = j->esc + (size_t)ch * cells + c0;
            for (c = 0; c < n; c++)
                q[c] = (1.0f - p[c]) * f[c] + esc[c] * (a * p[c] * (gain[c] + fs * f[c] + bs * fo[c]) + (src ? src[c] : 0.0f));
        }
    }
}

/* Collision of the nodes in slices [z0, z1): post = Theta f + S / 6. Loops run along the
 * nodes (contiguous per direction and channel) so the compiler vectorises them. */
static void collide_slices(void *arg, int z0, int y0, int z1, int y1)
{
    step_job *j = arg;
    const size_t cells = j->l->cells, slice = (size_t)j->l->res[0] * j->l->res[1];
    const size_t c0 = (size_t)z0 * slice, n = (size_t)(z1 - z0) * slice;
    float *gain = j->gain + c0;
    const float *p = j->collide + c0;
    size_t c;
    int ch, i;
    (void)y0;
    (void)y1;
    if (j->l->anisotropic) {
        collide_anisotropic(j, c0, n);
        return;
    }
    for (ch = 0; ch < CH; ch++) {
        const float a6 = j->albedo[ch] / 6.0f;
        const float *src = j->source ? j->source + (size_t)ch * cells + c0 : NULL;
        for (c = 0; c < n; c++) gain[c] = 0.0f;
        for (i = 0; i < DIRS; i++) {
            const float *f = j->l->f + ((size_t)i * CH + ch) * cells + c0;
            for (c = 0; c < n; c++) gain[c] += f[c];
        }
        {
            const float *esc = j->esc + (size_t)ch * cells + c0;
            for (c = 0; c < n; c++) gain[c] = esc[c] * (a6 * p[c] * gain[c] + (src ? src[c] * (1.0f / 6.0f) : 0.0f));
        }
        for (i = 0; i < DIRS; i++) {
            const size_t o = ((size_t)i * CH + ch) * cells + c0;
            const float *f = j->l->f + o;
            float *q = j->post + o;
            for (c = 0; c < n; c++) q[c] = (1.0f - p[c]) * f[c] + gain[c];
        }
    }
}

/* Streaming into slices [z0, z1): f_i(x) = post_i(x - c_i), 0 from outside the lattice. */
static void stream_slices(void *arg, int z0, int y0, int z1, int y1)
{
    step_job *j = arg;
    const int32_t nx = j->l->res[0], ny = j->l->res[1], nz = j->l->res[2];
    const size_t cells = j->l->cells;
    int i, ch, z, y;
    (void)y0;
    (void)y1;
    for (i = 0; i < DIRS; i++)
        for (ch = 0; ch < CH; ch++) {
            float *dst = j->l->f + ((size_t)i * CH + ch) * cells;
            const float *src = j->post + ((size_t)i * CH + ch) * cells;
            for (z = z0; z < z1; z++)
                for (y = 0; y < ny; y++) {
                    size_t row = ((size_t)z * ny + y) * nx;
                    int32_t sy = y, sz = z;
                    if (dir_axis[i] == 0) {
                        if (dir_sign[i] > 0) {
                            dst[row] = 0.0f;
                            memcpy(dst + row + 1, src + row, sizeof(float) * (size_t)(nx - 1));
                        } else {
                            memcpy(dst + row, src + row + 1, sizeof(float) * (size_t)(nx - 1));
                            dst[row + nx - 1] = 0.0f;
                        }
                        continue;
                    }
                    if (dir_axis[i] == 1) sy = y - dir_sign[i];
                    else sz = z - dir_sign[i];
                    if (sy < 0 || sy >= ny || sz < 0 || sz >= nz)
                        memset(dst + row, 0, sizeof(float) * (size_t)nx);
                    else
                        memcpy(dst + row, src + ((size_t)sz * ny + sy) * nx, sizeof(float) * (size_t)nx);
                }
        }
}

/* one step: the z slices collide, then stream, on the CPU pool */
static vsd_status run_step(step_job *job, int threads)
{
    vsd_status st = vsd_cpu_run_items(job->l->res[2], threads, collide_slices, job, "lbl diffusion");
    return st ? st : vsd_cpu_run_items(job->l->res[2], threads, stream_slices, job, "lbl diffusion");
}

/* A step job over l with its scratch (post-collision populations, per-node gain); 0 when
 * that scratch could not be allocated (step_job_free in either case). */
static int step_job_init(step_job *job, vsd_lbl_lattice *l, const float *collide, const float albedo[3],
                         const float *source)
{
    int c;
    job->l = l;
    job->collide = collide;
    job->source = source;
    for (c = 0; c < CH; c++) job->albedo[c] = albedo[c];
    job->post = malloc(l->cells * DIRS * CH * sizeof *job->post);
    job->gain = malloc(l->cells * sizeof *job->gain);
    job->esc = malloc(l->cells * CH * sizeof *job->esc);
    if (!job->post || !job->gain || !job->esc) return 0;
    for (c = 0; c < CH; c++) {
        size_t n;
        for (n = 0; n < l->cells; n++) {
            float arriving, credit;
            in_cell(l, collide[n], albedo[c], &arriving, job->esc + (size_t)c * l->cells + n, &credit);
        }
    }
    return 1;
}

static void step_job_free(step_job *job)
{
    free(job->post);
    free(job->gain);
    free(job->esc);
}

/* Ready lattice l (whichever layout) for steps with this material: the global lattice's
 * step job and scratch, or the blocked and D3Q18 lattices' copies of the material. */
static vsd_status prepare(vsd_lbl_lattice *l, step_job *job, const float *collide, const float albedo[3],
                          const float *source, char *err, size_t errlen)
{
    memset(job, 0, sizeof *job);
    if (l->layout.block_steps > 0) return vsd_lbl_blocked_set_material(&l->blocked, collide, source, err, errlen);
    if (l->layout.d3q18) {
        vsd_lbl_q18_set_material(&l->q18, collide, source);
        return VSD_OK;
    }
    if (!step_job_init(job, l, collide, albedo, source))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the lattice's collision buffers");
    return VSD_OK;
}

/* One iteration of the prepared lattice: a step, or block_steps steps of a blocked one. */
static vsd_status advance(vsd_lbl_lattice *l, step_job *job, const float albedo[3], int threads)
{
    if (l->layout.block_steps > 0) return vsd_lbl_blocked_iterate(&l->blocked, albedo, threads);
    if (l->layout.d3q18) return vsd_lbl_q18_step(&l->q18, albedo, threads);
    return run_step(job, threads);
}

void vsd_lbl_lattice_step(vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source)
{
    step_job job;
    memset(&job, 0, sizeof job);
    if (allocated(l) && prepare(l, &job, collide, albedo, source, NULL, 0) == VSD_OK) advance(l, &job, albedo, 1);
    step_job_free(&job);
}

/* The photons at node c in channel ch: the sum of its six arriving populations. */
static float node_sum(const vsd_lbl_lattice *l, int ch, size_t c)
{
    float v = 0.0f;
    int i;
    if (l->layout.block_steps > 0) return vsd_lbl_blocked_node_sum(&l->blocked, ch, c);
    if (l->layout.d3q18) return vsd_lbl_q18_node_fluence(&l->q18, ch, c);
    for (i = 0; i < DIRS; i++) v += l->f[((size_t)i * CH + ch) * l->cells + c];
    return v;
}

void vsd_lbl_lattice_node_means(const vsd_lbl_lattice *l, const float *collide, const float albedo[3],
                                const float *source, int ch, size_t c, float mean[DIRS])
{
    const size_t cells = l->cells;
    const float p = collide[c], a = albedo[ch];
    float sum = 0.0f, f[DIRS], arriving, esc, credit;
    int i;
    in_cell(l, p, a, &arriving, &esc, &credit);
    for (i = 0; i < DIRS; i++) sum += f[i] = l->f[((size_t)i * CH + ch) * cells + c];
    for (i = 0; i < DIRS; i++) {
        /* what is born in the cell toward i: the collision's scattering and the source */
        float scattered = l->anisotropic ? l->side * sum + (l->forward - l->side) * f[i] + (l->backward - l->side) * f[i ^ 1]
                                         : sum * (1.0f / 6.0f);
        float s = !source ? 0.0f
                  : l->anisotropic ? source[((size_t)i * CH + ch) * cells + c]
                                   : source[(size_t)ch * cells + c] * (1.0f / 6.0f);
        mean[i] = arriving * f[i] + credit * (a * p * scattered + s);
    }
}

/* The photons in node c's cell, channel ch: the global lattice's cell means summed; the
 * paper's blocked and Geist's D3Q18 lattices keep their arriving sums. */
static float node_mean_sum(const vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source,
                           int ch, size_t c)
{
    float mean[DIRS], v = 0.0f;
    int i;
    if (!l->f) return node_sum(l, ch, c);
    vsd_lbl_lattice_node_means(l, collide, albedo, source, ch, c, mean);
    for (i = 0; i < DIRS; i++) v += mean[i];
    return v;
}

double vsd_lbl_lattice_total(const vsd_lbl_lattice *l, int ch)
{
    double s = 0.0;
    size_t c;
    if (l->layout.block_steps > 0) return vsd_lbl_blocked_total(&l->blocked, ch);
    if (l->layout.d3q18) return vsd_lbl_q18_total(&l->q18, ch);
    for (c = 0; c < l->cells; c++) s += node_sum(l, ch, c);
    return s;
}

/* The probe nodes (every 7th), all channels: their fluence now into probes[], and the sum
 * of |now - before| over them (before = the last call's values) into *moved. Returns the
 * summed fluence. Absolute changes, so light that moves between probes counts even when
 * the total stays (a rotated environment). */
static double probe_fluence(const vsd_lbl_lattice *l, float *probes, int first, double *moved)
{
    double s = 0.0, m = 0.0;
    size_t c, k = 0;
    int ch;
    for (c = 0; c < l->cells; c += 7)
        for (ch = 0; ch < CH; ch++, k++) {
            float v = node_sum(l, ch, c);
            if (!first) m += fabsf(v - probes[k]);
            probes[k] = v;
            s += v;
        }
    *moved = m;
    return s;
}

vsd_status vsd_lbl_diffuse(vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source,
                           double tolerance, int max_steps, int threads, float *fluence, vsd_lbl_diffusion_stats *stats,
                           char *err, size_t errlen)
{
    double t0 = vsd_clock_seconds(), last = -1.0, last_change = -1.0;
    float *probes;
    step_job job;
    vsd_status st = VSD_OK;
    size_t c;
    int k, ch;
    const int per = l->layout.block_steps > 0 ? l->layout.block_steps : 1;
    int next_check = per > 8 ? per : 8;
    memset(stats, 0, sizeof *stats);
    if (!allocated(l)) return VSD_OK;
    if ((st = prepare(l, &job, collide, albedo, source, err, errlen))) {
        step_job_free(&job);
        return st;
    }
    probes = malloc(((l->cells + 6) / 7) * CH * sizeof *probes);
    if (!probes) {
        step_job_free(&job);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the lattice's convergence probes");
    }
    /* k counts lattice steps; a blocked lattice advances block_steps per iteration, and the
     * convergence test runs every 8 steps or every iteration, whichever is longer */
    for (k = 0; k < max_steps; k += per) {
        if ((st = advance(l, &job, albedo, threads))) {
            st = vsd_fail(st, err, errlen, "lbl diffusion cancelled");
            break;
        }
        stats->steps = k + per;
        if (stats->steps >= next_check) {
            next_check += per > 8 ? per : 8;
            double moved, now = probe_fluence(l, probes, last < 0.0, &moved), change = now > 0.0 ? moved / now : 0.0;
            /* the change still to come, from the geometric decay of the last two windows'
             * changes (the paper stops on the change alone, which a warm start meets long
             * before the new steady state: 2.4% off after 16 steps on smoke64) */
            double r = last_change > 0.0 ? change / last_change : 1.0;
            stats->change = r < 1.0 ? change * r / (1.0 - r) + change : change * 1e3;
            if (last >= 0.0 && last_change >= 0.0 && stats->change < tolerance) {
                stats->converged = 1;
                break;
            }
            if (last >= 0.0) last_change = change;
            last = now;
        }
    }
    step_job_free(&job);
    free(probes);
    for (ch = 0; ch < CH; ch++)
        for (c = 0; c < l->cells; c++) fluence[(size_t)ch * l->cells + c] = node_mean_sum(l, collide, albedo, source, ch, c);
    stats->seconds = vsd_clock_seconds() - t0;
    return st;
}
