/* The record grid on the CUDA device (record_grid_device.h). */
#include "record_grid_device.h"
#include "device_frame.h"
#include <stddef.h>

/* The grid's resident slots. */
VSD_DEVICE_SLOT(rg_cells, "record grid cells");
VSD_DEVICE_SLOT(rg_records, "record grid records");
VSD_DEVICE_SLOT(rg_pos, "record grid positions");
VSD_DEVICE_SLOT(rg_dirs, "record grid directions");
VSD_DEVICE_SLOT(rg_basis, "record grid basis");
VSD_DEVICE_SLOT(rg_radiance, "record grid direction radiance");
VSD_DEVICE_SLOT(rg_light, "record grid light SH");
VSD_DEVICE_SLOT(rg_lights, "record grid lights");
VSD_DEVICE_SLOT(rg_light_trans, "record grid light transmittances");
VSD_DEVICE_SLOT(rg_records_ms, "record grid multiple scattering");
VSD_DEVICE_SLOT(rg_records_emission_once, "record grid emission scattered once");
VSD_DEVICE_SLOT(rg_local_lights, "record grid local lights");
VSD_DEVICE_SLOT(rg_local_trans, "record grid local light transmittances");

/* One array of the grid on the device (NULL stays NULL). At render time the arrays are
 * final for the lighting generation and stay resident; during the prepare stages shgrid.c
 * still rewrites some in place (the HEALPix radiance, the environment SH, the extracted
 * lights) between record passes of one generation, so record passes always copy. */
static vsd_status put(const vsd_frame_ctx *ctx, int record_pass, vsd_cuda_slot slot, const void *host, size_t bytes,
                      const void **dev, char *err, size_t errlen)
{
    if (!record_pass) return vsd_device_array(ctx, slot, ctx->lighting_gen, host, bytes, dev, err, errlen);
    return vsd_device_copy(ctx, slot, host, bytes, dev, err, errlen);
}

vsd_status vsd_record_grid_output(const vsd_frame_ctx *ctx, int lights, size_t bytes, void **dev, char *err,
                                  size_t errlen)
{
    return vsd_device_scratch(ctx, lights ? rg_light_trans : rg_records, bytes, 0, dev, err, errlen);
}

vsd_status vsd_record_grid_device(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int with_records, vsd_krecord_grid *d,
                              char *err, size_t errlen)
{
    size_t cells = (size_t)g->res[0] * g->res[1] * g->res[2], recs = (size_t)g->record_count;
    size_t dirs = (size_t)g->dir_count, n2 = (size_t)g->n2, lights = (size_t)g->light_count;
    const void *p;
    vsd_status st;
    *d = *g;
#define PUT(field, slot, bytes) \
    do { if ((st = put(ctx, !with_records, slot, g->field, bytes, &p, err, errlen))) return st; d->field = p; } while (0)
    PUT(cell_record, rg_cells, cells * sizeof(int32_t));
    PUT(light, rg_light, 3 * n2 * sizeof(float));
    PUT(lights, rg_lights, (lights + (size_t)g->sub_count) * 8 * sizeof(float));
    if (with_records) {
        /* the view pass reads the records, not what made them */
        PUT(records, rg_records, recs * (size_t)g->stride * sizeof(float));
        PUT(light_trans, rg_light_trans, recs * lights * sizeof(float));
        if (g->records_ms_per_view) {
            /* a new view brings new values in the same host array: copied every time */
            if ((st = vsd_device_copy(ctx, rg_records_ms, g->records_ms, recs * 3 * sizeof(float), &p, err,
                                      errlen)))
                return st;
            d->records_ms = p;
        } else {
            PUT(records_ms, rg_records_ms, g->records_ms ? recs * 3 * sizeof(float) : 0);
        }
        PUT(records_emission_once, rg_records_emission_once, g->records_emission_once ? recs * 3 * sizeof(float) : 0);
        d->record_pos = d->dirs = d->basis = d->dir_radiance = NULL;
        if (g->local_count > 0) {
            /* the local lights' phase is toward the light from each record's position */
            PUT(local_lights, rg_local_lights, (size_t)g->local_count * VSD_KLIGHT_FLOATS * sizeof(float));
            PUT(local_trans, rg_local_trans, recs * (size_t)g->local_count * sizeof(float));
            PUT(record_pos, rg_pos, recs * 4 * sizeof(float));
        }
    } else {
        PUT(record_pos, rg_pos, recs * 4 * sizeof(float));
        PUT(dirs, rg_dirs, dirs * 4 * sizeof(float));
        PUT(basis, rg_basis, dirs * n2 * sizeof(float));
        PUT(dir_radiance, rg_radiance, dirs * 4 * sizeof(float));
        d->records = NULL;
        d->light_trans = NULL;
        d->records_ms = NULL;
        d->records_emission_once = NULL;
        d->local_lights = d->local_trans = NULL;
    }
#undef PUT
    return VSD_OK;
}

void vsd_record_grid_arrays(const vsd_krecord_grid *g, int view, int lights, vsd_pass_array_visit visit, void *user)
{
    size_t rc = (size_t)g->record_count, dc = (size_t)g->dir_count, n2 = (size_t)g->n2, lc = (size_t)g->light_count;
    if (view) {
        visit(user, g->cell_record, (size_t)g->res[0] * g->res[1] * g->res[2] * sizeof(int32_t), "records.cell_record");
        visit(user, g->records, rc * (size_t)g->stride * sizeof(float), "records.records");
        visit(user, g->light_trans, rc * lc * sizeof(float), "records.light_trans");
        if (g->records_ms) visit(user, g->records_ms, rc * 3 * sizeof(float), "records.records_ms");
        if (g->records_emission_once) visit(user, g->records_emission_once, rc * 3 * sizeof(float), "records.records_emission_once");
        if (g->kind == VSD_RECORDS_SH_SCALAR) visit(user, g->light, 3 * n2 * sizeof(float), "records.light");
        if (g->local_count > 0) {
            size_t lo = (size_t)g->local_count;
            visit(user, g->local_lights, lo * VSD_KLIGHT_FLOATS * sizeof(float), "records.local_lights");
            visit(user, g->local_trans, rc * lo * sizeof(float), "records.local_trans");
            visit(user, g->record_pos, rc * 4 * sizeof(float), "records.record_pos");
        }
    } else {
        visit(user, g->record_pos, rc * 4 * sizeof(float), "records.record_pos");
        if (!lights) {
            visit(user, g->dirs, dc * 4 * sizeof(float), "records.dirs");
            visit(user, g->basis, dc * n2 * sizeof(float), "records.basis");
            if (g->kind == VSD_RECORDS_SH_RGB) visit(user, g->dir_radiance, dc * 4 * sizeof(float), "records.dir_radiance");
        }
    }
    if (view || lights) visit(user, g->lights, (lc + (size_t)g->sub_count) * 8 * sizeof(float), "records.lights");
}

static vsd_sample_result view_sample(const void *g, int x, int y, int s, int n)
{
    return vsd_records_pass_sample((const vsd_krecord_grid *)g, x, y, s, n);
}

static void view_arrays(const void *g, vsd_pass_args a, vsd_pass_array_visit visit, void *user)
{
    (void)a;
    vsd_record_grid_arrays(g, 1, 0, visit, user);
}

VSD_CUDA_ENTRY_DECL(vsd_cuda_record_grid_view);
const vsd_device_pass vsd_record_grid_view_pass = {
    "ray marching", 1, 256, sizeof(vsd_krecord_grid), offsetof(vsd_krecord_grid, kd), view_sample, NULL, view_arrays,
    VSD_CUDA_ENTRY(vsd_cuda_record_grid_view),
};

vsd_status vsd_record_grid_view_struct(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err, size_t errlen)
{
    return vsd_record_grid_device(ctx, host, 1, dev, err, errlen);
}
