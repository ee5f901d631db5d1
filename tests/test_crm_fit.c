/* The crm RBF fit (§5.1 of Zhou et al. 2008) and its cache: recovery of a known sum of
 * Gaussians, the analytic gradient against central differences, bounds, coherent frames
 * (far fewer iterations, insertion when the field gains a blob), empty and NaN grids,
 * option checking, and the cache file (exact round trip, hit without fitting, truncated /
 * corrupt / foreign / other-version files). */
#define _POSIX_C_SOURCE 200809L
#include "test_common.h"
#include "methods/crm/crm_fit.h"
#include "methods/crm/crm_fit_cache.h"
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct grid {
    int n;
    float *d;
} grid;

/* sum of RBFs with the renderer's kernel (vsd_crm_rasterise), on an n^3 grid */
static grid make_grid(int n, const vsd_crm_rbf *b, int count)
{
    grid g = {n, malloc(sizeof(float) * n * n * n)};
    vsd_crm_rbfs r = {(vsd_crm_rbf *)b, count};
    vsd_crm_rasterise(&r, n, n, n, g.d);
    return g;
}

static const vsd_crm_rbf *nearest(const vsd_crm_rbfs *r, const vsd_crm_rbf *t, double *dist)
{
    const vsd_crm_rbf *best = NULL;
    double bd = 1e30;
    for (int l = 0; l < r->count; l++) {
        double dx = r->rbf[l].c[0] - t->c[0], dy = r->rbf[l].c[1] - t->c[1], dz = r->rbf[l].c[2] - t->c[2];
        double dd = sqrt(dx * dx + dy * dy + dz * dz);
        if (dd < bd) bd = dd, best = &r->rbf[l];
    }
    *dist = bd;
    return best;
}

static const vsd_crm_rbf truth[5] = {
    {{12.3f, 14.1f, 20.7f}, 3.2f, 0.9f},
    {{27.6f, 13.4f, 18.2f}, 2.4f, 0.6f},
    {{19.2f, 28.8f, 25.5f}, 4.1f, 0.5f},
    {{30.1f, 30.5f, 9.4f}, 2.0f, 1.0f},
    {{9.7f, 27.3f, 31.2f}, 2.8f, 0.35f},
};

static void small_options(vsd_crm_fit_options *o, int count)
{
    vsd_crm_fit_defaults(o);
    o->rbf_count = count;
    o->radius_min = 0.03f;  /* 1.2 .. 6 voxels on a 40^3 grid */
    o->radius_max = 0.15f;
    o->weight_max = 2.0f;   /* the peaks fall between voxel centres: max density < max weight */
    o->fit_stride = 1;
    o->max_iterations = 4000;
}

/* Five well separated Gaussians are found again: the fit's global optimum is the truth
 * (up to the e^-9 shift of the fit's kernel, ~1e-4 of a weight). */
static void test_recover(void)
{
    grid g = make_grid(40, truth, 5);
    vsd_crm_dense d = {40, 40, 40, g.d};
    vsd_crm_fit_options o;
    vsd_crm_rbfs r = {0};
    vsd_crm_fit_stats st;
    char err[256] = "";
    small_options(&o, 5);
    vsd_status s = vsd_crm_fit(&d, &o, NULL, 0.0, &r, &st, err, sizeof err);
    CHECK_MSG(s == VSD_OK, "%s", err);
    CHECK(r.count == 5 && st.rbf_count == 5);
    CHECK_MSG(st.rel_error < 1e-5, "rel_error %g", st.rel_error);
    CHECK(st.iterations > 0 && st.evaluations >= st.iterations);
    for (int t = 0; t < 5; t++) {
        double dist;
        const vsd_crm_rbf *b = nearest(&r, &truth[t], &dist);
        CHECK_MSG(b && dist < 0.02, "RBF %d: centre off by %g voxels", t, dist);
        if (!b) continue;
        CHECK_NEAR(b->r, truth[t].r, 0.005 * truth[t].r);
        CHECK_NEAR(b->w, truth[t].w, 0.005 * truth[t].w);
    }
    /* Same seed, same fit. */
    vsd_crm_rbfs r2 = {0};
    s = vsd_crm_fit(&d, &o, NULL, 0.0, &r2, NULL, err, sizeof err);
    CHECK(s == VSD_OK && r2.count == r.count && memcmp(r.rbf, r2.rbf, sizeof(vsd_crm_rbf) * r.count) == 0);
    printf("recover: rel_error %.3g, %d iterations, %d evaluations, %d teleports, %.2f s\n", st.rel_error,
           st.iterations, st.evaluations, st.teleports, st.seconds);
    vsd_crm_rbfs_free(&r);
    vsd_crm_rbfs_free(&r2);
    free(g.d);
}

/* Analytic gradient vs central differences f(x±h), h = 1e-2 (voxels / density units) on a
 * noisy field at stride 1 and 2. Measured agreement is ~5e-5: the O(h^2 f''') truncation
 * error and float rounding of residuals (~1e-7 of f, / 2h) are both far below the 1e-3
 * relative tolerance, while a wrong sign or factor in any term is off by >= 50%. */
static void test_gradient(void)
{
    const int n = 24;
    float *d = malloc(sizeof(float) * n * n * n);
    uint64_t s = 7;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double x = i + .5 - 11, y = j + .5 - 12, z = k + .5 - 13;
                s = s * 6364136223846793005ull + 1442695040888963407ull;
                d[i + n * (j + n * k)] = (float)(exp(-(x * x + 0.5 * y * y + 0.7 * z * z) / 20.0) +
                                                 0.05 * (double)(s >> 40) / (1 << 24));
            }
    vsd_crm_dense D = {n, n, n, d};
    vsd_crm_rbf b[3] = {{{10.3f, 11.7f, 12.2f}, 3.1f, 0.6f},
                        {{14.2f, 9.1f, 15.5f}, 2.3f, 0.4f},
                        {{8.8f, 15.2f, 10.1f}, 4.2f, 0.3f}};
    vsd_crm_rbfs R = {b, 3};
    double worst = 0.0;
    for (int stride = 1; stride <= 2; stride++) {
        double g[15], gmax = 0.0;
        double f = vsd_crm_fit_objective(&D, stride, &R, g);
        CHECK(f > 0);
        for (int i = 0; i < 15; i++) gmax = fmax(gmax, fabs(g[i]));
        for (int l = 0; l < 3; l++)
            for (int a = 0; a < 5; a++) {
                float *v = a < 3 ? &b[l].c[a] : a == 3 ? &b[l].r : &b[l].w, v0 = *v;
                const float h = 1e-2f;
                *v = v0 + h;
                double fp = vsd_crm_fit_objective(&D, stride, &R, NULL);
                *v = v0 - h;
                double fm = vsd_crm_fit_objective(&D, stride, &R, NULL);
                *v = v0;
                double fd = (fp - fm) / (2.0 * h), an = g[5 * l + a];
                double tol = 1e-3 * fabs(an) + 1e-5 * gmax;
                CHECK_MSG(fabs(fd - an) <= tol, "stride %d RBF %d param %d: analytic %g, differences %g", stride,
                          l, a, an, fd);
                worst = fmax(worst, fabs(fd - an) / fmax(fabs(an), 1e-12));
            }
    }
    printf("gradient: worst relative difference to central differences %.2e\n", worst);
    /* Bad arguments are -1, not a crash. */
    CHECK(vsd_crm_fit_objective(&D, 0, &R, NULL) == -1.0);
    CHECK(vsd_crm_fit_objective(NULL, 1, &R, NULL) == -1.0);
    free(d);
}

/* A field the RBFs cannot represent exactly (a box plus noise, pulling radii and weights to
 * their bounds): every fitted parameter stays inside the bounds. */
static void test_bounds(void)
{
    const int n = 32;
    float *d = calloc(n * n * n, sizeof(float));
    uint64_t s = 11;
    double dmax = 0.0;
    for (int k = 6; k < 26; k++)
        for (int j = 4; j < 28; j++)
            for (int i = 8; i < 20; i++) {
                s = s * 6364136223846793005ull + 1442695040888963407ull;
                float v = (float)(2.0 + (double)(s >> 40) / (1 << 24));
                d[i + n * (j + n * k)] = v;
                dmax = fmax(dmax, v);
            }
    vsd_crm_dense D = {n, n, n, d};
    vsd_crm_fit_options o;
    vsd_crm_fit_defaults(&o);
    o.rbf_count = 12;
    o.radius_min = 0.05f;
    o.radius_max = 0.1f;
    o.weight_min = 0.2f;
    o.weight_max = 0.5f;
    o.fit_stride = 2;
    o.max_iterations = 400;
    vsd_crm_rbfs r = {0};
    vsd_crm_fit_stats st;
    char err[256] = "";
    CHECK(vsd_crm_fit(&D, &o, NULL, 0.0, &r, &st, err, sizeof err) == VSD_OK);
    CHECK(r.count == 12 && st.iterations <= o.max_iterations);
    int bad = 0, at_bound = 0;
    for (int l = 0; l < r.count; l++) {
        const vsd_crm_rbf *b = &r.rbf[l];
        for (int a = 0; a < 3; a++) bad += !(b->c[a] >= 0 && b->c[a] <= n);
        bad += !(b->r >= 0.05f * n * (1 - 1e-6) && b->r <= 0.1f * n * (1 + 1e-6));
        bad += !(b->w >= 0.2 * dmax * (1 - 1e-6) && b->w <= 0.5 * dmax * (1 + 1e-6));
        at_bound += b->r >= 0.1f * n * (1 - 1e-4) || b->w >= 0.5 * dmax * (1 - 1e-4);
    }
    CHECK_MSG(bad == 0, "%d parameters outside their bounds", bad);
    CHECK_MSG(at_bound > 0, "no parameter reached an upper bound: the test field does not test them");
    vsd_crm_rbfs_free(&r);
    free(d);
}

/* Frame 2 = frame 1 moved by 0.4 voxel: starting from frame 1's fit it converges in far
 * fewer iterations, without teleports; a frame with a new blob gets RBFs inserted. */
static void test_coherent(void)
{
    vsd_crm_rbf moved[5], more[6];
    for (int t = 0; t < 5; t++) {
        moved[t] = truth[t];
        moved[t].c[0] += 0.4f;
        moved[t].c[2] -= 0.3f;
        more[t] = truth[t];
    }
    more[5] = (vsd_crm_rbf){{22.0f, 20.0f, 33.0f}, 2.5f, 0.8f};
    grid g1 = make_grid(40, truth, 5), g2 = make_grid(40, moved, 5), g3 = make_grid(40, more, 6);
    vsd_crm_dense d1 = {40, 40, 40, g1.d}, d2 = {40, 40, 40, g2.d}, d3 = {40, 40, 40, g3.d};
    vsd_crm_fit_options o;
    small_options(&o, 5);
    o.delete_per_frame = 0;
    vsd_crm_rbfs r1 = {0}, r2 = {0}, r3 = {0};
    vsd_crm_fit_stats s1, s2, s3;
    char err[256] = "";
    CHECK(vsd_crm_fit(&d1, &o, NULL, 0.0, &r1, &s1, err, sizeof err) == VSD_OK);
    CHECK(vsd_crm_fit(&d2, &o, &r1, s1.rel_error, &r2, &s2, err, sizeof err) == VSD_OK);
    /* Against a cold first-frame fit of the same moved field. */
    vsd_crm_rbfs cold = {0};
    vsd_crm_fit_stats sc;
    CHECK(vsd_crm_fit(&d2, &o, NULL, 0.0, &cold, &sc, err, sizeof err) == VSD_OK);
    CHECK_MSG(s2.iterations * 3 < sc.iterations && s2.iterations * 3 < s1.iterations,
              "coherent %d vs first %d / cold %d iterations", s2.iterations, s1.iterations, sc.iterations);
    vsd_crm_rbfs_free(&cold);
    CHECK(s2.teleports == 0 && s2.deleted == 0 && r2.count == 5);
    CHECK_MSG(s2.rel_error < 1e-5, "coherent rel_error %g", s2.rel_error);
    printf("coherent: first frame %d iterations, moved frame %d (cold fit of it: %d), rel_error %.3g, %.3g\n",
           s1.iterations, s2.iterations, sc.iterations, s1.rel_error, s2.rel_error);
    /* New blob: 5 RBFs cannot fit it, so RBFs are inserted until the error is back under
     * error_ratio * the first frame's (floored so the ratio rule is reachable). */
    double first = 1e-4;
    CHECK(vsd_crm_fit(&d3, &o, &r1, first, &r3, &s3, err, sizeof err) == VSD_OK);
    CHECK_MSG(s3.inserted >= 1 && s3.inserted <= o.insert_max && r3.count == 5 + s3.inserted,
              "inserted %d, count %d", s3.inserted, r3.count);
    CHECK_MSG(s3.rel_error <= o.error_ratio * first, "rel_error %g after %d insertions", s3.rel_error,
              s3.inserted);
    /* Deletion: the least significant RBFs go first. */
    vsd_crm_rbfs r4 = {0};
    vsd_crm_fit_stats s4;
    o.delete_per_frame = 2;
    o.insert_max = 0;
    CHECK(vsd_crm_fit(&d2, &o, &r1, s1.rel_error, &r4, &s4, err, sizeof err) == VSD_OK);
    CHECK(s4.deleted == 2 && r4.count == 3 && s4.inserted == 0);
    printf("coherent: new blob -> %d inserted, rel_error %.3g; 2 deleted -> rel_error %.3g\n", s3.inserted,
           s3.rel_error, s4.rel_error);
    vsd_crm_rbfs_free(&r1);
    vsd_crm_rbfs_free(&r2);
    vsd_crm_rbfs_free(&r3);
    vsd_crm_rbfs_free(&r4);
    free(g1.d);
    free(g2.d);
    free(g3.d);
}

static void test_empty_and_nan(void)
{
    const int n = 16;
    float *d = calloc(n * n * n, sizeof(float));
    vsd_crm_dense D = {n, n, n, d};
    vsd_crm_fit_options o;
    vsd_crm_fit_defaults(&o);
    vsd_crm_rbfs r = {0};
    vsd_crm_fit_stats st;
    char err[256] = "";
    CHECK(vsd_crm_fit(&D, &o, NULL, 0.0, &r, &st, err, sizeof err) == VSD_OK);
    CHECK(r.count == 0 && st.rbf_count == 0 && st.rel_error == 0.0 && st.evaluations == 0);
    vsd_crm_rbfs_free(&r);
    d[3 + n * (4 + n * 5)] = NAN;
    CHECK(vsd_crm_fit(&D, &o, NULL, 0.0, &r, &st, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "(3, 4, 5)");
    CHECK_CONTAINS(err, "NaN");
    CHECK(r.count == 0 && r.rbf == NULL);
    d[3 + n * (4 + n * 5)] = 0.0f;
    d[15 + n * (0 + n * 9)] = -INFINITY;
    CHECK(vsd_crm_fit(&D, &o, NULL, 0.0, &r, &st, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "(15, 0, 9)");
    CHECK_CONTAINS(err, "infinite");
    vsd_crm_dense bad = {0, n, n, d};
    CHECK(vsd_crm_fit(&bad, &o, NULL, 0.0, &r, &st, err, sizeof err) == VSD_ERR_INVALID);
    /* A previous set needs a usable first_rel_error. */
    d[15 + n * (0 + n * 9)] = 1.0f;
    vsd_crm_rbf one = {{8, 8, 8}, 2, 1};
    vsd_crm_rbfs prev = {&one, 1};
    CHECK(vsd_crm_fit(&D, &o, &prev, NAN, &r, &st, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "first_rel_error");
    free(d);
}

static void test_options(void)
{
    vsd_crm_fit_options o;
    char err[256];
    vsd_crm_fit_defaults(&o);
    CHECK(vsd_crm_fit_options_check(&o, err, sizeof err) == VSD_OK);
    CHECK(o.rbf_count == 800 && o.teleport_every == 20 && o.delete_per_frame == 3 && o.insert_max == 8);
    CHECK_NEAR(o.radius_min, 0.015, 1e-7);
    CHECK_NEAR(o.radius_max, 0.09, 1e-7);
    CHECK_NEAR(o.weight_min, 0.01, 1e-7);
    CHECK_NEAR(o.weight_max, 1.0, 1e-7);
    CHECK_NEAR(o.error_ratio, 1.1, 1e-6);
#define BAD(f, v) do { vsd_crm_fit_defaults(&o); o.f = v; err[0] = '\0'; \
        CHECK(vsd_crm_fit_options_check(&o, err, sizeof err) == VSD_ERR_INVALID); CHECK_CONTAINS(err, #f); \
    } while (0)
    BAD(rbf_count, 0);
    BAD(rbf_count, -5);
    BAD(radius_min, 0.0f);
    BAD(radius_min, NAN);
    BAD(radius_max, 0.01f); /* below radius_min */
    BAD(radius_max, 1.5f);
    BAD(weight_min, -0.1f);
    BAD(weight_max, 0.001f); /* below weight_min */
    BAD(teleport_every, -1);
    BAD(max_iterations, 0);
    BAD(delete_per_frame, -1);
    BAD(insert_max, -2);
    BAD(error_ratio, 0.9f);
    BAD(error_ratio, INFINITY);
    BAD(fit_stride, -1);
    BAD(fit_stride, 65);
#undef BAD
    /* vsd_crm_fit reports them too, before touching the grid. */
    float v = 1.0f;
    vsd_crm_dense D = {1, 1, 1, &v};
    vsd_crm_rbfs r = {0};
    vsd_crm_fit_defaults(&o);
    o.error_ratio = 0.5f;
    CHECK(vsd_crm_fit(&D, &o, NULL, 0.0, &r, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "error_ratio");
}

static long file_size(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return -1;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fclose(f);
    return n;
}

static void write_bytes(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f) return;
    fwrite(p, 1, n, f);
    fclose(f);
}

static unsigned char *read_bytes(const char *path, size_t *n)
{
    long sz = file_size(path);
    unsigned char *b = malloc(sz > 0 ? (size_t)sz : 1);
    FILE *f = fopen(path, "rb");
    *n = f ? fread(b, 1, (size_t)sz, f) : 0;
    if (f) fclose(f);
    return b;
}

static int same_rbfs(const vsd_crm_rbfs *a, const vsd_crm_rbfs *b)
{
    return a->count == b->count && (a->count == 0 || memcmp(a->rbf, b->rbf, sizeof(vsd_crm_rbf) * a->count) == 0);
}

static void test_cache(void)
{
    char dir[1024], path[1200], key[65], key2[65], err[256] = "";
    snprintf(dir, sizeof dir, "%s", test_tmp("crm_fit_cache/nested"));
    grid g = make_grid(40, truth, 4);
    vsd_crm_dense d = {40, 40, 40, g.d};
    vsd_crm_fit_options o;
    small_options(&o, 4);
    o.max_iterations = 300;
    CHECK(vsd_crm_fit_cache_key(&d, &o, NULL, 0.0, key) == VSD_OK);
    CHECK(strlen(key) == 32 && strspn(key, "0123456789abcdef") == 32);
    snprintf(path, sizeof path, "%s/%s.crmfit", dir, key);
    unlink(path);
    /* The key follows the density, the options and the previous fit. */
    CHECK(vsd_crm_fit_cache_key(&d, &o, NULL, 0.5, key2) == VSD_OK && strcmp(key, key2) == 0);
    g.d[1000] += 1e-6f;
    CHECK(vsd_crm_fit_cache_key(&d, &o, NULL, 0.0, key2) == VSD_OK && strcmp(key, key2) != 0);
    g.d[1000] -= 1e-6f;
    o.seed++;
    CHECK(vsd_crm_fit_cache_key(&d, &o, NULL, 0.0, key2) == VSD_OK && strcmp(key, key2) != 0);
    o.seed--;
    vsd_crm_rbfs prev = {(vsd_crm_rbf *)truth, 2};
    CHECK(vsd_crm_fit_cache_key(&d, &o, &prev, 0.1, key2) == VSD_OK && strcmp(key, key2) != 0);
    char key3[65];
    CHECK(vsd_crm_fit_cache_key(&d, &o, &prev, 0.2, key3) == VSD_OK && strcmp(key3, key2) != 0);

    /* Miss, fit, save; then a hit that fits nothing and returns the same RBFs. */
    CHECK(vsd_crm_fit_cache_load(dir, key, &(vsd_crm_rbfs){0}, NULL, err, sizeof err) == VSD_ERR_NOT_FOUND);
    vsd_crm_rbfs a = {0}, b = {0};
    vsd_crm_fit_stats sa, sb;
    int cached = -1;
    vsd_status s = vsd_crm_fit_cached(dir, &d, &o, NULL, 0.0, &a, &sa, err, sizeof err, &cached);
    CHECK_MSG(s == VSD_OK, "%s", err);
    CHECK(cached == 0 && sa.evaluations > 0);
    CHECK(file_size(path) == 96 + 20 * a.count);
    s = vsd_crm_fit_cached(dir, &d, &o, NULL, 0.0, &b, &sb, err, sizeof err, &cached);
    CHECK(s == VSD_OK && cached == 1 && sb.evaluations == 0 && sb.iterations == 0);
    CHECK(same_rbfs(&a, &b) && sb.rel_error == sa.rel_error && sb.rbf_count == a.count);
    vsd_crm_rbfs_free(&b);

    /* Exact round trip of odd values through save/load. */
    vsd_crm_rbf odd[2] = {{{1e-30f, -0.0f, 3.4e38f}, 1e-3f, -7.25f}, {{0.1f, 0.2f, 0.3f}, 123.456f, 1e-20f}};
    vsd_crm_rbfs ro = {odd, 2}, back = {0};
    double rel = 0;
    CHECK(vsd_crm_fit_cache_save(dir, "0123abcd", &ro, 0.012345678901234, err, sizeof err) == VSD_OK);
    CHECK(vsd_crm_fit_cache_load(dir, "0123abcd", &back, &rel, err, sizeof err) == VSD_OK);
    CHECK(same_rbfs(&ro, &back) && rel == 0.012345678901234);
    vsd_crm_rbfs_free(&back);
    CHECK(vsd_crm_fit_cache_save(dir, "../evil", &ro, 0.0, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(vsd_crm_fit_cache_load(dir, "ABC", &back, &rel, err, sizeof err) == VSD_ERR_INVALID);

    size_t n;
    unsigned char *orig = read_bytes(path, &n);
    /* Truncated: FORMAT from load, refitted (same result, deterministic) by the cached call. */
    write_bytes(path, orig, n - 7);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, NULL, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "truncated");
    s = vsd_crm_fit_cached(dir, &d, &o, NULL, 0.0, &b, &sb, err, sizeof err, &cached);
    CHECK(s == VSD_OK && cached == 0 && sb.evaluations > 0 && same_rbfs(&a, &b));
    CHECK(file_size(path) == (long)n); /* rewritten whole */
    vsd_crm_rbfs_free(&b);
    /* One flipped payload bit. */
    orig[96 + 13] ^= 0x10;
    write_bytes(path, orig, n);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, NULL, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "checksum");
    s = vsd_crm_fit_cached(dir, &d, &o, NULL, 0.0, &b, &sb, err, sizeof err, &cached);
    CHECK(s == VSD_OK && cached == 0 && same_rbfs(&a, &b));
    vsd_crm_rbfs_free(&b);
    orig[96 + 13] ^= 0x10;
    /* A count that lies (huge, and one too many) is caught by the size, not trusted. */
    unsigned char *lie = malloc(n);
    memcpy(lie, orig, n);
    lie[12] = 0xff, lie[13] = 0xff, lie[14] = 0xff, lie[15] = 0x7f;
    write_bytes(path, lie, n);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, NULL, err, sizeof err) == VSD_ERR_FORMAT);
    memcpy(lie, orig, n);
    lie[12]++;
    write_bytes(path, lie, n);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, NULL, err, sizeof err) == VSD_ERR_FORMAT);
    /* Another version. */
    memcpy(lie, orig, n);
    lie[8] = 2;
    write_bytes(path, lie, n);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, NULL, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "version 2");
    /* Foreign files: text, empty, and a valid file under another key's name. */
    write_bytes(path, "# not a cache file\nhello\n", 25);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, NULL, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "not a crm fit cache file");
    write_bytes(path, "", 0);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, NULL, err, sizeof err) == VSD_ERR_FORMAT);
    char other[1200];
    snprintf(other, sizeof other, "%s/0123abcd.crmfit", dir);
    size_t on;
    unsigned char *ob = read_bytes(other, &on);
    write_bytes(path, ob, on);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, NULL, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "another key");
    CHECK(b.count == 0 && b.rbf == NULL);
    /* Restored file loads again. */
    write_bytes(path, orig, n);
    CHECK(vsd_crm_fit_cache_load(dir, key, &b, &rel, err, sizeof err) == VSD_OK && same_rbfs(&a, &b));
    vsd_crm_rbfs_free(&b);
    /* No folder: a plain fit. */
    s = vsd_crm_fit_cached(NULL, &d, &o, NULL, 0.0, &b, &sb, err, sizeof err, &cached);
    CHECK(s == VSD_OK && cached == 0 && same_rbfs(&a, &b));
    vsd_crm_rbfs_free(&b);
    unlink(path);
    unlink(other);
    free(ob);
    free(lie);
    free(orig);
    vsd_crm_rbfs_free(&a);
    free(g.d);
}

int main(void)
{
    test_options();
    test_empty_and_nan();
    test_gradient();
    test_recover();
    test_bounds();
    test_coherent();
    test_cache();
    return test_finish("test_crm_fit");
}
