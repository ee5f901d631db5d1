/* record_grid_bake.c — the lights' term of a record grid baked per record (record_grid.h:
 * vsd_record_grid_bake, vsd_record_grid_bake_view and its pair): each record's phase
 * weights over the lights and their sub-lights, then its radiance, once per view instead
 * of at every corner a view ray reads. */
#include "record_grid.h"
#include "record_phase.h"
#include "device/cpu/cpu_tiles.h"
#include "kernel/kernel_record_grid.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

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

/* The camera's eye and unit axes in world space (it looks down its -Z). */
static void camera_frame(const vsd_kcamera *cam, vsd_f3 *eye, vsd_f3 *right, vsd_f3 *up, vsd_f3 *forward)
{
    const float *m = cam->cam_to_world.m;
    *eye = f3(m[3], m[7], m[11]);
    *right = f3_normalize(f3(m[0], m[4], m[8]));
    *up = f3_normalize(f3(m[1], m[5], m[9]));
    *forward = f3_scale(f3_normalize(f3(m[2], m[6], m[10])), -1.0f);
}

/* The lights' phase weights of one direction d: with sub-lights their sums per light
 * (subs, allocated by the caller), else the lights' own. */
static void weights_toward(const vsd_krecord_grid *g, sub_light_dirs *subs, int use_subs, vsd_f3 d, float *ph)
{
    if (use_subs) sub_light_weights(g, subs, d, g->kd->medium.anisotropy, ph);
    else vsd_records_light_weights(g->lights, g->light_count, g->sub_count, d, g->kd->medium.anisotropy, ph);
}

/* A perspective view's phase weights tabulated over the camera's tangent plane (points
 * at a + b up + fwd, a and b on a square lattice over the film's extent and a margin), once
 * per view, and mixed bilinearly per record: a record's weights depend only on its
 * direction from the eye, which over a volume's records spans the view's few tens of
 * degrees, while the weights cost hundreds of phase evaluations per record with
 * sub-lights (the bake was 12% of lbl's camera change). Records outside the table
 * (behind the eye, beyond the margin) take their own weights. The lattice's step, 1/64 of
 * the film's larger side, is about 0.6 degrees at a 40-degree field of view; tests/
 * test_lighting.c bounds the difference from each record's own weights. */
enum { PHASE_TABLE_SIDE = 64 };
#define PHASE_TABLE_MARGIN 1.15f
typedef struct phase_table {
    vsd_f3 right, up, fwd;
    float a0, b0, step;   /* node (i, j) at a = a0 + i step, b = b0 + j step */
    int na, nb, lights;
    float *w;             /* [nb][na][3][lights]: ph's three rows, lights long */
    const vsd_krecord_grid *g;
    int use_subs;
    int failed;
} phase_table;

static void phase_table_rows(void *user, int j0, int unused0, int j1, int unused1)
{
    phase_table *t = user;
    sub_light_dirs subs = {0};
    float ph[VSD_RECORDS_PH_FLOATS];
    int i, j, c;
    (void)unused0, (void)unused1;
    if (t->use_subs && sub_light_dirs_make(t->g, &subs) != 0) {
        t->failed = 1;
        return;
    }
    for (j = j0; j < j1; j++)
        for (i = 0; i < t->na; i++) {
            const float a = t->a0 + (float)i * t->step, b = t->b0 + (float)j * t->step;
            float *w = t->w + ((size_t)j * t->na + i) * 3 * t->lights;
            weights_toward(t->g, &subs, t->use_subs,
                           f3_normalize(f3_add(t->fwd, f3_add(f3_scale(t->right, a), f3_scale(t->up, b)))), ph);
            for (c = 0; c < 3; c++) memcpy(w + c * t->lights, ph + c * VSD_RECORDS_MAX_LIGHTS, t->lights * sizeof *w);
        }
    free(subs.x);
}

/* 1 with t made for g's camera (perspective) when its records outnumber the table's nodes
 * enough to pay for it; 0: every record takes its own weights. */
static int phase_table_make(const vsd_krecord_grid *g, int use_subs, int threads, phase_table *t)
{
    const vsd_kcamera *cam = &g->kd->camera;
    const int maxdim = cam->width > cam->height ? cam->width : cam->height;
    float ha, hb;
    vsd_f3 eye;
    memset(t, 0, sizeof *t);
    if (cam->orthographic || !(cam->tan_half_fov > 0.0f) || maxdim <= 0 || g->light_count <= 0) return 0;
    ha = PHASE_TABLE_MARGIN * cam->tan_half_fov * (float)cam->width / (float)maxdim;
    hb = PHASE_TABLE_MARGIN * cam->tan_half_fov * (float)cam->height / (float)maxdim;
    t->step = 2.0f * PHASE_TABLE_MARGIN * cam->tan_half_fov / PHASE_TABLE_SIDE;
    t->na = (int)ceilf(2.0f * ha / t->step) + 1;
    t->nb = (int)ceilf(2.0f * hb / t->step) + 1;
    if ((size_t)g->record_count < 8 * (size_t)t->na * t->nb) return 0;
    t->a0 = -ha, t->b0 = -hb;
    camera_frame(cam, &eye, &t->right, &t->up, &t->fwd);
    t->lights = g->light_count;
    t->g = g;
    t->use_subs = use_subs;
    if (!(t->w = malloc(sizeof *t->w * 3 * (size_t)t->lights * t->na * t->nb))) return 0;
    if (vsd_cpu_run_items(t->nb, threads, phase_table_rows, t, "record bake") != VSD_OK || t->failed) {
        free(t->w);
        t->w = NULL;
        return 0;
    }
    return 1;
}

/* ph = the table's weights at d mixed from its four nearest nodes; 0 where d falls outside. */
static int phase_table_read(const phase_table *t, vsd_f3 d, float *ph)
{
    const float z = f3_dot(d, t->fwd);
    float fa, fb, u, v;
    const float *w00, *w10, *w01, *w11;
    int i, j, c, k;
    if (!(z > 1e-3f)) return 0;
    fa = (f3_dot(d, t->right) / z - t->a0) / t->step;
    fb = (f3_dot(d, t->up) / z - t->b0) / t->step;
    if (!(fa >= 0.0f && fb >= 0.0f && fa <= (float)(t->na - 1) && fb <= (float)(t->nb - 1))) return 0;
    i = (int)fa < t->na - 1 ? (int)fa : t->na - 2;
    j = (int)fb < t->nb - 1 ? (int)fb : t->nb - 2;
    u = fa - (float)i, v = fb - (float)j;
    w00 = t->w + ((size_t)j * t->na + i) * 3 * t->lights;
    w10 = w00 + 3 * t->lights;
    w01 = w00 + (size_t)t->na * 3 * t->lights;
    w11 = w01 + 3 * t->lights;
    for (c = 0; c < 3; c++) {
        float *restrict out = ph + c * VSD_RECORDS_MAX_LIGHTS;
        const int o = c * t->lights;
        for (k = 0; k < t->lights; k++)
            out[k] = (1.0f - v) * ((1.0f - u) * w00[o + k] + u * w10[o + k]) + v * ((1.0f - u) * w01[o + k] + u * w11[o + k]);
    }
    ph[VSD_RECORDS_PH_DIR] = d.x;
    ph[VSD_RECORDS_PH_DIR + 1] = d.y;
    ph[VSD_RECORDS_PH_DIR + 2] = d.z;
    ph[VSD_RECORDS_PH_DIR + 3] = t->g->kd->medium.anisotropy;
    return 1;
}

/* Records [r0, r1)'s radiance into out (3 floats each): with the phase at a fixed
 * direction (cam NULL: g = 0, any direction does), or at the direction from the camera to
 * the record. */
static void bake_range(const vsd_krecord_grid *g, const float *record_pos, const vsd_kcamera *cam,
                       const phase_table *table, int32_t r0, int32_t r1, float *out, const vsd_krecord_grid *g2,
                       float *out2)
{
    float ph[VSD_RECORDS_PH_FLOATS], w[VSD_SH_MAX_COEFFS];
    const int sh_rgb = g->kind == VSD_RECORDS_SH_RGB;
    vsd_f3 eye = f3s(0.0f), forward = f3(0.0f, 0.0f, 1.0f);
    sub_light_dirs subs = {0};
    /* (without memory for them, the scalar loop of vsd_records_light_weights) */
    int per_record_subs = cam && !cam->orthographic && sub_light_dirs_make(g, &subs) == 0 && subs.n > 0;
    int32_t r;
    if (cam) {
        vsd_f3 right, up;
        camera_frame(cam, &eye, &right, &up, &forward);
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
            if (!(table && phase_table_read(table, d, ph))) weights_toward(g, &subs, per_record_subs, d, ph);
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
    const phase_table *table;     /* the view's weights over its directions, or NULL */
} bake_job;

/* records in blocks of 256 as the items of the CPU pool: the per-record phase weights
 * (sub-lights: hundreds of phase evaluations a record) are the view's largest per-view cost */
static void bake_items(void *arg, int b0, int y0, int b1, int y1)
{
    const bake_job *j = arg;
    int32_t r0 = b0 * 256, r1 = b1 * 256 < j->g->record_count ? b1 * 256 : j->g->record_count;
    (void)y0;
    (void)y1;
    bake_range(j->g, j->record_pos, &j->g->kd->camera, j->table, r0, r1, j->out, j->g2, j->out2);
}

vsd_status vsd_record_grid_bake(const vsd_krecord_grid *g, float **out, char *err, size_t errlen)
{
    float *baked;
    *out = NULL;
    baked = malloc(sizeof(float) * 3 * (size_t)(g->record_count > 0 ? g->record_count : 1));
    if (!baked) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d baked records", (int)g->record_count);
    /* g = 0: the weights are the same for every direction */
    bake_range(g, NULL, NULL, NULL, 0, g->record_count, baked, NULL, NULL);
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
    bake_job job = {g, record_pos, out, out2 ? &g2 : NULL, out2, NULL};
    phase_table table;
    /* the table takes the weights the records would: their sub-lights' sums where they have
     * some (a row without memory for them fails the table, and the records take their own) */
    if (phase_table_make(g, g->sub_count > 0, threads, &table)) job.table = &table;
    if (vsd_cpu_run_items((g->record_count + 255) / 256, threads, bake_items, &job, "record bake") != VSD_OK)
        /* (the pool cannot fail without cancel) */
        bake_range(g, record_pos, &g->kd->camera, job.table, 0, g->record_count, out, job.g2, out2);
    free(table.w);
}

