/* The `constellation` method (issue 3): the distance transform against brute force, the
 * accelerations changing nothing at threshold 0 (bit-identical images) and little above
 * it, environment rotation == rotating volume and camera the other way, option
 * validation, and single scattering against `reference` on smoke64 and cloud128. */
#include "test_common.h"
#include "method_vs_reference.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#include "vsd/compare.h"
#include "src/grids/distance_map.h"
#include "src/grids/record_grid.h"
#include "src/grids/kvolume_boxes.h"
#include "src/render/kernel_setup.h"
#include "methods/constellation/dense_grid.h"
#include "methods/constellation/constellation_kernel.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Exact squared EDT on random sparse occupancy (odd sizes, empty lines, one empty case)
 * equals the brute-force minimum over all sites. */
static void test_edt_exact(void)
{
    const int32_t sizes[3][3] = {{13, 7, 9}, {1, 17, 4}, {8, 8, 8}};
    int c;
    srand(5);
    for (c = 0; c < 3; c++) {
        const int32_t *d = sizes[c];
        size_t n = (size_t)d[0] * d[1] * d[2], i, j;
        uint8_t *occ = calloc(n, 1);
        float *d2 = malloc(sizeof(float) * n);
        int bad = 0;
        for (i = 0; i < n; i++) occ[i] = (c < 2) && (rand() % 23 == 0);
        CHECK(vsd_edt_squared(occ, d, d2, 2));
        for (i = 0; i < n && bad < 5; i++) {
            int xi = (int)(i % d[0]), yi = (int)(i / d[0] % d[1]), zi = (int)(i / ((size_t)d[0] * d[1]));
            double best = 1e30;
            for (j = 0; j < n; j++)
                if (occ[j]) {
                    int xj = (int)(j % d[0]), yj = (int)(j / d[0] % d[1]), zj = (int)(j / ((size_t)d[0] * d[1]));
                    double e = (double)(xi - xj) * (xi - xj) + (double)(yi - yj) * (yi - yj) + (double)(zi - zj) * (zi - zj);
                    if (e < best) best = e;
                }
            if (best >= 1e30 ? d2[i] < 1e29f : d2[i] != (float)best) {
                bad++;
                CHECK_MSG(0, "size %d cell %zu: EDT %g, brute force %g", c, i, d2[i], best);
            }
        }
        free(occ);
        free(d2);
    }
}

/* A sparse synthetic volume: two blobs far apart in a 40^3 grid, voxel 0.05, centred. */
static vsd_volume *blobs_volume(void)
{
    int32_t dims[3] = {40, 40, 40}, lo[3] = {0, 0, 0};
    double m[16] = {0.05, 0, 0, -1, 0, 0.05, 0, -1, 0, 0, 0.05, -1, 0, 0, 0, 1};
    float *v = calloc(40 * 40 * 40, sizeof(float));
    vsd_volume *vol = NULL;
    int x, y, z;
    for (z = 0; z < 40; z++)
        for (y = 0; y < 40; y++)
            for (x = 0; x < 40; x++) {
                double a = ((x - 10) * (x - 10) + (y - 12) * (y - 12) + (z - 10) * (z - 10)) / 16.0;
                double b = ((x - 29) * (x - 29) + (y - 27) * (y - 27) + (z - 28) * (z - 28)) / 25.0;
                double f = (a < 1 ? 1 - a : 0) + (b < 1 ? 0.6 * (1 - b) : 0);
                v[(z * 40 + y) * 40 + x] = (float)f;
            }
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &vol, NULL, 0) == VSD_OK);
    free(v);
    return vol;
}

/* The automatic shadow grid's layout (vsd_record_grid_build_shaped): cubic cells following
 * an elongated box (the bricks of 16 x 48 x 24 voxels of medium, `cells` = 24 along the
 * longest axis, as many as fit along the others), every record at the centre of its cell;
 * the fixed form keeps `cells` per axis. */
static void test_shadow_grid_shape(void)
{
    int32_t dims[3] = {16, 48, 24}, lo[3] = {0, 0, 0};
    double m[16] = {0.1, 0, 0, 0, 0, 0.1, 0, 0, 0, 0, 0.1, 0, 0, 0, 0, 1}, id[16] = {1, 0, 0, 0, 0, 1, 0, 0,
                                                                                     0, 0, 1, 0, 0, 0, 0, 1};
    double blo[3], bhi[3], side;
    float *v = calloc(16 * 48 * 24, sizeof(float));
    vsd_volume *vol = NULL;
    vsd_kvolume kv;
    vsd_record_grid g = {0};
    int i, a, centred = 1;
    for (i = 0; i < 16 * 48 * 24; i++) v[i] = 1.0f;
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &vol, NULL, 0) == VSD_OK);
    free(v);
    if (!vol) return;
    CHECK(vsd_kvolume_setup(&kv, vol, id, 1.0f, NULL, 0) == VSD_OK);
    CHECK(vsd_kvolume_active_index_box(&kv, blo, bhi));
    side = (bhi[1] - blo[1]) / 24.0;   /* y is the longest axis */
    CHECK(vsd_record_grid_build_shaped(&kv, 24, 0, &g, NULL, 0) == VSD_OK);
    printf("shaped shadow grid over a %g x %g x %g box: %d x %d x %d cells, %d records\n", bhi[0] - blo[0],
           bhi[1] - blo[1], bhi[2] - blo[2], g.res[0], g.res[1], g.res[2], g.count);
    for (a = 0; a < 3; a++)
        CHECK_MSG(g.res[a] == (int)ceil((bhi[a] - blo[a]) / side - 1e-9), "axis %d: %d cells for %g voxels of %g",
                  a, g.res[a], bhi[a] - blo[a], side);
    CHECK(g.res[1] == 24 && g.res[0] < g.res[2] && g.res[2] < g.res[1]);
    /* cubic: the world-to-grid map scales every axis alike (the voxels are cubic) */
    CHECK(fabsf(g.world_to_grid.m[0] - g.world_to_grid.m[5]) < 1e-6f &&
          fabsf(g.world_to_grid.m[5] - g.world_to_grid.m[10]) < 1e-6f);
    CHECK(g.count > 0 && g.count <= g.res[0] * g.res[1] * g.res[2]);
    for (i = 0; i < g.count; i++)
        for (a = 0; a < 3; a++) {
            const float *r = g.world_to_grid.m + 4 * a, *p = g.record_pos + 4 * i;
            float c = r[0] * p[0] + r[1] * p[1] + r[2] * p[2] + r[3];
            centred &= fabsf(c - floorf(c) - 0.5f) < 1e-3f;
        }
    CHECK_MSG(centred, "a record off its cell's centre");
    vsd_record_grid_free(&g);
    CHECK(vsd_record_grid_build(&kv, 24, 0, &g, NULL, 0) == VSD_OK);
    CHECK(g.res[0] == 24 && g.res[1] == 24 && g.res[2] == 24);
    vsd_record_grid_free(&g);
    vsd_volume_destroy(vol);
}

/* Every point within the stored leap radius of any cell holds field <= threshold: sample
 * random cells and random points in their balls, on the blobs at two thresholds. */
static void test_leap_is_safe(void)
{
    vsd_volume *vol = blobs_volume();
    const float thr[2] = {0.0f, 0.2f};
    int t, trial, bad = 0;
    if (!vol) return;
    srand(11);
    for (t = 0; t < 2; t++) {
        vsd_distance_map dm;
        CHECK(vsd_distance_map_build(vol, thr[t], 2, &dm, NULL, 0) == VSD_OK);
        CHECK(dm.occupied > 0);
        for (trial = 0; trial < 200000 && bad < 5; trial++) {
            int i = rand() % dm.dims[0], j = rand() % dm.dims[1], k = rand() % dm.dims[2];
            int r = dm.skip[((size_t)k * dm.dims[1] + j) * dm.dims[0] + i];
            double p[3], q[3], dir[3], len, rad;
            int a;
            if (r == 0) continue;
            for (a = 0; a < 3; a++) {
                p[a] = (a == 0 ? i : a == 1 ? j : k) + dm.origin[a] + rand() / (RAND_MAX + 1.0);
                dir[a] = rand() / (RAND_MAX + 1.0) - 0.5;
            }
            len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
            rad = r * (rand() / (RAND_MAX + 1.0)) * 0.9999;
            for (a = 0; a < 3; a++) q[a] = p[a] + dir[a] / len * rad;
            if (fabs(vsd_volume_sample_index(vol, q)) > thr[t]) {
                bad++;
                CHECK_MSG(0, "threshold %g: field %g at distance %g inside the leap radius %d of cell %d,%d,%d", thr[t],
                          vsd_volume_sample_index(vol, q), rad, r, i, j, k);
            }
        }
        vsd_distance_map_free(&dm);
    }
    vsd_volume_destroy(vol);
}

/* The dense grid the shadow rays read (dense_grid.h) returns the same float as the brick
 * lookup at random points (both fast and cross-brick paths, negative index coordinates),
 * and its shadow codes say exactly what they promise: 0 only for cells with a corner above
 * the threshold and no leap, 1 for cells within it and no leap, skip + 1 (capped)
 * otherwise; at threshold 0 code 1 means all corners are exactly 0. */
static void test_dense_grid(void)
{
    int32_t dims[3] = {40, 40, 40}, lo[3] = {-13, 5, 2};
    float *v = calloc(40 * 40 * 40, sizeof(float));
    vsd_volume *vol = NULL;
    int x, y, z, t, trial, bad = 0;
    double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    srand(5);
    for (z = 0; z < 40; z++)
        for (y = 0; y < 40; y++)
            for (x = 0; x < 40; x++) {
                double a = ((x - 12) * (x - 12) + (y - 11) * (y - 11) + (z - 13) * (z - 13)) / 30.0;
                v[(z * 40 + y) * 40 + x] = a < 1 ? (float)(1 - a) * (float)rand() / (float)RAND_MAX : 0.0f;
            }
    CHECK(vsd_volume_create_dense(v, dims, lo, ident, &vol, NULL, 0) == VSD_OK);
    free(v);
    if (!vol) return;
    for (t = 0; t < 2; t++) {
        vsd_distance_map dm, other;
        vsd_dense_grid g;
        vsd_kvolume kv;
        char err[256];
        size_t sy, sz, c = 0;
        int empty_cells = 0, leap_cells = 0, sampled_cells = 0;
        CHECK(vsd_distance_map_build(vol, t ? 0.3f : 0.0f, 2, &dm, NULL, 0) == VSD_OK);
        CHECK(vsd_dense_grid_build(vol, t ? &dm : NULL, t ? 0.3f : 0.0f, &g, err, sizeof err) == VSD_OK);
        CHECK(vsd_kvolume_setup(&kv, vol, ident, 1.0f, NULL, 0) == VSD_OK);
        CHECK(g.v && g.code);
        if (!g.v || !g.code) break;
        sy = (size_t)g.dims[0] + 1;
        sz = sy * ((size_t)g.dims[1] + 1);
        for (trial = 0; trial < 200000 && bad < 5; trial++) {
            vsd_f3 q;
            int32_t i, j, l;
            float a, b;
            q.x = (float)g.origin[0] + (float)g.dims[0] * (float)rand() / ((float)RAND_MAX + 1.0f);
            q.y = (float)g.origin[1] + (float)g.dims[1] * (float)rand() / ((float)RAND_MAX + 1.0f);
            q.z = (float)g.origin[2] + (float)g.dims[2] * (float)rand() / ((float)RAND_MAX + 1.0f);
            i = (int32_t)floorf(q.x) - g.origin[0];
            j = (int32_t)floorf(q.y) - g.origin[1];
            l = (int32_t)floorf(q.z) - g.origin[2];
            if (i >= g.dims[0] || j >= g.dims[1] || l >= g.dims[2]) continue;
            a = vsd_cst_trilinear(g.v + (size_t)l * sz + (size_t)j * sy + i, sy, sz, q.x - floorf(q.x),
                                  q.y - floorf(q.y), q.z - floorf(q.z));
            b = vsd_kvolume_field(&kv, q);
            if (memcmp(&a, &b, sizeof a) != 0) {
                bad++;
                CHECK_MSG(0, "dense grid %.9g != brick lookup %.9g at %g %g %g", a, b, q.x, q.y, q.z);
            }
        }
        for (z = 0; z < g.dims[2]; z++)
            for (y = 0; y < g.dims[1]; y++)
                for (x = 0; x < g.dims[0]; x++, c++) {
                    int gx = g.origin[0] + x, gy = g.origin[1] + y, gz = g.origin[2] + z, dx, dy, dz, empty = 1;
                    int skip = t ? dm.skip[c] : 0, want;
                    for (dz = 0; dz < 2; dz++)
                        for (dy = 0; dy < 2; dy++)
                            for (dx = 0; dx < 2; dx++)
                                if (fabsf(vsd_volume_voxel(vol, gx + dx, gy + dy, gz + dz)) > (t ? 0.3f : 0.0f)) empty = 0;
                    want = skip > 0 ? (skip >= 254 ? 255 : skip + 1) : empty;
                    empty_cells += want == 1;
                    leap_cells += want > 1;
                    sampled_cells += want == 0;
                    if (g.code[c] != want && bad < 10) {
                        bad++;
                        CHECK_MSG(0, "threshold %d: cell %d,%d,%d code %d, expected %d", t, x, y, z, g.code[c], want);
                    }
                }
        CHECK_MSG(empty_cells > 0 && sampled_cells > 0 && (t == 0 || leap_cells > 0),
                  "cell classes: %d empty, %d leap, %d sampled", empty_cells, leap_cells, sampled_cells);
        vsd_dense_grid_free(&g);
        /* a map over other cells is refused, naming the problem */
        other = dm;
        other.dims[0] += 8;
        CHECK(vsd_dense_grid_build(vol, &other, 0.0f, &g, err, sizeof err) == VSD_ERR_INVALID);
        CHECK_CONTAINS(err, "distance map covers other cells");
        CHECK(vsd_dense_grid_build(vol, NULL, -1.0f, &g, err, sizeof err) == VSD_ERR_INVALID);
        CHECK_CONTAINS(err, "threshold -1 must be >= 0");
        vsd_distance_map_free(&dm);
    }
    vsd_volume_destroy(vol);
}

static int load_scene(const char *json, const char *const *ov, int nov, vsd_scene *sc)
{
    char err[1024];
    vsd_status st = vsd_scene_parse(json, "", ov, nov, sc, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "scene: %s", err);
    return st == VSD_OK;
}

static vsd_framebuffer *render_mem(const vsd_scene *sc, const vsd_volume *vol, const vsd_volume *emis,
                                   const vsd_env *env)
{
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    char err[1024];
    vsd_status st = vsd_renderer_create(sc, NULL, &r, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "create: %s", err);
    if (st) return NULL;
    vsd_renderer_use_volume(r, 0, vol, emis, NULL);
    if (env) vsd_renderer_use_env(r, env);
    st = vsd_renderer_render(r, 1, &fb, NULL, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "render: %s", err);
    vsd_renderer_destroy(r);
    return fb;
}

static vsd_framebuffer *render_file(const char *scene, const char *const *ov, int nov, int frame)
{
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    char err[1024];
    vsd_status st = vsd_scene_load(test_data(scene), ov, nov, &sc, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "%s", err);
    if (st) return NULL;
    st = vsd_renderer_create(&sc, NULL, &r, err, sizeof err);
    if (!st) st = vsd_renderer_render(r, frame, &fb, NULL, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "%s", err);
    vsd_renderer_destroy(r);
    return fb;
}

static int fb_identical(const vsd_framebuffer *a, const vsd_framebuffer *b)
{
    int p;
    for (p = 0; p < VSD_PASS_COUNT; p++)
        if (memcmp(a->pass[p], b->pass[p], sizeof(float) * (size_t)a->width * a->height * vsd_pass_channels(p)))
            return 0;
    return 1;
}

static const char *blob_scene =
    "{\"version\":1,\"volume\":{\"file\":\"memory.vdb\"},"
    "\"medium\":{\"density\":20.0,\"albedo\":[0.9,0.8,0.7],\"anisotropy\":0.3,"
    "\"emission_color\":[1,0.5,0.2],\"emission_strength\":2.0},"
    "\"camera\":{\"position\":[0.3,-3.5,1.2],\"look_at\":[0,0,0],\"up\":[0,0,1],\"fov\":0.8},"
    "\"film\":{\"width\":40,\"height\":30,\"transparent\":false},"
    "\"render\":{\"method\":\"constellation\",\"options\":{\"lights\":24,\"shadows\":\"rays\"}}}";

/* A sky-like map: bright lobe (a sun) plus a blue gradient. */
static vsd_env *sky_env(void)
{
    float z[3] = {0, 0, 0};
    vsd_env *e = NULL;
    int x, y;
    CHECK(vsd_env_create_uniform(z, 128, 64, &e, NULL, 0) == VSD_OK);
    if (!e) return NULL;
    for (y = 0; y < 64; y++)
        for (x = 0; x < 128; x++) {
            float *p = e->rgb + 3 * (y * 128 + x);
            float u = (x + 0.5f) / 128, v = (y + 0.5f) / 64;
            float sun = 200.0f * expf(-((u - 0.62f) * (u - 0.62f) + (v - 0.3f) * (v - 0.3f)) / 0.0006f);
            p[0] = 0.3f * (1 - v) + sun;
            p[1] = 0.4f * (1 - v) + 0.9f * sun;
            p[2] = 0.8f * (1 - v) + 0.7f * sun;
        }
    return e;
}

/* Threshold 0: with and without distance map and validity mask, every pass of every
 * pixel is bit-identical (synthetic blobs with emission and an anisotropic phase, 2x2
 * rays, early termination on). Threshold 0.01: the mask drops the faint fringe in front
 * of the first sample above 0.01 and the map leaps over cells whose 8 voxels are all
 * below it, which darkens silhouettes; these blobs are only 4-5 voxels in radius, so the
 * fringe matters: measured 2.5% VolumeDir rel. RMSE, bound 5% (on smoke64 threshold 0.001
 * gives 0.12%, see test_acceleration_exact_smoke). */
static void test_acceleration_exact(void)
{
    vsd_volume *vol = blobs_volume();
    vsd_env *env = sky_env();
    const char *modes[4][2] = {{"render.options.distance_map=false", "render.options.validity_mask=false"},
                               {"render.options.distance_map=true", "render.options.validity_mask=false"},
                               {"render.options.distance_map=false", "render.options.validity_mask=true"},
                               {"render.options.distance_map=true", "render.options.validity_mask=true"}};
    vsd_framebuffer *fb[4] = {NULL, NULL, NULL, NULL}, *thr = NULL;
    int m;
    if (!vol || !env) return;
    for (m = 0; m < 4; m++) {
        vsd_scene sc;
        const char *ov[3] = {modes[m][0], modes[m][1], "render.options.pixel_samples=2"};
        if (!load_scene(blob_scene, ov, 3, &sc)) continue;
        fb[m] = render_mem(&sc, vol, vol, env);
    }
    for (m = 1; m < 4; m++)
        CHECK_MSG(fb[0] && fb[m] && fb_identical(fb[0], fb[m]), "mode %d (dm %s, mask %s) differs from no acceleration",
                  m, modes[m][0], modes[m][1]);
    if (fb[0]) {
        double s = 0, e = 0;
        int i;
        for (i = 0; i < 40 * 30 * 3; i++) {
            s += fb[0]->pass[VSD_PASS_VOLUME_DIR][i];
            e += fb[0]->pass[VSD_PASS_EMIT][i];
        }
        CHECK_MSG(s > 1.0 && e > 0.1, "the test scene is too dark to mean anything (dir %g, emit %g)", s, e);
    }
    {
        vsd_scene sc;
        const char *ov[2] = {"render.options.density_threshold=0.01", "render.options.pixel_samples=2"};
        if (load_scene(blob_scene, ov, 2, &sc)) thr = render_mem(&sc, vol, vol, env);
        if (thr && fb[0]) {
            double e = 1;
            CHECK(vsd_block_rel_rmse(thr->pass[VSD_PASS_VOLUME_DIR], fb[0]->pass[VSD_PASS_VOLUME_DIR], 40, 30, 3, 3, 1,
                                     &e, NULL, 0) == VSD_OK);
            printf("threshold 0.01 vs exact (blobs): VolumeDir rel. RMSE %.5f\n", e);
            CHECK_MSG(e > 0 && e < 0.05, "threshold 0.01: VolumeDir rel. RMSE %.5f not in (0, 0.05)", e);
        }
    }
    for (m = 0; m < 4; m++) vsd_framebuffer_destroy(fb[m]);
    vsd_framebuffer_destroy(thr);
    vsd_env_destroy(env);
    vsd_volume_destroy(vol);
}

/* The same on real data: smoke64 frame 24 at 48x27, accelerations on and off, identical;
 * threshold 0.001 within 0.5% (measured 0.11% at 128x128). */
static void test_acceleration_exact_smoke(void)
{
    const char *base[4] = {"film.width=48", "film.height=27", "render.method=constellation",
                           "render.options.shadows=\"rays\""};
    const char *ov_off[6] = {base[0], base[1], base[2], base[3], "render.options.distance_map=false",
                             "render.options.validity_mask=false"};
    const char *ov_thr[5] = {base[0], base[1], base[2], base[3], "render.options.density_threshold=0.001"};
    /* cached shadows: the lighting stage's shadow rays leap the same way */
    const char *grid_on[3] = {base[0], base[1], base[2]};
    const char *grid_off[4] = {base[0], base[1], base[2], "render.options.distance_map=false"};
    vsd_framebuffer *on = render_file("scenes/smoke64_sunset.json", base, 4, 24);
    vsd_framebuffer *off = render_file("scenes/smoke64_sunset.json", ov_off, 6, 24);
    vsd_framebuffer *thr = render_file("scenes/smoke64_sunset.json", ov_thr, 5, 24);
    vsd_framebuffer *g_on = render_file("scenes/smoke64_sunset.json", grid_on, 3, 24);
    vsd_framebuffer *g_off = render_file("scenes/smoke64_sunset.json", grid_off, 4, 24);
    CHECK_MSG(g_on && g_off && fb_identical(g_on, g_off), "smoke64, cached shadows: distance map changes the image");
    vsd_framebuffer_destroy(g_on);
    vsd_framebuffer_destroy(g_off);
    CHECK_MSG(on && off && fb_identical(on, off), "smoke64: accelerated image differs at threshold 0");
    if (thr && off) {
        double e = 1;
        CHECK(vsd_block_rel_rmse(thr->pass[VSD_PASS_VOLUME_DIR], off->pass[VSD_PASS_VOLUME_DIR], 48, 27, 3, 3, 1, &e,
                                 NULL, 0) == VSD_OK);
        printf("smoke64 threshold 0.001 vs exact: VolumeDir rel. RMSE %.5f\n", e);
        CHECK_MSG(e < 0.005, "threshold 0.001: VolumeDir rel. RMSE %.5f >= 0.005", e);
    }
    vsd_framebuffer_destroy(on);
    vsd_framebuffer_destroy(off);
    vsd_framebuffer_destroy(thr);
}

static void rot_z(double th, double r[16])
{
    double c = cos(th), s = sin(th);
    double m[16] = {c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    memcpy(r, m, sizeof m);
}

/* Turning the environment by theta about Z (rotation_z = -theta: the Mapping node rotates
 * the lookup, so the visible map turns the other way) equals turning the volume and the
 * camera by -theta, the environment fixed: the constellation is rotated, not rebuilt, and
 * the shells, shadow rays and distance map are rigid-motion invariant. Agreement to float
 * rounding of the transformed positions (< 2e-3 rel. RMSE per pixel; measured ~1e-4). */
static void test_rotation_equivalence(void)
{
    vsd_volume *vol = blobs_volume();
    vsd_env *env = sky_env();
    const double theta = 0.9;
    vsd_scene a, b;
    const char *ov[1] = {"render.options.pixel_samples=1"};
    vsd_framebuffer *fa = NULL, *fb = NULL;
    if (!vol || !env) return;
    if (load_scene(blob_scene, ov, 1, &a) && load_scene(blob_scene, ov, 1, &b)) {
        double r[16];
        a.environment.rotation_z = (float)-theta;
        rot_z(-theta, r);
        vsd_mat4_mul(r, b.volumes[0].matrix, b.volumes[0].matrix);
        vsd_mat4_mul(r, b.camera.matrix, b.camera.matrix);
        fa = render_mem(&a, vol, vol, env);
        fb = render_mem(&b, vol, vol, env);
    }
    if (fa && fb) {
        double e = 1, et = 1, s = 0;
        int i;
        CHECK(vsd_block_rel_rmse(fa->pass[VSD_PASS_VOLUME_DIR], fb->pass[VSD_PASS_VOLUME_DIR], 40, 30, 3, 3, 1, &e, NULL,
                                 0) == VSD_OK);
        CHECK(vsd_block_rel_rmse(fa->pass[VSD_PASS_TRANSMITTANCE], fb->pass[VSD_PASS_TRANSMITTANCE], 40, 30, 3, 3, 1,
                                 &et, NULL, 0) == VSD_OK);
        for (i = 0; i < 40 * 30 * 3; i++) s += fa->pass[VSD_PASS_VOLUME_DIR][i];
        printf("environment turned by theta vs volume+camera turned by -theta: VolumeDir %.2e, Transmittance %.2e\n", e,
               et);
        CHECK_MSG(e < 2e-3 && et < 2e-3, "rotation: VolumeDir %.3g, Transmittance %.3g", e, et);
        CHECK(s > 1.0);
        /* and the rotation matters: without turning the volume the image changes a lot */
        {
            vsd_scene c = a;
            vsd_framebuffer *fc;
            c.environment.rotation_z = 0;
            fc = render_mem(&c, vol, vol, env);
            if (fc) {
                CHECK(vsd_block_rel_rmse(fc->pass[VSD_PASS_VOLUME_DIR], fa->pass[VSD_PASS_VOLUME_DIR], 40, 30, 3, 3, 1,
                                         &e, NULL, 0) == VSD_OK);
                CHECK_MSG(e > 0.05, "rotating the environment changed VolumeDir by only %.4f", e);
            }
            vsd_framebuffer_destroy(fc);
        }
    }
    vsd_framebuffer_destroy(fa);
    vsd_framebuffer_destroy(fb);
    vsd_env_destroy(env);
    vsd_volume_destroy(vol);
}

/* Options are validated: unknown keys, wrong types, out-of-range values. */
static void test_options(void)
{
    const char *bad[][2] = {
        {"render.options.lights=0", "out of range"},
        {"render.options.lights=2.5", "expected integer"},
        {"render.options.lights_method=voronoi", "not one of"},
        {"render.options.distance_map=1", "expected boolean"},
        {"render.options.slice=-1", "out of range"},
        {"render.options.early_termination=2", "out of range"},
        {"render.options.step=1", "unknown option"},
        {"render.options={\"lights\":65}", "more than the 64 lights"},
        {"render.options.shadows=\"maps\"", "not one of"},
        {"render.options.density_threshold=\"x\"", "expected a finite number"},
    };
    size_t i;
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        vsd_scene sc;
        vsd_renderer *r = NULL;
        char err[1024] = "";
        const char *ov[1] = {bad[i][0]};
        if (!load_scene(blob_scene, ov, 1, &sc)) continue;
        CHECK_MSG(vsd_renderer_create(&sc, NULL, &r, err, sizeof err) != VSD_OK, "%s accepted", bad[i][0]);
        CHECK_CONTAINS(err, bad[i][1]);
        vsd_renderer_destroy(r);
    }
}

/* Single scattering against the path tracer's VolumeDir at 48x27 through the harness
 * (common/method_vs_reference.h: the mean of two reference seeds, its noise measured from
 * them in the same run, tolerance >= 3x that noise, the pass scaled by 0.9 as the control
 * that must fail). Constellation: 64 lights, 2x2 rays per pixel, grid and ray shadows.
 * Measured (2026-12-03, CPU): against 2 x 2048 spp, noise of the mean 0.0104 (smoke64) and
 * 0.0101 (cloud128), constellation 0.0379 / 0.0364 (smoke64 grid / rays) and 0.0251 / 0.0244
 * (cloud128), so about 0.036 and 0.023 of the error are the method's own; against
 * 2 x 1024 spp (what runs here, the references' cost of the old 1 x 1024 spp check x2) noise
 * 0.0146 / 0.0135 (3x 0.044 / 0.041), constellation 0.0386 / 0.0378 and 0.0262 / 0.0256,
 * controls 0.194 / 0.147. The old bound, 7% on both against one 1024 spp reference with no noise check,
 * sat 2-3x above the errors and under 3x that reference's noise (0.027 each: the pair's
 * difference at 64x36, 3.8% / 2.9%, over sqrt 2). Now 0.05 smoke64 (1.3x its error, above
 * 3x noise), 0.045 cloud128 (3x noise sets it: 1.7x its error). */
#define CST_REF_SPP 1024
#define TOL_SMOKE 0.05
#define TOL_CLOUD 0.045
static void test_against_reference(void)
{
    const char *scenes[2] = {"scenes/smoke64_sunset.json", "scenes/cloud128_interior.json"};
    const char *labels[2][2] = {{"smoke64 constellation (grid)", "smoke64 constellation (rays)"},
                                {"cloud128 constellation (grid)", "cloud128 constellation (rays)"}};
    const char *shadows[2] = {"render.options.shadows=\"grid\"", "render.options.shadows=\"rays\""};
    const int frames[2] = {24, 1};
    const double bound[2] = {TOL_SMOKE, TOL_CLOUD};
    int s, m;
    for (s = 0; s < 2; s++) {
        const char *ov_ref[2] = {"film.width=48", "film.height=27"};
        const mvr_scene sc = {scenes[s], NULL, NULL, NULL, frames[s]};
        mvr_refs refs;
        if (!mvr_render_references(&sc, ov_ref, 2, CST_REF_SPP, &refs)) {
            mvr_refs_free(&refs);
            continue;
        }
        for (m = 0; m < 2; m++) {
            const char *ov_cst[5] = {"film.width=48", "film.height=27", "render.method=constellation", "render.options.pixel_samples=2", shadows[m]};
            vsd_framebuffer *cst = mvr_render(&sc, ov_cst, 5, NULL, NULL);
            CHECK(cst != NULL);
            if (cst) {
                double et = mvr_error(cst, &refs, VSD_PASS_TRANSMITTANCE);
                mvr_check(labels[s][m], cst, &refs, VSD_PASS_VOLUME_DIR, bound[s], 0.9);
                printf("    %s: Transmittance %.4f\n", labels[s][m], et);
                CHECK_MSG(et < 0.02, "%s: Transmittance rel. RMSE %.4f >= 0.02", labels[s][m], et);
            }
            vsd_framebuffer_destroy(cst);
        }
        mvr_refs_free(&refs);
    }
}

int main(void)
{
    test_shadow_grid_shape();
    test_edt_exact();
    test_leap_is_safe();
    test_dense_grid();
    test_options();
    test_acceleration_exact();
    test_acceleration_exact_smoke();
    test_rotation_equivalence();
    test_against_reference();
    return test_finish("test_constellation");
}
