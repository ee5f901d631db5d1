/* The OpenVDB loader (vsd/vdbio.h) on every .vdb file of the shared data: each grid loads
 * with the count, bounds and transform OpenVDB reports (vsd_vdb_list reads them from the
 * file's own statistics, a path independent of the loader), values land where the index
 * says (pool sum == sum over the index bbox, non-zero bbox == active bbox), majorants bound
 * the field, and every broken input gets its status and a message naming file and problem. */
#include "test_common.h"

#include "vsd/vdbio.h"

#include <dirent.h>
#include <float.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <time.h>

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static uint64_t rng_state = 0x2545F4914F6CDD1Dull;
static double rnd(void)
{
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (double)((rng_state * 2685821657736338717ull) >> 11) / 9007199254740992.0;
}

static vsd_grid_select by_name(const char *name)
{
    vsd_grid_select s = {name, -1};
    return s;
}

static vsd_grid_select by_index(int index)
{
    vsd_grid_select s = {NULL, index};
    return s;
}

/* ---- invariants of one loaded grid against its listing ----------------------------------- */

typedef struct nz_stats {
    uint64_t count;
    double sum;
    int32_t lo[3], hi[3];
} nz_stats;

/* Walk the pool: count, sum and index bbox of the non-zero voxels. */
static nz_stats pool_stats(const vsd_volume *vol)
{
    nz_stats s = {0, 0.0, {INT32_MAX, INT32_MAX, INT32_MAX}, {INT32_MIN, INT32_MIN, INT32_MIN}};
    size_t cell = 0;
    for (int bz = 0; bz < vol->brick_dims[2]; ++bz)
        for (int by = 0; by < vol->brick_dims[1]; ++by)
            for (int bx = 0; bx < vol->brick_dims[0]; ++bx, ++cell) {
                const int32_t slot = vol->brick_slots[cell];
                if (slot < 0)
                    continue;
                const float *v = vol->voxels + (size_t)slot * VSD_BRICK_VOXELS;
                for (int n = 0; n < VSD_BRICK_VOXELS; ++n) {
                    if (v[n] == 0.0f)
                        continue;
                    const int32_t p[3] = {vol->origin[0] + 8 * bx + (n & 7),
                                          vol->origin[1] + 8 * by + ((n >> 3) & 7),
                                          vol->origin[2] + 8 * bz + (n >> 6)};
                    for (int a = 0; a < 3; ++a) {
                        if (p[a] < s.lo[a]) s.lo[a] = p[a];
                        if (p[a] > s.hi[a]) s.hi[a] = p[a];
                    }
                    s.count++;
                    s.sum += v[n];
                }
            }
    return s;
}

/* The same sum the slow way: vsd_volume_voxel over the listed index bbox. */
static double bbox_sum(const vsd_volume *vol, const vsd_grid_info *g)
{
    double sum = 0.0;
    for (int32_t k = g->index_bbox_min[2]; k <= g->index_bbox_max[2]; ++k)
        for (int32_t j = g->index_bbox_min[1]; j <= g->index_bbox_max[1]; ++j)
            for (int32_t i = g->index_bbox_min[0]; i <= g->index_bbox_max[0]; ++i)
                sum += vsd_volume_voxel(vol, i, j, k);
    return sum;
}

/* Majorants: a sample of cells against the 9^3 brute force, random points against their cell. */
static void check_ranges(const char *what, const vsd_volume *vol)
{
    const int ncell = vol->brick_dims[0] * vol->brick_dims[1] * vol->brick_dims[2];
    int bad = 0, above = 0, below = 0;
    for (int t = 0; t < 300 && ncell > 0; ++t) {
        const int cell = ncell <= 300 ? t % ncell : (int)(rnd() * ncell);
        const int c[3] = {cell % vol->brick_dims[0], (cell / vol->brick_dims[0]) % vol->brick_dims[1],
                          cell / (vol->brick_dims[0] * vol->brick_dims[1])};
        float lo = FLT_MAX, hi = -FLT_MAX;
        for (int z = 0; z <= 8; ++z)
            for (int y = 0; y <= 8; ++y)
                for (int x = 0; x <= 8; ++x) {
                    const float v = vsd_volume_voxel(vol, vol->origin[0] + 8 * c[0] + x,
                                                     vol->origin[1] + 8 * c[1] + y, vol->origin[2] + 8 * c[2] + z);
                    lo = v < lo ? v : lo;
                    hi = v > hi ? v : hi;
                }
        bad += lo != vol->brick_min[cell] || hi != vol->brick_max[cell];
    }
    for (int t = 0; t < 5000 && ncell > 0; ++t) {
        double p[3];
        int c[3];
        for (int a = 0; a < 3; ++a) {
            p[a] = vol->origin[a] + rnd() * 8.0 * vol->brick_dims[a];
            c[a] = (int)floor((p[a] - vol->origin[a]) / 8.0);
        }
        const size_t cell = (size_t)c[0] + (size_t)vol->brick_dims[0] * ((size_t)c[1] + (size_t)vol->brick_dims[1] * c[2]);
        const float s = vsd_volume_sample_index(vol, p);
        above += s > vol->brick_max[cell];
        below += s < vol->brick_min[cell];
    }
    CHECK_MSG(bad == 0, "%s: %d cells whose range differs from the 9^3 brute force", what, bad);
    CHECK_MSG(above == 0 && below == 0, "%s: %d samples above brick_max, %d below brick_min", what, above, below);
}

/* The loader's world placement (vol->index_to_world) against the listing's (OpenVDB's
 * transform): world_bounds holds the listed box and exceeds it by less than a brick; the
 * box of the non-zero voxels' cells matches the listed box when every active voxel is
 * non-zero (then the two boxes are the same voxels). */
static void check_world(const char *what, const vsd_volume *vol, const vsd_grid_info *g, const nz_stats *nz)
{
    double lo[3], hi[3];
    vsd_volume_world_bounds(vol, NULL, lo, hi);
    for (int a = 0; a < 3; ++a) {
        const double tol = 1e-6 * (1.0 + fabs(g->world_bbox_min[a]) + fabs(g->world_bbox_max[a]));
        const double brick = 8.0 * g->voxel_size[a];
        CHECK_MSG(lo[a] <= g->world_bbox_min[a] + tol && hi[a] >= g->world_bbox_max[a] - tol,
                  "%s axis %d: world bounds [%g, %g] do not hold the listed box [%g, %g]", what, a,
                  lo[a], hi[a], g->world_bbox_min[a], g->world_bbox_max[a]);
        CHECK_MSG(lo[a] >= g->world_bbox_min[a] - brick - tol && hi[a] <= g->world_bbox_max[a] + brick + tol,
                  "%s axis %d: world bounds [%g, %g] exceed the listed box [%g, %g] by a brick", what,
                  a, lo[a], hi[a], g->world_bbox_min[a], g->world_bbox_max[a]);
    }
    if (nz->count != g->active_voxels)
        return;
    double wlo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, whi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    for (int n = 0; n < 8; ++n) {
        const double p[3] = {n & 1 ? nz->hi[0] + 0.5 : nz->lo[0] - 0.5, n & 2 ? nz->hi[1] + 0.5 : nz->lo[1] - 0.5,
                             n & 4 ? nz->hi[2] + 0.5 : nz->lo[2] - 0.5};
        const double *m = vol->index_to_world;
        for (int r = 0; r < 3; ++r) {
            const double w = m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3];
            wlo[r] = w < wlo[r] ? w : wlo[r];
            whi[r] = w > whi[r] ? w : whi[r];
        }
    }
    for (int a = 0; a < 3; ++a) {
        const double tol = 1e-6 * (1.0 + fabs(wlo[a]) + fabs(whi[a]));
        CHECK_NEAR(wlo[a], g->world_bbox_min[a], tol);
        CHECK_NEAR(whi[a], g->world_bbox_max[a], tol);
    }
}

static void check_loaded(const char *path, const vsd_grid_info *g, const vsd_volume *vol)
{
    char what[4400];
    snprintf(what, sizeof what, "%.4000s grid '%.255s'", path, g->name);
    CHECK_MSG(vol->active_voxels == g->active_voxels, "%s: %llu active voxels loaded, %llu listed", what,
              (unsigned long long)vol->active_voxels, (unsigned long long)g->active_voxels);
    CHECK(strcmp(vol->grid_name, g->name) == 0);
    CHECK(strcmp(vol->file, path) == 0);
    for (int a = 0; a < 3; ++a)
        CHECK_NEAR(vol->voxel_size[a], g->voxel_size[a], 1e-9 * g->voxel_size[a]);
    if (g->active_voxels == 0) {
        CHECK(vol->brick_dims[0] == 0 && vol->brick_dims[1] == 0 && vol->brick_dims[2] == 0);
        CHECK(vol->brick_count == 0);
        CHECK(g->index_bbox_min[0] > g->index_bbox_max[0]);
        return;
    }
    for (int a = 0; a < 3; ++a) {
        CHECK(vol->origin[a] % 8 == 0);
        /* one voxel of room below (trilinear support) and the whole box covered */
        CHECK(vol->origin[a] <= g->index_bbox_min[a] - 1);
        CHECK(vol->origin[a] + 8 * vol->brick_dims[a] > g->index_bbox_max[a]);
        CHECK(vol->origin[a] > g->index_bbox_min[a] - 1 - 8);
    }
    const nz_stats nz = pool_stats(vol);
    CHECK_MSG(nz.count <= g->active_voxels, "%s: %llu non-zero voxels > %llu active", what,
              (unsigned long long)nz.count, (unsigned long long)g->active_voxels);
    for (int a = 0; a < 3 && nz.count; ++a) {
        CHECK_MSG(nz.lo[a] >= g->index_bbox_min[a] && nz.hi[a] <= g->index_bbox_max[a],
                  "%s axis %d: non-zero voxels [%d, %d] outside the active bbox [%d, %d]", what, a,
                  nz.lo[a], nz.hi[a], g->index_bbox_min[a], g->index_bbox_max[a]);
        if (nz.count == g->active_voxels)   /* then both boxes bound the same voxels */
            CHECK_MSG(nz.lo[a] == g->index_bbox_min[a] && nz.hi[a] == g->index_bbox_max[a],
                      "%s axis %d: non-zero bbox [%d, %d] != active bbox [%d, %d]", what, a, nz.lo[a],
                      nz.hi[a], g->index_bbox_min[a], g->index_bbox_max[a]);
    }
    const double slow = bbox_sum(vol, g);
    CHECK_MSG(fabs(slow - nz.sum) <= 1e-9 * (1.0 + fabs(nz.sum)), "%s: pool sum %.17g, bbox sum %.17g", what,
              nz.sum, slow);
    CHECK(vol->value_max >= vol->value_min);
    check_ranges(what, vol);
    check_world(what, vol, g, &nz);
}

/* ---- every file ---------------------------------------------------------------------------- */

static int files_checked, grids_loaded;

static void check_file(const char *path)
{
    vsd_grid_info *grids = NULL;
    int count = -1;
    char err[2048] = "";
    const vsd_status st = vsd_vdb_list(path, &grids, &count, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "%s: %s", path, err);
    if (st != VSD_OK)
        return;
    CHECK(count > 0);
    files_checked++;
    for (int i = 0; i < count; ++i) {
        const vsd_grid_info *g = &grids[i];
        vsd_volume *vol = NULL;
        const vsd_status ls = vsd_vdb_load(path, by_index(i), &vol, err, sizeof err);
        const int scalar = !strcmp(g->type, "float") || !strcmp(g->type, "double");
        if (!scalar) {
            CHECK_MSG(ls == VSD_ERR_TYPE, "%s grid %d (%s): status %s", path, i, g->type, vsd_status_str(ls));
            CHECK_CONTAINS(err, g->type);
            CHECK_CONTAINS(err, path);
            CHECK(vol == NULL);
            continue;
        }
        CHECK_MSG(ls == VSD_OK, "%s grid %d: %s", path, i, err);
        if (vol) {
            check_loaded(path, g, vol);
            grids_loaded++;
        }
        vsd_volume_destroy(vol);
    }
    vsd_vdb_list_free(grids);
}

static int ends_with(const char *s, const char *suffix)
{
    const size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcmp(s + n - m, suffix);
}

static void check_every_file(void)
{
    static const char *dirs[] = {"smoke64", "smoke128", "fire96", "cloud", "external"};
    for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; ++d) {
        char dir[2048];
        snprintf(dir, sizeof dir, "%s", test_data(dirs[d]));
        DIR *h = opendir(dir);
        CHECK_MSG(h != NULL, "cannot list %s", dir);
        if (!h)
            continue;
        struct dirent *e;
        while ((e = readdir(h)) != NULL) {
            if (!ends_with(e->d_name, ".vdb"))
                continue;
            char path[4200];
            snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
            check_file(path);
        }
        closedir(h);
    }
    printf("checked %d files, %d float grids\n", files_checked, grids_loaded);
    CHECK(files_checked >= 44);
}

/* ---- what the data README documents --------------------------------------------------------- */

static vsd_volume *load_ok(const char *rel, vsd_grid_select sel)
{
    vsd_volume *vol = NULL;
    char err[2048] = "";
    const vsd_status st = vsd_vdb_load(test_data(rel), sel, &vol, err, sizeof err);
    CHECK_MSG(st == VSD_OK && vol, "%s: %s", rel, err);
    return vol;
}

static int find_grid(const vsd_grid_info *g, int n, const char *name)
{
    for (int i = 0; i < n; ++i)
        if (!strcmp(g[i].name, name))
            return i;
    return -1;
}

static void test_smoke64(void)
{
    const char *path = test_data("smoke64/fluid_data_0001.vdb");
    vsd_grid_info *g = NULL;
    int n = 0;
    CHECK(vsd_vdb_list(path, &g, &n, NULL, 0) == VSD_OK);
    CHECK(n == 5);
    const int d = find_grid(g, n, "density"), s = find_grid(g, n, "shadow");
    CHECK(d >= 0 && s >= 0 && find_grid(g, n, "flame") >= 0 && find_grid(g, n, "velocity") >= 0);
    if (d >= 0) {
        CHECK(!strcmp(g[d].type, "float"));
        CHECK(g[d].active_voxels == 3456);
        CHECK(g[d].half_float == 1);
        CHECK_CONTAINS(g[d].compression, "blosc");
        CHECK(g[d].index_bbox_min[0] == 21 && g[d].index_bbox_min[2] == 2 && g[d].index_bbox_max[1] == 42 &&
              g[d].index_bbox_max[2] == 23);
        CHECK_NEAR(g[d].voxel_size[0], 2.0 / 64, 1e-12);
        CHECK_NEAR(g[d].world_bbox_min[2], 1.5 / 32, 1e-12);   /* voxel cells: (2 - 1/2) * 2/64 */
        CHECK_NEAR(g[d].world_bbox_max[0], 42.5 / 32, 1e-12);
    }
    vsd_volume *vol = load_ok("smoke64/fluid_data_0001.vdb", by_name(NULL));   /* first float grid */
    if (vol) {
        CHECK(!strcmp(vol->grid_name, "density"));   /* grid 0 is 'velocity' (vec3s) */
        CHECK(vol->value_min >= 0.0f && vol->value_max > 0.0f && vol->value_max <= 1.5f);
        vsd_volume_destroy(vol);
    }
    /* 'shadow' is all active tiles (no leaves): they must become bricks. */
    vol = load_ok("smoke64/fluid_data_0001.vdb", by_name("shadow"));
    if (vol && s >= 0) {
        CHECK(vol->active_voxels == 64 * 64 * 64 && g[s].active_voxels == 64 * 64 * 64);
        const nz_stats nz = pool_stats(vol);
        CHECK_MSG(nz.count > 0 && vol->brick_count > 0, "tiles were not densified");
        CHECK_MSG(vol->brick_count == 512 || nz.count < 64 * 64 * 64, "%d bricks", vol->brick_count);
    }
    vsd_volume_destroy(vol);
    /* 'flame' is empty in this frame: an empty volume, not an error. */
    vol = load_ok("smoke64/fluid_data_0001.vdb", by_name("flame"));
    if (vol) {
        CHECK(vol->brick_dims[0] == 0 && vol->brick_count == 0 && vol->active_voxels == 0);
        CHECK_NEAR(vol->index_to_world[0], 2.0 / 64, 1e-12);
        double lo[3], hi[3];
        vsd_volume_world_bounds(vol, NULL, lo, hi);
        CHECK(lo[0] > hi[0]);
    }
    vsd_volume_destroy(vol);
    vsd_vdb_list_free(g);
}

static void test_arnold_grids(void)
{
    const char *path = test_data("external/arnold_grids.vdb");
    vsd_grid_info *g = NULL;
    int n = 0;
    CHECK(vsd_vdb_list(path, &g, &n, NULL, 0) == VSD_OK);
    CHECK(n == 3);
    vsd_volume *v[3] = {NULL, NULL, NULL};
    for (int i = 0; i < 3 && i < n; ++i) {
        CHECK(!strcmp(g[i].name, "density"));
        v[i] = load_ok("external/arnold_grids.vdb", by_index(i));
        if (v[i])
            CHECK(v[i]->active_voxels == g[i].active_voxels);
    }
    if (v[0] && v[1] && v[2]) {
        /* three different grids: different voxel counts and different placements */
        CHECK(v[0]->active_voxels != v[1]->active_voxels && v[1]->active_voxels != v[2]->active_voxels &&
              v[0]->active_voxels != v[2]->active_voxels);
        const double t0 = v[0]->index_to_world[3], t1 = v[1]->index_to_world[3], t2 = v[2]->index_to_world[3];
        CHECK(t0 != t1 && t1 != t2 && t0 != t2);
        CHECK_NEAR(t0 + t1 + t2, 6.0, 1e-9);   /* x translations 0, 2 and 4 */
        /* by name: the first of them */
        vsd_volume *first = load_ok("external/arnold_grids.vdb", by_name("density"));
        if (first)
            CHECK(first->active_voxels == v[0]->active_voxels && first->index_to_world[3] == t0);
        vsd_volume_destroy(first);
        /* name and index together must agree; "density[1]" is OpenVDB's unique name */
        vsd_grid_select both = {"density", 2};
        vsd_volume *third = load_ok("external/arnold_grids.vdb", both);
        if (third)
            CHECK(third->active_voxels == v[2]->active_voxels);
        vsd_volume_destroy(third);
        vsd_volume *second = load_ok("external/arnold_grids.vdb", by_name("density[1]"));
        if (second)
            CHECK(second->active_voxels == v[1]->active_voxels);
        vsd_volume_destroy(second);
    }
    for (int i = 0; i < 3; ++i)
        vsd_volume_destroy(v[i]);
    vsd_vdb_list_free(g);
}

static void test_external(void)
{
    /* a grid not called density: the default picks it, "density" lists it */
    vsd_volume *vol = load_ok("external/arnold_torus01.vdb", by_name(""));
    if (vol) {
        CHECK(!strcmp(vol->grid_name, "voxel_fog_density"));
        CHECK(vol->active_voxels == 2450);
        vsd_volume_destroy(vol);
    }
    /* half floats, a transform with its own translation */
    vol = load_ok("external/gaffer_smoke.vdb", by_name("density"));
    if (vol) {
        CHECK(vol->active_voxels == 1049275);
        CHECK_NEAR(vol->voxel_size[0], 10.0 / 21.0, 1e-6);
        /* OpenVDB keeps the translation in the last row; vsd in the last column */
        CHECK_NEAR(vol->index_to_world[3], -34.047619, 1e-5);
        CHECK_NEAR(vol->index_to_world[7], -13.095238, 1e-5);
        CHECK_NEAR(vol->index_to_world[11], -26.428571, 1e-5);
        CHECK(vol->index_to_world[12] == 0.0 && vol->index_to_world[15] == 1.0);
        CHECK(vol->value_max > 0.0f);
        vsd_volume_destroy(vol);
    }
    vsd_grid_info *g = NULL;
    int n = 0;
    CHECK(vsd_vdb_list(test_data("external/gaffer_smoke.vdb"), &g, &n, NULL, 0) == VSD_OK);
    if (n == 1) {
        CHECK(g[0].half_float == 1);
        CHECK(g[0].index_bbox_max[0] - g[0].index_bbox_min[0] + 1 == 111);
        CHECK(g[0].index_bbox_max[1] - g[0].index_bbox_min[1] + 1 == 222);
        CHECK(g[0].index_bbox_max[2] - g[0].index_bbox_min[2] + 1 == 112);
        CHECK_NEAR(g[0].world_bbox_min[0], -34.047619 + 0.5 * (10.0 / 21.0), 1e-5);
    }
    vsd_vdb_list_free(g);
    /* the emission grid */
    vol = load_ok("external/usd_densityAndHeat.vdb", by_name("heat"));
    if (vol) {
        CHECK(vol->active_voxels == 5224);
        CHECK(!strcmp(vol->grid_name, "heat"));
        CHECK(vol->value_max > 0.0f);
        CHECK(fabs(vol->voxel_size[2] - vol->voxel_size[0]) > 0.01);   /* non-uniform scale */
        vsd_volume_destroy(vol);
    }
    /* all grids empty: an empty volume */
    vol = load_ok("external/usd_smoke_000001.vdb", by_name("density"));
    if (vol) {
        CHECK(vol->brick_dims[0] == 0 && vol->brick_dims[1] == 0 && vol->brick_dims[2] == 0);
        CHECK(vol->active_voxels == 0 && vol->brick_count == 0);
        vsd_volume_destroy(vol);
    }
    vol = load_ok("external/usd_smoke_000003.vdb", by_name("density"));
    if (vol) {
        CHECK(vol->active_voxels == 90197);
        vsd_volume_destroy(vol);
    }
}

/* ---- errors ------------------------------------------------------------------------------- */

static void expect_error(const char *path, vsd_grid_select sel, vsd_status want, const char *problem)
{
    vsd_volume *vol = (vsd_volume *)1;
    char err[2048] = "";
    const vsd_status st = vsd_vdb_load(path, sel, &vol, err, sizeof err);
    CHECK_MSG(st == want, "%s: got %s (%s), want %s", path, vsd_status_str(st), err, vsd_status_str(want));
    CHECK(vol == NULL);
    CHECK_CONTAINS(err, path);
    CHECK_CONTAINS(err, problem);
    if (st == VSD_OK)
        vsd_volume_destroy(vol);
}

/* The listing fails the same way as the load on files that are broken as a whole. */
static void expect_list_error(const char *path, vsd_status want, const char *problem)
{
    vsd_grid_info *g = (vsd_grid_info *)1;
    int n = -1;
    char err[2048] = "";
    const vsd_status st = vsd_vdb_list(path, &g, &n, err, sizeof err);
    CHECK_MSG(st == want, "list %s: got %s (%s)", path, vsd_status_str(st), err);
    CHECK(g == NULL && n == 0);
    CHECK_CONTAINS(err, path);
    CHECK_CONTAINS(err, problem);
}

/* First `len` bytes of src into dst (a temp copy: the data folder is read-only). */
static int copy_prefix(const char *src, const char *dst, long len)
{
    FILE *in = fopen(src, "rb"), *out = fopen(dst, "wb");
    int ok = in && out;
    char buf[65536];
    while (ok && len > 0) {
        const size_t want = len < (long)sizeof buf ? (size_t)len : sizeof buf;
        const size_t got = fread(buf, 1, want, in);
        ok = got == want && fwrite(buf, 1, got, out) == got;
        len -= (long)got;
    }
    if (in) fclose(in);
    if (out && fclose(out) != 0) ok = 0;
    return ok;
}

static long file_size(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long)sb.st_size : -1;
}

static void test_errors(void)
{
    char src[2048], path[2048];
    snprintf(src, sizeof src, "%s", test_data("smoke64/fluid_data_0001.vdb"));

    snprintf(path, sizeof path, "%s", test_data("smoke64/no_such_frame.vdb"));
    expect_error(path, by_name("density"), VSD_ERR_IO, "no such file");
    expect_list_error(path, VSD_ERR_IO, "no such file");

    snprintf(path, sizeof path, "%s", test_data("env/sunset.exr"));
    expect_error(path, by_name("density"), VSD_ERR_FORMAT, "not an OpenVDB file");
    expect_list_error(path, VSD_ERR_FORMAT, "not an OpenVDB file");

    snprintf(path, sizeof path, "%s", test_data("smoke64"));
    expect_error(path, by_name("density"), VSD_ERR_IO, "not a regular file");

    /* truncated at several places: in the header, in the middle, in the last grid */
    const long size = file_size(src);
    const long cuts[] = {0, 4, 10, 60, size / 2, size - 100, size - 1};
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; ++i) {
        char name[64];
        snprintf(name, sizeof name, "truncated_%ld.vdb", cuts[i]);
        snprintf(path, sizeof path, "%s", test_tmp(name));
        CHECK(copy_prefix(src, path, cuts[i]));
        /* an empty file is nothing; 4 bytes of VDB magic are the start of a VDB */
        const char *problem = cuts[i] == 0 ? "not an OpenVDB file" : "truncated";
        expect_error(path, by_name("density"), VSD_ERR_FORMAT, problem);
        expect_error(path, by_index(4), VSD_ERR_FORMAT, problem);
        expect_list_error(path, VSD_ERR_FORMAT, problem);
        remove(path);
    }

    /* no such grid: the message lists what is there */
    vsd_volume *vol = NULL;
    char err[2048] = "";
    CHECK(vsd_vdb_load(src, by_name("smoke"), &vol, err, sizeof err) == VSD_ERR_NOT_FOUND);
    CHECK_CONTAINS(err, src);
    CHECK_CONTAINS(err, "'smoke'");
    CHECK_CONTAINS(err, "density");
    CHECK_CONTAINS(err, "'velocity' (vec3s)");
    expect_error(src, by_index(5), VSD_ERR_NOT_FOUND, "no grid at index 5");
    vsd_grid_select wrong = {"density", 0};
    expect_error(src, wrong, VSD_ERR_NOT_FOUND, "'velocity', not 'density'");
    snprintf(path, sizeof path, "%s", test_data("external/arnold_torus01.vdb"));
    expect_error(path, by_name("density"), VSD_ERR_NOT_FOUND, "voxel_fog_density");

    /* not a float grid: the message names the type */
    expect_error(src, by_name("velocity"), VSD_ERR_TYPE, "vec3s");
    snprintf(path, sizeof path, "%s", test_data("external/usd_smoke_000001.vdb"));
    expect_error(path, by_name("obstacles"), VSD_ERR_TYPE, "int32");

    /* bad arguments */
    CHECK(vsd_vdb_load(NULL, by_name("density"), &vol, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(vsd_vdb_load(src, by_name("density"), NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(vsd_vdb_list(src, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
}

/* Structural damage (lengths and counts that point past the end of the file) is caught by the
 * loader's own scan before OpenVDB sees the file. Damage inside the tree: test_tiny_trees and
 * test_corrupt_tree below. */
static void test_corrupt_structure(void)
{
    const char *src = test_data("smoke64/fluid_data_0001.vdb");
    char path[2048];
    snprintf(path, sizeof path, "%s", test_tmp("corrupt.vdb"));
    /* header: magic 8, format 4, library 2x4, offsets flag 1, uuid 36 -> file metadata at 57 */
    const long at[] = {57, 61};
    for (size_t i = 0; i < sizeof at / sizeof at[0]; ++i) {
        CHECK(copy_prefix(src, path, file_size(src)));
        FILE *f = fopen(path, "r+b");
        CHECK(f != NULL);
        if (!f)
            continue;
        const unsigned char huge[4] = {0xff, 0xff, 0xff, 0x7f};   /* metadata count / a length */
        fseek(f, at[i], SEEK_SET);
        CHECK(fwrite(huge, 1, 4, f) == 4);
        fclose(f);
        expect_error(path, by_name("density"), VSD_ERR_FORMAT, "truncated or corrupt");
        expect_list_error(path, VSD_ERR_FORMAT, "truncated or corrupt");
    }
    remove(path);
}

/* ---- damage inside the tree (vdbio/vdb_tree_scan.cpp) --------------------------------------- */

/* OpenVDB 10 trusts the sizes inside a grid's tree (chunk sizes, counts, mask-dependent
 * lengths), so vdbio walks the tree before OpenVDB reads it. Tested two ways: VDBs written
 * here byte by byte, whose every field is known (valid variants of each layout rule must
 * load with the right voxels; a damaged field must be refused, naming grid and node), and a
 * real shared file whose fields are found by parsing it. */

typedef struct bytes {
    unsigned char *p;
    long n, cap;
} bytes;

static void put(bytes *b, const void *src, long n)
{
    if (b->n + n > b->cap) {
        long cap = b->cap ? b->cap : 4096;
        while (cap < b->n + n)
            cap *= 2;
        unsigned char *q = realloc(b->p, (size_t)cap);
        if (!q)
            abort();
        b->p = q;
        b->cap = cap;
    }
    if (n > 0)
        memcpy(b->p + b->n, src, (size_t)n);
    b->n += n;
}
static void put_u8(bytes *b, unsigned v) { unsigned char c = (unsigned char)v; put(b, &c, 1); }
static void put_u32(bytes *b, uint32_t v) { put(b, &v, 4); }
static void put_i32(bytes *b, int32_t v) { put(b, &v, 4); }
static void put_i64(bytes *b, int64_t v) { put(b, &v, 8); }
static void put_f64(bytes *b, double v) { put(b, &v, 8); }
static void put_zeros(bytes *b, long n) { static const unsigned char z[4096]; while (n > 0) { long k = n < 4096 ? n : 4096; put(b, z, k); n -= k; } }
static void put_str(bytes *b, const char *s) { put_u32(b, (uint32_t)strlen(s)); put(b, s, (long)strlen(s)); }
static void set_i64(bytes *b, long at, int64_t v) { memcpy(b->p + at, &v, 8); }
static void set_i32(bytes *b, long at, int32_t v) { memcpy(b->p + at, &v, 4); }

/* IEEE half of a float that is exact in half (the test's values are multiples of 1/8). */
static uint16_t to_half(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    if ((u & 0x7fffffffu) == 0)
        return (uint16_t)(u >> 16);
    return (uint16_t)(((u >> 16) & 0x8000u) | ((((u >> 23) & 0xffu) - 127 + 15) << 10) | ((u >> 13) & 0x3ffu));
}

enum { TV_ZIP = 1, TV_MASK = 2, TV_BLOSC = 4 };   /* io::COMPRESS_* */

/* One hand-written grid 'density': an optional inactive root tile, then one or two root
 * children, each an InternalNode<5> -> InternalNode<4> -> one leaf whose every fifth voxel is
 * active with value 0.125 * (1 + n % 7). Where the writer put the fields tests damage. */
typedef struct tiny_vdb {
    uint32_t version;     /* 224, or 221 (file-wide zlib flag, old node and leaf layouts) */
    uint32_t compression; /* TV_* flags (221: only TV_ZIP counts) */
    int value_bytes;      /* 4 float, 8 double */
    int half_data;        /* values stored as 16-bit halves */
    int half_suffix;      /* "_HalfFloat" on the type name */
    int half_meta;        /* "is_saved_as_half_float": -1 absent, 0 or 1 */
    int leaf_flag;        /* the leaves' mask-compression flag (0..6) */
    int tile;             /* an inactive root tile before the children */
    int children;         /* 1 or 2 */
    int descending;       /* write the two children in descending order */
    const char *instance; /* type of a second grid 'density_copy' sharing the tree, or NULL */
    int frustum;          /* a NonlinearFrustumMap transform instead of a uniform scale */
    int far_tile;         /* with 'tile_a', two active zero tiles in the first InternalNode<5> */
    int tile_a, tile_b;   /* their child-table indices */
    /* filled in by tiny_write */
    long block_field, counts_at, tile_active_at, child_origin_at, node5_flag_at, node5_size_at, leaf_flag_at,
        leaf_size_at, leaf_origin_at;
} tiny_vdb;

static const int32_t tiny_keys[2][3] = {{4096, 0, -4096}, {8192, 0, -4096}};
/* node5 child (1, 2, 3) -> +(128, 256, 384); node4 child (4, 5, 6) -> +(32, 40, 48) */
enum { TINY_N5 = (1 << 10) | (2 << 5) | 3, TINY_N4 = (4 << 8) | (5 << 4) | 6 };

static void tiny_leaf_origin(int child, int32_t o[3])
{
    const int32_t d[3] = {128 + 32, 256 + 40, 384 + 48};
    for (int a = 0; a < 3; ++a)
        o[a] = tiny_keys[child][a] + d[a];
}
static int tiny_active(int n) { return n % 5 == 0; }
static double tiny_value(int n) { return 0.125 * (1 + n % 7); }

/* A value chunk (io::readData): Blosc as a "memcpyed" chunk (no compressor needed), zlib as
 * the raw form OpenVDB writes when zlib does not help (size -n), or plain bytes. */
static void put_chunk(bytes *b, uint32_t comp, const unsigned char *data, long nbytes, int typesize,
                      long *size_at)
{
    *size_at = -1;
    if (comp & TV_BLOSC) {
        *size_at = b->n;
        put_i64(b, nbytes + 16);
        put_u8(b, 2);      /* BLOSC_VERSION_FORMAT */
        put_u8(b, 1);
        put_u8(b, 0x02);   /* BLOSC_MEMCPYED */
        put_u8(b, (unsigned)typesize);
        put_u32(b, (uint32_t)nbytes);
        put_u32(b, (uint32_t)nbytes);   /* one block */
        put_u32(b, (uint32_t)nbytes + 16);
    } else if (comp & TV_ZIP) {
        *size_at = b->n;
        put_i64(b, -nbytes);
    }
    put(b, data, nbytes);
}

/* io::writeCompressedValues' layout for `count` values (vals[i]) under value mask `mask`. */
static void put_values(bytes *b, const tiny_vdb *t, int flag, const double *vals, const unsigned char *mask, long count,
                       long mask_bytes, long *flag_at, long *size_at)
{
    const int newer = t->version >= 222;
    const uint32_t comp = newer ? t->compression : (t->compression & TV_ZIP);
    *flag_at = -1;
    if (newer) {
        *flag_at = b->n;
        put_u8(b, (unsigned)flag);
    } else {
        flag = 6;
    }
    if (flag == 2 || flag == 4 || flag == 5) {   /* one or two inactive values, full size */
        for (int k = 0; k < (flag == 5 ? 2 : 1); ++k) {
            if (t->value_bytes == 8) put_f64(b, 0.75 + k);
            else { float f = 0.75f + (float)k; put(b, &f, 4); }
        }
    }
    if (flag == 3 || flag == 4 || flag == 5)
        put_zeros(b, mask_bytes);   /* selection mask */
    const int active_only = newer && (comp & TV_MASK) && flag != 6;
    const int elem = t->half_data ? 2 : t->value_bytes;
    unsigned char *data = malloc((size_t)(count * elem + 1));
    long n = 0;
    for (long i = 0; i < count; ++i) {
        if (active_only && !(mask[i >> 3] >> (i & 7) & 1))
            continue;
        if (t->half_data) { uint16_t h = to_half((float)vals[i]); memcpy(data + n * 2, &h, 2); }
        else if (elem == 8) memcpy(data + n * 8, &vals[i], 8);
        else { float f = (float)vals[i]; memcpy(data + n * 4, &f, 4); }
        ++n;
    }
    if (!(t->half_data && n == 0))   /* io::HalfWriter writes nothing for no values */
        put_chunk(b, comp, data, n * elem, elem, size_at);
    free(data);
}

static void put_internal(bytes *b, tiny_vdb *t, int log2dim, int child_index, int first)
{
    const long size = 1L << (3 * log2dim), mask_bytes = size / 8;
    unsigned char *child = calloc((size_t)mask_bytes, 1), *value = calloc((size_t)mask_bytes, 1);
    double *vals = calloc((size_t)size, sizeof *vals);
    long flag_at, size_at;
    child[child_index >> 3] |= (unsigned char)(1u << (child_index & 7));
    if (log2dim == 5 && first && t->far_tile) {   /* active tiles of value 0 */
        value[t->tile_a >> 3] |= (unsigned char)(1u << (t->tile_a & 7));
        value[t->tile_b >> 3] |= (unsigned char)(1u << (t->tile_b & 7));
    }
    put(b, child, mask_bytes);
    put(b, value, mask_bytes);
    /* before 222 only the tile slots' values are stored */
    put_values(b, t, 0, vals, value, t->version >= 222 ? size : size - 1, mask_bytes, &flag_at, &size_at);
    if (log2dim == 5 && first) {
        t->node5_flag_at = flag_at;
        t->node5_size_at = size_at;
    }
    free(child);
    free(value);
    free(vals);
}

static bytes tiny_write(tiny_vdb *t)
{
    bytes b = {NULL, 0, 0};
    const int newer = t->version >= 222;
    unsigned char leaf_mask[64] = {0};
    double leaf_vals[512];
    for (int n = 0; n < 512; ++n) {
        if (tiny_active(n)) leaf_mask[n >> 3] |= (unsigned char)(1u << (n & 7));
        leaf_vals[n] = tiny_active(n) ? tiny_value(n) : 0.0;
    }
    /* header: magic, format, library 10.0, has grid offsets, [221: zlib flag], uuid */
    put_i64(&b, 0x56444220);
    put_u32(&b, t->version);
    put_u32(&b, 10);
    put_u32(&b, 0);
    put_u8(&b, 1);
    if (!newer) put_u8(&b, t->compression & TV_ZIP);
    put(&b, "00000000-0000-0000-0000-000000000000", 36);
    put_u32(&b, 0);   /* file metadata */
    put_i32(&b, t->instance ? 2 : 1);   /* grids */
    char type[64];
    snprintf(type, sizeof type, "Tree_%s_5_4_3%s", t->value_bytes == 8 ? "double" : "float",
             t->half_suffix ? "_HalfFloat" : "");
    put_str(&b, "density");
    put_str(&b, type);
    put_str(&b, "");   /* no instance parent */
    const long offsets = b.n;
    put_i64(&b, 0); put_i64(&b, 0); put_i64(&b, 0);
    const long grid_pos = b.n;
    if (newer) put_u32(&b, t->compression);
    put_u32(&b, t->half_meta >= 0 ? 1 : 0);
    if (t->half_meta >= 0) {
        put_str(&b, "is_saved_as_half_float");
        put_str(&b, "bool");
        put_u32(&b, 1);
        put_u8(&b, (unsigned)t->half_meta);
    }
    if (t->frustum) {   /* bbox (double), taper, depth, then a second map with its own type name */
        put_str(&b, "NonlinearFrustumMap");
        const double box[6] = {0, 0, 0, 16, 16, 16};
        for (int k = 0; k < 6; ++k) put_f64(&b, box[k]);
        put_f64(&b, 0.5);
        put_f64(&b, 2.0);
        put_str(&b, "AffineMap");
        for (int k = 0; k < 16; ++k) put_f64(&b, k % 5 == 0 ? 1.0 : 0.0);
    } else {
        put_str(&b, "UniformScaleMap");   /* scale, voxel size, inverse, 1/s^2, 1/2s */
        const double s = 0.1, m[5] = {s, s, 1 / s, 1 / (s * s), 1 / (2 * s)};
        for (int k = 0; k < 15; ++k) put_f64(&b, m[k / 3]);
    }
    /* topology */
    put_i32(&b, 1);
    put_zeros(&b, t->value_bytes);   /* background 0 */
    t->counts_at = b.n;
    put_u32(&b, t->tile ? 1 : 0);
    put_u32(&b, (uint32_t)t->children);
    if (t->tile) {
        put_i32(&b, -4096); put_i32(&b, 0); put_i32(&b, 0);
        if (t->value_bytes == 8) put_f64(&b, 0.5); else { float f = 0.5f; put(&b, &f, 4); }
        t->tile_active_at = b.n;
        put_u8(&b, 0);
    }
    for (int c = 0; c < t->children; ++c) {
        const int k = t->descending ? t->children - 1 - c : c;
        if (c == 0) t->child_origin_at = b.n;
        put_i32(&b, tiny_keys[k][0]); put_i32(&b, tiny_keys[k][1]); put_i32(&b, tiny_keys[k][2]);
        put_internal(&b, t, 5, TINY_N5, c == 0);
        put_internal(&b, t, 4, TINY_N4, c == 0);
        put(&b, leaf_mask, 64);
    }
    const long block_pos = b.n;
    for (int c = 0; c < t->children; ++c) {
        long flag_at, size_at;
        put(&b, leaf_mask, 64);
        if (!newer) {
            int32_t o[3];
            tiny_leaf_origin(t->descending ? t->children - 1 - c : c, o);
            if (c == 0) t->leaf_origin_at = b.n;
            put(&b, o, 12);
            put_u8(&b, 1);   /* buffer count */
        }
        put_values(&b, t, t->leaf_flag, leaf_vals, leaf_mask, 512, 64, &flag_at, &size_at);
        if (c == 0) {
            t->leaf_flag_at = flag_at;
            t->leaf_size_at = size_at;
        }
    }
    set_i64(&b, offsets, grid_pos);
    set_i64(&b, offsets + 8, block_pos);
    set_i64(&b, offsets + 16, b.n);
    t->block_field = offsets + 8;
    if (t->instance) {
        /* io::Archive::writeGridInstance: descriptor (with the parent's unique name), then
         * compression, metadata and transform; the block position stays 0 */
        put_str(&b, "density_copy");
        put_str(&b, t->instance);
        put_str(&b, "density");
        const long at = b.n;
        put_i64(&b, 0); put_i64(&b, 0); put_i64(&b, 0);
        const long pos = b.n;
        if (newer) put_u32(&b, t->compression);
        put_u32(&b, 0);
        put_str(&b, "TranslationMap");
        put_f64(&b, 1.0); put_f64(&b, 2.0); put_f64(&b, 3.0);
        set_i64(&b, at, pos);
        set_i64(&b, at + 16, b.n);
    }
    return b;
}

static tiny_vdb tiny_default(void)
{
    tiny_vdb t;
    memset(&t, 0, sizeof t);
    t.version = 224;
    t.compression = TV_ZIP | TV_MASK;
    t.value_bytes = 4;
    t.half_meta = -1;
    t.children = 1;
    return t;
}

static int write_bytes(const char *path, const bytes *b)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(b->p, 1, (size_t)b->n, f) == (size_t)b->n;
    if (f) ok = fclose(f) == 0 && ok;
    return ok;
}

/* The grid must load (and list, through the whole-grid fallback: it has no statistics) with
 * every leaf's active voxels, values and positions. */
static void expect_tiny_loads(const char *what, tiny_vdb t)
{
    bytes b = tiny_write(&t);
    char path[2048];
    snprintf(path, sizeof path, "%s", test_tmp("tiny.vdb"));
    CHECK(write_bytes(path, &b));
    free(b.p);
    const uint64_t active = 103u * (uint64_t)t.children;   /* n % 5 == 0 for n < 512 */
    vsd_grid_info *g = NULL;
    int n = 0;
    char err[2048] = "";
    const int grids = t.instance ? 2 : 1;
    CHECK_MSG(vsd_vdb_list(path, &g, &n, err, sizeof err) == VSD_OK && n == grids, "%s: list: %s", what, err);
    for (int i = 0; g && i < n; ++i)
        CHECK_MSG(g[i].active_voxels == active, "%s: grid %d: listed %llu active voxels", what, i,
                  (unsigned long long)g[i].active_voxels);
    vsd_vdb_list_free(g);
    vsd_volume *vol = NULL;
    CHECK_MSG(vsd_vdb_load(path, by_name("density"), &vol, err, sizeof err) == VSD_OK && vol, "%s: load: %s", what, err);
    if (!vol)
        return;
    CHECK_MSG(vol->active_voxels == active, "%s: %llu active voxels", what, (unsigned long long)vol->active_voxels);
    int wrong = 0;
    for (int c = 0; c < t.children; ++c) {
        int32_t o[3];
        tiny_leaf_origin(c, o);
        for (int k = 0; k < 512; ++k) {
            const float want = tiny_active(k) ? (float)tiny_value(k) : 0.0f;
            wrong += vsd_volume_voxel(vol, o[0] + (k >> 6), o[1] + ((k >> 3) & 7), o[2] + (k & 7)) != want;
        }
    }
    CHECK_MSG(wrong == 0, "%s: %d voxels differ from what was written", what, wrong);
    vsd_volume_destroy(vol);
    if (t.instance) {   /* the instance reads its parent's tree: the same voxels */
        vol = NULL;
        CHECK_MSG(vsd_vdb_load(path, by_name("density_copy"), &vol, err, sizeof err) == VSD_OK && vol, "%s: load: %s",
                  what, err);
        if (vol) {
            CHECK(vol->active_voxels == active);
            int32_t o[3];
            tiny_leaf_origin(0, o);
            CHECK(vsd_volume_voxel(vol, o[0], o[1], o[2]) == (float)tiny_value(0));
            CHECK_NEAR(vol->voxel_size[0], 1.0, 1e-12);   /* its own transform */
        }
        vsd_volume_destroy(vol);
    }
}

/* Write variant t, let `damage` change it, and expect both load and list (which reads the
 * whole grid: no statistics) to be refused as corrupt, naming the grid and `problem`. */
static void expect_tiny_refused(const char *what, tiny_vdb t, void (*damage)(bytes *, const tiny_vdb *), const char *problem)
{
    bytes b = tiny_write(&t);
    if (damage)
        damage(&b, &t);
    char path[2048];
    snprintf(path, sizeof path, "%s", test_tmp("tiny_bad.vdb"));
    CHECK(write_bytes(path, &b));
    free(b.p);
    vsd_volume *vol = NULL;
    char err[2048] = "";
    const vsd_status st = vsd_vdb_load(path, by_name("density"), &vol, err, sizeof err);
    CHECK_MSG(st == VSD_ERR_FORMAT && !vol, "%s: load gave %s (%s)", what, vsd_status_str(st), err);
    CHECK_CONTAINS(err, path);
    CHECK_CONTAINS(err, "corrupt OpenVDB file (grid 'density': ");
    CHECK_CONTAINS(err, problem);
    vsd_volume_destroy(vol);
    expect_list_error(path, VSD_ERR_FORMAT, problem);
    remove(path);
}

static void damage_child_count(bytes *b, const tiny_vdb *t) { set_i32(b, t->counts_at + 4, 1000); }
static void damage_node5_size(bytes *b, const tiny_vdb *t) { set_i64(b, t->node5_size_at, 912345678); }
static void damage_node5_raw(bytes *b, const tiny_vdb *t) { set_i64(b, t->node5_size_at, -(32768 * 4 + 4)); }
static void damage_node5_min(bytes *b, const tiny_vdb *t) { set_i64(b, t->node5_size_at, INT64_MIN); }
static void damage_leaf_size(bytes *b, const tiny_vdb *t) { set_i64(b, t->leaf_size_at, 0x7f3f1e000000007fLL); }
static void damage_leaf_small(bytes *b, const tiny_vdb *t) { set_i64(b, t->leaf_size_at, 5); }
static void damage_blosc_nbytes(bytes *b, const tiny_vdb *t) { set_i32(b, t->leaf_size_at + 8 + 4, 4000); }
static void damage_blosc_cbytes(bytes *b, const tiny_vdb *t) { set_i32(b, t->leaf_size_at + 8 + 12, 100000); }
static void damage_leaf_flag(bytes *b, const tiny_vdb *t) { b->p[t->leaf_flag_at] = 7; }
static void damage_tile_active(bytes *b, const tiny_vdb *t) { b->p[t->tile_active_at] = 2; }
static void damage_child_origin(bytes *b, const tiny_vdb *t) { set_i32(b, t->child_origin_at, 4097); }
static void damage_block_pos(bytes *b, const tiny_vdb *t)
{
    int64_t v;
    memcpy(&v, b->p + t->block_field, 8);
    set_i64(b, t->block_field, v + 1);
}
static void damage_leaf_origin(bytes *b, const tiny_vdb *t) { set_i32(b, t->leaf_origin_at + 4, 297); }

static void test_tiny_trees(void)
{
    /* valid: every compression, mask compression on and off, float/double/half, every
     * mask-compression flag, an inactive root tile, two children, the 221 layout */
    static const uint32_t comps[] = {0, TV_MASK, TV_ZIP, TV_ZIP | TV_MASK, TV_BLOSC, TV_BLOSC | TV_MASK,
                                     TV_BLOSC | TV_ZIP | TV_MASK};
    char what[128];
    for (size_t c = 0; c < sizeof comps / sizeof comps[0]; ++c) {
        for (int kind = 0; kind < 3; ++kind) {   /* float, double, half */
            tiny_vdb t = tiny_default();
            t.compression = comps[c];
            t.value_bytes = kind == 1 ? 8 : 4;
            t.half_data = kind == 2;
            t.half_suffix = kind == 2;
            t.half_meta = kind == 2 ? 1 : -1;
            snprintf(what, sizeof what, "compression %u, %s", (unsigned)comps[c], kind == 0 ? "float" : kind == 1 ? "double" : "half");
            expect_tiny_loads(what, t);
        }
    }
    for (int flag = 0; flag <= 6; ++flag) {
        for (int half = 0; half < 2; ++half) {
            tiny_vdb t = tiny_default();
            t.leaf_flag = flag;
            t.half_data = t.half_suffix = half;
            t.half_meta = half ? 1 : -1;
            snprintf(what, sizeof what, "mask-compression flag %d%s", flag, half ? ", half" : "");
            expect_tiny_loads(what, t);
        }
    }
    tiny_vdb t = tiny_default();
    t.tile = 1;
    t.children = 2;
    t.compression = TV_BLOSC | TV_MASK;
    expect_tiny_loads("tile and two children", t);
    for (int zip = 0; zip < 2; ++zip) {
        for (int half = 0; half < 2; ++half) {
            t = tiny_default();
            t.version = 221;
            t.compression = zip ? TV_ZIP : 0;
            t.half_data = t.half_suffix = half;
            t.half_meta = half ? 1 : -1;
            t.children = 2;
            snprintf(what, sizeof what, "format 221%s%s", zip ? ", zlib" : "", half ? ", half" : "");
            expect_tiny_loads(what, t);
        }
    }
    /* OpenVDB decides "half" from the grid's metadata, not the type name's suffix */
    t = tiny_default();
    t.half_suffix = 1;
    t.half_meta = 0;
    expect_tiny_loads("_HalfFloat suffix, metadata false, float data", t);
    t = tiny_default();
    t.half_data = 1;
    t.half_meta = 1;
    expect_tiny_loads("no suffix, metadata true, half data", t);
    t = tiny_default();
    t.half_data = t.half_suffix = 1;
    t.compression = TV_ZIP;
    expect_tiny_refused("_HalfFloat suffix, no metadata, half data", t, NULL, "value chunk");

    /* a frustum transform is walked too (its second map has a type name of its own): the grid
     * gets through the scan to vdbio's own refusal of non-linear transforms */
    t = tiny_default();
    t.frustum = 1;
    {
        bytes b = tiny_write(&t);
        char path[2048];
        snprintf(path, sizeof path, "%s", test_tmp("tiny_frustum.vdb"));
        CHECK(write_bytes(path, &b));
        free(b.p);
        expect_error(path, by_name("density"), VSD_ERR_UNSUPPORTED, "NonlinearFrustumMap transform; vsd supports linear");
        remove(path);
    }

    /* damaged */
    expect_tiny_refused("root child count", tiny_default(), damage_child_count, "the root's 1000 children need at least");
    t = tiny_default();
    t.compression = TV_ZIP;   /* no mask compression: the internal node stores all 32768 values */
    expect_tiny_refused("internal node chunk size", t, damage_node5_size,
                        "the internal node at (4096, 0, -4096)'s compressed value chunk claims 912345678 bytes");
    expect_tiny_refused("internal node raw chunk size", t, damage_node5_raw,
                        "uncompressed value chunk holds 131076 bytes, not the 131072 its values take");
    expect_tiny_refused("internal node chunk size INT64_MIN", t, damage_node5_min, "holds 2^63 bytes");
    t = tiny_default();
    t.compression = TV_BLOSC | TV_MASK;
    expect_tiny_refused("leaf chunk size", t, damage_leaf_size,
                        "leaf 0 at (4256, 296, -3664)'s compressed value chunk claims 9169080351698452607 bytes");
    expect_tiny_refused("leaf chunk shorter than a Blosc header", t, damage_leaf_small, "Blosc chunk claims 5 bytes");
    expect_tiny_refused("Blosc uncompressed size", t, damage_blosc_nbytes, "Blosc header says 4000 uncompressed bytes, not the 412");
    expect_tiny_refused("Blosc compressed size", t, damage_blosc_cbytes, "Blosc header says 100000 compressed bytes");
    t = tiny_default();
    t.compression = TV_ZIP | TV_MASK;
    expect_tiny_refused("zlib chunk size", t, damage_leaf_size, "leaf 0 at (4256, 296, -3664)'s compressed value chunk claims");
    expect_tiny_refused("mask-compression flag", tiny_default(), damage_leaf_flag, "leaf 0 at (4256, 296, -3664) has a mask-compression flag of 7");
    t = tiny_default();
    t.tile = 1;
    expect_tiny_refused("tile active flag", t, damage_tile_active, "root tile 0 at (-4096, 0, 0) has an active flag of 2");
    expect_tiny_refused("unaligned child", tiny_default(), damage_child_origin, "root child 0 at (4097, 0, -4096) is not aligned");
    t = tiny_default();
    t.children = 2;
    t.descending = 1;
    expect_tiny_refused("children out of order", t, NULL, "root child 1 at (4096, 0, -4096) does not come after");
    expect_tiny_refused("block position", tiny_default(), damage_block_pos, "its topology ends at byte");
    /* instances: OpenVDB reads the parent's tree, so that is the tree checked */
    t = tiny_default();
    t.instance = "Tree_float_5_4_3";
    t.compression = TV_BLOSC | TV_MASK;
    expect_tiny_loads("instance", t);
    {
        bytes b = tiny_write(&t);
        damage_leaf_size(&b, &t);
        char path[2048];
        snprintf(path, sizeof path, "%s", test_tmp("tiny_instance.vdb"));
        CHECK(write_bytes(path, &b));
        free(b.p);
        expect_error(path, by_name("density_copy"), VSD_ERR_FORMAT,
                     "grid 'density': leaf 0 at (4256, 296, -3664)'s compressed value chunk claims");
        t.instance = "Tree_vec3s_5_4_3";
        b = tiny_write(&t);
        CHECK(write_bytes(path, &b));
        free(b.p);
        vsd_grid_select sel = {NULL, 1};
        expect_error(path, sel, VSD_ERR_TYPE, "vec3s");
        t.instance = "Tree_double_5_4_3";
        b = tiny_write(&t);
        CHECK(write_bytes(path, &b));
        free(b.p);
        expect_error(path, sel, VSD_ERR_FORMAT, "grid 'density_copy' shares the tree of grid 'density', which has another type");
        remove(path);
    }
    t = tiny_default();
    t.version = 221;
    expect_tiny_refused("format 221 leaf origin", t, damage_leaf_origin, "leaf 0 at (4256, 296, -3664)'s buffer says it is at (4256, 297, -3664)");
}

/* vsd's brick index is dense over the active bbox: a box that is large and nearly empty
 * (here: two active zero-valued tiles 4096 voxels apart and one leaf) is refused, a small one
 * loads. */
static void test_sparse_box(void)
{
    char path[2048], err[2048] = "";
    snprintf(path, sizeof path, "%s", test_tmp("tiny_sparse.vdb"));
    for (int far = 0; far < 2; ++far) {
        tiny_vdb t = tiny_default();
        t.far_tile = 1;
        t.tile_a = 0;                  /* local (0, 0, 0) */
        t.tile_b = far ? 32767 : 1;    /* (31, 31, 31) or (0, 0, 1): 128-voxel tiles */
        bytes b = tiny_write(&t);
        CHECK(write_bytes(path, &b));
        free(b.p);
        vsd_grid_info *g = NULL;
        int n = 0;
        CHECK_MSG(vsd_vdb_list(path, &g, &n, err, sizeof err) == VSD_OK && n == 1, "%s", err);
        if (g)
            CHECK(g[0].active_voxels == 103u + 2u * 128u * 128u * 128u);
        vsd_vdb_list_free(g);
        vsd_volume *vol = NULL;
        const vsd_status st = vsd_vdb_load(path, by_name("density"), &vol, err, sizeof err);
        if (far) {
            CHECK_MSG(st == VSD_ERR_UNSUPPORTED && !vol, "far tiles: %s (%s)", vsd_status_str(st), err);
            CHECK_CONTAINS(err, path);
            CHECK_CONTAINS(err, "grid 'density': its active voxels span 135005697 brick cells, but only 1 bricks hold data");
        } else {
            CHECK_MSG(st == VSD_OK && vol, "near tiles: %s", err);
            if (vol)
                CHECK(vol->brick_count == 1 && vol->active_voxels == 103u + 2u * 128u * 128u * 128u);
        }
        vsd_volume_destroy(vol);
    }
    remove(path);
}

/* Where one grid's parts lie in a real file (a small parser of its own: header, file
 * metadata, descriptors, then the grid's compression, metadata and transform). */
typedef struct grid_loc {
    long grid_pos, block_pos, end_pos, topo_pos;
    long delayed_at;      /* value of the "__delayedload" entry */
    long voxcount_bytes;  /* byte count field of "file_voxel_count" */
    uint32_t compression;
} grid_loc;

static uint32_t rd32(const unsigned char *b, long at) { uint32_t v; memcpy(&v, b + at, 4); return v; }
static int64_t rd64(const unsigned char *b, long at) { int64_t v; memcpy(&v, b + at, 8); return v; }

static int locate_grid(const unsigned char *b, long size, const char *name, grid_loc *out)
{
    long p = 8;
    const uint32_t version = rd32(b, p);
    p += 4 + 8 + 1 + (version < 222 ? 1 : 0) + 36;
    uint32_t count = rd32(b, p);
    p += 4;
    for (uint32_t i = 0; i < count; ++i) {   /* file metadata */
        p += 4 + rd32(b, p);
        p += 4 + rd32(b, p);
        p += 4 + rd32(b, p);
    }
    const int32_t grids = (int32_t)rd32(b, p);
    p += 4;
    for (int32_t i = 0; i < grids && p < size; ++i) {
        const uint32_t n = rd32(b, p);
        const int match = n == strlen(name) && memcmp(b + p + 4, name, n) == 0;
        p += 4 + n;
        p += 4 + rd32(b, p);   /* type */
        p += 4 + rd32(b, p);   /* instance parent */
        memset(out, 0, sizeof *out);
        out->grid_pos = (long)rd64(b, p);
        out->block_pos = (long)rd64(b, p + 8);
        out->end_pos = (long)rd64(b, p + 16);
        if (!match) {
            p = out->end_pos;
            continue;
        }
        long q = out->grid_pos;
        out->compression = rd32(b, q);
        q += 4;
        const uint32_t entries = rd32(b, q);
        q += 4;
        for (uint32_t e = 0; e < entries; ++e) {
            const uint32_t nl = rd32(b, q);
            const int voxcount = nl == 16 && memcmp(b + q + 4, "file_voxel_count", 16) == 0;
            q += 4 + nl;
            const uint32_t tl = rd32(b, q);
            const int delayed = tl == 13 && memcmp(b + q + 4, "__delayedload", 13) == 0;
            q += 4 + tl;
            if (voxcount) out->voxcount_bytes = q;
            if (delayed) out->delayed_at = q + 4;
            q += 4 + rd32(b, q);
        }
        const uint32_t tl = rd32(b, q);
        static const struct { const char *type; long bytes; } maps[] = {
            {"UniformScaleMap", 120}, {"ScaleMap", 120}, {"UniformScaleTranslateMap", 144},
            {"ScaleTranslateMap", 144}, {"TranslationMap", 24}, {"AffineMap", 128}, {"UnitaryMap", 128}};
        for (size_t m = 0; m < sizeof maps / sizeof maps[0]; ++m)
            if (tl == strlen(maps[m].type) && memcmp(b + q + 4, maps[m].type, tl) == 0)
                out->topo_pos = q + 4 + tl + maps[m].bytes;
        return out->topo_pos > 0;
    }
    return 0;
}

/* A copy of `src` with `n` bytes at `at` replaced. */
static int patched_copy(const unsigned char *buf, long size, const char *dst, long at, const void *bytes_, int n)
{
    unsigned char *c = malloc((size_t)size);
    if (!c) return 0;
    memcpy(c, buf, (size_t)size);
    memcpy(c + at, bytes_, (size_t)n);
    FILE *f = fopen(dst, "wb");
    int ok = f && fwrite(c, 1, (size_t)size, f) == (size_t)size;
    if (f) ok = fclose(f) == 0 && ok;
    free(c);
    return ok;
}

static void test_corrupt_tree(void)
{
    const char *rel = "smoke64/fluid_data_0001.vdb";   /* 'density': half floats, Blosc, no mask compression */
    long size = 0;
    unsigned char *buf = test_read_file(test_data(rel), &size);
    grid_loc g;
    CHECK(buf != NULL);
    if (!buf)
        return;
    const int found = locate_grid(buf, size, "density", &g);
    CHECK_MSG(found, "could not locate grid 'density' in %s", rel);
    if (!found) {
        free(buf);
        return;
    }
    char path[2048];
    snprintf(path, sizeof path, "%s", test_tmp("tree_damage.vdb"));
    /* root: buffer count, float background, tile count, child count */
    const long tiles = (long)rd32(buf, g.topo_pos + 8);
    CHECK(rd32(buf, g.topo_pos + 12) >= 1);
    const int32_t many = 0x10000000;
    CHECK(patched_copy(buf, size, path, g.topo_pos + 12, &many, 4));
    expect_error(path, by_name("density"), VSD_ERR_FORMAT, "grid 'density': the root's 268435456 children need at least");
    /* the first internal node's values (32768 halves, Blosc): flag byte, then the chunk size */
    const long node5 = g.topo_pos + 16 + tiles * 17 + 12 + 2 * 4096;
    CHECK(buf[node5] == 6);   /* NO_MASK_AND_ALL_VALS: no mask compression in this file */
    const int64_t claim = 912345678;
    CHECK(patched_copy(buf, size, path, node5 + 1, &claim, 8));
    expect_error(path, by_name("density"), VSD_ERR_FORMAT,
                 "grid 'density': the internal node at (0, 0, 0)'s compressed value chunk claims 912345678 bytes");
    const unsigned char flag = 9;
    CHECK(patched_copy(buf, size, path, node5, &flag, 1));
    expect_error(path, by_name("density"), VSD_ERR_FORMAT, "has a mask-compression flag of 9");
    /* the first leaf buffer: value mask, flag byte (6), then its chunk size */
    CHECK(buf[g.block_pos + 64] == 6);
    CHECK(patched_copy(buf, size, path, g.block_pos + 65, &claim, 8));
    expect_error(path, by_name("density"), VSD_ERR_FORMAT, "grid 'density': leaf 0 at (");
    expect_error(path, by_name("density"), VSD_ERR_FORMAT, "'s compressed value chunk claims 912345678 bytes");
    /* the other grids of the file still load: only the damaged tree is walked */
    vsd_volume *vol = load_ok(rel, by_name("density"));
    vsd_volume_destroy(vol);
    vsd_volume *other = NULL;
    char err[2048] = "";
    CHECK_MSG(vsd_vdb_load(path, by_name("temperature"), &other, err, sizeof err) == VSD_OK, "%s", err);
    vsd_volume_destroy(other);
    /* metadata OpenVDB would misread: the delayed-load leaf count, a fixed-size entry's length */
    CHECK(g.delayed_at > 0 && g.voxcount_bytes > 0);
    const uint32_t leaves = 0x7fffffffu;
    CHECK(patched_copy(buf, size, path, g.delayed_at, &leaves, 4));
    expect_error(path, by_name("density"), VSD_ERR_FORMAT, "'file_delayed_load' (__delayedload) claims 2147483647 leaves");
    expect_list_error(path, VSD_ERR_FORMAT, "claims 2147483647 leaves");
    const uint32_t nine = 9;
    CHECK(patched_copy(buf, size, path, g.voxcount_bytes, &nine, 4));
    expect_list_error(path, VSD_ERR_FORMAT, "entry 'file_voxel_count' (int64) holds 9 bytes, not 8");
    remove(path);
    free(buf);
}

/* ---- speed -------------------------------------------------------------------------------- */

static void test_load_time(void)
{
    const char *path = test_data("smoke128/fluid_data_0060.vdb");
    double best = 1e30;
    for (int rep = 0; rep < 3; ++rep) {
        const double t0 = now_ms();
        vsd_volume *vol = load_ok("smoke128/fluid_data_0060.vdb", by_name("density"));
        const double t = now_ms() - t0;
        best = t < best ? t : best;
        if (vol && rep == 0)
            printf("smoke128 frame 60 density: %llu active voxels, %d bricks of %d cells\n",
                   (unsigned long long)vol->active_voxels, vol->brick_count,
                   vol->brick_dims[0] * vol->brick_dims[1] * vol->brick_dims[2]);
        vsd_volume_destroy(vol);
    }
    vsd_grid_info *g = NULL;
    int n = 0;
    const double t0 = now_ms();
    CHECK(vsd_vdb_list(path, &g, &n, NULL, 0) == VSD_OK);
    const double tl = now_ms() - t0;
    vsd_vdb_list_free(g);
    printf("load time smoke128/fluid_data_0060.vdb (15 MB) density: %.1f ms (best of 3); list: %.1f ms\n",
           best, tl);
    CHECK_MSG(best < 5000.0, "loading took %.0f ms", best);   /* loose: sanitizer builds too */
}

/* A half-float infinity written over voxel data of a real file (gaffer_smoke.vdb stores half
 * floats without Blosc, so its leaf values are plain bytes near the end): the load is refused
 * with an error naming the file, the grid and a voxel. Two bytes at a time from the end
 * until one lands on a voxel value (the last bytes may be metadata or a mask). */
static void test_non_finite_file(void)
{
    const char *src = test_data("external/gaffer_smoke.vdb");
    FILE *f = fopen(src, "rb");
    long size = 0;
    unsigned char *buf = NULL;
    int found = 0;
    char path[1024];
    snprintf(path, sizeof path, "%s", test_tmp("gaffer_inf.vdb"));
    if (f && fseek(f, 0, SEEK_END) == 0 && (size = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0 &&
        (buf = malloc((size_t)size)) && fread(buf, 1, (size_t)size, f) == (size_t)size) {
        for (long off = size - 4096; off > size / 2 && !found; off -= 4094) {
            unsigned char keep[2] = {buf[off], buf[off + 1]};
            vsd_volume *vol = NULL;
            char err[2048] = "";
            FILE *o = fopen(path, "wb");
            buf[off] = 0x00;
            buf[off + 1] = 0x7C;   /* +Inf as an IEEE half, little-endian */
            CHECK(o && fwrite(buf, 1, (size_t)size, o) == (size_t)size);
            if (o) fclose(o);
            const vsd_status st = vsd_vdb_load(path, by_name("density"), &vol, err, sizeof err);
            if (st == VSD_ERR_FORMAT && strstr(err, "NaN or infinite")) {
                found = 1;
                CHECK_CONTAINS(err, path);
                CHECK_CONTAINS(err, "grid 'density'");
                CHECK_CONTAINS(err, "= inf");
                CHECK(vol == NULL);
            } else {
                CHECK_MSG(st == VSD_OK || st == VSD_ERR_FORMAT, "offset %ld: status %d: %s", off, (int)st, err);
                vsd_volume_destroy(vol);
            }
            buf[off] = keep[0];
            buf[off + 1] = keep[1];
        }
    }
    CHECK_MSG(found, "no 2-byte position near the end of %s decoded to an infinite voxel", src);
    if (f) fclose(f);
    free(buf);
    remove(path);
}

int main(void)
{
    test_non_finite_file();
    test_smoke64();
    test_arnold_grids();
    test_external();
    test_errors();
    test_corrupt_structure();
    test_tiny_trees();
    test_sparse_box();
    test_corrupt_tree();
    test_load_time();
    check_every_file();
    return test_finish("test_vdbio");
}
