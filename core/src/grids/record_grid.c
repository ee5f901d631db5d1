/* The record grid (record_grid.h), moved here from shgrid.c so constellation's cached
 * shadows use the same cells. */
#include "record_grid.h"
#include "kvolume_boxes.h"
#include "vsd/volume.h"
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
