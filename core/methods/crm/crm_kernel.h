/* crm_kernel.h — the compensated ray march of Zhou et al. 2008 (§5.5), shared by the CPU
 * tiles and CUDA (crm_cuda.cu). Common subset of C11 and CUDA C++.
 *
 * Per view ray, the shared march (kernel/kernel_march.h: step placement, empty bricks,
 * early termination, emission) with crm's own source and the density `view_density` names:
 *   voxels        the scene's density grid itself (default): nothing is fitted for the view.
 *                 The paper's D~ + R is this grid again, to the residual's 8-bit
 *                 quantisation, so the fit and the hash were work no pixel needed (issue 31).
 *   compensated   D = D~ + R, the paper's §5.2: the RBF model rasterised on the voxel grid
 *                 (D~) plus the 8-bit residual from the perfect hash (R), decoded once per
 *                 frame into one grid (the paper's volume pass reconstructs D the same way).
 *   eq8           the paper's eq. 8 literally: transmittance from D~ alone, the source from
 *                 D~ + R, so where R < 0 more light gets through (its "enlightenment").
 *   source        J~(x, w_o), precomputed per lighting change on a coarse node grid as SH
 *                 coefficients (order-4 single, order-3 multiple scattering, albedo and phase
 *                 already applied); per view, the node pass (the paper's volume pass,
 *                 vsd_crm_view_node) evaluates each node's SH toward the eye once, and the
 *                 march reads the 8 surrounding nodes' values trilinearly (corners cached
 *                 per cell).
 *   lights        with `lights` (crm_lights.h), the map's bright texels as K directional
 *                 lights outside the SH: each node's transmittance toward each, and the
 *                 node pass adds albedo E_k T_k HG(-w_k . w_o) with the exact phase.
 * VolumeDir receives the single-scattering source, VolumeInd the multiple.
 *
 * Coordinates: "crm space" is the RBF fit's voxel index space, voxel (i,j,k) of the dense
 * grid centred at (i + .5, j + .5, k + .5) (crm_rbf.h); world p maps to it through the
 * density's world_to_index minus the dense grid's origin plus one half. */
#ifndef VSD_CRM_KERNEL_H
#define VSD_CRM_KERNEL_H
#include "kernel/kernel_types.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_camera.h"
#include "kernel/kernel_march.h"
#include "kernel/kernel_sh.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_record_grid.h" /* vsd_records_dot */
#include "device/device_pass.h"

enum { CRM_VIEW_VOXELS = 0, CRM_VIEW_COMPENSATED = 1, CRM_VIEW_EQ8 = 2 };
/* SH coefficients per node: order-4 single scattering (16) and order-3 multiple (9: bands
 * 0-2; the orders fill bands 0-1 alone with `ms_bands` 2, the rest stays 0), RGB */
enum { CRM_SS_ORDER = 4, CRM_SS_N = 16, CRM_MS_N = 9, CRM_NODE_FLOATS = 3 * (CRM_SS_N + CRM_MS_N) };
enum { CRM_NODE_SINGLE = 1, CRM_NODE_MULTIPLE = 2 };
enum { CRM_VIEW_FLOATS = 6 };
/* entries of crm_sky.h's cap-averaged phase table, uniform in the cosine from -1 to 1 */
enum { CRM_SKY_PHASE_N = 2048 };
/* below this a node's single scattering counts as zero in the log interpolation */
#define CRM_LOG_FLOOR 1e-12f
#define CRM_LOG_ZERO (-27.0f) /* log(2e-12): a blend of floors only */

typedef struct VSD_ALIGN16 vsd_kcrm {
    const vsd_kernel_data *kd;
    const float *dtilde;           /* [nx*ny*nz] D~ per voxel (unscaled density); eq8 only, else NULL */
    const float *dfull;            /* [nx*ny*nz] D~ + R decoded per frame; NULL with CRM_VIEW_VOXELS */
    const float *nodes;            /* [node count * CRM_NODE_FLOATS]: ss R,G,B (16 each), ms R,G,B (9 each) */
    const uint8_t *node_valid;     /* [node count] CRM_NODE_SINGLE | CRM_NODE_MULTIPLE bits */
    /* [node count * CRM_VIEW_FLOATS], per view: each node's source toward the eye (log of the
     * single-scattering RGB, then the multiple-scattering RGB), written by the node pass */
    float *view_nodes;
    vsd_affine node_to_world;      /* node coordinates -> world */
    int32_t dims[3];               /* dense grid nx, ny, nz */
    int32_t origin[3];             /* index coordinate of dense voxel (0,0,0) */
    int32_t node_res[3];           /* nodes per axis */
    float node_spacing;            /* voxels between nodes (crm space) */
    int32_t view_density;          /* CRM_VIEW_* */
    int32_t order;                 /* of the single-scattering SH actually used (<= 4) */
    /* the extracted lights (crm_lights.h), light_count 0 = none */
    const float *light_tr;         /* [node count * light_count] T from each node toward each light */
    const float *lights;           /* [light_count * 8] world direction xyz, 0, albedo * E rgb, 0 */
    int32_t light_count;
    float light_g;                 /* HG's g of the single scattering */
    /* the sky's remainder summed per view over its HEALPix pixels (crm_sky.h, `sky_view:
     * "sum"`), sky_count 0 = it is in the nodes' SH */
    const float *sky_tr;           /* [sky_rows * sky_count] T from each node with density toward each pixel */
    const int32_t *sky_row;        /* [node count] the node's row of sky_tr, -1 none */
    const float *sky;              /* [sky_count * 8] pixel centre xyz, 0, albedo L Omega rgb, 0 */
    const float *sky_phase;        /* [CRM_SKY_PHASE_N] HG over a pixel's cap against the cosine, -1 to 1 */
    int32_t sky_count;
    int32_t sky_rows;
} vsd_kcrm;

/* Trilinear weights of the 8 voxels around crm-space point q (voxel centres at +0.5) and
 * the lower corner's voxel. */
VSD_DEVICE void vsd_crm_cell(vsd_f3 q, int32_t ijk[3], float w[8])
{
    float x = q.x - 0.5f, y = q.y - 0.5f, z = q.z - 0.5f, fx = floorf(x), fy = floorf(y), fz = floorf(z);
    float tx = x - fx, ty = y - fy, tz = z - fz;
    int32_t a;
    ijk[0] = (int32_t)fx;
    ijk[1] = (int32_t)fy;
    ijk[2] = (int32_t)fz;
    for (a = 0; a < 8; a++)
        w[a] = ((a & 1) ? tx : 1.0f - tx) * (((a >> 1) & 1) ? ty : 1.0f - ty) * (((a >> 2) & 1) ? tz : 1.0f - tz);
}

/* sum_a w[a] grid[voxel a], voxels outside the grid counting 0. */
VSD_DEVICE float vsd_crm_blend(const float *grid, const int32_t dims[3], const int32_t ijk[3], const float w[8])
{
    float v = 0.0f;
    int32_t a;
    for (a = 0; a < 8; a++) {
        int32_t ii = ijk[0] + (a & 1), jj = ijk[1] + ((a >> 1) & 1), kk = ijk[2] + ((a >> 2) & 1);
        if (ii < 0 || jj < 0 || kk < 0 || ii >= dims[0] || jj >= dims[1] || kk >= dims[2]) continue;
        v += w[a] * grid[((size_t)kk * dims[1] + jj) * dims[0] + ii];
    }
    return v;
}

/* The fitted medium at crm-space point q, 0 outside the grid (CRM_VIEW_COMPENSATED, EQ8):
 * returns D~ + R and sets *dt to what attenuates, D~ alone under eq. 8, else D~ + R too. */
VSD_DEVICE float vsd_crm_density(const vsd_kcrm *c, vsd_f3 q, float *dt)
{
    int32_t ijk[3];
    float w[8], full;
    vsd_crm_cell(q, ijk, w);
    full = vsd_crm_blend(c->dfull, c->dims, ijk, w);
    *dt = c->view_density == CRM_VIEW_EQ8 ? vsd_crm_blend(c->dtilde, c->dims, ijk, w) : full;
    return full;
}

/* Source radiance of one node toward the viewer: y holds the SH basis at -d. */
VSD_DEVICE void vsd_crm_node_source(const vsd_kcrm *c, int32_t node, const float *y, vsd_f3 *ss, vsd_f3 *ms)
{
    const float *n = c->nodes + (size_t)node * CRM_NODE_FLOATS;
    float s[3], m[3];
    int32_t ch, n2 = c->order * c->order;
    for (ch = 0; ch < 3; ch++) {
        /* four-lane sums: the dot products are this pass's hot loop (perf: a serial sum was
         * a third of the view's time, bound by the add latency) */
        float a = vsd_records_dot(y, n + ch * CRM_SS_N, n2), b = vsd_records_dot(y, n + 3 * CRM_SS_N + ch * CRM_MS_N, CRM_MS_N);
        /* truncated SH rings below zero; radiance does not */
        s[ch] = a > 0.0f ? a : 0.0f;
        m[ch] = b > 0.0f ? b : 0.0f;
    }
    *ss = f3(s[0], s[1], s[2]);
    *ms = f3(m[0], m[1], m[2]);
}

/* The cap-averaged phase at cos mu between a pixel's light and the eye (crm_sky.h's table,
 * linear between its entries). */
VSD_DEVICE float vsd_crm_sky_phase(const float *table, float mu)
{
    float x = (0.5f * mu + 0.5f) * (float)(CRM_SKY_PHASE_N - 1), f;
    int32_t i;
    x = x > 0.0f ? x : 0.0f;
    i = (int32_t)x;
    if (i >= CRM_SKY_PHASE_N - 1) return table[CRM_SKY_PHASE_N - 1];
    f = x - (float)i;
    return table[i] + f * (table[i + 1] - table[i]);
}

/* acc plus the single scattering toward w of `count` directional lights: light k (8 floats:
 * world direction toward it xyz, 0, albedo E rgb, 0) travels along -w_k, its transmittance
 * t[k] at the node, scattered by HG at g, or with `phase_table` by crm_sky.h's HG averaged
 * over a pixel's cap. */
VSD_DEVICE vsd_f3 vsd_crm_add_directional(vsd_f3 acc, const float *t, const float *lights, int32_t count, vsd_f3 w,
                                          float g, const float *phase_table)
{
    int32_t k;
    for (k = 0; k < count; k++) {
        const float *l = lights + 8 * (size_t)k;
        float mu = -(w.x * l[0] + w.y * l[1] + w.z * l[2]);
        float f = t[k] * (phase_table ? vsd_crm_sky_phase(phase_table, mu) : vsd_hg_eval(mu, g));
        acc = f3(acc.x + f * l[4], acc.y + f * l[5], acc.z + f * l[6]);
    }
    return acc;
}

/* The paper's volume pass (§5.5), on the nodes: each node's source radiance toward the eye
 * for this view, the SH evaluated once per node and view instead of once per ray and cell.
 * The direction is the node's own toward the camera (the camera's backward axis when
 * orthographic); a ray through a cell sees its nodes from within a fraction of a degree
 * of that (node spacing over distance). Item i = node i. */
VSD_DEVICE void vsd_crm_view_node(const vsd_kcrm *c, int i, int n, void *out)
{
    const float *m = c->kd->camera.cam_to_world.m;
    float *o = (float *)out + (size_t)i * CRM_VIEW_FLOATS, y[CRM_SS_N];
    vsd_f3 ss, ms, w;
    int32_t x, yy, z;
    (void)n;
    if (!c->node_valid[i]) {
        o[0] = o[1] = o[2] = logf(CRM_LOG_FLOOR);
        o[3] = o[4] = o[5] = 0.0f;
        return;
    }
    x = i % c->node_res[0];
    yy = (i / c->node_res[0]) % c->node_res[1];
    z = i / (c->node_res[0] * c->node_res[1]);
    if (c->kd->camera.orthographic) {
        w = f3_normalize(f3(m[2], m[6], m[10]));
    } else {
        vsd_f3 p = vsd_affine_point(&c->node_to_world, f3((float)x, (float)yy, (float)z));
        w = f3_normalize(f3_sub(f3(m[3], m[7], m[11]), p));
    }
    /* at least order 3: the multiple scattering's bands 1-2 are read whatever the single
     * scattering's order (y has room for 16) */
    vsd_sh_eval_f(c->order > 3 ? c->order : 3, w, y);
    vsd_crm_node_source(c, i, y, &ss, &ms);
    /* the bright texels, outside the SH, with the exact phase; the rest of the sky, pixel by
     * pixel, with the phase averaged over each pixel (crm_sky.h) */
    if (c->light_count > 0 && (c->node_valid[i] & CRM_NODE_SINGLE))
        ss = vsd_crm_add_directional(ss, c->light_tr + (size_t)i * c->light_count, c->lights, c->light_count, w,
                                     c->light_g, NULL);
    if (c->sky_count > 0 && c->sky_row[i] >= 0)
        ss = vsd_crm_add_directional(ss, c->sky_tr + (size_t)c->sky_row[i] * c->sky_count, c->sky, c->sky_count, w,
                                     0.0f, c->sky_phase);
    /* single scattering falls exponentially into the medium: the view blends its log (the
     * weighted geometric mean), as shgrid's records do */
    o[0] = logf(ss.x > CRM_LOG_FLOOR ? ss.x : CRM_LOG_FLOOR);
    o[1] = logf(ss.y > CRM_LOG_FLOOR ? ss.y : CRM_LOG_FLOOR);
    o[2] = logf(ss.z > CRM_LOG_FLOOR ? ss.z : CRM_LOG_FLOOR);
    o[3] = ms.x;
    o[4] = ms.y;
    o[5] = ms.z;
}

/* The eight nodes around the current sample, evaluated for this ray once per node cell.
 * A node's single- and multiple-scattering parts are valid separately (node_valid bits
 * CRM_NODE_SINGLE, CRM_NODE_MULTIPLE: the RBFs cover the first, the medium the second), and
 * each is interpolated over its own valid corners. */
typedef struct vsd_crm_corners {
    int32_t key[3], filled, valid;
    vsd_f3 ss[8], ms[8];
} vsd_crm_corners;

VSD_DEVICE void vsd_crm_source(const vsd_kcrm *c, vsd_f3 q, vsd_crm_corners *cc, vsd_f3 *ss, vsd_f3 *ms)
{
    float u = q.x / c->node_spacing, v = q.y / c->node_spacing, w = q.z / c->node_spacing, ws = 0.0f, wm = 0.0f;
    int32_t i0 = (int32_t)floorf(u), j0 = (int32_t)floorf(v), k0 = (int32_t)floorf(w), a;
    float tx = u - (float)i0, ty = v - (float)j0, tz = w - (float)k0;
    *ss = *ms = f3s(0.0f);
    if (!cc->filled || cc->key[0] != i0 || cc->key[1] != j0 || cc->key[2] != k0) {
        /* a ray moving into a neighbouring cell shares 4 (or 2, or 1) corners with the last
         * one: those are copied, not re-evaluated (the same values) */
        int32_t di = i0 - cc->key[0], dj = j0 - cc->key[1], dk = k0 - cc->key[2], had = cc->filled, old_valid = cc->valid;
        vsd_f3 old_ss[8], old_ms[8];
        for (a = 0; a < 8; a++) {
            old_ss[a] = cc->ss[a];
            old_ms[a] = cc->ms[a];
        }
        cc->key[0] = i0; cc->key[1] = j0; cc->key[2] = k0;
        cc->filled = 1;
        cc->valid = 0;
        for (a = 0; a < 8; a++) {
            int32_t i = i0 + (a & 1), j = j0 + ((a >> 1) & 1), k = k0 + ((a >> 2) & 1), node;
            int32_t ox = (a & 1) + di, oy = ((a >> 1) & 1) + dj, oz = ((a >> 2) & 1) + dk;
            if (had && ox >= 0 && ox <= 1 && oy >= 0 && oy <= 1 && oz >= 0 && oz <= 1) {
                int32_t b = ox | (oy << 1) | (oz << 2);
                cc->ss[a] = old_ss[b];
                cc->ms[a] = old_ms[b];
                cc->valid |= ((old_valid >> (2 * b)) & 3) << (2 * a);
                continue;
            }
            if (i < 0 || j < 0 || k < 0 || i >= c->node_res[0] || j >= c->node_res[1] || k >= c->node_res[2]) continue;
            node = (k * c->node_res[1] + j) * c->node_res[0] + i;
            if (!c->node_valid[node]) continue;
            {
                const float *v = c->view_nodes + (size_t)node * CRM_VIEW_FLOATS;
                cc->ss[a] = f3(v[0], v[1], v[2]);
                cc->ms[a] = f3(v[3], v[4], v[5]);
            }
            cc->valid |= (int32_t)c->node_valid[node] << (2 * a);
        }
    }
    if (cc->valid == 0xffff) {
        /* every corner holds both parts (inside the medium): the weights sum to one */
        *ss = f3_trilerp(cc->ss, tx, ty, tz);
        *ms = f3_trilerp(cc->ms, tx, ty, tz);
        *ss = f3(ss->x > CRM_LOG_ZERO ? expf(ss->x) : 0.0f, ss->y > CRM_LOG_ZERO ? expf(ss->y) : 0.0f,
                 ss->z > CRM_LOG_ZERO ? expf(ss->z) : 0.0f);
        return;
    }
    for (a = 0; a < 8; a++) {
        float wt = ((a & 1) ? tx : 1.0f - tx) * (((a >> 1) & 1) ? ty : 1.0f - ty) * (((a >> 2) & 1) ? tz : 1.0f - tz);
        int32_t bits = (cc->valid >> (2 * a)) & 3;
        if (wt <= 0.0f) continue;
        if (bits & CRM_NODE_SINGLE) {
            *ss = f3_add(*ss, f3_scale(cc->ss[a], wt));
            ws += wt;
        }
        if (bits & CRM_NODE_MULTIPLE) {
            *ms = f3_add(*ms, f3_scale(cc->ms[a], wt));
            wm += wt;
        }
    }
    if (ws > 0.0f) {
        *ss = f3_scale(*ss, 1.0f / ws);
        /* corners all at the floor mean no light, not the floor's 1e-12 */
        *ss = f3(ss->x > CRM_LOG_ZERO ? expf(ss->x) : 0.0f, ss->y > CRM_LOG_ZERO ? expf(ss->y) : 0.0f,
                 ss->z > CRM_LOG_ZERO ? expf(ss->z) : 0.0f);
    }
    if (wm > 0.0f) *ms = f3_scale(*ms, 1.0f / wm);
}

/* One view ray through pixel (px, py) at sub-pixel (jx, jy). */
VSD_DEVICE vsd_sample_result vsd_crm_pixel(const vsd_kcrm *c, int32_t px, int32_t py, float jx, float jy)
{
    const vsd_kernel_data *kd = c->kd;
    vsd_march_acc acc;
    vsd_crm_corners cc;
    vsd_f3 o, d;
    float t0, t1;
    int32_t a;
    vsd_march_begin(&acc);
    cc.filled = 0;
    cc.valid = 0;
    cc.key[0] = cc.key[1] = cc.key[2] = 0;
    for (a = 0; a < 8; a++) cc.ss[a] = cc.ms[a] = f3s(0.0f);
    vsd_camera_ray(&kd->camera, px, py, jx, jy, &o, &d);
    if (vsd_march_extent(kd, o, d, &t0, &t1)) {
        vsd_march_walk walk;
        float tm, hs;
        vsd_march_walk_begin(&walk, kd, o, d, t0, t1);
        while (vsd_march_walk_next(&walk, kd, acc.tr, &tm, &hs)) {
            vsd_f3 p = f3_madd(o, d, tm), ix = vsd_affine_point(&kd->density.world_to_index, p);
            vsd_f3 q = f3(ix.x - (float)c->origin[0] + 0.5f, ix.y - (float)c->origin[1] + 0.5f,
                          ix.z - (float)c->origin[2] + 0.5f);
            float dt, full, absorbed, shrink;
            if (c->view_density == CRM_VIEW_VOXELS) full = dt = vsd_kvolume_field(&kd->density, ix);
            else full = vsd_crm_density(c, q, &dt);
            full = full > 0.0f ? full : 0.0f;
            absorbed = vsd_march_medium_sigma(kd, &acc, p, hs, kd->density.scale * full);
            shrink = c->view_density == CRM_VIEW_EQ8 ? 1.0f - expf(-kd->density.scale * (dt > 0.0f ? dt : 0.0f) * hs)
                                                      : absorbed;
            if (absorbed > 0.0f || shrink > 0.0f) {
                vsd_f3 ss, ms;
                vsd_crm_source(c, q, &cc, &ss, &ms);
                vsd_march_source(&acc, ss, ms, tm, absorbed, shrink);
            }
        }
    }
    return vsd_march_finish(kd, &acc, d);
}

/* Stratum s of the n x n strata of pixel (x, y) (device/device_pass.h). */
VSD_STRATIFIED_SAMPLE(vsd_crm_pass_sample, vsd_kcrm, vsd_crm_pixel)

#endif
