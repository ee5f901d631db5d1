/* crm over several volumes (crm_parts.h). */
#include "crm_parts.h"
#include "crm_volumes_kernel.h"
#include "crm_device.h"
#include "src/grids/volume_groups.h"
#include "src/grids/kvolume_boxes.h"
#include "device/cpu/cpu_tiles.h"
#include "vsd/sh.h"
#include <math.h>
#include <stddef.h>
#include <stdlib.h>

/* every volume of the scene (the part's box holds whichever of them reach into it) */
static uint32_t all_volumes(const vsd_kernel_data *kd) { return kd->volume_count >= 32 ? ~0u : (1u << kd->volume_count) - 1u; }

/* Volume j's world box (its non-empty bricks) in the part's index space, the box of its
 * corners: 0 when the volume is empty. */
static int index_box(const vsd_kernel_data *kd, int j, double lo[3], double hi[3])
{
    const float *m = kd->density.world_to_index.m;
    double wlo[3], whi[3], w2i[16] = {0};
    int k;
    if (!vsd_kobject_world_box(&kd->volumes[j], wlo, whi)) return 0;
    for (k = 0; k < 12; k++) w2i[k] = m[k];
    w2i[15] = 1.0;
    vsd_affine_box(w2i, wlo, whi, lo, hi);
    return 1;
}

void vsd_crm_part_box(const vsd_frame_ctx *ctx, int32_t origin[3], int32_t dims[3])
{
    const vsd_kernel_data *kd = &ctx->kd;
    double lo[3], hi[3];
    int j, a;
    for (a = 0; a < 3; a++) {
        lo[a] = origin[a];
        hi[a] = (double)origin[a] + dims[a];
    }
    for (j = 0; j < kd->volume_count && j < 32; j++) {
        double jlo[3], jhi[3];
        if (j == ctx->part.volume) continue;
        if (!((ctx->part.group >> j) & 1u) && !vsd_volumes_near(kd, ctx->part.volume, j)) continue;
        if (!index_box(kd, j, jlo, jhi)) continue;
        for (a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], jlo[a]);
            hi[a] = fmax(hi[a], jhi[a]);
        }
    }
    /* whole bricks outward from the volume's own origin, so the box stays the brick box's
     * kind (the shadows clip with it as a vsd_kvolume) */
    for (a = 0; a < 3; a++) {
        int32_t below = (int32_t)ceil((origin[a] - lo[a]) / 8.0), above = (int32_t)ceil((hi[a] - origin[a]) / 8.0);
        origin[a] -= 8 * below;
        dims[a] = 8 * (below + above);
    }
}

int vsd_crm_part_one_phase(const vsd_frame_ctx *ctx, const int32_t origin[3], const int32_t dims[3])
{
    const vsd_kernel_data *kd = &ctx->kd;
    int j, a;
    for (j = 0; j < kd->volume_count; j++) {
        double lo[3], hi[3];
        int meets = 1;
        if (j == ctx->part.volume || kd->volumes[j].medium.anisotropy == kd->medium.anisotropy) continue;
        if (!index_box(kd, j, lo, hi)) continue;
        for (a = 0; a < 3 && meets; a++) meets = lo[a] < (double)origin[a] + dims[a] && hi[a] > (double)origin[a];
        if (meets) return 0;
    }
    return 1;
}

void vsd_crm_part_medium(const vsd_frame_ctx *ctx, const int32_t node_res[3], const vsd_affine *n2w, float scale,
                         float *density, float *albedo, float *emission)
{
    const vsd_kernel_data *kd = &ctx->kd;
    uint32_t all = all_volumes(kd);
    size_t n = 0;
    int32_t i, j, k, u, v, w;
    for (k = 0; k < node_res[2]; k++)
        for (j = 0; j < node_res[1]; j++)
            for (i = 0; i < node_res[0]; i++, n++) {
                double sigma = 0.0, scatter[3] = {0.0, 0.0, 0.0};
                vsd_f3 e = f3s(0.0f);
                for (w = -1; w <= 1; w++)
                    for (v = -1; v <= 1; v++)
                        for (u = -1; u <= 1; u++) {
                            vsd_f3 p = vsd_affine_point(n2w, f3((float)i + (float)u / 3.0f, (float)j + (float)v / 3.0f,
                                                                (float)k + (float)w / 3.0f));
                            sigma += vsd_group_scattering(kd, all, p, scatter);
                            if (emission) e = f3_add(e, vsd_group_emission(kd, all, p));
                        }
                density[n] = sigma > 0.0 ? (float)(sigma / 27.0 / scale) : 0.0f;
                albedo[3 * n] = sigma > 0.0 ? (float)(scatter[0] / sigma) : kd->medium.albedo.x;
                albedo[3 * n + 1] = sigma > 0.0 ? (float)(scatter[1] / sigma) : kd->medium.albedo.y;
                albedo[3 * n + 2] = sigma > 0.0 ? (float)(scatter[2] / sigma) : kd->medium.albedo.z;
                if (emission) {
                    emission[3 * n] = e.x > 0.0f ? e.x / 27.0f : 0.0f;
                    emission[3 * n + 1] = e.y > 0.0f ? e.y / 27.0f : 0.0f;
                    emission[3 * n + 2] = e.z > 0.0f ? e.z / 27.0f : 0.0f;
                }
            }
}

/* The shadows are computed on every second node per axis (coarse point k at node
 * coordinate 2k, one past the grid where the count is even) and interpolated: the depth
 * beyond the box changes smoothly from node to node, and this stage was over a third of
 * a cold frame of the issue-30 scene when every node marched its 108 directions. */
typedef struct shadow_job {
    const vsd_frame_ctx *ctx;
    const vsd_affine *n2w;
    vsd_kvolume box;           /* the node grid's box (the density's transform) */
    const double *dirs;
    int directions;
    int32_t cres[3];
    float step;
    float *od;                 /* [coarse points * directions], scaled */
} shadow_job;

/* coarse points [a, b) */
static void shadow_items(void *user, int a, int y0, int b, int y1)
{
    const shadow_job *job = user;
    const vsd_kernel_data *kd = &job->ctx->kd;
    uint32_t inside = job->ctx->part.group | 1u << job->ctx->part.volume;   /* in the box */
    int m, d;
    (void)y0;
    (void)y1;
    for (m = a; m < b; m++) {
        vsd_f3 p = vsd_affine_point(job->n2w, f3(2.0f * (float)(m % job->cres[0]),
                                                 2.0f * (float)((m / job->cres[0]) % job->cres[1]),
                                                 2.0f * (float)(m / (job->cres[0] * job->cres[1]))));
        for (d = 0; d < job->directions; d++) {
            vsd_f3 dir = f3((float)job->dirs[3 * d], (float)job->dirs[3 * d + 1], (float)job->dirs[3 * d + 2]);
            float t0 = 0.0f, t1 = VSD_INF, tr;
            /* the medium inside the box (every volume's) is in the node grid already */
            if (!vsd_kvolume_clip(&job->box, p, dir, &t0, &t1)) t1 = 0.0f;
            tr = vsd_kvolumes_march_transmittance(kd, f3_madd(p, dir, t1), dir, VSD_INF, inside, job->step);
            job->od[(size_t)m * job->directions + d] = tr > 1e-30f ? -logf(tr) : 69.0f;
        }
    }
}

vsd_status vsd_crm_part_shadows(const vsd_frame_ctx *ctx, vsd_crm_node_depths *c, const vsd_affine *n2w,
                                const int32_t origin[3], const int32_t dims[3], float scale, float step, int threads,
                                char *err, size_t errlen)
{
    shadow_job job;
    size_t points, m;
    vsd_status st;
    int a, d;
    if (!(scale > 0.0f) || c->count == 0) return VSD_OK;
    for (a = 0; a < 3; a++) job.cres[a] = c->res[a] / 2 + 1;
    points = (size_t)job.cres[0] * job.cres[1] * job.cres[2];
    if (c->directions == 0) return VSD_OK;
    job.od = malloc(sizeof *job.od * points * (size_t)c->directions);
    if (!job.od || points > 0x7fffffff) {
        free(job.od);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the shadows of %zu points x %d directions",
                        points, c->directions);
    }
    job.ctx = ctx;
    job.n2w = n2w;
    job.box = ctx->kd.density;
    for (a = 0; a < 3; a++) {
        job.box.origin[a] = origin[a];
        job.box.dims[a] = dims[a] / 8;
    }
    job.dirs = c->dirs;
    job.directions = c->directions;
    job.step = step;
    st = vsd_cpu_run_items((int)points, threads, shadow_items, &job, "crm shadows of the other volumes");
    for (m = 0; !st && m < c->count; m++) {
        /* trilinear between the 8 coarse points around the node */
        int32_t node = c->which[m], q[3] = {node % c->res[0], (node / c->res[0]) % c->res[1],
                                            node / (c->res[0] * c->res[1])}, k0[3];
        float t[3];
        for (a = 0; a < 3; a++) {
            k0[a] = q[a] / 2;
            t[a] = (q[a] & 1) ? 0.5f : 0.0f;
        }
        for (d = 0; d < c->directions; d++) {
            float sum = 0.0f;
            int corner;
            for (corner = 0; corner < 8; corner++) {
                float w = 1.0f;
                size_t idx;
                int32_t k[3];
                for (a = 0; a < 3; a++) {
                    int up = (corner >> a) & 1;
                    w *= up ? t[a] : 1.0f - t[a];
                    k[a] = k0[a] + up < job.cres[a] ? k0[a] + up : job.cres[a] - 1;
                }
                if (w == 0.0f) continue;
                idx = ((size_t)k[2] * job.cres[1] + k[1]) * job.cres[0] + k[0];
                sum += w * job.od[idx * c->directions + d];
            }
            c->od[m * c->directions + d] += sum / scale;
        }
    }
    free(job.od);
    return st;
}

vsd_status vsd_crm_parts_view(vsd_frame_ctx *ctx, vsd_framebuffer *fb, const vsd_kcrm *parts, int count, int n,
                              const vsd_view_sampling *vs, int *samples, char *err, size_t errlen)
{
    vsd_kcrm_volumes cv;
    if (count != ctx->kd.volume_count)
        return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "internal: %d crm parts for %d volumes", count,
                        ctx->kd.volume_count);
    cv.kd = &ctx->kd;
    cv.part = parts;
    cv.count = count;
    cv.pad[0] = cv.pad[1] = cv.pad[2] = 0;
    return vsd_method_render_view(ctx, fb, n, vs, &vsd_crm_volumes_view_pass, vsd_crm_volumes_view_struct, &cv,
                                  samples, err, errlen);
}
