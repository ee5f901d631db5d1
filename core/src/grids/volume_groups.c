/* Groups of volumes that share lighting grids (volume_groups.h). */
#include "volume_groups.h"
#include "kvolume_boxes.h"
#include "vsd/volume.h"
#include "kernel/kernel_volumes.h"
#include "kernel/kernel_lights.h"
#include "device/cpu/cpu_tiles.h"
#include <math.h>
#include <stdlib.h>

/* [lo, hi] grown by [blo, bhi] (set when !any) */
static void grow_box(const double blo[3], const double bhi[3], double lo[3], double hi[3], int any)
{
    int a;
    for (a = 0; a < 3; a++) {
        if (!any || blo[a] < lo[a]) lo[a] = blo[a];
        if (!any || bhi[a] > hi[a]) hi[a] = bhi[a];
    }
}

/* Grow [lo, hi) by v's non-empty bricks' world box; returns whether [lo, hi) holds anything. */
static int add_kvolume_box(const vsd_kvolume *v, double lo[3], double hi[3], int any)
{
    double i2w[16], blo[3], bhi[3], wlo[3], whi[3];
    if (!vsd_kvolume_active_index_box(v, blo, bhi) || !vsd_kvolume_index_to_world(v, i2w)) return any;
    vsd_affine_box(i2w, blo, bhi, wlo, whi);
    grow_box(wlo, whi, lo, hi, any);
    return 1;
}

int vsd_kobject_world_box(const vsd_kobject *o, double lo[3], double hi[3])
{
    int any = add_kvolume_box(&o->density, lo, hi, 0);
    if (o->medium.has_emission) any = add_kvolume_box(&o->emission, lo, hi, any);
    return any;
}

/* The world boxes of a volume's non-empty bricks (density, and emission when it emits),
 * 6 doubles each, into a malloc'd array; *count of them (0 and NULL when none or no memory). */
static double *brick_boxes(const vsd_kobject *o, int *count)
{
    const vsd_kvolume *vs[2] = {&o->density, o->medium.has_emission ? &o->emission : NULL};
    size_t total = 0, n = 0;
    double *out;
    int k;
    *count = 0;
    for (k = 0; k < 2; k++)
        if (vs[k] && vs[k]->dims[0] > 0 && vs[k]->brick_max)
            total += (size_t)vs[k]->dims[0] * vs[k]->dims[1] * vs[k]->dims[2];
    if (!total || !(out = malloc(6 * total * sizeof *out))) return NULL;
    for (k = 0; k < 2; k++) {
        const vsd_kvolume *v = vs[k];
        double i2w[16];
        int x, y, z, a;
        if (!v || v->dims[0] == 0 || !v->brick_max || !vsd_kvolume_index_to_world(v, i2w)) continue;
        for (z = 0; z < v->dims[2]; z++)
            for (y = 0; y < v->dims[1]; y++)
                for (x = 0; x < v->dims[0]; x++) {
                    double blo[3], bhi[3];
                    int bi[3] = {x, y, z};
                    if (!(v->brick_max[((size_t)z * v->dims[1] + y) * v->dims[0] + x] > 0.0f)) continue;
                    for (a = 0; a < 3; a++) {
                        blo[a] = v->origin[a] + 8.0 * bi[a];
                        bhi[a] = blo[a] + 8.0;
                    }
                    vsd_affine_box(i2w, blo, bhi, out + 6 * n, out + 6 * n + 3);
                    n++;
                }
    }
    *count = (int)n;
    return out;
}

/* density, plus emission where the volume emits: is there medium at p? */
static int medium_at(const vsd_kobject *o, vsd_f3 p)
{
    return vsd_kvolume_at(&o->density, p) > 0.0f || (o->medium.has_emission && vsd_kvolume_at(&o->emission, p) > 0.0f);
}

/* Whether the two volumes' media overlap: some pair of their non-empty bricks meets, and
 * one of 4^3 probes over the two bricks' common box finds both media there. */
static int media_overlap(const vsd_kobject *oa, const double *a, int na, const vsd_kobject *ob, const double *b, int nb)
{
    enum { K = 4 };
    int i, j, k;
    for (i = 0; i < na; i++)
        for (j = 0; j < nb; j++) {
            const double *p = a + 6 * (size_t)i, *q = b + 6 * (size_t)j;
            double lo[3], hi[3];
            int meet = 1;
            for (k = 0; k < 3 && meet; k++) {
                lo[k] = fmax(p[k], q[k]);
                hi[k] = fmin(p[3 + k], q[3 + k]);
                meet = lo[k] <= hi[k];
            }
            if (!meet) continue;
            for (k = 0; k < K * K * K; k++) {
                vsd_f3 at = vsd_box_probe(lo, hi, K, k);
                if (medium_at(oa, at) && medium_at(ob, at)) return 1;
            }
        }
    return 0;
}

void vsd_volume_groups(const vsd_kernel_data *kd, uint32_t group[VSD_KMAX_VOLUMES])
{
    int n = kd->volume_count > 1 ? kd->volume_count : 1, i, j, a, changed;
    double lo[VSD_KMAX_VOLUMES][3], hi[VSD_KMAX_VOLUMES][3];
    double *bricks[VSD_KMAX_VOLUMES] = {NULL};
    int has[VSD_KMAX_VOLUMES], nb[VSD_KMAX_VOLUMES];
    for (i = 0; i < n; i++) {
        group[i] = 1u << i;
        has[i] = n > 1 && vsd_kobject_world_box(&kd->volumes[i], lo[i], hi[i]);
    }
    for (i = 0; i < n; i++)
        for (j = i + 1; j < n; j++) {
            int meet = has[i] && has[j];
            for (a = 0; a < 3 && meet; a++) meet = lo[i][a] <= hi[j][a] && lo[j][a] <= hi[i][a];
            if (!meet) continue;
            /* the boxes meet: do the media? (no memory for the bricks: the boxes decide) */
            if (!bricks[i]) bricks[i] = brick_boxes(&kd->volumes[i], &nb[i]);
            if (!bricks[j]) bricks[j] = brick_boxes(&kd->volumes[j], &nb[j]);
            if (bricks[i] && bricks[j] &&
                !media_overlap(&kd->volumes[i], bricks[i], nb[i], &kd->volumes[j], bricks[j], nb[j]))
                continue;
            group[i] |= 1u << j;
            group[j] |= 1u << i;
        }
    for (i = 0; i < n; i++) free(bricks[i]);
    /* transitively: a chain of near volumes is one group */
    do {
        changed = 0;
        for (i = 0; i < n; i++)
            for (j = 0; j < n; j++)
                if (((group[i] >> j) & 1u) && (group[i] | group[j]) != group[i]) {
                    group[i] |= group[j];
                    changed = 1;
                }
    } while (changed);
}

float vsd_group_sigma(const vsd_kernel_data *kd, uint32_t group, vsd_f3 p)
{
    float sum = 0.0f;
    int i;
    if (kd->volume_count <= 1) return vsd_kvolume_at(&kd->density, p);
    for (i = 0; i < kd->volume_count; i++)
        if ((group >> i) & 1u) sum += vsd_kvolume_at(&kd->volumes[i].density, p);
    return sum;
}

vsd_f3 vsd_group_emission(const vsd_kernel_data *kd, uint32_t group, vsd_f3 p)
{
    vsd_f3 sum = f3s(0.0f);
    int i;
    if (kd->volume_count <= 1)
        return kd->medium.has_emission ? f3_scale(kd->medium.emission, vsd_kvolume_at(&kd->emission, p)) : sum;
    for (i = 0; i < kd->volume_count; i++) {
        const vsd_kobject *o = &kd->volumes[i];
        if (((group >> i) & 1u) && o->medium.has_emission)
            sum = f3_madd(sum, o->medium.emission, vsd_kvolume_at(&o->emission, p));
    }
    return sum;
}

float vsd_group_scattering(const vsd_kernel_data *kd, uint32_t group, vsd_f3 p, double scatter[3])
{
    float sum = 0.0f;
    int i;
    for (i = 0; i < kd->volume_count; i++) {
        const vsd_kobject *o = &kd->volumes[i];
        float s;
        if (!((group >> i) & 1u)) continue;
        s = vsd_kvolume_at(&o->density, p);
        sum += s;
        scatter[0] += (double)s * o->medium.albedo.x;
        scatter[1] += (double)s * o->medium.albedo.y;
        scatter[2] += (double)s * o->medium.albedo.z;
    }
    return sum;
}

int vsd_group_emits(const vsd_kernel_data *kd, uint32_t group)
{
    int i;
    if (kd->volume_count <= 1) return kd->medium.has_emission;
    for (i = 0; i < kd->volume_count; i++)
        if (((group >> i) & 1u) && kd->volumes[i].medium.has_emission) return 1;
    return 0;
}

int vsd_group_has_outside(const vsd_kernel_data *kd, uint32_t group)
{
    int i;
    for (i = 0; i < kd->volume_count; i++)
        if (!((group >> i) & 1u)) return 1;
    return 0;
}

typedef struct shadow_job {
    const vsd_kernel_data *kd;
    uint32_t group;
    const float *record_pos, *dir_lights, *local_lights;
    int dir_count, local_count;
    float *light_trans, *light_lost, *local_trans;
} shadow_job;

static void shadow_items(void *arg, int r0, int y0, int r1, int y1)
{
    const shadow_job *j = arg;
    int r, k;
    (void)y0;
    (void)y1;
    for (r = r0; r < r1; r++) {
        const float *x = j->record_pos + 4 * (size_t)r;
        vsd_f3 p = f3(x[0], x[1], x[2]);
        for (k = 0; k < j->dir_count; k++) {
            size_t at = (size_t)r * j->dir_count + k;
            const float *l = j->dir_lights + 8 * (size_t)k;
            float t;
            if (!(j->light_trans[at] > 0.0f) && !(j->light_lost && j->light_lost[at] > 0.0f)) continue;
            t = vsd_kvolumes_march_transmittance(j->kd, p, f3(l[0], l[1], l[2]), VSD_INF, j->group, 0.0f);
            j->light_trans[at] *= t;
            if (j->light_lost) j->light_lost[at] *= t;
        }
        for (k = 0; k < j->local_count; k++) {
            size_t at = (size_t)r * j->local_count + k;
            const float *l = j->local_lights + (size_t)VSD_KLIGHT_FLOATS * k;
            vsd_f3 to = f3_sub(f3(l[0], l[1], l[2]), p);
            float dist = sqrtf(f3_dot(to, to));
            if (!(j->local_trans[at] > 0.0f) || !(dist > 0.0f)) continue;
            j->local_trans[at] *= vsd_kvolumes_march_transmittance(j->kd, p, f3_scale(to, 1.0f / dist), dist, j->group, 0.0f);
        }
    }
}

void vsd_group_shadow_records(const vsd_kernel_data *kd, uint32_t group, const float *record_pos, int records,
                              const float *dir_lights, int dir_count, const float *local_lights, int local_count,
                              float *light_trans, float *light_lost, float *local_trans, int threads)
{
    shadow_job j = {kd, group, record_pos, dir_lights, local_lights, dir_count, local_count,
                    light_trans, light_lost, local_trans};
    if (records <= 0 || !vsd_group_has_outside(kd, group)) return;
    /* (the pool fails only when cancelled, which this stage is not) */
    if (vsd_cpu_run_items(records, threads, shadow_items, &j, "shadows of other volumes") != VSD_OK)
        shadow_items(&j, 0, 0, records, 1);
}

int vsd_volumes_near(const vsd_kernel_data *kd, int i, int j)
{
    double lo[2][3], hi[2][3], gap2 = 0.0, extent = 0.0;
    int a, k;
    if (!vsd_kobject_world_box(&kd->volumes[i], lo[0], hi[0]) || !vsd_kobject_world_box(&kd->volumes[j], lo[1], hi[1]))
        return 0;
    for (a = 0; a < 3; a++) {
        double gap = fmax(0.0, fmax(lo[1][a] - hi[0][a], lo[0][a] - hi[1][a]));
        gap2 += gap * gap;
        for (k = 0; k < 2; k++) extent = fmax(extent, hi[k][a] - lo[k][a]);
    }
    return gap2 <= 0.25 * extent * extent;
}

int vsd_group_near_outside(const vsd_kernel_data *kd, uint32_t group)
{
    int i, j;
    for (i = 0; i < kd->volume_count; i++)
        for (j = 0; j < kd->volume_count; j++)
            if (((group >> i) & 1u) && !((group >> j) & 1u) && vsd_volumes_near(kd, i, j)) return 1;
    return 0;
}
