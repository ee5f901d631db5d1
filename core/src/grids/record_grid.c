/* The record grid (record_grid.h), moved here from shgrid.c so constellation's cached
 * shadows use the same cells. */
#include "record_grid.h"
#include "kvolume_boxes.h"
#include "record_phase.h"
#include "vsd/volume.h"
#include "device/cpu/cpu_tiles.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_record_grid.h"
#include "kernel/kernel_record_grids.h"
#include "src/method/method.h"
#include "src/device_data/record_grid_device.h"
#include "src/render/kernel_setup.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Is the cell with index-space box [lo, hi) non-empty? First the brick majorants (exact:
 * a cell over empty bricks is empty), then the paper's k^3 probes of the density. */
static int cell_nonempty(const vsd_kvolume *v, const double lo[3], const double hi[3], int k)
{
    int b0[3], b1[3], a, x, y, z, any = 0;
    for (a = 0; a < 3; a++) {
        b0[a] = (int)floor((lo[a] - v->origin[a]) / 8.0);
        b1[a] = (int)floor((hi[a] - v->origin[a]) / 8.0);
        if (b0[a] < 0) b0[a] = 0;
        if (b1[a] > v->dims[a] - 1) b1[a] = v->dims[a] - 1;
    }
    for (z = b0[2]; z <= b1[2] && !any; z++)
        for (y = b0[1]; y <= b1[1] && !any; y++)
            for (x = b0[0]; x <= b1[0] && !any; x++)
                if (v->brick_max[((size_t)z * v->dims[1] + y) * v->dims[0] + x] > 0.0f) any = 1;
    if (!any || k == 0) return any;
    for (a = 0; a < k * k * k; a++)   /* a: the probe */
        if (vsd_kvolume_field(v, vsd_box_probe(lo, hi, k, a)) > 0.0f) return 1;
    return 0;
}

double vsd_record_grid_cell_world(const vsd_record_grid *g)
{
    double thinnest = INFINITY;
    int a;
    for (a = 0; a < 3; a++) {
        const float *r = g->world_to_grid.m + 4 * a;
        double n = sqrt((double)r[0] * r[0] + (double)r[1] * r[1] + (double)r[2] * r[2]);
        if (n > 0 && 1.0 / n < thinnest) thinnest = 1.0 / n;
    }
    return thinnest;
}

void vsd_record_grid_free(vsd_record_grid *g)
{
    free(g->cell_record);
    free(g->record_pos);
    memset(g, 0, sizeof *g);
}

/* from's index space -> to's (from_i2w: from's index -> world) */
static void index_between(const double from_i2w[16], const vsd_kvolume *to, double m[16])
{
    double w2i[16];
    vsd_kvolume_world_to_index_d(to, w2i);
    vsd_mat4_mul(w2i, from_i2w, m);
}

vsd_status vsd_record_grid_build(const vsd_kvolume *v, int cells, int probes, vsd_record_grid *g, char *err,
                                 size_t errlen)
{
    return vsd_record_grid_build_over(v, NULL, 0, cells, probes, g, err, errlen);
}

static vsd_status build(const vsd_kvolume *v, const vsd_kvolume *const *others, int other_count, int cells,
                        int shaped, int probes, vsd_record_grid *g, char *err, size_t errlen);

vsd_status vsd_record_grid_build_over(const vsd_kvolume *v, const vsd_kvolume *const *others, int other_count,
                                      int cells, int probes, vsd_record_grid *g, char *err, size_t errlen)
{
    return build(v, others, other_count, cells, 0, probes, g, err, errlen);
}

vsd_status vsd_record_grid_build_shaped(const vsd_kvolume *v, int cells, int probes, vsd_record_grid *g, char *err,
                                        size_t errlen)
{
    return build(v, NULL, 0, cells, 1, probes, g, err, errlen);
}

static vsd_status build(const vsd_kvolume *v, const vsd_kvolume *const *others, int other_count, int cells,
                        int shaped, int probes, vsd_record_grid *g, char *err, size_t errlen)
{
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, cell[3], i2w[16], to_other[VSD_KMAX_VOLUMES][16];
    int a, x, y, z, o, any;
    size_t ncell;
    vsd_record_grid_free(g);
    if (v->dims[0] == 0) return VSD_OK;
    if (other_count > VSD_KMAX_VOLUMES - 1)
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "internal: %d other volumes for one record grid", other_count);
    if (!vsd_kvolume_index_to_world(v, i2w)) return vsd_fail(VSD_ERR_INVALID, err, errlen, "volume transform is singular");
    /* the medium's box: the union of non-empty brick cells (index space), and the other
     * volumes' boxes seen from v's index space */
    any = vsd_kvolume_active_index_box(v, lo, hi);
    for (o = 0; o < other_count; o++) {
        double olo[3], ohi[3], oi2w[16], blo[3], bhi[3];
        if (!vsd_kvolume_active_index_box(others[o], olo, ohi)) continue;
        if (!vsd_kvolume_index_to_world(others[o], oi2w))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "volume transform is singular");
        {
            double m[16];
            index_between(oi2w, v, m);
            vsd_affine_box(m, olo, ohi, blo, bhi);
        }
        for (a = 0; a < 3; a++) {
            if (!any || blo[a] < lo[a]) lo[a] = blo[a];
            if (!any || bhi[a] > hi[a]) hi[a] = bhi[a];
        }
        any = 1;
    }
    if (!any) return VSD_OK;
    if (shaped) {
        /* cubic cells (in index space), `cells` of them along the box's longest axis */
        double side = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2])) / cells;
        for (a = 0; a < 3; a++) {
            g->res[a] = (int32_t)ceil((hi[a] - lo[a]) / side - 1e-9);
            if (g->res[a] < 1) g->res[a] = 1;
            cell[a] = side;
        }
    } else {
        for (a = 0; a < 3; a++) {
            g->res[a] = cells;
            cell[a] = (hi[a] - lo[a]) / cells;
        }
    }
    /* world -> grid = scale(1/cell) . translate(-lo) . world_to_index */
    for (a = 0; a < 3; a++) {
        int c;
        for (c = 0; c < 4; c++) g->world_to_grid.m[4 * a + c] = (float)(v->world_to_index.m[4 * a + c] / cell[a]);
        g->world_to_grid.m[4 * a + 3] -= (float)(lo[a] / cell[a]);
    }
    for (o = 0; o < other_count; o++) index_between(i2w, others[o], to_other[o]);
    ncell = (size_t)g->res[0] * g->res[1] * g->res[2];
    g->cell_record = malloc(sizeof(int32_t) * ncell);
    if (!g->cell_record) {
        vsd_record_grid_free(g);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for a %dx%dx%d record grid", g->res[0], g->res[1],
                        g->res[2]);
    }
    for (z = 0; z < g->res[2]; z++)
        for (y = 0; y < g->res[1]; y++)
            for (x = 0; x < g->res[0]; x++) {
                double cl[3], ch[3];
                int c[3] = {x, y, z}, full;
                for (a = 0; a < 3; a++) {
                    cl[a] = lo[a] + cell[a] * c[a];
                    ch[a] = cl[a] + cell[a];
                }
                full = cell_nonempty(v, cl, ch, probes);
                /* another volume's medium in the cell: its probes over the cell's box in its
                 * own index space (a little more than the cell where the axes differ) */
                for (o = 0; o < other_count && !full; o++) {
                    double ol[3], oh[3];
                    if (others[o]->dims[0] == 0) continue;
                    vsd_affine_box(to_other[o], cl, ch, ol, oh);
                    full = cell_nonempty(others[o], ol, oh, probes);
                }
                g->cell_record[((size_t)z * g->res[1] + y) * g->res[0] + x] = full ? g->count++ : -1;
            }
    g->record_pos = malloc(sizeof(float) * 4 * (size_t)(g->count ? g->count : 1));
    if (!g->record_pos) {
        vsd_record_grid_free(g);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d records", (int)g->count);
    }
    for (z = 0; z < g->res[2]; z++)
        for (y = 0; y < g->res[1]; y++)
            for (x = 0; x < g->res[0]; x++) {
                int r = g->cell_record[((size_t)z * g->res[1] + y) * g->res[0] + x], c[3] = {x, y, z};
                double p[3], w[3];
                if (r < 0) continue;
                for (a = 0; a < 3; a++) p[a] = lo[a] + cell[a] * (c[a] + 0.5);
                vsd_affine_apply_d(i2w, p, w);
                for (a = 0; a < 3; a++) g->record_pos[4 * r + a] = (float)w[a];
                g->record_pos[4 * r + 3] = 1.0f;
            }
    return VSD_OK;
}

/* The sub-lights as separate arrays: directions (vsd_hg_eval_many's input), colours and
 * the light each belongs to; pk the phases of one record's direction. Where each light's
 * sub-lights are one run, lights in order (`grouped`), they are laid out by rank instead:
 * entry q * L + k is light k's q-th sub-light (L lights, `ranks` the most any has; a light
 * with fewer is padded with its first direction and colour 0, added last: x + 0 = x). The
 * sums over a light's run then go across the lights, L independent chains a vector wide,
 * each light's in its run's order: the same bits as one light at a time, where its chain
 * of dependent adds made the bake wait on every add (most of a small view's bake). */
typedef struct sub_light_dirs {
    float *x, *y, *z, *r, *g, *b, *pk;
    int32_t *light;
    int32_t n;         /* entries: sub-lights, or ranks x lights when grouped */
    int32_t grouped;
    int32_t ranks;
} sub_light_dirs;

static int sub_light_dirs_alloc(sub_light_dirs *s, int32_t n)
{
    if (!(s->x = malloc(8 * sizeof(float) * (size_t)n))) return -1;
    s->y = s->x + n;
    s->z = s->y + n;
    s->r = s->z + n;
    s->g = s->r + n;
    s->b = s->g + n;
    s->pk = s->b + n;
    s->light = (int32_t *)(s->pk + n);
    s->n = n;
    return 0;
}

static void sub_light_set(sub_light_dirs *s, int32_t i, const float *l, int weighted)
{
    s->x[i] = l[0];
    s->y[i] = l[1];
    s->z[i] = l[2];
    s->r[i] = weighted ? l[4] : 0.0f;
    s->g[i] = weighted ? l[5] : 0.0f;
    s->b[i] = weighted ? l[6] : 0.0f;
    s->light[i] = (int32_t)l[7];
}

static int sub_light_dirs_make(const vsd_krecord_grid *g, sub_light_dirs *s)
{
    const int32_t n = g->sub_count, nl = g->light_count;
    const float *subs = g->lights + 8 * (size_t)nl;
    int32_t k, first = 0, run = 0, q;
    memset(s, 0, sizeof *s);
    if (n <= 0) return 0;
    s->grouped = nl > 0;
    for (k = 0; k < n; k++) {
        int32_t j = (int32_t)subs[8 * (size_t)k + 7], prev = k ? (int32_t)subs[8 * (size_t)(k - 1) + 7] : -1;
        if (j < 0 || j >= nl || j < prev) s->grouped = 0;
        run = j == prev ? run + 1 : 1;
        if (run > s->ranks) s->ranks = run;
    }
    if (!s->grouped) {
        if (sub_light_dirs_alloc(s, n)) return -1;
        for (k = 0; k < n; k++) sub_light_set(s, k, subs + 8 * (size_t)k, 1);
        return 0;
    }
    if (sub_light_dirs_alloc(s, s->ranks * nl)) return -1;
    /* light k with no sub-light: its own direction at weight 0 (its sum stays 0) */
    for (k = 0; k < nl; k++)
        for (q = 0; q < s->ranks; q++) sub_light_set(s, q * nl + k, g->lights + 8 * (size_t)k, 0);
    for (k = 0; k < n; k = first) {
        const int32_t j = (int32_t)subs[8 * (size_t)k + 7];
        for (first = k; first < n && (int32_t)subs[8 * (size_t)first + 7] == j; first++)
            sub_light_set(s, (first - k) * nl + j, subs + 8 * (size_t)first, 1);
        for (q = first - k; q < s->ranks; q++) {   /* the padding: its first direction, weight 0 */
            sub_light_set(s, q * nl + j, subs + 8 * (size_t)k, 0);
        }
    }
    return 0;
}

/* vsd_records_light_weights with sub-lights, their phases computed together first and
 * each light's sum in registers where its sub-lights are one run: the same sums in the
 * same order, so the same bits (the per-element += through memory chained every add on
 * the last store: 8% of lbl's camera change). */
static void sub_light_weights(const vsd_krecord_grid *g, sub_light_dirs *s, vsd_f3 d, float an, float *ph)
{
    int32_t k;
    ph[VSD_RECORDS_PH_DIR] = d.x;
    ph[VSD_RECORDS_PH_DIR + 1] = d.y;
    ph[VSD_RECORDS_PH_DIR + 2] = d.z;
    ph[VSD_RECORDS_PH_DIR + 3] = an;
    for (k = 0; k < g->light_count; k++) ph[k] = ph[VSD_RECORDS_MAX_LIGHTS + k] = ph[2 * VSD_RECORDS_MAX_LIGHTS + k] = 0.0f;
    vsd_hg_eval_many(s->x, s->y, s->z, s->n, d, an, s->pk);
    if (s->grouped) {
        const int32_t nl = g->light_count;
        float *restrict pr = ph, *restrict pg = ph + VSD_RECORDS_MAX_LIGHTS, *restrict pb = ph + 2 * VSD_RECORDS_MAX_LIGHTS;
        int32_t q;
        for (q = 0; q < s->ranks; q++) {
            const float *restrict pk = s->pk + (size_t)q * nl, *restrict r = s->r + (size_t)q * nl,
                                  *restrict gg = s->g + (size_t)q * nl, *restrict b = s->b + (size_t)q * nl;
            for (k = 0; k < nl; k++) {
                pr[k] += pk[k] * r[k];
                pg[k] += pk[k] * gg[k];
                pb[k] += pk[k] * b[k];
            }
        }
        return;
    }
    for (k = 0; k < s->n; k++) {
        int32_t j = s->light[k];
        if (j < 0 || j >= g->light_count) continue;
        ph[j] += s->pk[k] * s->r[k];
        ph[VSD_RECORDS_MAX_LIGHTS + j] += s->pk[k] * s->g[k];
        ph[2 * VSD_RECORDS_MAX_LIGHTS + j] += s->pk[k] * s->b[k];
    }
}

/* Records [r0, r1)'s radiance into out (3 floats each): with the phase at a fixed
 * direction (cam NULL: g = 0, any direction does), or at the direction from the camera to
 * the record. */
static void bake_range(const vsd_krecord_grid *g, const float *record_pos, const vsd_kcamera *cam, int32_t r0,
                       int32_t r1, float *out, const vsd_krecord_grid *g2, float *out2)
{
    float ph[VSD_RECORDS_PH_FLOATS], w[VSD_SH_MAX_COEFFS];
    const int sh_rgb = g->kind == VSD_RECORDS_SH_RGB;
    vsd_f3 eye = f3s(0.0f), forward = f3(0.0f, 0.0f, 1.0f);
    sub_light_dirs subs = {0};
    /* (without memory for them, the scalar loop of vsd_records_light_weights) */
    int per_record_subs = cam && !cam->orthographic && sub_light_dirs_make(g, &subs) == 0 && subs.n > 0;
    int32_t r;
    if (cam) {
        const float *m = cam->cam_to_world.m;
        eye = f3(m[3], m[7], m[11]);
        forward = f3_scale(f3_normalize(f3(m[2], m[6], m[10])), -1.0f);   /* the camera looks down -Z */
    }
    if (!cam || cam->orthographic) {
        vsd_records_light_weights(g->lights, g->light_count, g->sub_count, forward, cam ? g->kd->medium.anisotropy : 0.0f, ph);
        if (sh_rgb) vsd_records_sh_view_weights(g->order, g->kd->medium.anisotropy, forward, w);
    }
    for (r = r0; r < r1; r++) {
        vsd_f3 v;
        if (cam && !cam->orthographic) {
            const float *p = record_pos + 4 * (size_t)r;
            vsd_f3 d = f3_normalize(f3_sub(f3(p[0], p[1], p[2]), eye));
            if (per_record_subs) sub_light_weights(g, &subs, d, g->kd->medium.anisotropy, ph);
            else vsd_records_light_weights(g->lights, g->light_count, g->sub_count, d, g->kd->medium.anisotropy, ph);
            if (sh_rgb) vsd_records_sh_view_weights(g->order, g->kd->medium.anisotropy, d, w);
        }
        v = vsd_records_radiance(g, r, sh_rgb ? w : NULL, ph);
        if (g2) {
            vsd_f3 v2 = vsd_records_radiance(g2, r, NULL, ph);
            out2[3 * (size_t)r] = v2.x;
            out2[3 * (size_t)r + 1] = v2.y;
            out2[3 * (size_t)r + 2] = v2.z;
        }
        out[3 * (size_t)r] = v.x;
        out[3 * (size_t)r + 1] = v.y;
        out[3 * (size_t)r + 2] = v.z;
        if (cam && g->interp == VSD_RECORDS_LOG_TRILINEAR) {
            /* the log the view's corners would take, once per record instead of per corner visit */
            int a;
            for (a = 0; a < 3; a++) out[3 * (size_t)r + a] = logf(fmaxf(out[3 * (size_t)r + a], VSD_RECORDS_LOG_FLOOR));
        }
    }
    free(subs.x);
}

typedef struct bake_job {
    const vsd_krecord_grid *g;
    const float *record_pos;
    float *out;
    const vsd_krecord_grid *g2;   /* the second transmittances' grid, or NULL */
    float *out2;
} bake_job;

/* records in blocks of 256 as the items of the CPU pool: the per-record phase weights
 * (sub-lights: hundreds of phase evaluations a record) are the view's largest per-view cost */
static void bake_items(void *arg, int b0, int y0, int b1, int y1)
{
    const bake_job *j = arg;
    int32_t r0 = b0 * 256, r1 = b1 * 256 < j->g->record_count ? b1 * 256 : j->g->record_count;
    (void)y0;
    (void)y1;
    bake_range(j->g, j->record_pos, &j->g->kd->camera, r0, r1, j->out, j->g2, j->out2);
}

vsd_status vsd_record_grid_bake(const vsd_krecord_grid *g, float **out, char *err, size_t errlen)
{
    float *baked;
    *out = NULL;
    baked = malloc(sizeof(float) * 3 * (size_t)(g->record_count > 0 ? g->record_count : 1));
    if (!baked) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d baked records", (int)g->record_count);
    /* g = 0: the weights are the same for every direction */
    bake_range(g, NULL, NULL, 0, g->record_count, baked, NULL, NULL);
    *out = baked;
    return VSD_OK;
}

void vsd_record_grid_use_baked(vsd_krecord_grid *g, const float *baked)
{
    g->kind = VSD_RECORDS_BAKED;
    g->records_log = g->interp == VSD_RECORDS_LOG_TRILINEAR;
    g->records = baked;
    g->stride = 3;
    g->lights = NULL;
    g->light_trans = NULL;
    g->light_count = 0;
    g->sub_count = 0;
    g->local_count = 0;
}

void vsd_record_grid_bake_view(const vsd_krecord_grid *g, const float *record_pos, int threads, float *out)
{
    vsd_record_grid_bake_view_pair(g, record_pos, threads, out, NULL, NULL, NULL);
}

/* g's lights with other transmittances and no other term, baked linear */
static vsd_krecord_grid lights_only(const vsd_krecord_grid *g, const float *light_trans, const float *local_trans)
{
    vsd_krecord_grid l = *g;
    l.light_trans = light_trans;
    l.local_trans = local_trans;
    l.records_ms = NULL;
    l.records_emission_once = NULL;
    l.interp = VSD_RECORDS_TRILINEAR;
    return l;
}

void vsd_record_grid_bake_view_lights(const vsd_krecord_grid *g, const float *record_pos, int threads,
                                      const float *light_trans, const float *local_trans, float *out)
{
    vsd_krecord_grid l = lights_only(g, light_trans, local_trans);
    vsd_record_grid_bake_view(&l, record_pos, threads, out);
}

void vsd_record_grid_bake_view_pair(const vsd_krecord_grid *g, const float *record_pos, int threads, float *out,
                                    const float *light_trans2, const float *local_trans2, float *out2)
{
    vsd_krecord_grid g2 = lights_only(g, light_trans2, local_trans2);
    bake_job job = {g, record_pos, out, out2 ? &g2 : NULL, out2};
    if (vsd_cpu_run_items((g->record_count + 255) / 256, threads, bake_items, &job, "record bake") != VSD_OK)
        /* (the pool cannot fail without cancel) */
        bake_range(g, record_pos, &g->kd->camera, 0, g->record_count, out, job.g2, out2);
}

vsd_status vsd_record_grid_render(vsd_frame_ctx *ctx, vsd_framebuffer *fb, const vsd_krecord_grid *g, int n,
                                  double step, double stop, const vsd_view_sampling *vs, int *samples, char *err,
                                  size_t errlen)
{
    ctx->kd.march_step = step > 0 ? (float)step : 2.0f * vsd_method_march_step(ctx, 0.0);
    ctx->kd.march_stop = (float)stop;
    return vsd_method_render_view(ctx, fb, n, vs, &vsd_record_grid_view_pass, vsd_record_grid_view_struct, g, samples,
                                  err, errlen);
}

vsd_status vsd_record_grid_render_baked(vsd_frame_ctx *ctx, vsd_framebuffer *fb, const vsd_krecord_grid *g,
                                        const float *record_pos, int n, double step, double stop,
                                        const vsd_view_sampling *vs, int *samples, char *err, size_t errlen)
{
    vsd_krecord_grid b = *g;
    float *baked = malloc(3 * sizeof *baked * (size_t)(g->record_count > 0 ? g->record_count : 1));
    vsd_status st;
    if (!baked) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d view records", (int)g->record_count);
    vsd_record_grid_bake_view(g, record_pos, ctx->threads, baked);
    vsd_record_grid_use_baked(&b, baked);
    st = vsd_record_grid_render(ctx, fb, &b, n, step, stop, vs, samples, err, errlen);
    free(baked);
    return st;
}

vsd_status vsd_record_grids_render(vsd_frame_ctx *ctx, vsd_framebuffer *fb, const vsd_krecord_grid *grids, int count,
                                   int n, double step, double stop, const vsd_view_sampling *vs, int *samples, char *err,
                                   size_t errlen)
{
    vsd_krecord_grids gs;
    if (count != ctx->kd.volume_count)
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "internal: %d record grids for %d volumes", count,
                        ctx->kd.volume_count);
    memset(&gs, 0, sizeof gs);
    gs.kd = &ctx->kd;
    gs.grid = grids;
    gs.count = count;
    ctx->kd.march_step = step > 0 ? (float)step : 2.0f * vsd_method_march_step(ctx, 0.0);
    ctx->kd.march_stop = (float)stop;
    return vsd_method_render_view(ctx, fb, n, vs, &vsd_record_grids_view_pass, vsd_record_grids_view_struct, &gs,
                                  samples, err, errlen);
}
