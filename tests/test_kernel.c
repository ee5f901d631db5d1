/* Analytic checks of the shared kernels: HG normalisation and sampling, the environment
 * mapping (Cycles' equirectangular convention) and its sampling pdf, delta/ratio tracking
 * against exp(-sigma d) in a homogeneous medium, and the brick DDA's field integral. */
#include "test_common.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#include "kernel/kernel_volume.h"
#include "kernel/kernel_env.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_sobol.h"
#include "kernel/kernel_record_grid.h"
#include "src/render/kernel_setup.h"
#include "src/grids/record_phase.h"
#include <string.h>
#include <stdlib.h>

static void test_hg_normalisation(void)
{
    const float gs[] = {-0.7f, 0.0f, 0.3f, 0.9f};
    int gi;
    for (gi = 0; gi < 4; gi++) {
        /* integrate over cos theta with a fine midpoint rule: 2 pi * int p(mu) dmu = 1 */
        double sum = 0;
        int i, n = 200000;
        for (i = 0; i < n; i++) {
            float mu = -1.0f + 2.0f * ((float)i + 0.5f) / (float)n;
            sum += vsd_hg_eval(mu, gs[gi]) * (2.0 / n);
        }
        CHECK_NEAR(sum * 2.0 * M_PI, 1.0, 2e-3);
    }
}

static void test_hg_sampling(void)
{
    /* histogram of sampled cos theta against the analytic bin probabilities, and the
     * returned pdf equals the phase value of the sampled direction */
    const float g = 0.6f;
    enum { BINS = 20, N = 400000 };
    double hist[BINS] = {0};
    vsd_rng rng = vsd_rng_init(7, 1, 2);
    vsd_f3 dir = f3_normalize(f3(0.3f, -0.5f, 0.8f));
    int i, bad_pdf = 0;
    for (i = 0; i < N; i++) {
        float pdf;
        vsd_f3 w = vsd_hg_sample(dir, g, vsd_rng_float(&rng), vsd_rng_float(&rng), &pdf);
        float mu = f3_dot(dir, w);
        int b = (int)((mu + 1.0f) * 0.5f * BINS);
        if (b >= BINS) b = BINS - 1;
        if (b < 0) b = 0;
        hist[b] += 1;
        if (fabsf(pdf - vsd_hg_eval(mu, g)) > 1e-3f * pdf + 1e-5f) bad_pdf++;
        if (fabsf(f3_dot(w, w) - 1.0f) > 1e-4f) bad_pdf++;
    }
    CHECK_MSG(bad_pdf == 0, "%d samples with a wrong pdf or non-unit direction", bad_pdf);
    for (i = 0; i < BINS; i++) {
        double p = 0;
        int k;
        for (k = 0; k < 1000; k++) {
            float mu = -1.0f + (2.0f / BINS) * (i + (k + 0.5f) / 1000.0f);
            p += vsd_hg_eval(mu, g) * 2.0 * M_PI * (2.0 / BINS) / 1000.0;
        }
        CHECK_NEAR(hist[i] / N, p, 4.0 * sqrt(p / N) + 1e-4);
    }
}

/* vsd_hg_eval_many (the per-view bake's vectorised loop) gives vsd_hg_eval's bits for
 * every direction, on counts that are no multiple of a vector (1, 7, 13, 515) and for
 * g = 0, forward, backward and nearly 1: the bake's images do not depend on the CPU. */
static void test_hg_eval_many(void)
{
    static const float gs[] = {0.0f, 0.2f, 0.7f, -0.4f, 0.97f};
    static const int ns[] = {1, 7, 13, 515};
    float dx[515], dy[515], dz[515], pk[515];
    int gi, ni, s, bad = 0;
    unsigned seed = 12345u;
    for (s = 0; s < 515; s++) {
        float x, y, z, r;
        seed = seed * 1664525u + 1013904223u; x = (float)(seed >> 8) / 8388608.0f - 1.0f;
        seed = seed * 1664525u + 1013904223u; y = (float)(seed >> 8) / 8388608.0f - 1.0f;
        seed = seed * 1664525u + 1013904223u; z = (float)(seed >> 8) / 8388608.0f - 1.0f;
        r = sqrtf(x * x + y * y + z * z) + 1e-6f;
        dx[s] = x / r; dy[s] = y / r; dz[s] = z / r;
    }
    for (gi = 0; gi < 5; gi++)
        for (ni = 0; ni < 4; ni++) {
            vsd_f3 d = f3_normalize(f3(0.3f, -0.5f, 0.81f));
            vsd_hg_eval_many(dx, dy, dz, ns[ni], d, gs[gi], pk);
            for (s = 0; s < ns[ni]; s++) {
                float want = vsd_hg_eval(f3_dot(d, f3(dx[s], dy[s], dz[s])), gs[gi]);
                if (memcmp(&want, &pk[s], sizeof want) != 0) {
                    if (bad++ < 3) fprintf(stderr, "g %g n %d [%d]: %.9g, scalar %.9g\n", gs[gi], ns[ni], s, pk[s], want);
                }
            }
        }
    CHECK_MSG(bad == 0, "%d phase values differ from vsd_hg_eval's", bad);
}

/* f3_trilerp (the record and crm node lookups where all eight corners are set) against the
 * weighted mean it replaces there (sum of w_a v_a over the trilinear weights, divided by
 * their sum): within float rounding at random points and at the corners. */
static void test_f3_trilerp(void)
{
    unsigned seed = 777u;
    int i, a, bad = 0;
    double worst = 0.0;
    for (i = 0; i < 2000; i++) {
        vsd_f3 v[8], got, want = f3s(0.0f);
        float t[3], wsum = 0.0f;
        for (a = 0; a < 8; a++) {
            float c[3];
            int k;
            for (k = 0; k < 3; k++) {
                seed = seed * 1664525u + 1013904223u;
                c[k] = (float)(seed >> 8) / 16777216.0f * 40.0f - 30.0f;   /* logs of 1e-13 .. 2e4 */
            }
            v[a] = f3(c[0], c[1], c[2]);
        }
        for (a = 0; a < 3; a++) {
            seed = seed * 1664525u + 1013904223u;
            t[a] = i < 8 ? (float)((i >> a) & 1) : (float)(seed >> 8) / 16777216.0f;   /* the corners first */
        }
        for (a = 0; a < 8; a++) {
            float wt = ((a & 1) ? t[0] : 1.0f - t[0]) * (((a >> 1) & 1) ? t[1] : 1.0f - t[1]) *
                       (((a >> 2) & 1) ? t[2] : 1.0f - t[2]);
            want = f3_add(want, f3_scale(v[a], wt));
            wsum += wt;
        }
        want = f3_scale(want, 1.0f / wsum);
        got = f3_trilerp(v, t[0], t[1], t[2]);
        {
            float d = fmaxf(fabsf(got.x - want.x), fmaxf(fabsf(got.y - want.y), fabsf(got.z - want.z)));
            if (d > worst) worst = d;
            if (d > 2e-5f) bad++;
        }
    }
    CHECK_MSG(bad == 0, "%d of 2000 trilinear lookups differ from the weighted mean by more than 2e-5 (worst %g)", bad,
              worst);
}

/* A 64x32 black map with one bright texel at (col, row). */
static vsd_env *bright_texel_env(int col, int row)
{
    vsd_env *env = NULL;
    float black[3] = {0, 0, 0};
    if (vsd_env_create_uniform(black, 64, 32, &env, NULL, 0) != VSD_OK) return NULL;
    env->rgb[3 * (row * 64 + col) + 0] = 100.0f;
    env->rgb[3 * (row * 64 + col) + 1] = 50.0f;
    env->rgb[3 * (row * 64 + col) + 2] = 25.0f;
    return env;
}

static void test_env_mapping(void)
{
    /* Cycles: u = 0.5 - atan2(y,x)/(2pi), v = 1 - acos(z)/pi (v=1 is row 0).
     * +X -> u = 0.5, v = 0.5: column 32, row 16 of a 64x32 map; +Y -> u = 0.25; -Y -> 0.75. */
    struct { float x, y, z; int col, row; float rot; } cases[] = {
        {1, 0, 0.001f, 32, 15, 0.0f}, {0, 1, 0.001f, 16, 15, 0.0f}, {0, -1, 0.001f, 48, 15, 0.0f},
        {0.0f, 0.0f, 1.0f, -1, 0, 0.0f}, /* straight up: top row */
        {1, 0, 0.001f, 16, 15, (float)(M_PI / 2)}, /* Mapping Z rotation 90 deg: +X looks up +Y's texel */
    };
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        vsd_f3 d = f3_normalize(f3(cases[i].x, cases[i].y, cases[i].z));
        int col = cases[i].col < 0 ? 10 : cases[i].col;
        vsd_env *env = bright_texel_env(col, cases[i].row);
        vsd_env_tables tabs;
        vsd_kenv ke;
        vsd_f3 l;
        CHECK(env != NULL);
        if (!env) return;
        CHECK(vsd_env_tables_build(env, VSD_ENV_CLOSEST, &tabs, NULL, 0) == VSD_OK);
        vsd_kenv_setup(&ke, env, &tabs, VSD_ENV_CLOSEST, 2.0f, cases[i].rot);
        l = vsd_env_eval(&ke, d);
        if (cases[i].col >= 0) {
            CHECK_NEAR(l.x, 200.0, 1e-3);
            CHECK_NEAR(l.z, 50.0, 1e-3);
        } else {
            /* the pole: any column of row 0 */
            CHECK(vsd_env_texel(&ke, d, NULL) / 64 == 0);
        }
        vsd_env_tables_free(&tabs);
        vsd_env_destroy(env);
    }
}

/* A 64x32 map with structure at every scale: a pattern, and one texel 1000x brighter
 * (a sun) beside a black texel, where interpolation and sampling differ most. */
static vsd_env *patterned_env(void)
{
    vsd_env *env = NULL;
    float grey[3] = {0.2f, 0.2f, 0.2f};
    int x, y;
    if (vsd_env_create_uniform(grey, 64, 32, &env, NULL, 0) != VSD_OK) return NULL;
    for (y = 0; y < 32; y++)
        for (x = 0; x < 64; x++) {
            float v = 0.2f + 3.0f * (float)((x * 7 + y * 13) % 11) / 11.0f;
            if (x == 20 && y == 10) v = 1000.0f;
            if (x == 21 && y == 10) v = 0.0f;
            env->rgb[3 * (y * 64 + x)] = env->rgb[3 * (y * 64 + x) + 1] = env->rgb[3 * (y * 64 + x) + 2] = v;
        }
    return env;
}

/* The direction through texture coordinates (u, r) with rotation rot undone. */
static vsd_f3 env_dir(float u, float r, float rot)
{
    float theta = r * (float)M_PI, phi = (0.5f - u) * 2.0f * (float)M_PI;
    float tx = sinf(theta) * cosf(phi), ty = sinf(theta) * sinf(phi);
    return f3(cosf(rot) * tx + sinf(rot) * ty, -sinf(rot) * tx + cosf(rot) * ty, cosf(theta));
}

/* The map's integral over the sphere as evaluated (closest or linear): a 16x16 midpoint
 * rule inside every texel, each point weighted by its exact solid angle. */
static double env_integral(const vsd_kenv *ke, float rot)
{
    const int s = 16, w = ke->width, h = ke->height;
    double sum = 0;
    for (int y = 0; y < h * s; y++) {
        double t0 = M_PI * y / (h * s), t1 = M_PI * (y + 1) / (h * s);
        double dw = (2 * M_PI / (w * s)) * (cos(t0) - cos(t1));
        for (int x = 0; x < w * s; x++)
            sum += vsd_env_eval(ke, env_dir((x + 0.5f) / (w * s), (y + 0.5f) / (h * s), rot)).x * dw;
    }
    return sum;
}

/* E[L/pdf] over env samples equals the map's integral over the sphere as evaluated, for
 * both interpolations; a sampled direction's pdf is vsd_env_pdf of it and its radiance
 * vsd_env_eval of it. A sampler that drew from one map and weighted by another, or an
 * interpolated map sampled with the nearest texel's radiance, fails the first check. */
static void test_env_sampling(int interpolation)
{
    vsd_env *env = patterned_env();
    vsd_env_tables tabs;
    vsd_kenv ke;
    double exact, est = 0, est2 = 0, se;
    int i, n = 400000, mismatched = 0;
    vsd_rng rng = vsd_rng_init(3, 4, 5 + interpolation);
    CHECK(env != NULL);
    if (!env) return;
    CHECK(vsd_env_tables_build(env, interpolation, &tabs, NULL, 0) == VSD_OK);
    vsd_kenv_setup(&ke, env, &tabs, interpolation, 1.0f, 0.7f);
    exact = env_integral(&ke, 0.7f);
    for (i = 0; i < n; i++) {
        vsd_f3 l;
        float pdf;
        vsd_f3 d = vsd_env_sample(&ke, vsd_rng_float(&rng), vsd_rng_float(&rng), &l, &pdf);
        double f = pdf > 0 ? l.x / pdf : 0;
        est += f;
        est2 += f * f;
        if (fabsf(vsd_env_pdf(&ke, d) - pdf) > 1e-3f * pdf) mismatched++;
        if (fabsf(vsd_env_eval(&ke, d).x - l.x) > 1e-4f * fmaxf(1.0f, l.x)) mismatched++;
    }
    est /= n;
    se = sqrt((est2 / n - est * est) / n);
    CHECK_MSG(fabs(est - exact) < 4 * se + 1e-3 * exact, "interpolation %d: E[L/pdf] %.5f, integral %.5f (se %.5f)",
              interpolation, est, exact, se);
    CHECK_MSG(mismatched < n / 1000, "%d of %d samples disagree with pdf/eval", mismatched, n);
    vsd_env_tables_free(&tabs);
    vsd_env_destroy(env);
}

/* Linear: texel centres give the texel; halfway between centres the mean, across the u
 * seam too; beyond the last row's centre the row itself (clamped at the poles). */
static void test_env_linear_lookup(void)
{
    vsd_env *env = patterned_env();
    vsd_env_tables tabs;
    vsd_kenv ke;
    const float *p;
    CHECK(env != NULL);
    if (!env) return;
    p = env->rgb;
    CHECK(vsd_env_tables_build(env, VSD_ENV_LINEAR, &tabs, NULL, 0) == VSD_OK);
    vsd_kenv_setup(&ke, env, &tabs, VSD_ENV_LINEAR, 1.0f, 0.0f);
    CHECK_NEAR(vsd_env_lookup(&ke, 20.5f / 64, 10.5f / 32).x, 1000.0, 1e-2);
    CHECK_NEAR(vsd_env_lookup(&ke, 21.0f / 64, 10.5f / 32).x, 500.0, 1e-2);
    CHECK_NEAR(vsd_env_lookup(&ke, 20.75f / 64, 10.5f / 32).x, 500.0 + 0.5 * 500.0, 1e-2);
    CHECK_NEAR(vsd_env_lookup(&ke, 20.5f / 64, 11.0f / 32).x, 0.5 * (1000.0 + p[3 * (11 * 64 + 20)]), 1e-2);
    CHECK_NEAR(vsd_env_lookup(&ke, 0.0f, 5.5f / 32).x, 0.5 * (p[3 * (5 * 64)] + p[3 * (5 * 64 + 63)]), 1e-4);
    CHECK_NEAR(vsd_env_lookup(&ke, 3.5f / 64, 0.0f).x, p[3 * 3], 1e-4);
    CHECK_NEAR(vsd_env_lookup(&ke, 3.5f / 64, 1.0f).x, p[3 * (31 * 64 + 3)], 1e-4);
    /* the Closest map of the same texels keeps its steps */
    ke.linear = 0;
    CHECK_NEAR(vsd_env_lookup(&ke, 20.99f / 64, 10.5f / 32).x, 1000.0, 1e-3);
    vsd_env_tables_free(&tabs);
    vsd_env_destroy(env);
}

/* A homogeneous cube: 64^3 voxels of 1, voxel size 1/16 (world cube of side 4). */
static vsd_volume *homogeneous_cube(void)
{
    int32_t dims[3] = {64, 64, 64}, lo[3] = {0, 0, 0};
    double m[16] = {1.0 / 16, 0, 0, 0, 0, 1.0 / 16, 0, 0, 0, 0, 1.0 / 16, 0, 0, 0, 0, 1};
    float *v = malloc(sizeof(float) * 64 * 64 * 64);
    vsd_volume *vol = NULL;
    int i;
    for (i = 0; i < 64 * 64 * 64; i++) v[i] = 1.0f;
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &vol, NULL, 0) == VSD_OK);
    free(v);
    return vol;
}

static void test_tracking_homogeneous(void)
{
    const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    vsd_volume *vol = homogeneous_cube();
    vsd_kvolume kv;
    vsd_rng rng = vsd_rng_init(11, 0, 0);
    const float sigma = 1.7f, d = 1.3f;
    vsd_f3 o = f3(0.8f, 1.1f, 0.9f), dir = f3_normalize(f3(1.0f, 0.7f, 0.4f));
    double sum_ratio = 0;
    int i, n = 50000, collided = 0;
    double expect = exp(-sigma * d);
    if (!vol) return;
    CHECK(vsd_kvolume_setup(&kv, vol, ident, sigma, NULL, 0) == VSD_OK);
    for (i = 0; i < n; i++) {
        sum_ratio += vsd_ratio_track(&kv, o, dir, d, &rng);
        if (vsd_delta_track(&kv, o, dir, d, &rng) < d) collided++;
    }
    /* ratio tracking in a homogeneous medium at its majorant is exact up to roulette */
    CHECK_NEAR(sum_ratio / n, expect, 4 * sqrt(expect * (1 - expect) / n) + 1e-4);
    CHECK_NEAR((double)collided / n, 1 - expect, 4 * sqrt(expect * (1 - expect) / n));
    /* the quadrature of a constant field is exact: sigma * d */
    CHECK_NEAR(vsd_field_integral(&kv, o, dir, 0.0f, d, 0.37f), sigma * d, 1e-2 * sigma * d);
    vsd_volume_destroy(vol);
}

static void test_field_integral_random(void)
{
    /* DDA + jittered quadrature over a sparse random field agrees with brute-force sampling */
    int32_t dims[3] = {40, 24, 33}, lo[3] = {-5, 3, 0};
    float *v = calloc(40 * 24 * 33, sizeof(float));
    const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    double m[16] = {0.05, 0.01, 0, 0.2, 0, 0.04, 0, -0.1, 0.005, 0, 0.06, 0.3, 0, 0, 0, 1};
    vsd_volume *vol = NULL;
    vsd_kvolume kv;
    int i, r;
    srand(5);
    for (i = 0; i < 40 * 24 * 33; i++)
        if (rand() % 5 == 0) v[i] = (float)(rand() % 1000) / 500.0f;
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &vol, NULL, 0) == VSD_OK);
    free(v);
    if (!vol) return;
    CHECK(vsd_kvolume_setup(&kv, vol, ident, 3.0f, NULL, 0) == VSD_OK);
    for (r = 0; r < 20; r++) {
        vsd_f3 o = f3(-2.0f + 0.1f * r, -1.5f, -0.5f + 0.07f * r);
        vsd_f3 dir = f3_normalize(f3(1.0f, 0.8f + 0.05f * r, 0.6f));
        double brute = 0, fast = 0;
        int k, nj = 16;
        float h = 1e-4f;
        for (k = 0; k < 60000; k++) brute += vsd_kvolume_at(&kv, f3_madd(o, dir, (k + 0.5f) * h)) * h;
        for (k = 0; k < nj; k++) fast += vsd_field_integral(&kv, o, dir, 0.0f, 6.0f, (k + 0.5f) / nj);
        fast /= nj;
        CHECK_NEAR(fast, brute, 0.01 * brute + 1e-3);
    }
    vsd_volume_destroy(vol);
}

/* kernel_sobol.h: the first 2^m points of every (pixel, pair) form a (0,m,2)-net (each
 * dyadic box of area 2^-m, of every shape, holds exactly one point), for prefixes of 16,
 * 64 and 256 points, and over many pixels the points are uniform (means 1/2, the two
 * coordinates and different pairs uncorrelated). */
static void test_sobol_pairs(void)
{
    static const int prefixes[3] = {4, 6, 8};
    double mean_u = 0, mean_v = 0, uv = 0, cross = 0;
    const int pixels = 64, n = 256;
    int px, k;
    for (px = 0; px < pixels; px++) {
        for (k = 0; k < 3; k++) {
            const int m = prefixes[k], count = 1 << m;
            int a, bad = 0;
            for (a = 0; a <= m && !bad; a++) {
                int boxes[256] = {0}, i;
                for (i = 0; i < count; i++) {
                    float u, v;
                    vsd_sobol_pair(7u, (uint32_t)px, (uint32_t)i, (uint32_t)(px % 5), &u, &v);
                    boxes[((int)(u * (1 << a))) * (1 << (m - a)) + (int)(v * (1 << (m - a)))]++;
                }
                for (i = 0; i < count; i++) bad |= boxes[i] != 1;
            }
            CHECK_MSG(!bad, "pixel %d: the first %d points are not a (0,%d,2)-net", px, count, m);
        }
        for (k = 0; k < n; k++) {
            float u, v, u2, v2;
            vsd_sobol_pair(7u, (uint32_t)px, (uint32_t)k, 1u, &u, &v);
            vsd_sobol_pair(7u, (uint32_t)px, (uint32_t)k, 2u, &u2, &v2);
            mean_u += u, mean_v += v, uv += (u - 0.5) * (v - 0.5), cross += (u - 0.5) * (u2 - 0.5);
        }
    }
    mean_u /= pixels * n, mean_v /= pixels * n, uv /= pixels * n, cross /= pixels * n;
    /* a uniform variable's variance is 1/12: the correlations below are relative to it */
    CHECK_MSG(fabs(mean_u - 0.5) < 0.005 && fabs(mean_v - 0.5) < 0.005, "means %.4f %.4f", mean_u, mean_v);
    CHECK_MSG(fabs(uv * 12) < 0.02 && fabs(cross * 12) < 0.02, "correlation within a pair %.4f, across pairs %.4f",
              uv * 12, cross * 12);
}

int main(void)
{
    test_sobol_pairs();
    test_hg_normalisation();
    test_hg_sampling();
    test_hg_eval_many();
    test_f3_trilerp();
    test_env_mapping();
    test_env_sampling(VSD_ENV_CLOSEST);
    test_env_sampling(VSD_ENV_LINEAR);
    test_env_linear_lookup();
    test_tracking_homogeneous();
    test_field_integral_random();
    return test_finish("test_kernel");
}
