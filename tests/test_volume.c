/* The sparse brick volume (vsd/volume.h): dense round trip, trilinear exactness, majorant
 * bounds, world bounds, empty volumes and argument errors. */
#include "test_common.h"

#include "vsd/volume.h"

#include <float.h>
#include <stdint.h>
#include <stdlib.h>

/* Small deterministic generator (xorshift64*), so failures reproduce. */
static uint64_t rng_state = 0x9E3779B97F4A7C15ull;
static double rnd(void)
{
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (double)((rng_state * 2685821657736338717ull) >> 11) / 9007199254740992.0;
}

static size_t dense_index(const int32_t dims[3], int x, int y, int z)
{
    return (size_t)x + (size_t)dims[0] * ((size_t)y + (size_t)dims[1] * (size_t)z);
}

/* A sparse random field: blobs of non-zero values in some 4^3 blocks, zero elsewhere, so that
 * some bricks are empty and must be dropped. Values in [lo, hi]. */
static float *random_field(const int32_t dims[3], double fill, double lo, double hi)
{
    float *v = calloc((size_t)dims[0] * dims[1] * dims[2], sizeof *v);
    for (int z = 0; z < dims[2]; z += 4)
        for (int y = 0; y < dims[1]; y += 4)
            for (int x = 0; x < dims[0]; x += 4) {
                if (rnd() > fill)
                    continue;
                for (int k = z; k < z + 4 && k < dims[2]; ++k)
                    for (int j = y; j < y + 4 && j < dims[1]; ++j)
                        for (int i = x; i < x + 4 && i < dims[0]; ++i)
                            v[dense_index(dims, i, j, k)] = (float)(lo + (hi - lo) * rnd());
            }
    return v;
}

static int cell_of(const vsd_volume *vol, const double p[3], int c[3])
{
    for (int a = 0; a < 3; ++a) {
        c[a] = (int)floor((p[a] - vol->origin[a]) / 8.0);
        if (c[a] < 0 || c[a] >= vol->brick_dims[a])
            return 0;
    }
    return 1;
}

static size_t cell_index(const vsd_volume *vol, const int c[3])
{
    return (size_t)c[0] + (size_t)vol->brick_dims[0] * ((size_t)c[1] + (size_t)vol->brick_dims[1] * (size_t)c[2]);
}

/* Every voxel comes back where it was put, zero outside; empty bricks are dropped and the
 * pool holds exactly the non-empty ones. */
static void test_round_trip(void)
{
    const int32_t dims[3] = {21, 13, 30};
    const int32_t index_min[3] = {-5, 8, 3};   /* y starts on a multiple of 8: margin cell */
    float *v = random_field(dims, 0.3, 0.1, 2.0);
    vsd_volume *vol = NULL;
    char err[256] = "";
    CHECK(vsd_volume_create_dense(v, dims, index_min, NULL, &vol, err, sizeof err) == VSD_OK);
    if (!vol) {
        free(v);
        return;
    }
    uint64_t nonzero = 0;
    double sum = 0.0;
    int mismatches = 0;
    for (int z = -9; z < dims[2] + 9; ++z)
        for (int y = -9; y < dims[1] + 9; ++y)
            for (int x = -9; x < dims[0] + 9; ++x) {
                const int inside = x >= 0 && y >= 0 && z >= 0 && x < dims[0] && y < dims[1] && z < dims[2];
                const float want = inside ? v[dense_index(dims, x, y, z)] : 0.0f;
                const float got = vsd_volume_voxel(vol, index_min[0] + x, index_min[1] + y, index_min[2] + z);
                mismatches += got != want;
                nonzero += want != 0.0f;
                sum += want;
            }
    CHECK_MSG(mismatches == 0, "%d voxels differ", mismatches);
    CHECK(vol->active_voxels == nonzero);
    for (int a = 0; a < 3; ++a)
        CHECK(vol->origin[a] % 8 == 0);
    CHECK(vol->origin[1] == 0);   /* floor8(8 - 1): covers the support below index 8 */

    /* Pool = exactly the non-zero bricks, each non-empty; its sum equals the dense sum. */
    int present = 0, empty_in_pool = 0;
    const int ncell = vol->brick_dims[0] * vol->brick_dims[1] * vol->brick_dims[2];
    for (int c = 0; c < ncell; ++c) {
        const int32_t s = vol->brick_slots[c];
        if (s < 0)
            continue;
        ++present;
        int any = 0;
        for (int n = 0; n < VSD_BRICK_VOXELS; ++n)
            any |= vol->voxels[(size_t)s * VSD_BRICK_VOXELS + n] != 0.0f;
        empty_in_pool += !any;
    }
    CHECK(present == vol->brick_count);
    CHECK(empty_in_pool == 0);
    CHECK(vol->brick_count < ncell);   /* some bricks were all zero and dropped */
    double pool_sum = 0.0;
    for (size_t n = 0; n < (size_t)vol->brick_count * VSD_BRICK_VOXELS; ++n)
        pool_sum += vol->voxels[n];
    CHECK_NEAR(pool_sum, sum, 1e-9 * sum);
    CHECK(vol->value_min >= 0.0f && vol->value_max <= 2.0f && vol->value_max > 1.5f);
    vsd_volume_destroy(vol);
    free(v);
}

/* Trilinear interpolation reproduces a linear field exactly wherever all 8 corners are
 * inside the data, and equals the voxel at integer points. */
static void test_trilinear_linear_field(void)
{
    const int32_t dims[3] = {19, 11, 14};
    const int32_t index_min[3] = {3, -6, 16};
    const double a0 = 2.0, ax = 0.25, ay = -0.125, az = 0.5;
    float *v = malloc((size_t)dims[0] * dims[1] * dims[2] * sizeof *v);
    for (int z = 0; z < dims[2]; ++z)
        for (int y = 0; y < dims[1]; ++y)
            for (int x = 0; x < dims[0]; ++x)
                v[dense_index(dims, x, y, z)] = (float)(a0 + ax * (index_min[0] + x) +
                                                         ay * (index_min[1] + y) + az * (index_min[2] + z));
    vsd_volume *vol = NULL;
    CHECK(vsd_volume_create_dense(v, dims, index_min, NULL, &vol, NULL, 0) == VSD_OK);
    if (!vol) {
        free(v);
        return;
    }
    double worst = 0.0;
    for (int n = 0; n < 20000; ++n) {
        double p[3];
        for (int a = 0; a < 3; ++a)
            p[a] = index_min[a] + rnd() * (dims[a] - 1);
        const double want = a0 + ax * p[0] + ay * p[1] + az * p[2];
        const double err = fabs(vsd_volume_sample_index(vol, p) - want);
        if (err > worst)
            worst = err;
    }
    CHECK_MSG(worst < 2e-5, "worst trilinear error %g", worst);
    const double q[3] = {index_min[0] + 4.0, index_min[1] + 7.0, index_min[2] + 2.0};
    CHECK(vsd_volume_sample_index(vol, q) == vsd_volume_voxel(vol, (int32_t)q[0], (int32_t)q[1], (int32_t)q[2]));
    /* Half way past the last voxel the field falls linearly to the zero outside. */
    const double last = index_min[0] + dims[0] - 1;
    const double r[3] = {last + 0.5, index_min[1] + 5.0, index_min[2] + 5.0};
    const double edge = a0 + ax * last + ay * r[1] + az * r[2];
    CHECK_NEAR(vsd_volume_sample_index(vol, r), 0.5 * edge, 1e-5);
    const double far[3] = {last + 1.0, r[1], r[2]};
    CHECK(vsd_volume_sample_index(vol, far) == 0.0f);
    vsd_volume_destroy(vol);
    free(v);
}

/* brick_min/brick_max over the 9^3 voxels of a cell, the slow way. */
static void brute_range(const vsd_volume *vol, const int c[3], float *lo, float *hi)
{
    *lo = FLT_MAX;
    *hi = -FLT_MAX;
    for (int z = 0; z <= 8; ++z)
        for (int y = 0; y <= 8; ++y)
            for (int x = 0; x <= 8; ++x) {
                const float v = vsd_volume_voxel(vol, vol->origin[0] + 8 * c[0] + x,
                                                 vol->origin[1] + 8 * c[1] + y, vol->origin[2] + 8 * c[2] + z);
                if (v < *lo) *lo = v;
                if (v > *hi) *hi = v;
            }
}

/* brick_max is an upper (brick_min a lower) bound of the field anywhere in the cell, it is
 * tight (equals the 9^3 brute force), and outside the cells the field is exactly 0. Run on
 * a positive field and on one with negative values. */
static void test_majorant(double lo_value, const int32_t index_min[3])
{
    const int32_t dims[3] = {29, 17, 24};
    float *v = random_field(dims, 0.35, lo_value, 3.0);
    vsd_volume *vol = NULL;
    CHECK(vsd_volume_create_dense(v, dims, index_min, NULL, &vol, NULL, 0) == VSD_OK);
    if (!vol) {
        free(v);
        return;
    }
    int bad_range = 0, above = 0, below = 0, outside_nonzero = 0, skipped_nonzero = 0;
    int c[3];
    for (c[2] = 0; c[2] < vol->brick_dims[2]; ++c[2])
        for (c[1] = 0; c[1] < vol->brick_dims[1]; ++c[1])
            for (c[0] = 0; c[0] < vol->brick_dims[0]; ++c[0]) {
                float lo, hi;
                brute_range(vol, c, &lo, &hi);
                const size_t i = cell_index(vol, c);
                bad_range += lo != vol->brick_min[i] || hi != vol->brick_max[i];
            }
    for (int n = 0; n < 200000; ++n) {
        double p[3];
        for (int a = 0; a < 3; ++a)   /* the cells plus a shell of 3 voxels around them */
            p[a] = vol->origin[a] - 3.0 + rnd() * (8.0 * vol->brick_dims[a] + 6.0);
        if (n % 7 == 0)
            p[n % 3] = floor(p[n % 3]);   /* hit voxel planes and brick faces too */
        const float s = vsd_volume_sample_index(vol, p);
        if (!cell_of(vol, p, c)) {
            outside_nonzero += s != 0.0f;
            continue;
        }
        const size_t i = cell_index(vol, c);
        above += s > vol->brick_max[i];
        below += s < vol->brick_min[i];
        skipped_nonzero += vol->brick_min[i] == 0.0f && vol->brick_max[i] == 0.0f && s != 0.0f;
    }
    CHECK_MSG(bad_range == 0, "%d cells with a range different from the 9^3 brute force", bad_range);
    CHECK_MSG(above == 0, "%d samples above brick_max", above);
    CHECK_MSG(below == 0, "%d samples below brick_min", below);
    CHECK_MSG(outside_nonzero == 0, "%d non-zero samples outside the brick cells", outside_nonzero);
    CHECK_MSG(skipped_nonzero == 0, "%d non-zero samples in cells marked empty", skipped_nonzero);
    vsd_volume_destroy(vol);
    free(v);
}

static void transform_point(const double m[16], const double p[3], double w[3])
{
    for (int r = 0; r < 3; ++r)
        w[r] = m[r * 4] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3];
}

/* World bounds contain every world point where the field is non-zero, through
 * object_matrix * index_to_world, and follow the transform (scale, translation). */
static void test_world_bounds(void)
{
    const int32_t dims[3] = {10, 12, 9};
    const int32_t index_min[3] = {0, 4, -3};
    float *v = random_field(dims, 0.8, 0.5, 1.0);
    v[0] = 1.0f;   /* make sure index (0,4,-3) is non-zero: its support starts at -1 */
    const double i2w[16] = {0.5, 0, 0, 10, 0, 0.25, 0, -2, 0, 0, 2.0, 1, 0, 0, 0, 1};
    const double obj[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 5, 0, 0, 0, 1};
    vsd_volume *vol = NULL;
    CHECK(vsd_volume_create_dense(v, dims, index_min, i2w, &vol, NULL, 0) == VSD_OK);
    if (!vol) {
        free(v);
        return;
    }
    CHECK_NEAR(vol->voxel_size[0], 0.5, 1e-12);
    CHECK_NEAR(vol->voxel_size[1], 0.25, 1e-12);
    CHECK_NEAR(vol->voxel_size[2], 2.0, 1e-12);
    double lo[3], hi[3], olo[3], ohi[3];
    vsd_volume_world_bounds(vol, NULL, lo, hi);
    vsd_volume_world_bounds(vol, obj, olo, ohi);
    for (int a = 0; a < 3; ++a) {
        CHECK_NEAR(olo[a], lo[a] + (a == 2 ? 5.0 : 0.0), 1e-9);
        CHECK_NEAR(ohi[a], hi[a] + (a == 2 ? 5.0 : 0.0), 1e-9);
    }
    /* x: data from index 0 needs the margin cell [-8, 0); the last voxel 9 lies in cell [8,16) */
    CHECK_NEAR(lo[0], 10.0 + 0.5 * -8, 1e-9);
    CHECK_NEAR(hi[0], 10.0 + 0.5 * 16, 1e-9);
    int escaped = 0;
    for (int n = 0; n < 50000; ++n) {
        double p[3], w[3];
        for (int a = 0; a < 3; ++a)
            p[a] = index_min[a] - 2.0 + rnd() * (dims[a] + 4.0);
        if (vsd_volume_sample_index(vol, p) == 0.0f)
            continue;
        transform_point(i2w, p, w);
        for (int a = 0; a < 3; ++a)
            escaped += w[a] < lo[a] || w[a] > hi[a];
    }
    CHECK_MSG(escaped == 0, "%d non-zero samples outside the world bounds", escaped);
    vsd_volume_destroy(vol);
    free(v);
}

static void test_empty(void)
{
    vsd_volume *vol = NULL;
    char err[256];
    CHECK(vsd_volume_create_empty(NULL, &vol, err, sizeof err) == VSD_OK);
    if (vol) {
        for (int a = 0; a < 3; ++a)
            CHECK(vol->brick_dims[a] == 0);
        CHECK(vol->brick_count == 0 && vol->active_voxels == 0);
        CHECK(vol->index_to_world[0] == 1.0 && vol->index_to_world[15] == 1.0 && vol->index_to_world[3] == 0.0);
        CHECK(vsd_volume_voxel(vol, 0, 0, 0) == 0.0f);
        const double p[3] = {0.5, 0.5, 0.5};
        CHECK(vsd_volume_sample_index(vol, p) == 0.0f);
        double lo[3], hi[3];
        vsd_volume_world_bounds(vol, NULL, lo, hi);
        CHECK(lo[0] > hi[0] && lo[1] > hi[1] && lo[2] > hi[2]);
        vsd_volume_update_ranges(vol);   /* harmless on an empty volume */
        CHECK(vol->value_min == 0.0f && vol->value_max == 0.0f);
        vsd_volume_destroy(vol);
    }
    /* An all-zero dense array is an empty volume, too. */
    const int32_t dims[3] = {9, 9, 9}, org[3] = {0, 0, 0};
    float *z = calloc(9 * 9 * 9, sizeof *z);
    vol = NULL;
    CHECK(vsd_volume_create_dense(z, dims, org, NULL, &vol, err, sizeof err) == VSD_OK);
    if (vol) {
        CHECK(vol->brick_count == 0 && vol->brick_dims[0] == 0 && vol->active_voxels == 0);
        vsd_volume_destroy(vol);
    }
    free(z);
    vsd_volume_destroy(NULL);
}

/* NaN and Inf voxels are refused, naming the voxel: a NaN majorant would stall or poison
 * delta tracking (issue 16). */
static void test_non_finite(void)
{
    const int32_t dims[3] = {4, 4, 4}, org[3] = {10, 20, 30};
    float v[64] = {0};
    char err[512] = "";
    vsd_volume *vol = NULL;
    v[1 + 4 * 2 + 16 * 3] = NAN;   /* voxel (1, 2, 3) of the array: index (11, 22, 33) */
    v[5] = 0.5f;
    CHECK(vsd_volume_create_dense(v, dims, org, NULL, &vol, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK(vol == NULL);
    CHECK_CONTAINS(err, "NaN or infinite");
    CHECK_CONTAINS(err, "(11, 22, 33)");
    CHECK_CONTAINS(err, "1 voxel that is");
    v[1 + 4 * 2 + 16 * 3] = 1.0f;
    v[63] = -INFINITY;
    v[62] = INFINITY;
    CHECK(vsd_volume_create_dense(v, dims, org, NULL, &vol, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "2 voxels that are");
    CHECK_CONTAINS(err, "(12, 23, 33) = inf");
    v[62] = v[63] = 3.0e38f;   /* huge but finite: a volume (the trackers cap such majorants) */
    CHECK(vsd_volume_create_dense(v, dims, org, NULL, &vol, err, sizeof err) == VSD_OK);
    vsd_volume_destroy(vol);
}

static void test_errors(void)
{
    vsd_volume *vol = (vsd_volume *)1;
    char err[256] = "";
    const int32_t dims[3] = {4, 4, 4}, bad[3] = {4, -1, 4}, org[3] = {0, 0, 0};
    CHECK(vsd_volume_create_dense(NULL, dims, org, NULL, &vol, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(vol == NULL);
    CHECK_CONTAINS(err, "vsd_volume_create_dense");
    float v[64] = {0};
    CHECK(vsd_volume_create_dense(v, bad, org, NULL, &vol, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "out of range");
    const int32_t huge[3] = {INT32_MAX - 2, 0, 0};
    CHECK(vsd_volume_create_dense(v, dims, huge, NULL, &vol, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(vsd_volume_create_empty(NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
}

int main(void)
{
    test_round_trip();
    test_trilinear_linear_field();
    const int32_t org_a[3] = {0, 0, 0}, org_b[3] = {-13, 5, 40};
    test_majorant(0.0, org_a);
    test_majorant(-1.0, org_b);
    test_world_bounds();
    test_empty();
    test_errors();
    test_non_finite();
    return test_finish("test_volume");
}
