/* The light other groups of volumes send a lattice, seen at its faces (lbl_exchange.h). */
#include "lbl_exchange.h"
#include "device/cpu/cpu_tiles.h"
#include "src/common/fibonacci_sphere.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct exchange_job {
    const vsd_krecord_grids *gs;
    uint32_t sources;
    const vsd_lbl_exchange_grid *g;
    vsd_lbl_exchange_light all[VSD_LBL_EXCHANGE_DIRS];
    int first[7];             /* the first item (face block) of each face */
    int nb[6][2];
} exchange_job;

/* the face's two in-plane axes */
static void face_axes(int a, int *u, int *v)
{
    *u = (a + 1) % 3;
    *v = (a + 2) % 3;
}

/* the centre of block b of 2 cells along an axis of n cells */
static double block_centre(int b, int n)
{
    int hi = 2 * b + 2 < n ? 2 * b + 2 : n;
    return 0.5 * (2 * b + hi);
}

static void gather_items(void *arg, int i0, int y0, int i1, int y1)
{
    exchange_job *j = arg;
    const vsd_lbl_exchange_grid *g = j->g;
    int item;
    (void)y0;
    (void)y1;
    for (item = i0; item < i1; item++) {
        int face = 0, a, u, v, k;
        size_t b;
        double gp[3];
        vsd_f3 o;
        while (item >= j->first[face + 1]) face++;
        a = face / 2;
        face_axes(a, &u, &v);
        b = (size_t)(item - j->first[face]);
        gp[a] = (face & 1) ? g->res[a] : 0.0;
        gp[u] = block_centre((int)(b % (size_t)j->nb[face][0]), g->res[u]);
        gp[v] = block_centre((int)(b / (size_t)j->nb[face][0]), g->res[v]);
        o = vsd_affine_point(&g->grid_to_world, f3((float)gp[0], (float)gp[1], (float)gp[2]));
        for (k = 0; k < VSD_LBL_EXCHANGE_DIRS; k++) {
            vsd_lbl_exchange_light *l = &j->all[k];
            vsd_march_acc acc;
            vsd_volumes_walk walk;
            vsd_f3 s;
            if (l->face != face) continue;
            vsd_march_begin(&acc);
            if (!vsd_volumes_walk_begin(&walk, j->gs->kd, o, l->w)) continue;
            vsd_records_march_volumes(j->gs, &acc, &walk, o, l->w, j->sources);
            s = f3_add(acc.res.direct, acc.res.indirect);
            l->ls[3 * b] = s.x, l->ls[3 * b + 1] = s.y, l->ls[3 * b + 2] = s.z;
            l->le[3 * b] = acc.res.emit.x, l->le[3 * b + 1] = acc.res.emit.y, l->le[3 * b + 2] = acc.res.emit.z;
        }
    }
}

void vsd_lbl_exchange_free(vsd_lbl_exchange *x)
{
    int k;
    for (k = 0; k < x->count; k++) free(x->light[k].ls);   /* le shares ls's block */
    x->count = 0;
    x->emits = 0;
}

/* whether any of the n floats is above 0 */
static int any_light(const float *v, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++)
        if (v[i] > 0.0f) return 1;
    return 0;
}

vsd_status vsd_lbl_exchange_gather(const vsd_krecord_grids *senders, uint32_t sources, const vsd_lbl_exchange_grid *g,
                                   float step, int threads, vsd_lbl_exchange *x, char *err, size_t errlen)
{
    vsd_kernel_data kd = *senders->kd;
    vsd_krecord_grids gs = *senders;
    exchange_job j;
    int face, k, items;
    vsd_lbl_exchange_free(x);
    x->grid = *g;
    x->domega = (float)(4.0 * 3.14159265358979323846 / VSD_LBL_EXCHANGE_DIRS);
    if (!sources || (size_t)g->res[0] * g->res[1] * g->res[2] == 0) return VSD_OK;
    memset(&j, 0, sizeof j);
    kd.march_step = step > 0.0f ? step : kd.march_step;
    gs.kd = &kd;
    j.gs = &gs;
    j.sources = sources;
    j.g = g;
    for (face = 0, items = 0; face < 6; face++) {
        int u, v;
        face_axes(face / 2, &u, &v);
        j.nb[face][0] = (g->res[u] + 1) / 2;
        j.nb[face][1] = (g->res[v] + 1) / 2;
        j.first[face] = items;
        items += j.nb[face][0] * j.nb[face][1];
    }
    j.first[6] = items;
    for (k = 0; k < VSD_LBL_EXCHANGE_DIRS; k++) {
        vsd_lbl_exchange_light *l = &j.all[k];
        double p[3];
        vsd_f3 q;
        float c[3], s[3];
        int a;
        size_t blocks;
        vsd_fibonacci_point(k, VSD_LBL_EXCHANGE_DIRS, p);
        l->w = f3((float)p[0], (float)p[1], (float)p[2]);
        q = vsd_affine_vector(&g->world_to_grid, l->w);
        c[0] = fabsf(q.x), c[1] = fabsf(q.y), c[2] = fabsf(q.z);
        s[0] = q.x, s[1] = q.y, s[2] = q.z;
        a = c[0] >= c[1] && c[0] >= c[2] ? 0 : c[1] >= c[2] ? 1 : 2;
        l->face = 2 * a + (s[a] > 0.0f);
        l->nb[0] = j.nb[l->face][0];
        l->nb[1] = j.nb[l->face][1];
        blocks = 3 * (size_t)l->nb[0] * l->nb[1];
        if (!(l->ls = calloc(2 * blocks, sizeof *l->ls))) {
            for (; k >= 0; k--) free(j.all[k].ls);
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the light between groups");
        }
        l->le = l->ls + blocks;
    }
    /* (the pool fails only when cancelled, which this stage is not) */
    if (vsd_cpu_run_items(items, threads, gather_items, &j, "light between groups") != VSD_OK)
        gather_items(&j, 0, 0, items, 1);
    for (k = 0; k < VSD_LBL_EXCHANGE_DIRS; k++) {
        vsd_lbl_exchange_light *l = &j.all[k];
        size_t n = 3 * (size_t)l->nb[0] * l->nb[1];
        int ls = any_light(l->ls, n), le = any_light(l->le, n);
        if (!ls && !le) {
            free(l->ls);
            continue;
        }
        x->emits |= le;
        x->light[x->count++] = *l;
    }
    return VSD_OK;
}

/* block b0, b1 and the weight of b1 at face coordinate t (cell units) of an axis with nb blocks */
static void block_lerp(double t, int nb, int *b0, int *b1, double *f)
{
    double s = 0.5 * (t - 1.0);   /* block centres at 2b + 1 */
    int b = (int)floor(s);
    *f = s - b;
    if (b < 0) b = 0, *f = 0.0;
    if (b >= nb - 1) b = nb - 1, *f = 0.0;
    *b0 = b;
    *b1 = b + 1 < nb ? b + 1 : b;
}

void vsd_lbl_exchange_radiance(const vsd_lbl_exchange *x, int k, vsd_f3 q, vsd_f3 *ls, vsd_f3 *le)
{
    const vsd_lbl_exchange_light *l = &x->light[k];
    const vsd_lbl_exchange_grid *g = &x->grid;
    const vsd_f3 w = vsd_affine_vector(&g->world_to_grid, l->w);
    const double p[3] = {q.x, q.y, q.z}, d[3] = {w.x, w.y, w.z};
    const int a = l->face / 2;
    const double plane = (l->face & 1) ? g->res[a] : 0.0, t = d[a] != 0.0 ? (plane - p[a]) / d[a] : 0.0;
    int u, v, u0, u1, v0, v1, ch;
    double fu, fv, out[2][3];
    face_axes(a, &u, &v);
    block_lerp(p[u] + t * d[u], l->nb[0], &u0, &u1, &fu);
    block_lerp(p[v] + t * d[v], l->nb[1], &v0, &v1, &fv);
    for (ch = 0; ch < 3; ch++) {
        const float *src[2] = {l->ls, l->le};
        int s;
        for (s = 0; s < 2; s++) {
#define B(bu, bv) ((double)src[s][3 * ((size_t)(bv) * l->nb[0] + (bu)) + ch])
            out[s][ch] = (1.0 - fv) * ((1.0 - fu) * B(u0, v0) + fu * B(u1, v0)) + fv * ((1.0 - fu) * B(u0, v1) + fu * B(u1, v1));
#undef B
        }
    }
    *ls = f3((float)out[0][0], (float)out[0][1], (float)out[0][2]);
    *le = f3((float)out[1][0], (float)out[1][1], (float)out[1][2]);
}
