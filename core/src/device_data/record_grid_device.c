/* The record grid on the CUDA device (record_grid_device.h). */
#include "record_grid_device.h"
#include "device_frame.h"
#include "kernel/kernel_record_grids.h"
#include <stddef.h>
#include <string.h>

/* A grid's resident slots; a view over several volumes keeps grid i in set i. */
enum { RG_CELLS, RG_RECORDS, RG_POS, RG_DIRS, RG_BASIS, RG_RADIANCE, RG_LIGHT, RG_LIGHTS, RG_LIGHT_TRANS, RG_RECORDS_MS,
       RG_EMISSION_ONCE, RG_LOCAL_LIGHTS, RG_LOCAL_TRANS, RG_SLOTS };
#define GRID_SLOTS(g)                                                                                        \
    {{g " cells", VSD_CUDA_METHOD_SLOT},                       {g " records", VSD_CUDA_METHOD_SLOT},         \
     {g " positions", VSD_CUDA_METHOD_SLOT},                   {g " directions", VSD_CUDA_METHOD_SLOT},      \
     {g " basis", VSD_CUDA_METHOD_SLOT},                       {g " direction radiance", VSD_CUDA_METHOD_SLOT}, \
     {g " light SH", VSD_CUDA_METHOD_SLOT},                    {g " lights", VSD_CUDA_METHOD_SLOT},          \
     {g " light transmittances", VSD_CUDA_METHOD_SLOT},        {g " multiple scattering", VSD_CUDA_METHOD_SLOT}, \
     {g " emission scattered once", VSD_CUDA_METHOD_SLOT},     {g " local lights", VSD_CUDA_METHOD_SLOT},    \
     {g " local light transmittances", VSD_CUDA_METHOD_SLOT}}
static const vsd_cuda_slot_desc grid_slots[VSD_KMAX_VOLUMES][RG_SLOTS] = {
    GRID_SLOTS("record grid"),      GRID_SLOTS("record grid[1]"),  GRID_SLOTS("record grid[2]"),
    GRID_SLOTS("record grid[3]"),   GRID_SLOTS("record grid[4]"),  GRID_SLOTS("record grid[5]"),
    GRID_SLOTS("record grid[6]"),   GRID_SLOTS("record grid[7]"),  GRID_SLOTS("record grid[8]"),
    GRID_SLOTS("record grid[9]"),   GRID_SLOTS("record grid[10]"), GRID_SLOTS("record grid[11]"),
    GRID_SLOTS("record grid[12]"),  GRID_SLOTS("record grid[13]"), GRID_SLOTS("record grid[14]"),
    GRID_SLOTS("record grid[15]")};
#undef GRID_SLOTS
/* the grids of a view over several volumes, with device pointers */
VSD_DEVICE_SLOT(rg_table, "record grid table (several volumes)");

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
    return vsd_device_scratch(ctx, &grid_slots[0][lights ? RG_LIGHT_TRANS : RG_RECORDS], bytes, 0, dev, err, errlen);
}

/* vsd_record_grid_device in slot set `set` */
static vsd_status grid_device(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int with_records, int set,
                              vsd_krecord_grid *d, char *err, size_t errlen)
{
    const vsd_cuda_slot_desc *sl = grid_slots[set];
    size_t cells = (size_t)g->res[0] * g->res[1] * g->res[2], recs = (size_t)g->record_count;
    size_t dirs = (size_t)g->dir_count, n2 = (size_t)g->n2, lights = (size_t)g->light_count;
    const void *p;
    vsd_status st;
    *d = *g;
#define PUT(field, slot, bytes) \
    do { if ((st = put(ctx, !with_records, slot, g->field, bytes, &p, err, errlen))) return st; d->field = p; } while (0)
    PUT(cell_record, &sl[RG_CELLS], cells * sizeof(int32_t));
    PUT(light, &sl[RG_LIGHT], 3 * n2 * sizeof(float));
    PUT(lights, &sl[RG_LIGHTS], (lights + (size_t)g->sub_count) * 8 * sizeof(float));
    if (with_records) {
        /* the view pass reads the records, not what made them */
        PUT(records, &sl[RG_RECORDS], recs * (size_t)g->stride * sizeof(float));
        PUT(light_trans, &sl[RG_LIGHT_TRANS], recs * lights * sizeof(float));
        if (g->records_ms_per_view) {
            /* a new view brings new values in the same host array: copied every time */
            if ((st = vsd_device_copy(ctx, &sl[RG_RECORDS_MS], g->records_ms, recs * 3 * sizeof(float), &p, err,
                                      errlen)))
                return st;
            d->records_ms = p;
        } else {
            PUT(records_ms, &sl[RG_RECORDS_MS], g->records_ms ? recs * 3 * sizeof(float) : 0);
        }
        PUT(records_emission_once, &sl[RG_EMISSION_ONCE], g->records_emission_once ? recs * 3 * sizeof(float) : 0);
        d->record_pos = d->dirs = d->basis = d->dir_radiance = NULL;
        if (g->local_count > 0) {
            /* the local lights' phase is toward the light from each record's position */
            PUT(local_lights, &sl[RG_LOCAL_LIGHTS], (size_t)g->local_count * VSD_KLIGHT_FLOATS * sizeof(float));
            PUT(local_trans, &sl[RG_LOCAL_TRANS], recs * (size_t)g->local_count * sizeof(float));
            PUT(record_pos, &sl[RG_POS], recs * 4 * sizeof(float));
        }
    } else {
        PUT(record_pos, &sl[RG_POS], recs * 4 * sizeof(float));
        PUT(dirs, &sl[RG_DIRS], dirs * 4 * sizeof(float));
        PUT(basis, &sl[RG_BASIS], dirs * n2 * sizeof(float));
        PUT(dir_radiance, &sl[RG_RADIANCE], dirs * 4 * sizeof(float));
        d->records = NULL;
        d->light_trans = NULL;
        d->records_ms = NULL;
        d->records_emission_once = NULL;
        d->local_lights = d->local_trans = NULL;
    }
#undef PUT
    return VSD_OK;
}

vsd_status vsd_record_grid_device(const vsd_frame_ctx *ctx, const vsd_krecord_grid *g, int with_records,
                                  vsd_krecord_grid *d, char *err, size_t errlen)
{
    return grid_device(ctx, g, with_records, 0, d, err, errlen);
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

VSD_CPU_VIEW_SAMPLE
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

VSD_CPU_VIEW_SAMPLE
static vsd_sample_result volumes_sample(const void *m, int x, int y, int s, int n)
{
    return vsd_records_volumes_sample((const vsd_krecord_grids *)m, x, y, s, n);
}

/* The grids' table; each grid's arrays are reached through it on the device, where the
 * host cannot read them (they go in the grids' own slots, as one grid's do). */
static void volumes_arrays(const void *m, vsd_pass_args a, vsd_pass_array_visit visit, void *user)
{
    const vsd_krecord_grids *gs = m;
    (void)a;
    visit(user, gs->grid, (size_t)gs->count * sizeof *gs->grid, "records.grid (several volumes)");
}

VSD_CUDA_ENTRY_DECL(vsd_cuda_record_grids_view);
const vsd_device_pass vsd_record_grids_view_pass = {
    "ray marching (several volumes)", 1, 256, sizeof(vsd_krecord_grids), offsetof(vsd_krecord_grids, kd),
    volumes_sample, NULL, volumes_arrays, VSD_CUDA_ENTRY(vsd_cuda_record_grids_view),
};

vsd_status vsd_record_grids_view_struct(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err, size_t errlen)
{
    const vsd_krecord_grids *h = host;
    vsd_krecord_grids *d = dev;
    vsd_krecord_grid table[VSD_KMAX_VOLUMES];
    const void *p;
    vsd_status st;
    int i;
    if (h->count < 1 || h->count > VSD_KMAX_VOLUMES)
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "internal: %d record grids on the device", (int)h->count);
    memset(table, 0, sizeof table);   /* the table's key hashes its bytes, padding included */
    for (i = 0; i < h->count; i++) {
        if ((st = grid_device(ctx, &h->grid[i], 1, i, &table[i], err, errlen))) return st;
        table[i].kd = NULL;   /* the view reads the scene's kd through the grids' struct */
    }
    if ((st = vsd_device_content(ctx, rg_table, table, (size_t)h->count * sizeof table[0], &p, err, errlen))) return st;
    *d = *h;
    d->grid = p;
    return VSD_OK;
}
