#include "crm_device.h"
#include "src/device_data/device_frame.h"
#include "device/cpu/cpu_tiles.h"
#include <stddef.h>

/* crm's resident slots (cuda_backend.h) */
VSD_DEVICE_SLOT(crm_dtilde, "crm reduced density");
VSD_DEVICE_SLOT(crm_dfull, "crm full density");
VSD_DEVICE_SLOT(crm_nodes, "crm nodes");
VSD_DEVICE_SLOT(crm_valid, "crm node validity");
VSD_DEVICE_SLOT(crm_view_nodes, "crm view nodes");

static size_t voxels(const vsd_kcrm *c) { return (size_t)c->dims[0] * c->dims[1] * c->dims[2]; }
static size_t nodes(const vsd_kcrm *c) { return (size_t)c->node_res[0] * c->node_res[1] * c->node_res[2]; }

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
}

VSD_CUDA_ENTRY_DECL(vsd_cuda_crm_view_nodes);
static const vsd_device_pass crm_node_pass = {
    "crm view nodes", 0, 1 << 16, sizeof(vsd_kcrm), offsetof(vsd_kcrm, kd), NULL, node_item, node_arrays,
    VSD_CUDA_ENTRY(vsd_cuda_crm_view_nodes),
};

/* The node pass on the CPU threads, into the host struct's view_nodes. */
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
    PUT(nodes, crm_nodes, ctx->lighting_gen, nodes(h) * CRM_NODE_FLOATS * sizeof(float));
    PUT(node_valid, crm_valid, ctx->lighting_gen, nodes(h));
#undef PUT
    {
        /* the node pass for this view, on the device into a scratch slot the view then reads:
         * a new camera copies nothing but the structs */
        size_t bytes = nodes(h) * CRM_VIEW_FLOATS * sizeof(float);
        vsd_pass_args a = {0, 0, 0};
        void *view;
        if ((st = vsd_device_scratch(ctx, crm_view_nodes, bytes, 0, &view, err, errlen))) return st;
        d->view_nodes = view;
        if ((st = vsd_device_run(ctx, &crm_node_pass, d, h->kd, a, (int)nodes(h), view, bytes, 0.0f, 0.0f, err, errlen)))
            return st;
    }
    return VSD_OK;
}
