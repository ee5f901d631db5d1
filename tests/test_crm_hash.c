/* The residual hash of compensated ray marching (Zhou et al. 2008 §5.2; crm_residual_hash.h,
 * crm_hash_kernel.h) against its contract: the quantisation (round half away from zero,
 * auto step max|R|/127, saturation, zeros not stored); a full-grid scan in which every stored
 * voxel decodes exactly to q * step and every other voxel, and every point outside the grid,
 * to exactly 0; the table sizes of the paper and L&H (m^3 >= K within the load slack,
 * r starting at ceil(cbrt(K/3)) + 9 and coprime with m); trilinear decoding against
 * trilinear interpolation of the quantised field; empty, dense and unavoidably colliding
 * inputs; NaN/Inf errors naming the voxel; the bounded give-up naming K and r. */
#include "test_common.h"
#include "methods/crm/crm_residual_hash.h"
#include <stdint.h>
#include <stdlib.h>

static unsigned long long rng_state = 20080811;
static double urand(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

static size_t idx(int nx, int ny, int i, int j, int k) { return (size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * k); }

static int ceil_cbrt(double v)
{
    int c = 0;
    while ((double)c * c * c < v) c++;
    return c;
}

static int gcd(int a, int b) { return b ? gcd(b, a % b) : a; }

/* Random sparse residual: a fraction `frac` of voxels get |R| in [0.02, 1] of either sign,
 * a few more get values far below half a step (they must quantise to 0 and not be stored). */
static float *random_residual(int nx, int ny, int nz, double frac)
{
    size_t n = (size_t)nx * ny * nz, v;
    float *R = malloc(n * sizeof *R);
    for (v = 0; v < n && R; v++) {
        double u = urand();
        if (u < frac)
            R[v] = (float)((0.02 + 0.98 * urand()) * (urand() < 0.5 ? -1 : 1));
        else
            R[v] = u < frac + 0.02 ? (float)(1e-4 * (urand() - 0.5)) : 0.0f;
    }
    return R;
}

/* A smoke-like residual on 128^3: D - D~ is noise-like inside the plume (a ball here) and 0
 * outside; quantisation with the auto step zeroes the small values, leaving ~10-20%. */
static float *plume_residual(int n)
{
    float *R = malloc((size_t)n * n * n * sizeof *R);
    int i, j, k;
    for (k = 0; k < n && R; k++)
        for (j = 0; j < n; j++)
            for (i = 0; i < n; i++) {
                double x = (i + 0.5) / n - 0.5, y = (j + 0.5) / n - 0.45, z = (k + 0.5) / n - 0.5;
                double g = (urand() - 0.5) + (urand() - 0.5) + (urand() - 0.5); /* ~bell-shaped */
                double inside = x * x + y * y * 0.5 + z * z < 0.12;
                /* heavy tail: most residuals are tiny, a few are large (the RBFs miss detail) */
                R[idx(n, n, i, j, k)] = inside ? (float)(0.3 * g * g * g * (urand() < 0.3 ? 10.0 : 1.0)) : 0.0f;
            }
    return R;
}

/* Reference trilinear of the quantised field, voxel (i,j,k) at (i+.5, j+.5, k+.5), 0 outside. */
static double ref_voxel(const int8_t *q, float step, int nx, int ny, int nz, int i, int j, int k)
{
    if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return 0.0;
    return (double)q[idx(nx, ny, i, j, k)] * step;
}

static double ref_trilinear(const int8_t *q, float step, int nx, int ny, int nz, double x, double y, double z)
{
    double fx = x - 0.5, fy = y - 0.5, fz = z - 0.5, s = 0.0;
    int i = (int)floor(fx), j = (int)floor(fy), k = (int)floor(fz), a, b, c;
    double tx = fx - i, ty = fy - j, tz = fz - k;
    for (c = 0; c < 2; c++)
        for (b = 0; b < 2; b++)
            for (a = 0; a < 2; a++)
                s += (a ? tx : 1 - tx) * (b ? ty : 1 - ty) * (c ? tz : 1 - tz) *
                     ref_voxel(q, step, nx, ny, nz, i + a, j + b, k + c);
    return s;
}

/* Build the hash of R and check the whole contract against an independent quantisation.
 * Returns the stats (stored = (size_t)-1 when the build failed). */
static vsd_crm_hash_stats check_hash(const char *name, int nx, int ny, int nz, const float *R, float step_in)
{
    size_t n = (size_t)nx * ny * nz, K = 0, bad_stored = 0, bad_absent = 0;
    int8_t *q = malloc(n);
    float step = 0.0f;
    char err[512] = "";
    vsd_crm_hash *h = NULL;
    vsd_crm_hash_stats s;
    vsd_crm_hash_view view;
    double max_tri_err = 0.0, tol;
    int t, i, j, k;
    memset(&s, 0, sizeof s);
    s.stored = (size_t)-1;
    CHECK(q != NULL);
    if (!q) return s;
    CHECK(vsd_crm_quantise_residual(nx, ny, nz, R, step_in, q, &step, &K, NULL, err, sizeof err) == VSD_OK);
    CHECK_MSG(vsd_crm_hash_build(nx, ny, nz, R, step_in, &h, err, sizeof err) == VSD_OK, "%s: %s", name, err);
    if (!h) {
        free(q);
        return s;
    }
    s = vsd_crm_hash_get_stats(h);
    view = vsd_crm_hash_get_view(h);
    CHECK(s.stored == K && vsd_crm_hash_stored(h) == K);
    CHECK(s.voxels == n);
    CHECK(s.quant_step == step && view.step == step && vsd_crm_hash_quant_step(h) == step);

    /* Every voxel of the grid: stored ones exactly q * step, absent ones exactly 0. */
    for (k = 0; k < nz; k++)
        for (j = 0; j < ny; j++)
            for (i = 0; i < nx; i++) {
                int8_t qv = q[idx(nx, ny, i, j, k)];
                float d = vsd_crm_residual(&view, i, j, k);
                if (qv && d != (float)qv * step) bad_stored++;
                if (!qv && d != 0.0f) bad_absent++;
            }
    CHECK_MSG(bad_stored == 0, "%s: %zu stored voxels decode wrongly", name, bad_stored);
    CHECK_MSG(bad_absent == 0, "%s: %zu absent voxels decode to nonzero", name, bad_absent);

    /* Outside the grid: 0, including coordinates that alias inside under mod m or mod r. */
    {
        int out[][3] = {{-1, 0, 0}, {0, -1, 0}, {0, 0, -1}, {nx, 0, 0}, {0, ny, 0}, {0, 0, nz},
                        {nx + 5, ny / 2, nz / 2}, {-nx, -ny, -nz}, {2147483647, 0, 0}, {-2147483647 - 1, 3, 3}};
        for (t = 0; t < (int)(sizeof out / sizeof out[0]); t++)
            CHECK(vsd_crm_residual(&view, out[t][0], out[t][1], out[t][2]) == 0.0f);
    }

    /* Sizes: the paper's r0 = ceil(cbrt(K/3)) + 9 made coprime with m0 = ceil(cbrt(K)); H a cube
     * holding K within the load slack (or the tightest cube when that is already above it). */
    if (K > 0) {
        int m0 = ceil_cbrt((double)K), r_paper = ceil_cbrt((double)K / 3.0) + 9;
        CHECK((size_t)s.m * s.m * s.m >= K);
        CHECK(s.m_initial == m0 && s.m >= m0);
        CHECK_MSG(s.m == m0 || (double)s.m * s.m * s.m <= VSD_CRM_HASH_LOAD_SLACK * (double)K, "%s: m %d, K %zu",
                  name, s.m, K);
        CHECK(s.r_initial >= r_paper && s.r_initial < r_paper + 8 && gcd(s.r_initial, m0) == 1);
        CHECK(s.r >= s.r_initial && gcd(s.r, s.m) == 1);
        CHECK(s.attempts >= 1 && s.attempts <= VSD_CRM_HASH_MAX_GROWTHS + 1);
        CHECK(view.m == s.m && view.r == s.r && vsd_crm_hash_table_side(h) == s.m &&
              vsd_crm_hash_offset_side(h) == s.r);
        CHECK(view.n_table == (size_t)s.m * s.m * s.m && view.n_offsets == (size_t)s.r * s.r * s.r);
        CHECK(view.table != NULL && view.offsets != NULL);
    } else {
        CHECK(s.m == 0 && s.r == 0 && view.n_table == 0 && view.n_offsets == 0);
    }
    CHECK(view.n_occupancy == (n + 31) / 32);
    CHECK(s.bytes == view.n_occupancy * 4 + view.n_offsets * 4 + view.n_table && vsd_crm_hash_bytes(h) == s.bytes);
    CHECK(s.build_seconds >= 0.0 && vsd_crm_hash_build_seconds(h) == s.build_seconds);

    /* Trilinear: at random points (half a voxel past the grid on each side, where the field
     * fades to 0) and at voxel centres, against the quantised field interpolated in double. */
    tol = 1e-5 * 127.0 * step;
    for (t = 0; t < 20000; t++) {
        double x = -1.0 + (nx + 2.0) * urand(), y = -1.0 + (ny + 2.0) * urand(), z = -1.0 + (nz + 2.0) * urand();
        double e;
        if (t % 4 == 0) { /* voxel centres: exactly the voxel's value */
            x = floor(x) + 0.5;
            y = floor(y) + 0.5;
            z = floor(z) + 0.5;
            CHECK(vsd_crm_residual_trilinear(&view, (float)x, (float)y, (float)z) ==
                  vsd_crm_residual(&view, (int)floor(x), (int)floor(y), (int)floor(z)));
        }
        e = fabs(vsd_crm_residual_trilinear(&view, (float)x, (float)y, (float)z) -
                 ref_trilinear(q, step, nx, ny, nz, (float)x, (float)y, (float)z));
        if (e > max_tri_err) max_tri_err = e;
    }
    CHECK_MSG(max_tri_err <= tol, "%s: trilinear error %g > %g", name, max_tri_err, tol);
    CHECK(vsd_crm_residual_trilinear(&view, NAN, 1.0f, 1.0f) == 0.0f);
    CHECK(vsd_crm_residual_trilinear(&view, 1e30f, 1.0f, 1.0f) == 0.0f);
    CHECK(vsd_crm_residual_trilinear(&view, -0.5f, 1.5f, 1.5f) == 0.0f);

    printf("%-22s %3dx%3dx%3d K=%8zu (%5.1f%%) m=%3d (m0 %3d) r=%3d (r0 %3d) attempts=%d bytes=%9zu "
           "(%.2f B/stored; dense int8 %zu) %.3f s\n",
           name, nx, ny, nz, K, 100.0 * K / n, s.m, s.m_initial, s.r, s.r_initial, s.attempts, s.bytes,
           K ? (double)s.bytes / K : 0.0, n, s.build_seconds);
    vsd_crm_hash_destroy(h);
    free(q);
    return s;
}

/* check_hash on random n^3 residuals, one for each nonzero fraction of fracs[3] */
static void check_random_cubes(int n, const double fracs[3])
{
    int f;
    for (f = 0; f < 3; f++) {
        float *R = random_residual(n, n, n, fracs[f]);
        char name[64];
        snprintf(name, sizeof name, "random %d^3 %.0f%%", n, 100 * fracs[f]);
        CHECK(R != NULL);
        if (R) check_hash(name, n, n, n, R, 0.0f);
        free(R);
    }
}

static void test_random_grids(void)
{
    static const double fracs[] = {0.05, 0.15, 0.30};
    check_random_cubes(64, fracs);
    { /* non-cubic grid, explicit step */
        float *R = random_residual(37, 50, 23, 0.2);
        if (R) check_hash("random 37x50x23 step", 37, 50, 23, R, 0.01f);
        free(R);
    }
}

/* The report's sizes: 128^3 at 5%, 20% and 50% nonzero, and the smoke-like residual. */
static void test_128(void)
{
    static const double fracs[] = {0.05, 0.20, 0.50};
    check_random_cubes(128, fracs);
    {
        float *R = plume_residual(128);
        vsd_crm_hash_stats s;
        CHECK(R != NULL);
        if (!R) return;
        s = check_hash("plume 128^3", 128, 128, 128, R, 0.0f);
        CHECK(s.stored > 0 && s.stored < (size_t)128 * 128 * 128 / 3); /* realistic sparsity */
        free(R);
    }
}

/* Structured residuals (a thin slab, a point lattice) leave the free slots in patterns that
 * make the first sizes fail; the growth must still give an exact table. */
static void test_structured(void)
{
    int n = 64, i, j, k;
    float *R = calloc((size_t)n * n * n, sizeof *R);
    CHECK(R != NULL);
    if (!R) return;
    for (k = 0; k < n; k++)
        for (j = 0; j < n; j++)
            for (i = 0; i < 6; i++) R[idx(n, n, i, j, k)] = 0.5f + (float)urand();
    check_hash("slab 64^3", n, n, n, R, 0.0f);
    memset(R, 0, (size_t)n * n * n * sizeof *R);
    for (k = 0; k < n; k++)
        for (j = 0; j < n; j += 4)
            for (i = 0; i < n; i += 4)
                if (urand() < 0.8) R[idx(n, n, i, j, k)] = -0.5f - (float)urand();
    check_hash("lattice 64^3", n, n, n, R, 0.0f);
    free(R);
}

static void test_empty_and_dense(void)
{
    int n = 40;
    size_t N = (size_t)n * n * n, v;
    float *R = calloc(N, sizeof *R);
    vsd_crm_hash_stats s;
    CHECK(R != NULL);
    if (!R) return;
    /* All zero: nothing stored, auto step falls back to 1. */
    s = check_hash("empty", n, n, n, R, 0.0f);
    CHECK(s.stored == 0 && s.quant_step == 1.0f && s.bytes == (N + 31) / 32 * 4);
    /* Values all below half the explicit step: quantised to 0, nothing stored. */
    for (v = 0; v < N; v++) R[v] = (float)(0.49 * (urand() - 0.5));
    s = check_hash("below half step", n, n, n, R, 1.0f);
    CHECK(s.stored == 0);
    /* Dense: every voxel stored; m^3 >= K = N. */
    for (v = 0; v < N; v++) R[v] = (float)((0.1 + urand()) * (v % 3 ? 1 : -1));
    s = check_hash("dense 40^3", n, n, n, R, 0.0f);
    CHECK(s.stored == N);
    free(R);
}

/* Quantisation: round half away from zero, auto step, saturation, zeros not counted. */
static void test_quantise(void)
{
    float R[8] = {2.5f, -2.5f, 0.49f, -0.5f, 200.0f, -127.4f, 0.0f, 1.5f};
    int8_t q[8];
    float step = 0.0f;
    size_t stored = 0, clamped = 0;
    char err[256] = "";
    CHECK(vsd_crm_quantise_residual(2, 2, 2, R, 1.0f, q, &step, &stored, &clamped, err, sizeof err) == VSD_OK);
    CHECK(step == 1.0f);
    CHECK(q[0] == 3 && q[1] == -3 && q[2] == 0 && q[3] == -1 && q[4] == 127 && q[5] == -127 && q[6] == 0 &&
          q[7] == 2);
    CHECK(stored == 6 && clamped == 1);
    /* Auto: step = max|R| / 127, so the largest value maps to +-127 and nothing saturates. */
    CHECK(vsd_crm_quantise_residual(2, 2, 2, R, 0.0f, q, &step, &stored, &clamped, err, sizeof err) == VSD_OK);
    CHECK(step == 200.0f / 127.0f && q[4] == 127 && q[5] == -81 && clamped == 0);
    CHECK(q[2] == 0 && q[0] == 2); /* 2.5 / 1.5748 = 1.59 -> 2 */
    /* Bad steps and sizes. */
    CHECK(vsd_crm_quantise_residual(2, 2, 2, R, -1.0f, q, NULL, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "step");
    CHECK(vsd_crm_quantise_residual(2, 2, 2, R, NAN, q, NULL, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(vsd_crm_quantise_residual(2, 2, 2, R, INFINITY, q, NULL, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(vsd_crm_quantise_residual(0, 2, 2, R, 1.0f, q, NULL, NULL, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "0 x 2 x 2");
    CHECK(vsd_crm_quantise_residual(65536, 65536, 2, R, 1.0f, q, NULL, NULL, NULL, err, sizeof err) ==
          VSD_ERR_INVALID);
}

static void test_nan_inf(void)
{
    int nx = 8, ny = 9, nz = 10;
    float *R = calloc((size_t)nx * ny * nz, sizeof *R);
    vsd_crm_hash *h = (vsd_crm_hash *)1;
    char err[256] = "";
    CHECK(R != NULL);
    if (!R) return;
    R[idx(nx, ny, 1, 1, 1)] = 0.5f;
    R[idx(nx, ny, 3, 4, 5)] = NAN;
    CHECK(vsd_crm_hash_build(nx, ny, nz, R, 0.0f, &h, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(h == NULL);
    CHECK_CONTAINS(err, "(3, 4, 5)");
    CHECK_CONTAINS(err, "NaN");
    R[idx(nx, ny, 3, 4, 5)] = 0.0f;
    R[idx(nx, ny, 7, 8, 9)] = -INFINITY;
    CHECK(vsd_crm_hash_build(nx, ny, nz, R, 0.0f, &h, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "(7, 8, 9)");
    CHECK_CONTAINS(err, "infinite");
    CHECK(vsd_crm_hash_build(nx, ny, nz, R, 0.0f, NULL, err, sizeof err) == VSD_ERR_INVALID);
    vsd_crm_hash_destroy(NULL);
    free(R);
}

/* Two voxels 22 apart in x: with K = 2, m = 2 and r = 11 they share both h0 and h1, so no
 * offset separates them (an unavoidable collision); the builder must grow r and succeed, and
 * with no growth allowed give up with an error naming K and r. */
static void test_unavoidable_collision(void)
{
    int n = 32;
    float *R = calloc((size_t)n * n * n, sizeof *R);
    vsd_crm_hash *h = NULL;
    vsd_crm_hash_params p = vsd_crm_hash_default_params();
    vsd_crm_hash_stats s;
    char err[512] = "";
    CHECK(R != NULL);
    if (!R) return;
    R[idx(n, n, 0, 0, 0)] = 1.0f;
    R[idx(n, n, 22, 0, 0)] = -0.5f;
    s = check_hash("collision pair", n, n, n, R, 0.0f);
    CHECK(s.stored == 2 && s.m_initial == 2 && s.r_initial == 11 && s.attempts >= 2 && s.r > 11);
    p.max_growths = 0;
    CHECK(vsd_crm_hash_build_ex(n, n, n, R, 0.0f, &p, &h, err, sizeof err) == VSD_ERR_UNSUPPORTED);
    CHECK(h == NULL);
    CHECK_CONTAINS(err, "K = 2 ");
    CHECK_CONTAINS(err, "r = 11");
    CHECK_CONTAINS(err, "share a hash slot");
    /* An offset table past its size limit is refused, not allocated. */
    p = vsd_crm_hash_default_params();
    p.r_initial = 5000;
    CHECK(vsd_crm_hash_build_ex(n, n, n, R, 0.0f, &p, &h, err, sizeof err) == VSD_ERR_UNSUPPORTED);
    CHECK_CONTAINS(err, "r passed its limit");
    p.max_growths = -1;
    CHECK(vsd_crm_hash_build_ex(n, n, n, R, 0.0f, &p, &h, err, sizeof err) == VSD_ERR_INVALID);
    free(R);
}

/* Same input, same table: the build is deterministic. */
static void test_deterministic(void)
{
    float *R = random_residual(48, 48, 48, 0.2);
    vsd_crm_hash *a = NULL, *b = NULL;
    char err[256];
    CHECK(R != NULL);
    if (R && vsd_crm_hash_build(48, 48, 48, R, 0.0f, &a, err, sizeof err) == VSD_OK &&
        vsd_crm_hash_build(48, 48, 48, R, 0.0f, &b, err, sizeof err) == VSD_OK) {
        vsd_crm_hash_view va = vsd_crm_hash_get_view(a), vb = vsd_crm_hash_get_view(b);
        CHECK(va.m == vb.m && va.r == vb.r);
        CHECK(memcmp(va.table, vb.table, va.n_table) == 0);
        CHECK(memcmp(va.offsets, vb.offsets, va.n_offsets * 4) == 0);
    } else {
        CHECK(0);
    }
    vsd_crm_hash_destroy(a);
    vsd_crm_hash_destroy(b);
    free(R);
}

int main(void)
{
    test_quantise();
    test_nan_inf();
    test_empty_and_dense();
    test_unavoidable_collision();
    test_random_grids();
    test_structured();
    test_deterministic();
    test_128();
    return test_finish("test_crm_hash");
}
