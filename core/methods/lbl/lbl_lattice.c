#include "lbl_lattice.h"
#include "device/cpu/cpu_tiles.h"
#include "device/cpu/cpu_wavefront.h"
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
    vsd_lbl_lattice_set_cell_shape(l, NULL);
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

void vsd_lbl_lattice_set_source_per_direction(vsd_lbl_lattice *l)
{
    /* the anisotropic step with equal shares is the isotropic one, reading S per direction */
    l->anisotropic = l->f != NULL;
}

void vsd_lbl_lattice_set_cell_light(vsd_lbl_lattice *l, int cell_light) { l->cell_light = cell_light; }

void vsd_lbl_lattice_set_order(vsd_lbl_lattice *l, int order) { l->order = order; }

void vsd_lbl_lattice_set_keep(vsd_lbl_lattice *l, const float *keep) { l->keep = keep; }

void vsd_lbl_lattice_set_albedo_cells(vsd_lbl_lattice *l, const float *albedo_cells)
{
    l->albedo_cells = albedo_cells;
}

void vsd_lbl_lattice_set_cell_shape(vsd_lbl_lattice *l, const double shape[3])
{
    int a;
    for (a = 0; a < 3; a++) l->shape[a] = shape ? shape[a] : 1.0;
}

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
    float *gain;             /* [2][cells] scratch: per-node sums */
    float *recollide;        /* [DIRS][cells] scratch (path in the cell): the first collision's light
                                that collides in the cell again, then the next births' parts */
    float *axes;             /* [AXIS_FIELDS][3][cells] (path in the cell): each node's cell_axes */
    const float *keep;       /* [cells] (path in the cell): the lattice's keep, or ones_keep */
    float *ones_keep;        /* [cells] of 1 when the lattice has none */
    /* [CH][cells] (path in the cell, a lattice with albedo_cells): each cell's albedo times
     * its keep, which then stands for albedo[ch] * keep */
    float *akeep;
    /* [rows of x] or NULL (every row): 1 where a cell of the row collides (p > 0) or has a
     * source; a cell without either passes its photons unchanged, post = f to the bit
     * (path in the cell: p_a = 0 on every axis, so nothing collides, nothing is born,
     * nothing leaves but what came), and the collision skips the rows of such cells
     * (collide_runs; whole rows, so its loops keep their length). Set for a whole solve,
     * whose source is fixed; a stepper's source grows during the march: it has none. */
    uint8_t *active;
    int steps;               /* steps taken: the Gauss-Seidel order's direction alternates */
} step_job;

/* The light in a cell with its photons' path (cell_light "path"; the paper's step is the
 * limit of thin cells). The cell's optical depth along axis a is x_a = sigma lambda_a
 * (lambda_a its edge: cells are boxes, as long as the volume's box over `cells` per axis;
 * vsd_lbl_lattice_set_cell_shape), p_a = 1 - e^-x_a, and a photon moving along a:
 * - arriving at a face, passes with 1 - p_a, else collides;
 * - collided at depth s from the face it came in by (density x_a e^-x_a s / p_a) and
 *   scattered back, leaves through that face with E_b = (1 - e^-2x_a) / (2 p_a), scattered
 *   on through the far face with E_f = x_a e^-x_a / p_a, and scattered onto another axis b
 *   with e_b = p_b / x_b (its position across b is uniform). So in a thick cell what collides
 *   near the face it came in by mostly goes back out of it: the lattice's walk slows to the
 *   medium's diffusion (letting it leave every way alike, as the paper does, diffuses
 *   x / (2 tanh(x / 2)) times too fast: 1.66x at x = 3);
 * - what collides in the cell again (and the source) is taken as born at a uniform point:
 *   toward an axis-b direction it leaves with e_b, else collides again (d_b = 1 - e_b) and
 *   is born again with the phase P. Of such a birth B, E (I - albedo P D)^-1 B leaves (E, D
 *   diagonal: e and d by each direction's axis). P keeps the vectors odd along an axis
 *   (f_+ = -f_-) in place, times forward - backward, so that part divides by 1 - albedo
 *   (forward - backward) d_b; on the even vectors (one value v_a per axis) P D is
 *   (forward + backward - 2 side) d_a v_a + 2 side sum_b d_b v_b, a diagonal plus a rank
 *   one, inverted by Sherman-Morrison (resolve_even).
 * Every photon's path before it leaves or collides is its collision probability over sigma:
 * in units of the cube-equivalent cell lambda = V^(1/3) (x = sigma lambda), a node's light
 * toward k is (p_b f_k + (first collision's light toward k that stays) + d_b z_k) / x, z the
 * births summed over the generations (vsd_lbl_lattice_node_means). Cubic cells: x_a = x.
 * The paper's step lets what is born in a cell leave it whole and counts the arriving
 * photons only; that is off by the order of x, which made VolumeInd darker the coarser the
 * lattice, and emission-lit media brighter (docs/methods/lbl.md, "A photon's path through a
 * cell"). */
enum { AXIS_P = 0, AXIS_E = 1, AXIS_EF = 2, AXIS_EB = 3, AXIS_FIELDS = 4 };
typedef struct cell_axes {
    float x;                 /* sigma lambda, lambda the cube-equivalent edge */
    float v[AXIS_FIELDS][3]; /* per axis: p, e, E_f, E_b */
} cell_axes;

/* The three shares of the lattice's phase: the set ones, or isotropic. */
static void phase_shares(const vsd_lbl_lattice *l, float *forward, float *backward, float *side)
{
    if (l->anisotropic) {
        *forward = l->forward, *backward = l->backward, *side = l->side;
    } else {
        *forward = *backward = *side = 1.0f / 6.0f;
    }
}

/* Cell c's axes from its cube-equivalent collision probability p = 1 - e^-x. */
static void cell_axes_of(const vsd_lbl_lattice *l, float p, cell_axes *ca)
{
    /* in float p reaches 1 near x = 17.3 (2^-25), where the cell is opaque all the same: x
     * is capped there so everything stays continuous */
    const double x = p < 1.0f ? fmin(-log1p(-(double)p), 17.3) : 17.3;
    int a;
    ca->x = (float)x;
    for (a = 0; a < 3; a++) {
        const double xa = x * l->shape[a];
        if (xa > 1e-3) {
            const double pa = -expm1(-xa);
            ca->v[AXIS_P][a] = (float)pa;
            ca->v[AXIS_E][a] = (float)(pa / xa);
            ca->v[AXIS_EF][a] = (float)(xa * exp(-xa) / pa);
            ca->v[AXIS_EB][a] = (float)(-expm1(-2.0 * xa) / (2.0 * pa));
        } else {   /* the series: every exit 1 - x_a/2 */
            ca->v[AXIS_P][a] = (float)(xa - 0.5 * xa * xa);
            ca->v[AXIS_E][a] = ca->v[AXIS_EF][a] = ca->v[AXIS_EB][a] = (float)(1.0 - 0.5 * xa);
        }
    }
}

/* collide_path's first collision toward the directions of one axis (k = +, k^1 = -) over n
 * nodes (restrict: separate arrays, so the loop vectorises): g = p f per arriving direction
 * (gp, gm this axis's, gsum all six), e/ef/eb this axis's exits; what leaves goes into q
 * (after the photons that pass, f (1 - p)), what collides again into m and its sum into
 * msum. */
static void first_collision(size_t n, float a0, const float *restrict keep, float fw, float bw, float sd,
                            const float *restrict fp,
                            const float *restrict fm, const float *restrict pax, const float *restrict gsum,
                            const float *restrict e, const float *restrict ef, const float *restrict eb,
                            float *restrict qp, float *restrict qm, float *restrict mp, float *restrict mm,
                            float *restrict msum)
{
    size_t c;
    for (c = 0; c < n; c++) {
        const float a = a0 * keep[c];
        const float gp = pax[c] * fp[c], gm = pax[c] * fm[c], rest = a * sd * (gsum[c] - gp - gm);
        const float fwd_p = a * fw * gp, back_p = a * bw * gm, fwd_m = a * fw * gm, back_m = a * bw * gp;
        const float out_p = fwd_p * ef[c] + back_p * eb[c] + rest * e[c];
        const float out_m = fwd_m * ef[c] + back_m * eb[c] + rest * e[c];
        qp[c] = fp[c] - gp + out_p;
        qm[c] = fm[c] - gm + out_m;
        mp[c] = fwd_p + back_p + rest - out_p;
        mm[c] = fwd_m + back_m + rest - out_m;
        msum[c] += mp[c] + mm[c];
    }
}

/* The next births along one axis: B = albedo P m + S, into its even and odd parts (over m's
 * arrays: mp := (B_+ + B_-) / 2, mm := (B_+ - B_-) / 2). sp/sm the source per direction, or
 * NULL: then s6 (a sixth of the isotropic source) both ways. The albedo is a0 akeep[c], the
 * source kept is keep[c] S (akeep = keep with one albedo a0 for every cell). */
static void births_axis(size_t n, float a0, const float *restrict akeep, const float *restrict keep, float fw,
                        float bw, float sd, const float *restrict msum,
                        const float *restrict sp, const float *restrict sm, const float *restrict s6,
                        float *restrict mp, float *restrict mm)
{
    size_t c;
    if (!sp) sp = sm = s6;   /* (the same array both ways, read only) */
    if (!sp) {
        for (c = 0; c < n; c++) {
            const float a = a0 * akeep[c], common = a * sd * msum[c];
            const float bp = common + a * ((fw - sd) * mp[c] + (bw - sd) * mm[c]);
            const float bm = common + a * ((fw - sd) * mm[c] + (bw - sd) * mp[c]);
            mp[c] = 0.5f * (bp + bm);
            mm[c] = 0.5f * (bp - bm);
        }
        return;
    }
    for (c = 0; c < n; c++) {
        const float a = a0 * akeep[c], common = a * sd * msum[c];
        const float bp = common + a * ((fw - sd) * mp[c] + (bw - sd) * mm[c]) + keep[c] * sp[c];
        const float bm = common + a * ((fw - sd) * mm[c] + (bw - sd) * mp[c]) + keep[c] * sm[c];
        mp[c] = 0.5f * (bp + bm);
        mm[c] = 0.5f * (bp - bm);
    }
}

/* Sherman-Morrison for the even parts: z_b = (y_b + K) / M_b, M_b = 1 - albedo (fw + bw -
 * 2 sd) d_b, K = 2 albedo sd A / (1 - 2 albedo sd Bs), A = sum_b d_b y_b / M_b, Bs = sum_b
 * d_b / M_b. Accumulates A and Bs of one axis (y its even part, e its exit) over n nodes. */
static void even_sums(size_t n, float a_even, const float *restrict keep, const float *restrict e,
                      const float *restrict y, float *restrict as, float *restrict bs)
{
    size_t c;
    for (c = 0; c < n; c++) {
        const float d = 1.0f - e[c], w = d / (1.0f - a_even * keep[c] * d);
        as[c] += w * y[c];
        bs[c] += w;
    }
}

/* What leaves along one axis: q_+- += e (z_even +- z_odd), z_even = (even + K) / M, z_odd =
 * odd / (1 - albedo (fw - bw) d); k2 = 2 albedo sd. as/bs from even_sums. */
static void leave_axis(size_t n, float a_even, float a_odd, float k2, const float *restrict keep,
                       const float *restrict e, const float *restrict even, const float *restrict odd,
                       const float *restrict as, const float *restrict bs, float *restrict qp, float *restrict qm)
{
    size_t c;
    for (c = 0; c < n; c++) {
        const float d = 1.0f - e[c], kk = k2 * keep[c], k = kk * as[c] / (1.0f - kk * bs[c]);
        const float ze = (even[c] + k) / (1.0f - a_even * keep[c] * d), zo = odd[c] / (1.0f - a_odd * keep[c] * d);
        qp[c] += e[c] * (ze + zo);
        qm[c] += e[c] * (ze - zo);
    }
}

/* One channel's collision of nodes [c0, c0 + n) with the path in the cell (above): the
 * photons that pass, the first collision's light that leaves, and what leaves of the later
 * births (what collided again, and the source: per direction on an anisotropic lattice,
 * else a sixth of it each way). */
static void collide_path(step_job *j, int ch, size_t c0, size_t n)
{
    const vsd_lbl_lattice *l = j->l;
    const size_t cells = l->cells;
    /* one albedo times each cell's keep, or each cell's own albedo (akeep) */
    const float a = j->akeep ? 1.0f : j->albedo[ch];
    const float *ak = j->akeep ? j->akeep + (size_t)ch * cells + c0 : j->keep + c0;
    float fw, bw, sd;
    float *sum1 = j->gain + c0, *sum2 = j->gain + cells + c0;
    size_t c;
    int i, axis;
#define AX(field, axis) (j->axes + ((size_t)(field) * 3 + (axis)) * cells + c0)
#define POP(arr, dir) ((arr) + ((size_t)(dir) * CH + ch) * cells + c0)
    phase_shares(l, &fw, &bw, &sd);
    /* sum1 := the collided light of all six directions, sum_i p_axis(i) f_i */
    for (c = 0; c < n; c++) sum1[c] = sum2[c] = 0.0f;
    for (i = 0; i < DIRS; i++) {
        const float *f = POP(l->f, i), *pa = AX(AXIS_P, dir_axis[i]);
        for (c = 0; c < n; c++) sum1[c] += pa[c] * f[c];
    }
    /* the first collision; sum2 := what of it collides again */
    for (axis = 0; axis < 3; axis++)
        first_collision(n, a, ak, fw, bw, sd, POP(l->f, 2 * axis), POP(l->f, 2 * axis + 1), AX(AXIS_P, axis), sum1,
                        AX(AXIS_E, axis), AX(AXIS_EF, axis), AX(AXIS_EB, axis), POP(j->post, 2 * axis),
                        POP(j->post, 2 * axis + 1), j->recollide + (size_t)(2 * axis) * cells + c0,
                        j->recollide + (size_t)(2 * axis + 1) * cells + c0, sum2);
    /* the next births, even and odd per axis; sum1 := the isotropic source's sixth */
    if (j->source && !l->anisotropic) {
        const float *src = j->source + (size_t)ch * cells + c0;
        for (c = 0; c < n; c++) sum1[c] = src[c] * (1.0f / 6.0f);
    }
    for (axis = 0; axis < 3; axis++)
        births_axis(n, a, ak, j->keep + c0, fw, bw, sd, sum2, j->source && l->anisotropic ? POP(j->source, 2 * axis) : NULL,
                    j->source && l->anisotropic ? POP(j->source, 2 * axis + 1) : NULL,
                    j->source && !l->anisotropic ? sum1 : NULL, j->recollide + (size_t)(2 * axis) * cells + c0,
                    j->recollide + (size_t)(2 * axis + 1) * cells + c0);
    /* what of them leaves: sum1, sum2 := Sherman-Morrison's A and Bs */
    {
        const float a_even = a * (fw + bw - 2.0f * sd), a_odd = a * (fw - bw), k2 = 2.0f * a * sd;
        for (c = 0; c < n; c++) sum1[c] = sum2[c] = 0.0f;
        for (axis = 0; axis < 3; axis++)
            even_sums(n, a_even, ak, AX(AXIS_E, axis), j->recollide + (size_t)(2 * axis) * cells + c0, sum1, sum2);
        for (axis = 0; axis < 3; axis++)
            leave_axis(n, a_even, a_odd, k2, ak, AX(AXIS_E, axis), j->recollide + (size_t)(2 * axis) * cells + c0,
                       j->recollide + (size_t)(2 * axis + 1) * cells + c0, sum1, sum2, POP(j->post, 2 * axis),
                       POP(j->post, 2 * axis + 1));
    }
#undef AX
#undef POP
}

/* The anisotropic collision of nodes [c0, c0 + n) with the paper's cell light: post_i =
 * (1 - p) f_i + albedo p (side sum_j f_j + (forward - side) f_i + (backward - side)
 * f_opposite(i)) + S_i, the cube's symmetry making P_ij one of three shares. */
static void collide_anisotropic_faces(step_job *j, int ch, size_t c0, size_t n)
{
    const vsd_lbl_lattice *l = j->l;
    const size_t cells = l->cells;
    const float fs = l->forward - l->side, bs = l->backward - l->side, a = j->albedo[ch];
    float *gain = j->gain + c0;
    const float *p = j->collide + c0;
    size_t c;
    int i;
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
        for (c = 0; c < n; c++)
            q[c] = (1.0f - p[c]) * f[c] + a * p[c] * (gain[c] + fs * f[c] + bs * fo[c]) + (src ? src[c] : 0.0f);
    }
}

/* One channel's collision of nodes [c0, c0 + n) (whole rows) with the path in the cell,
 * over the runs of active rows only (job.active); the rows between copy their populations. */
static void collide_runs(step_job *j, int ch, size_t c0, size_t n)
{
    const size_t cells = j->l->cells, nx = (size_t)j->l->res[0], r1 = (c0 + n) / nx;
    size_t r = c0 / nx;
    int i;
    while (r < r1) {
        size_t a = r, b;
        while (a < r1 && !j->active[a]) a++;
        if (a > r)
            for (i = 0; i < DIRS; i++) {
                const size_t o = ((size_t)i * CH + ch) * cells;
                memcpy(j->post + o + r * nx, j->l->f + o + r * nx, (a - r) * nx * sizeof *j->post);
            }
        for (b = a; b < r1 && j->active[b]; b++) {}
        if (b > a) collide_path(j, ch, a * nx, (b - a) * nx);
        r = b;
    }
}

/* Collision of nodes [c0, c0 + n) (whole rows): post = Theta f + S / 6 (the paper's
 * isotropic step), or with the phase or the path in the cell. Loops run along the nodes
 * (contiguous per direction and channel) so the compiler vectorises them. */
static void collide_cells(step_job *j, size_t c0, size_t n)
{
    const size_t cells = j->l->cells;
    float *gain = j->gain + c0;
    const float *p = j->collide + c0;
    size_t c;
    int ch, i;
    for (ch = 0; ch < CH; ch++) {
        const float a6 = j->albedo[ch] / 6.0f;
        const float *src = j->source ? j->source + (size_t)ch * cells + c0 : NULL;
        if (j->l->cell_light == VSD_LBL_CELL_PATH) {
            if (j->active) collide_runs(j, ch, c0, n);
            else collide_path(j, ch, c0, n);
            continue;
        }
        if (j->l->anisotropic) {
            collide_anisotropic_faces(j, ch, c0, n);
            continue;
        }
        for (c = 0; c < n; c++) gain[c] = 0.0f;
        for (i = 0; i < DIRS; i++) {
            const float *f = j->l->f + ((size_t)i * CH + ch) * cells + c0;
            for (c = 0; c < n; c++) gain[c] += f[c];
        }
        for (c = 0; c < n; c++) gain[c] = a6 * p[c] * gain[c] + (src ? src[c] * (1.0f / 6.0f) : 0.0f);
        for (i = 0; i < DIRS; i++) {
            const size_t o = ((size_t)i * CH + ch) * cells + c0;
            const float *f = j->l->f + o;
            float *q = j->post + o;
            for (c = 0; c < n; c++) q[c] = (1.0f - p[c]) * f[c] + gain[c];
        }
    }
}

/* Collision of the nodes in slices [z0, z1). */
static void collide_slices(void *arg, int z0, int y0, int z1, int y1)
{
    step_job *j = arg;
    const size_t slice = (size_t)j->l->res[0] * j->l->res[1];
    (void)y0;
    (void)y1;
    collide_cells(j, (size_t)z0 * slice, (size_t)(z1 - z0) * slice);
}

/* A row's populations along +x (sign > 0) or -x moved on one node: dst[x] = src[x - sign],
 * 0 where that is outside the row. Both orders' streaming take their rows' x shift here. */
static void shift_row_x(float *dst, const float *src, int32_t nx, int32_t sign)
{
    if (sign > 0) {
        dst[0] = 0.0f;
        memcpy(dst + 1, src, sizeof(float) * (size_t)(nx - 1));
    } else {
        memcpy(dst, src + 1, sizeof(float) * (size_t)(nx - 1));
        dst[nx - 1] = 0.0f;
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
                        shift_row_x(dst + row, src + row, nx, dir_sign[i]);
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

/* The Gauss-Seidel order (vsd_lbl_lattice_set_order). A step takes the z slices in turn
 * (every other step from the last back), each in runs of ORDER_ROWS rows of nodes along x
 * taken in order of y: a run collides, then sends its populations on into its neighbours
 * at once, so the runs after it in the order (the next slice, the next run of the slice)
 * collide, in the same step, with what it sent them, and light crosses the lattice along
 * z in one step instead of one cell a step (along y, a run a step). The steady state is
 * the same (each node's populations are then what its neighbours send it, in either
 * order); only the way there is shorter (docs/methods/lbl.md, "The lattice in Gauss-Seidel
 * order"). Whole runs collide at once, as long loops over contiguous nodes: a row at a
 * time, with y in the order too, took fewer steps but each cost 1.65x (a sweep backward
 * through memory 256 bytes at a time, 1.7x a forward one). Threads take the runs in
 * wavefront order (cpu_wavefront.h: run u of slice v after run u - 1 of slice v and run u
 * of slice v - 1), which keeps every run's reads those of the one-thread order, so the
 * result does not depend on the thread count. */
enum { ORDER_ROWS = 8 };

/* Node row (y, z) streams: f_i(r + c_i) = post_i(r), 0 from outside (push: each
 * population array of a row has one sender, the row behind it along c_i). */
static void push_row(step_job *j, int32_t y, int32_t z)
{
    const int32_t nx = j->l->res[0], ny = j->l->res[1], nz = j->l->res[2];
    const size_t cells = j->l->cells, row = ((size_t)z * ny + y) * nx;
    int i, ch;
    for (i = 0; i < DIRS; i++) {
        int32_t ty = y, tz = z;
        if (dir_axis[i] == 1) ty += dir_sign[i];
        else if (dir_axis[i] == 2) tz += dir_sign[i];
        if (ty < 0 || ty >= ny || tz < 0 || tz >= nz) continue;
        for (ch = 0; ch < CH; ch++) {
            float *dst = j->l->f + ((size_t)i * CH + ch) * cells;
            const float *src = j->post + ((size_t)i * CH + ch) * cells + row;
            if (dir_axis[i] != 0) memcpy(dst + ((size_t)tz * ny + ty) * nx, src, sizeof(float) * (size_t)nx);
            else shift_row_x(dst + row, src, nx, dir_sign[i]);
        }
    }
}

/* Run u of slice v in the step's order collides, then streams: forward, rows
 * [u ORDER_ROWS, (u + 1) ORDER_ROWS) of slice v; backward, the slice and the rows
 * mirrored (slice nz - 1 - v, counted from the last row). */
static void order_run(void *user, int u, int v)
{
    step_job *j = user;
    const int32_t nx = j->l->res[0], ny = j->l->res[1], nz = j->l->res[2], forward = (j->steps & 1) == 0;
    int32_t y0 = u * ORDER_ROWS, y1 = y0 + ORDER_ROWS, z = forward ? v : nz - 1 - v, y;
    if (y1 > ny) y1 = ny;
    if (!forward) {
        const int32_t m0 = ny - y1;
        y1 = ny - y0;
        y0 = m0;
    }
    collide_cells(j, ((size_t)z * ny + y0) * nx, (size_t)(y1 - y0) * nx);
    for (y = y0; y < y1; y++) push_row(j, y, z);
}

/* One step on the CPU pool: in Gauss-Seidel order the runs of rows in wavefront order,
 * else (Jacobi) every z slice collides, then every slice streams. */
static vsd_status run_step(step_job *job, int threads)
{
    vsd_status st;
    if (job->l->order == VSD_LBL_ORDER_GAUSS_SEIDEL) {
        const int runs = (job->l->res[1] + ORDER_ROWS - 1) / ORDER_ROWS;
        st = vsd_cpu_run_wavefront(runs, job->l->res[2], threads, order_run, job, "lbl diffusion");
        job->steps++;
        return st;
    }
    st = vsd_cpu_run_each(job->l->res[2], threads, collide_slices, job, "lbl diffusion");
    return st ? st : vsd_cpu_run_each(job->l->res[2], threads, stream_slices, job, "lbl diffusion");
}

/* A step job over l with its scratch (post-collision populations, per-node sums) and, with
 * the path in the cell, each node's cell_axes; 0 when that could not be allocated
 * (step_job_free in either case). */
static int step_job_init(step_job *job, vsd_lbl_lattice *l, const float *collide, const float albedo[3],
                         const float *source)
{
    const size_t cells = l->cells;
    size_t n;
    int c, k, a;
    job->l = l;
    job->collide = collide;
    job->source = source;
    for (c = 0; c < CH; c++) job->albedo[c] = albedo[c];
    job->post = malloc(cells * DIRS * CH * sizeof *job->post);
    job->gain = malloc(2 * cells * sizeof *job->gain);
    if (!job->post || !job->gain) return 0;
    if (l->cell_light != VSD_LBL_CELL_PATH) return 1;
    job->recollide = malloc(cells * DIRS * sizeof *job->recollide);
    job->axes = malloc(cells * 3 * AXIS_FIELDS * sizeof *job->axes);
    if (!job->recollide || !job->axes) return 0;
    job->keep = l->keep;
    if (!job->keep) {
        if (!(job->ones_keep = malloc(cells * sizeof *job->ones_keep))) return 0;
        for (n = 0; n < cells; n++) job->ones_keep[n] = 1.0f;
        job->keep = job->ones_keep;
    }
    if (l->albedo_cells) {
        if (!(job->akeep = malloc(CH * cells * sizeof *job->akeep))) return 0;
        for (k = 0; k < CH; k++)
            for (n = 0; n < cells; n++) job->akeep[(size_t)k * cells + n] = l->albedo_cells[(size_t)k * cells + n] * job->keep[n];
    }
    for (n = 0; n < cells; n++) {
        cell_axes ca;
        cell_axes_of(l, collide[n], &ca);
        for (k = 0; k < AXIS_FIELDS; k++)
            for (a = 0; a < 3; a++) job->axes[((size_t)k * 3 + a) * cells + n] = ca.v[k][a];
    }
    return 1;
}

static void step_job_free(step_job *job)
{
    free(job->active);
    free(job->post);
    free(job->gain);
    free(job->recollide);
    free(job->axes);
    free(job->ones_keep);
    free(job->akeep);
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

/* The blocked and D3Q18 lattices take copies of the material (prepare), the global one
 * reads it in place. */
static int copies_material(const vsd_lbl_lattice *l) { return l->layout.block_steps > 0 || l->layout.d3q18; }

struct vsd_lbl_stepper {
    vsd_lbl_lattice *l;
    const float *collide, *source;
    float albedo[3];
    step_job job;            /* the global lattice's, kept across runs */
};

vsd_status vsd_lbl_stepper_new(vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source,
                               vsd_lbl_stepper **out, char *err, size_t errlen)
{
    vsd_lbl_stepper *s = calloc(1, sizeof *s);
    vsd_status st;
    *out = NULL;
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the lattice's stepper");
    s->l = l;
    s->collide = collide;
    s->source = source;
    memcpy(s->albedo, albedo, sizeof s->albedo);
    if (allocated(l) && !copies_material(l) && (st = prepare(l, &s->job, collide, albedo, source, err, errlen))) {
        vsd_lbl_stepper_free(s);
        return st;
    }
    *out = s;
    return VSD_OK;
}

vsd_status vsd_lbl_stepper_run(vsd_lbl_stepper *s, int steps, int threads)
{
    vsd_status st = VSD_OK;
    int k;
    if (!allocated(s->l)) return VSD_OK;
    /* their copies taken anew every run, so a source still being deposited counts as it
     * grows */
    if (copies_material(s->l) && (st = prepare(s->l, &s->job, s->collide, s->albedo, s->source, NULL, 0)))
        return st;
    for (k = 0; k < steps && !st; k++) st = advance(s->l, &s->job, s->albedo, threads);
    return st;
}

void vsd_lbl_stepper_free(vsd_lbl_stepper *s)
{
    if (!s) return;
    step_job_free(&s->job);
    free(s);
}

void vsd_lbl_lattice_steps(vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source,
                           int steps)
{
    vsd_lbl_stepper *s;
    if (vsd_lbl_stepper_new(l, collide, albedo, source, &s, NULL, 0) == VSD_OK) vsd_lbl_stepper_run(s, steps, 1);
    vsd_lbl_stepper_free(s);
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
    const double keep = l->keep ? l->keep[c] : 1.0,
                 a = (l->albedo_cells ? l->albedo_cells[(size_t)ch * cells + c] : albedo[ch]) * keep;
    double f[DIRS], g[DIRS], m[DIRS], born[DIRS], gsum = 0.0, msum = 0.0, as = 0.0, bs = 0.0;
    float fw, bw, sd;
    cell_axes ca;
    int i, axis;
    for (i = 0; i < DIRS; i++) f[i] = l->f[((size_t)i * CH + ch) * cells + c];
    if (l->cell_light != VSD_LBL_CELL_PATH) {   /* the paper's: the arriving photons */
        for (i = 0; i < DIRS; i++) mean[i] = (float)f[i];
        return;
    }
    cell_axes_of(l, collide[c], &ca);
    phase_shares(l, &fw, &bw, &sd);
    for (i = 0; i < DIRS; i++) gsum += g[i] = ca.v[AXIS_P][dir_axis[i]] * f[i];
    /* the first collision's light toward i that collides in the cell again */
    for (i = 0; i < DIRS; i++) {
        const int b = dir_axis[i];
        const double fwd = a * fw * g[i], back = a * bw * g[i ^ 1], rest = a * sd * (gsum - g[i] - g[i ^ 1]);
        m[i] = fwd * (1.0 - ca.v[AXIS_EF][b]) + back * (1.0 - ca.v[AXIS_EB][b]) + rest * (1.0 - ca.v[AXIS_E][b]);
        msum += m[i];
    }
    /* the next births and, summed over their generations, z (the resolvent of collide_path) */
    for (i = 0; i < DIRS; i++) {
        born[i] = a * (sd * msum + (fw - sd) * m[i] + (bw - sd) * m[i ^ 1]);
        if (source)
            born[i] += keep * (l->anisotropic ? source[((size_t)i * CH + ch) * cells + c]
                                              : source[(size_t)ch * cells + c] * (1.0 / 6.0));
    }
    for (axis = 0; axis < 3; axis++) {
        const double d = 1.0 - ca.v[AXIS_E][axis], w = d / (1.0 - a * (fw + bw - 2.0 * sd) * d);
        as += w * 0.5 * (born[2 * axis] + born[2 * axis + 1]);
        bs += w;
    }
    for (axis = 0; axis < 3; axis++) {
        const double d = 1.0 - ca.v[AXIS_E][axis], k = 2.0 * a * sd * as / (1.0 - 2.0 * a * sd * bs);
        const double ze = (0.5 * (born[2 * axis] + born[2 * axis + 1]) + k) / (1.0 - a * (fw + bw - 2.0 * sd) * d);
        const double zo = 0.5 * (born[2 * axis] - born[2 * axis + 1]) / (1.0 - a * (fw - bw) * d);
        /* the path: collisions over x (thin cells: its limits, f_i lambda_a / lambda and half
         * a cell for what is born) */
        for (i = 2 * axis; i < 2 * axis + 2; i++) {
            const double z = i == 2 * axis ? ze + zo : ze - zo;
            mean[i] = (float)(ca.x > 1e-6f ? (g[i] + m[i] + d * z) / ca.x
                                           : l->shape[axis] * (f[i] + 0.5 * z));
        }
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

/* The solve's fluence at the nodes of slices [z0, z1) (items): each node on its own. */
typedef struct fluence_job {
    const vsd_lbl_lattice *l;
    const float *collide, *albedo, *source;
    float *fluence;
} fluence_job;

static void fluence_slices(void *user, int z0, int y0, int z1, int y1)
{
    const fluence_job *j = user;
    const size_t cells = j->l->cells, slice = (size_t)j->l->res[0] * j->l->res[1];
    size_t c;
    int ch;
    (void)y0, (void)y1;
    for (ch = 0; ch < CH; ch++)
        for (c = (size_t)z0 * slice; c < (size_t)z1 * slice; c++)
            j->fluence[(size_t)ch * cells + c] = node_mean_sum(j->l, j->collide, j->albedo, j->source, ch, c);
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

/* job.active for a solve of collide and source (left NULL, every row collided, when out of
 * memory: the same result). */
static void mark_active(const vsd_lbl_lattice *l, step_job *job, const float *collide, const float *source)
{
    const size_t cells = l->cells, nx = (size_t)l->res[0], rows = cells / nx;
    const size_t arrays = source ? (l->anisotropic ? (size_t)DIRS * CH : (size_t)CH) : 0;
    size_t r, q, x;
    if (!(job->active = malloc(rows))) return;
    for (r = 0; r < rows; r++) {
        const size_t c0 = r * nx;
        int any = 0;
        for (x = 0; x < nx && !any; x++) any = collide[c0 + x] != 0.0f;
        for (q = 0; q < arrays && !any; q++)
            for (x = 0; x < nx && !any; x++) any = source[q * cells + c0 + x] != 0.0f;
        job->active[r] = (uint8_t)any;
    }
}

vsd_status vsd_lbl_diffuse(vsd_lbl_lattice *l, const float *collide, const float albedo[3], const float *source,
                           double tolerance, int max_steps, int threads, float *fluence, vsd_lbl_diffusion_stats *stats,
                           char *err, size_t errlen)
{
    double t0 = vsd_clock_seconds(), last = -1.0, last_change = -1.0;
    float *probes;
    step_job job;
    vsd_status st = VSD_OK;
    int k;
    const int per = l->layout.block_steps > 0 ? l->layout.block_steps : 1;
    int next_check = per > 8 ? per : 8;
    memset(stats, 0, sizeof *stats);
    if (!allocated(l)) return VSD_OK;
    if ((st = prepare(l, &job, collide, albedo, source, err, errlen))) {
        step_job_free(&job);
        return st;
    }
    if (!copies_material(l) && l->cell_light == VSD_LBL_CELL_PATH) mark_active(l, &job, collide, source);
    probes = malloc(((l->cells + 6) / 7) * CH * sizeof *probes);
    if (!probes) {
        step_job_free(&job);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the lattice's convergence probes");
    }
    /* k counts lattice steps; a blocked lattice advances block_steps per iteration, and the
     * convergence test runs every 8 steps or every iteration, whichever is longer */
    for (k = 0; k < max_steps; k += per) {
        if ((st = advance(l, &job, albedo, threads))) {
            st = vsd_fail(st, err, errlen, "lbl diffusion stopped: %s", vsd_status_str(st));
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
    {
        /* (0.08-0.14 s at 64^3 on one thread: each node's means solve its cell's births) */
        fluence_job fj = {l, collide, albedo, source, fluence};
        vsd_status fs = vsd_cpu_run_each(l->res[2], threads, fluence_slices, &fj, "lbl diffusion");
        if (fs && !st) st = vsd_fail(fs, err, errlen, "lbl: the fluence's threads failed");
    }
    stats->seconds = vsd_clock_seconds() - t0;
    return st;
}
