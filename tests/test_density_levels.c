/* The half-resolution volume (src/volume/volume_mip.h) and the density levels that
 * shgrid's records and constellation's cached shadows read (src/method/density_levels.h):
 * a linear field is reproduced exactly at the coarse voxels and at any world point, the mass
 * is kept, majorants bound the voxels, sparse volumes stay sparse, the level rule (the cell
 * and the data's own detail), the optical depth through a smooth ball at levels 1 and 2
 * against the source voxels, and two volumes at different levels in one context. */
#include "test_common.h"

#include "src/volume/volume_mip.h"
#include "src/method/density_levels.h"
#include "src/render/kernel_setup.h"
#include "kernel/kernel_volumes.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

/* A rotated (about z by 0.5 rad, then x by 0.3), non-uniformly scaled, translated grid. */
static void skewed_transform(double m[16])
{
    const double cz = cos(0.5), sz = sin(0.5), cx = cos(0.3), sx = sin(0.3);
    const double rz[16] = {cz, -sz, 0, 0, sz, cz, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const double rx[16] = {1, 0, 0, 0, 0, cx, -sx, 0, 0, sx, cx, 0, 0, 0, 0, 1};
    const double s[16] = {0.02, 0, 0, 0.3, 0, 0.035, 0, -1.2, 0, 0, 0.015, 0.7, 0, 0, 0, 1};
    double r[16];
    vsd_mat4_mul(rx, rz, r);
    vsd_mat4_mul(r, s, m);
}

static float linear_field(double i, double j, double k)
{
    return (float)(2.0 + 0.05 * i - 0.03 * j + 0.02 * k);
}

static vsd_volume *dense_volume(const float *v, const int32_t dims[3], const int32_t org[3], const double m[16])
{
    vsd_volume *vol = NULL;
    char err[256];
    CHECK(vsd_volume_create_dense(v, dims, org, m, &vol, err, sizeof err) == VSD_OK);
    return vol;
}

static void world_of(const double m[16], const double p[3], double w[3])
{
    int a;
    for (a = 0; a < 3; a++) w[a] = m[4 * a] * p[0] + m[4 * a + 1] * p[1] + m[4 * a + 2] * p[2] + m[4 * a + 3];
}

/* [1] Coarse voxel I is the field at fine index 2I + 1/2, and both volumes give the same
 * value at any world point inside (trilinear reproduces a linear field). */
static void test_linear_field(const double m[16], const int32_t org[3])
{
    const int32_t dims[3] = {37, 26, 45};
    float *v = malloc(sizeof *v * (size_t)dims[0] * dims[1] * dims[2]);
    vsd_volume *fine, *coarse = NULL, *coarse2 = NULL;
    double inv_c[16], inv_c2[16];
    char err[256];
    unsigned long long rng = 7;
    int x, y, z, a, n, checked = 0;
    for (z = 0; z < dims[2]; z++)
        for (y = 0; y < dims[1]; y++)
            for (x = 0; x < dims[0]; x++)
                v[((size_t)z * dims[1] + y) * dims[0] + x] = linear_field(org[0] + x, org[1] + y, org[2] + z);
    fine = dense_volume(v, dims, org, m);
    CHECK(vsd_volume_mip_half(fine, &coarse, err, sizeof err) == VSD_OK);
    if (!fine || !coarse) return;
    for (a = 0; a < 3; a++) {
        CHECK(coarse->origin[a] % 8 == 0);
        CHECK_NEAR(coarse->voxel_size[a], 2.0 * fine->voxel_size[a], 1e-12);
    }
    /* every coarse voxel whose 2x2x2 fine voxels all hold data */
    for (z = (org[2] + 1) / 2 + 1; 2 * z + 1 < org[2] + dims[2]; z++)
        for (y = (org[1] + 1) / 2 + 1; 2 * y + 1 < org[1] + dims[1]; y++)
            for (x = (org[0] + 1) / 2 + 1; 2 * x + 1 < org[0] + dims[0]; x++) {
                CHECK_NEAR(vsd_volume_voxel(coarse, x, y, z), linear_field(2 * x + 0.5, 2 * y + 0.5, 2 * z + 0.5),
                           1e-5);
                checked++;
            }
    CHECK(checked > 2000);
    CHECK(vsd_volume_mip_half(coarse, &coarse2, err, sizeof err) == VSD_OK);
    CHECK(vsd_mat4_invert(coarse->index_to_world, inv_c));
    CHECK(vsd_mat4_invert(coarse2->index_to_world, inv_c2));
    for (n = 0; n < 200; n++) {
        double pf[3], w[3], pc[3];
        for (a = 0; a < 3; a++) pf[a] = org[a] + 3.0 + test_urand(&rng) * (dims[a] - 6.0);
        world_of(fine->index_to_world, pf, w);
        world_of(inv_c, w, pc);
        CHECK_NEAR(vsd_volume_sample_index(coarse, pc), vsd_volume_sample_index(fine, pf), 2e-5);
        /* level 2 (voxels of 4): well inside, away from its data's edge */
        for (a = 0; a < 3; a++) pf[a] = org[a] + 7.0 + test_urand(&rng) * (dims[a] - 14.0);
        world_of(fine->index_to_world, pf, w);
        world_of(inv_c2, w, pc);
        CHECK_NEAR(vsd_volume_sample_index(coarse2, pc), vsd_volume_sample_index(fine, pf), 2e-5);
    }
    vsd_volume_destroy(coarse2);
    vsd_volume_destroy(coarse);
    vsd_volume_destroy(fine);
    free(v);
}

/* [2] A sparse random field: the mass (sum of voxels x voxel volume) is kept, majorants bound
 * every voxel of their brick, the coverage rule's margin is there, and two blobs far apart
 * give a few bricks, not the box between them. */
static void test_sparse_mass(void)
{
    const int32_t dims[3] = {520, 24, 24}, org[3] = {-21, 3, 8};
    float *v = calloc((size_t)dims[0] * dims[1] * dims[2], sizeof *v);
    vsd_volume *fine, *coarse = NULL;
    char err[256];
    unsigned long long rng = 11;
    double fine_sum = 0, coarse_sum = 0;
    int x, y, z, q, c, low[3] = {1 << 30, 1 << 30, 1 << 30};
    for (z = 4; z < 20; z++)
        for (y = 2; y < 21; y++)
            for (x = 0; x < dims[0]; x++) {
                if (x > 17 && x < 500) continue;
                v[((size_t)z * dims[1] + y) * dims[0] + x] = (float)test_urand(&rng);
            }
    fine = dense_volume(v, dims, org, identity);
    CHECK(vsd_volume_mip_half(fine, &coarse, err, sizeof err) == VSD_OK);
    if (!fine || !coarse) return;
    for (q = 0; q < fine->brick_count * VSD_BRICK_VOXELS; q++) fine_sum += fine->voxels[q];
    for (c = 0; c < coarse->brick_dims[0] * coarse->brick_dims[1] * coarse->brick_dims[2]; c++) {
        int32_t slot = coarse->brick_slots[c];
        const int bx = c % coarse->brick_dims[0], by = (c / coarse->brick_dims[0]) % coarse->brick_dims[1];
        const int bz = c / (coarse->brick_dims[0] * coarse->brick_dims[1]);
        if (slot < 0) continue;
        for (q = 0; q < VSD_BRICK_VOXELS; q++) {
            float s = coarse->voxels[(size_t)slot * VSD_BRICK_VOXELS + q];
            const int p[3] = {coarse->origin[0] + 8 * bx + (q & 7), coarse->origin[1] + 8 * by + ((q >> 3) & 7),
                              coarse->origin[2] + 8 * bz + (q >> 6)};
            coarse_sum += s;
            CHECK(s <= coarse->brick_max[c]);
            for (x = 0; s != 0.0f && x < 3; x++)
                if (p[x] < low[x]) low[x] = p[x];
        }
    }
    CHECK_NEAR(8.0 * coarse_sum, fine_sum, 1e-5 * fine_sum);
    for (x = 0; x < 3; x++) CHECK(coarse->origin[x] <= low[x] - 1);   /* the margin below the data */
    /* 2 blobs of 18 or 20 x 19 x 16 fine voxels: at most 2 x 3 x 2 coarse bricks each, where
       the box between them holds about 200 */
    CHECK_MSG(coarse->brick_count <= 24, "%d coarse bricks for two small blobs", coarse->brick_count);
    CHECK(coarse->brick_dims[0] >= 30);
    vsd_volume_destroy(coarse);
    vsd_volume_destroy(fine);
    free(v);
}

/* [3] An empty volume gives an empty one. */
static void test_empty(void)
{
    vsd_volume *e = NULL, *c = NULL;
    char err[256];
    CHECK(vsd_volume_create_empty(identity, &e, err, sizeof err) == VSD_OK);
    CHECK(vsd_volume_mip_half(e, &c, err, sizeof err) == VSD_OK);
    CHECK(c && c->brick_dims[0] == 0 && c->brick_count == 0);
    vsd_volume_destroy(c);
    vsd_volume_destroy(e);
}

/* A context holding one volume, as the renderer gives it to a method. */
static void one_volume_ctx(vsd_frame_ctx *ctx, const vsd_volume *vol, float density)
{
    char err[256];
    memset(ctx, 0, sizeof *ctx);
    ctx->density = vol;
    ctx->volume_density[0] = vol;
    ctx->volume_count = 1;
    ctx->kd.volume_count = 1;
    CHECK(vsd_kvolume_setup(&ctx->kd.density, vol, identity, density, err, sizeof err) == VSD_OK);
}

/* A Gaussian ball of standard deviation 10 voxels in a 64^3 grid of voxel 0.05 (cut at 31
 * voxels, where it is 0.008). Level L blurs it by a box of 2^L voxels and its own trilinear
 * tent: variance (4^L - 1)/12 + 4^L/6 voxels^2 per axis against the source's 1/6. */
static vsd_volume *ball(void)
{
    const int32_t dims[3] = {64, 64, 64}, org[3] = {0, 0, 0};
    const double m[16] = {0.05, 0, 0, -1.6, 0, 0.05, 0, -1.6, 0, 0, 0.05, -1.6, 0, 0, 0, 1};
    float *v = malloc(sizeof *v * 64 * 64 * 64);
    vsd_volume *vol;
    int x, y, z;
    for (z = 0; z < 64; z++)
        for (y = 0; y < 64; y++)
            for (x = 0; x < 64; x++) {
                double r2 = (x - 31.5) * (x - 31.5) + (y - 31.5) * (y - 31.5) + (z - 31.5) * (z - 31.5);
                v[(z * 64 + y) * 64 + x] = r2 < 31.0 * 31.0 ? (float)exp(-r2 / 200.0) : 0.0f;
            }
    vol = dense_volume(v, dims, org, m);
    free(v);
    return vol;
}

/* A ball (Gaussian of 0.4 world) whose density swings +-30% with a wavelength of 0.3 on each
 * axis. Sampled with voxels of 0.1 (3 a wavelength: detail at the voxels) or of 0.025 (the
 * same world field, 12 voxels a wavelength: a volume stored finer than its detail). */
static vsd_volume *wavy_ball(double voxel)
{
    const int n = (int)lround(2.4 / voxel);
    const int32_t org[3] = {0, 0, 0}, dims[3] = {n, n, n};
    const double t[16] = {voxel, 0, 0, -1.2, 0, voxel, 0, -1.2, 0, 0, voxel, -1.2, 0, 0, 0, 1};
    const double k = 2.0 * 3.14159265358979 / 0.3;
    float *v = malloc(sizeof *v * (size_t)n * n * n);
    vsd_volume *vol;
    int x, y, z;
    for (z = 0; z < n; z++)
        for (y = 0; y < n; y++)
            for (x = 0; x < n; x++) {
                const double w[3] = {x * voxel - 1.2, y * voxel - 1.2, z * voxel - 1.2};
                const double r2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
                v[((size_t)z * n + y) * n + x] =
                    (float)(exp(-r2 / 0.32) * (1.0 + 0.3 * sin(k * w[0]) * sin(k * w[1]) * sin(k * w[2])));
            }
    vol = dense_volume(v, dims, org, t);
    free(v);
    return vol;
}

/* [4] The level rule (density_levels.h): the cell bounds the level (2^L voxels no longer than
 * its thinnest slab, at most VSD_DENSITY_MAX_LEVEL) and so does the data: the ball with its
 * detail 3 voxels a wavelength keeps its voxels whatever the cell; the same field at 12
 * voxels a wavelength reads level 1 (6 a wavelength), and not level 2 (3), which loses it. "full" (option 0)
 * and a fixed level take no notice of the data. The rays step the cell where a level is read. */
static void test_level_rule(void)
{
    vsd_volume *noisy = wavy_ball(0.1), *up = wavy_ball(0.025);
    vsd_frame_ctx ctx;
    vsd_density_levels d;
    char err[256];
    const struct { int upsampled; double cell; int option, level; } cases[] = {
        {0, 0.4, -1, 0},  {0, 100, -1, 0},  {1, 0.049, -1, 0}, {1, 0.05, -1, 1}, {1, 0.099, -1, 1},
        {1, 100, -1, 1},  {1, 100, 0, 0},   {0, 0.01, 2, 2},   {1, 100, 9, VSD_DENSITY_MAX_LEVEL},
    };
    size_t k;
    if (!noisy || !up) return;
    memset(&d, 0, sizeof d);
    for (k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        one_volume_ctx(&ctx, cases[k].upsampled ? up : noisy, 1.0f);
        CHECK(vsd_density_levels_build(&d, &ctx, cases[k].cell, cases[k].option, err, sizeof err) == VSD_OK);
        CHECK_MSG(d.level[0] == cases[k].level, "%s field, cell %.3f, option %d: level %d, expected %d",
                  cases[k].upsampled ? "upsampled" : "noisy", cases[k].cell, cases[k].option, d.level[0],
                  cases[k].level);
        CHECK(vsd_density_levels_any(&d) == (cases[k].level > 0));
        CHECK_NEAR(d.step, cases[k].level > 0 && cases[k].option < 0 ? cases[k].cell : 0.0, 1e-6);
    }
    {
        /* what the data loses: the upsampled field at level 1 far less than the noisy one */
        vsd_volume *a = NULL, *b = NULL;
        double la, lb;
        CHECK(vsd_volume_mip_half(up, &a, err, sizeof err) == VSD_OK);
        CHECK(vsd_volume_mip_half(noisy, &b, err, sizeof err) == VSD_OK);
        la = vsd_volume_mip_loss(up, a, 1);
        lb = vsd_volume_mip_loss(noisy, b, 1);
        printf("level 1 loses %.5f of the finer ball, %.5f of the coarser one\n", la, lb);
        CHECK(la < VSD_DENSITY_MAX_LOSS && lb > 4 * VSD_DENSITY_MAX_LOSS);
        vsd_volume_destroy(a);
        vsd_volume_destroy(b);
    }
    vsd_density_levels_free(&d);
    vsd_volume_destroy(noisy);
    vsd_volume_destroy(up);
}

/* [5] Optical depth through the ball along rays from points inside and outside it, at
 * levels 1 and 2 (each stepping its own voxel) against the source voxels at half a voxel:
 * within 1.5% and 6% of each ray's depth (the blur above: a line through the centre loses
 * 1/(1 + v/100) with v = 0.92 and 3.92 voxels^2 more than the source's, 0.7% and 3.6%). */
static void test_optical_depth(void)
{
    vsd_volume *vol = ball();
    vsd_frame_ctx ctx;
    vsd_density_levels d;
    vsd_kernel_data coarse;
    vsd_kobject objects[VSD_KMAX_VOLUMES];
    char err[256];
    unsigned long long rng = 5;
    int level, n;
    if (!vol) return;
    memset(&d, 0, sizeof d);
    one_volume_ctx(&ctx, vol, 4.0f);
    for (level = 1; level <= 2; level++) {
        double worst = 0, centre;
        CHECK(vsd_density_levels_build(&d, &ctx, 1.0, level, err, sizeof err) == VSD_OK);
        vsd_density_levels_kd(&d, &ctx.kd, &coarse, objects);
        CHECK_NEAR(coarse.density.step, ctx.kd.density.step * (1 << level), 1e-7);
        centre = vsd_kvolumes_optical_depth(&ctx.kd, f3(0.0f, 0.0f, 0.0f), f3(1.0f, 0.0f, 0.0f),
                                            ctx.kd.density.step, 0.5f);
        for (n = 0; n < 300; n++) {
            double dir[3], r = 0.9 * test_urand(&rng), a, b;
            vsd_f3 p, dd;
            test_random_dir(&rng, dir);
            p = f3((float)(r * dir[0]), (float)(r * dir[1]), (float)(r * dir[2]));
            test_random_dir(&rng, dir);
            dd = f3((float)dir[0], (float)dir[1], (float)dir[2]);
            a = vsd_kvolumes_optical_depth(&ctx.kd, p, dd, ctx.kd.density.step, 0.5f);
            b = vsd_kvolumes_optical_depth(&coarse, p, dd, 2.0f * coarse.density.step, 0.5f);
            /* relative to the ray's own depth, or a tenth of the centre's for grazing rays */
            if (fabs(a - b) / fmax(a, 0.1 * centre) > worst) worst = fabs(a - b) / fmax(a, 0.1 * centre);
        }
        printf("level %d: optical depth within %.2f%% of the source's\n", level, 100 * worst);
        CHECK_MSG(worst < (level == 1 ? 0.015 : 0.06), "level %d: %.2f%% off", level, 100 * worst);
    }
    vsd_density_levels_free(&d);
    vsd_volume_destroy(vol);
}

/* [6] Two volumes (a part's context: kd.volumes holds both, kd.density the part's own): the
 * finer ball reads level 1, the coarser keeps its voxels; the kernel data for the rays has
 * each volume at its level, volume 0 of the context among them, and the optical depth
 * through both is the sum of each one's at its level. */
static void test_two_volumes(void)
{
    vsd_volume *fine = wavy_ball(0.025), *detailed = wavy_ball(0.1);
    vsd_frame_ctx ctx;
    vsd_kobject objs[2], coarse_objects[VSD_KMAX_VOLUMES];
    vsd_kernel_data coarse, one;
    vsd_density_levels d;
    char err[256];
    int i;
    if (!fine || !detailed) return;
    memset(&d, 0, sizeof d);
    memset(&ctx, 0, sizeof ctx);
    memset(objs, 0, sizeof objs);
    CHECK(vsd_kvolume_setup(&objs[0].density, fine, identity, 2.0f, err, sizeof err) == VSD_OK);
    CHECK(vsd_kvolume_setup(&objs[1].density, detailed, identity, 1.0f, err, sizeof err) == VSD_OK);
    ctx.volume_count = ctx.kd.volume_count = 2;
    ctx.kd.volumes = objs;
    /* the part of volume 1 */
    ctx.kd.density = objs[1].density;
    ctx.density = detailed;
    ctx.volume_density[0] = fine;
    ctx.volume_density[1] = detailed;
    CHECK(vsd_density_levels_build(&d, &ctx, 0.3, -1, err, sizeof err) == VSD_OK);
    CHECK(d.count == 2 && d.level[0] == 1 && d.level[1] == 0);
    vsd_density_levels_kd(&d, &ctx.kd, &coarse, coarse_objects);
    CHECK(coarse.volumes == coarse_objects && coarse.volume_count == 2);
    CHECK(coarse.volumes[0].density.voxels == d.mip[0][0]->voxels);
    CHECK(coarse.volumes[0].density.scale == 2.0f);
    CHECK(memcmp(&coarse.volumes[1].density, &objs[1].density, sizeof objs[1].density) == 0);
    CHECK(memcmp(&coarse.density, &objs[1].density, sizeof objs[1].density) == 0);
    CHECK(ctx.kd.volumes == objs && objs[0].density.voxels == fine->voxels);   /* the input is untouched */
    {
        const vsd_f3 p = f3(0.1f, -0.2f, 0.05f), dir = f3(0.6f, 0.8f, 0.0f);
        double both = vsd_kvolumes_optical_depth(&coarse, p, dir, 0.05f, 0.5f), sum = 0;
        memset(&one, 0, sizeof one);
        for (i = 0; i < 2; i++) {
            one.volume_count = 1;
            one.density = coarse.volumes[i].density;
            sum += vsd_kvolumes_optical_depth(&one, p, dir, 0.05f, 0.5f);
        }
        CHECK_NEAR(both, sum, 1e-5 * sum);
        CHECK(sum > 0.1);
    }
    vsd_density_levels_free(&d);
    vsd_volume_destroy(fine);
    vsd_volume_destroy(detailed);
}

int main(void)
{
    double m[16];
    const int32_t org_a[3] = {0, 0, 0}, org_b[3] = {-13, 5, 40};
    test_linear_field(identity, org_a);
    skewed_transform(m);
    test_linear_field(m, org_b);
    test_sparse_mass();
    test_empty();
    test_level_rule();
    test_optical_depth();
    test_two_volumes();
    return test_finish("test_density_levels");
}
