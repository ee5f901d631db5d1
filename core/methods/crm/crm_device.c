#include "crm_device.h"
#include "crm_volumes_kernel.h"
#include "src/device_data/device_frame.h"
#include "device/cpu/cpu_tiles.h"
#include <stddef.h>

/* crm's resident slots (cuda_backend.h) */
VSD_DEVICE_SLOT(crm_dtilde, "crm reduced density");
VSD_DEVICE_SLOT(crm_dfull, "crm full density");
/* The nodes, their validity, this view's node values, the extracted lights (their
 * transmittance per node, their directions and powers) and the sky summed per view (its
 * transmittance rows, each node's row, its pixels, the cap-averaged phase; crm_sky.h): set
 * 0 for one volume, set i for part i of several (crm_parts.h), each part's in slots of its
 * own. */
#define NODE_SLOTS(p)                                                                                      \
    {{p " nodes", VSD_CUDA_METHOD_SLOT}, {p " node validity", VSD_CUDA_METHOD_SLOT},                         \
     {p " view nodes", VSD_CUDA_METHOD_SLOT}, {p " light transmittance", VSD_CUDA_METHOD_SLOT},              \
     {p " lights", VSD_CUDA_METHOD_SLOT}, {p " sky transmittance", VSD_CUDA_METHOD_SLOT},                    \
     {p " sky rows", VSD_CUDA_METHOD_SLOT}, {p " sky", VSD_CUDA_METHOD_SLOT},                                \
     {p " sky phase", VSD_CUDA_METHOD_SLOT}}
static const vsd_cuda_slot_desc node_slots[VSD_KMAX_VOLUMES][9] = {
    NODE_SLOTS("crm"),         NODE_SLOTS("crm part 1"),  NODE_SLOTS("crm part 2"),  NODE_SLOTS("crm part 3"),
    NODE_SLOTS("crm part 4"),  NODE_SLOTS("crm part 5"),  NODE_SLOTS("crm part 6"),  NODE_SLOTS("crm part 7"),
    NODE_SLOTS("crm part 8"),  NODE_SLOTS("crm part 9"),  NODE_SLOTS("crm part 10"), NODE_SLOTS("crm part 11"),
    NODE_SLOTS("crm part 12"), NODE_SLOTS("crm part 13"), NODE_SLOTS("crm part 14"), NODE_SLOTS("crm part 15")};
#undef NODE_SLOTS

static size_t voxels(const vsd_kcrm *c) { return (size_t)c->dims[0] * c->dims[1] * c->dims[2]; }
static size_t nodes(const vsd_kcrm *c) { return (size_t)c->node_res[0] * c->node_res[1] * c->node_res[2]; }
static size_t light_tr_bytes(const vsd_kcrm *c) { return nodes(c) * (size_t)c->light_count * sizeof(float); }
static size_t lights_bytes(const vsd_kcrm *c) { return (size_t)c->light_count * 8 * sizeof(float); }
static size_t sky_tr_bytes(const vsd_kcrm *c) { return (size_t)c->sky_rows * (size_t)c->sky_count * sizeof(float); }
static size_t sky_bytes(const vsd_kcrm *c) { return (size_t)c->sky_count * 8 * sizeof(float); }

VSD_CPU_VIEW_SAMPLE
static vsd_sample_result view_sample(const void *m, int x, int y, int s, int n)
{
    return vsd_crm_pass_sample((const vsd_kcrm *)m, x, y, s, n);
}

static void view_arrays(const void *m, vsd_pass_args a, vsd_pass_array_visit visit, void *user)
{
    const vsd_kcrm *c = m;
    (void)a;
    /* the fitted grids exist only where view_density reads them (crm_kernel.h) */
    if (c->dtilde) visit(user, c->dtilde, voxels(c) * sizeof(float), "crm.dtilde");
    if (c->dfull) visit(user, c->dfull, voxels(c) * sizeof(float), "crm.dfull");
    visit(user, c->nodes, nodes(c) * CRM_NODE_FLOATS * sizeof(float), "crm.nodes");
    visit(user, c->node_valid, nodes(c), "crm.node_valid");
    visit(user, c->view_nodes, nodes(c) * CRM_VIEW_FLOATS * sizeof(float), "crm.view_nodes");
}

static void node_item(const void *m, int i, int n, void *out)
{
    vsd_crm_view_node((const vsd_kcrm *)m, i, n, out);
}

static void node_arrays(const void *m, vsd_pass_args a, vsd_pass_array_visit visit, void *user)
{
    const vsd_kcrm *c = m;
    (void)a;
    visit(user, c->nodes, nodes(c) * CRM_NODE_FLOATS * sizeof(float), "crm.nodes");
    visit(user, c->node_valid, nodes(c), "crm.node_valid");
    if (c->light_count > 0) {
        visit(user, c->light_tr, light_tr_bytes(c), "crm.light_tr");
        visit(user, c->lights, lights_bytes(c), "crm.lights");
    }
    if (c->sky_count > 0) {
        visit(user, c->sky_tr, sky_tr_bytes(c), "crm.sky_tr");
        visit(user, c->sky_row, nodes(c) * sizeof(int32_t), "crm.sky_row");
        visit(user, c->sky, sky_bytes(c), "crm.sky");
        visit(user, c->sky_phase, CRM_SKY_PHASE_N * sizeof(float), "crm.sky_phase");
    }
}

VSD_CUDA_ENTRY_DECL(vsd_cuda_crm_view_nodes);
static const vsd_device_pass crm_node_pass = {
    "crm view nodes", 0, 1 << 16, sizeof(vsd_kcrm), offsetof(vsd_kcrm, kd), NULL, node_item, node_arrays,
    VSD_CUDA_ENTRY(vsd_cuda_crm_view_nodes),
};

/* The node pass on the CPU threads, into the host struct's view_nodes; cloned for AVX2
 * as the view is (the sky's sum over its pixels, crm_sky.h, is most of it). */
VSD_CPU_VIEW_SAMPLE
static void node_tile(void *user, int i0, int y0, int i1, int y1)
{
    int i;
    (void)y0;
    (void)y1;
    for (i = i0; i < i1; i++) vsd_crm_view_node((const vsd_kcrm *)user, i, 0, ((const vsd_kcrm *)user)->view_nodes);
}

vsd_status vsd_crm_view_nodes_cpu(vsd_frame_ctx *ctx, const vsd_kcrm *c)
{
    vsd_tile_job job;
    vsd_method_item_job(&job, ctx, (int)nodes(c), node_tile, (void *)c, "crm view nodes");
    return vsd_cpu_run_tiles(&job);
}

VSD_CUDA_ENTRY_DECL(vsd_cuda_crm_view);
const vsd_device_pass vsd_crm_view_pass = {
    "ray marching", 1, 128, sizeof(vsd_kcrm), offsetof(vsd_kcrm, kd), view_sample, NULL, view_arrays,
    VSD_CUDA_ENTRY(vsd_cuda_crm_view),
};

/* d's nodes and validity resident in slot set `set`, and the per-view node pass run there
 * into its view nodes (ctx: the context whose volume the nodes light; h->kd its kd), so a
 * new camera copies nothing but the structs. */
static vsd_status nodes_to_device(const vsd_frame_ctx *ctx, const vsd_kcrm *h, int set, vsd_kcrm *d, char *err,
                                  size_t errlen)
{
    const vsd_cuda_slot_desc *sl = node_slots[set];
    size_t bytes = nodes(h) * CRM_VIEW_FLOATS * sizeof(float);
    vsd_pass_args a = {0, 0, 0};
    const void *p;
    void *view;
    vsd_status st;
    if ((st = vsd_device_array(ctx, &sl[0], ctx->lighting_gen, h->nodes, nodes(h) * CRM_NODE_FLOATS * sizeof(float),
                               &p, err, errlen)))
        return st;
    d->nodes = p;
    if ((st = vsd_device_array(ctx, &sl[1], ctx->lighting_gen, h->node_valid, nodes(h), &p, err, errlen))) return st;
    d->node_valid = p;
    if (h->light_count > 0) {
        if ((st = vsd_device_array(ctx, &sl[3], ctx->lighting_gen, h->light_tr, light_tr_bytes(h), &p, err, errlen)))
            return st;
        d->light_tr = p;
        if ((st = vsd_device_array(ctx, &sl[4], ctx->lighting_gen, h->lights, lights_bytes(h), &p, err, errlen)))
            return st;
        d->lights = p;
    }
    if (h->sky_count > 0) {
        if ((st = vsd_device_array(ctx, &sl[5], ctx->lighting_gen, h->sky_tr, sky_tr_bytes(h), &p, err, errlen)))
            return st;
        d->sky_tr = p;
        if ((st = vsd_device_array(ctx, &sl[6], ctx->lighting_gen, h->sky_row, nodes(h) * sizeof(int32_t), &p, err,
                                   errlen)))
            return st;
        d->sky_row = p;
        if ((st = vsd_device_array(ctx, &sl[7], ctx->lighting_gen, h->sky, sky_bytes(h), &p, err, errlen))) return st;
        d->sky = p;
        if ((st = vsd_device_array(ctx, &sl[8], ctx->lighting_gen, h->sky_phase, CRM_SKY_PHASE_N * sizeof(float), &p,
                                   err, errlen)))
            return st;
        d->sky_phase = p;
    }
    if ((st = vsd_device_scratch(ctx, &sl[2], bytes, 0, &view, err, errlen))) return st;
    d->view_nodes = view;
    return vsd_device_run(ctx, &crm_node_pass, d, h->kd, a, (int)nodes(h), view, bytes, 0.0f, 0.0f, err, errlen);
}

vsd_status vsd_crm_view_struct(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err, size_t errlen)
{
    const vsd_kcrm *h = host;
    vsd_kcrm *d = dev;
    const void *p;
    vsd_status st;
    *d = *h;
#define PUT(field, slot, gen, bytes) \
    do { if ((st = vsd_device_array(ctx, slot, gen, h->field, bytes, &p, err, errlen))) return st; d->field = p; } while (0)
    if (h->dtilde) PUT(dtilde, crm_dtilde, ctx->frame_gen, voxels(h) * sizeof(float));
    if (h->dfull) PUT(dfull, crm_dfull, ctx->frame_gen, voxels(h) * sizeof(float));
#undef PUT
    return nodes_to_device(ctx, h, 0, d, err, errlen);
}

/* Several volumes: the table of the parts' device structs (each part's nodes in node set i). */
VSD_DEVICE_SLOT(crm_part_table, "crm parts (several volumes)");

vsd_status vsd_crm_part_device(const vsd_frame_ctx *part_ctx, const vsd_kcrm *h, int i, vsd_kcrm *d, char *err,
                               size_t errlen)
{
    vsd_status st;
    if (i < 0 || i >= VSD_KMAX_VOLUMES) return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "internal: crm part %d", i);
    *d = *h;
    d->dtilde = d->dfull = NULL;   /* the fitted forms render one volume */
    d->view_nodes = NULL;
    if (!h->nodes) return VSD_OK;  /* an empty part: the march skips it */
    if ((st = nodes_to_device(part_ctx, h, i, d, err, errlen))) return st;
    d->kd = NULL;                  /* the view reads the scene's kd through the parts' struct */
    return VSD_OK;
}

VSD_CPU_VIEW_SAMPLE
static vsd_sample_result volumes_sample(const void *m, int x, int y, int s, int n)
{
    return vsd_crm_volumes_sample((const vsd_kcrm_volumes *)m, x, y, s, n);
}

/* The parts' table; each part's arrays are reached through it on the device. */
static void volumes_arrays(const void *m, vsd_pass_args a, vsd_pass_array_visit visit, void *user)
{
    const vsd_kcrm_volumes *cv = m;
    (void)a;
    visit(user, cv->part, (size_t)cv->count * sizeof *cv->part, "crm.part (several volumes)");
}

VSD_CUDA_ENTRY_DECL(vsd_cuda_crm_volumes_view);
const vsd_device_pass vsd_crm_volumes_view_pass = {
    "ray marching (several volumes)", 1, 128, sizeof(vsd_kcrm_volumes), offsetof(vsd_kcrm_volumes, kd),
    volumes_sample, NULL, volumes_arrays, VSD_CUDA_ENTRY(vsd_cuda_crm_volumes_view),
};

vsd_status vsd_crm_volumes_view_struct(const vsd_frame_ctx *ctx, const void *host, void *dev, char *err,
                                       size_t errlen)
{
    const vsd_kcrm_volumes *h = host;
    vsd_kcrm_volumes *d = dev;
    const void *p;
    vsd_status st;
    *d = *h;
    if ((st = vsd_device_content(ctx, crm_part_table, h->part, (size_t)h->count * sizeof *h->part, &p, err, errlen)))
        return st;
    d->part = p;
    return VSD_OK;
}
