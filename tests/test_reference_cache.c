/* test_reference_cache.c — `reference` with a fast method's light as a control variate
 * (render.options.cache, issue 33; kernel/kernel_radiance_cache.h, docs/methods/reference.md):
 *   1. the closed form m(x, d) = a - g B . d is the mean of c(x, w) = a - B . w over w drawn
 *      by the path tracer's own HG sampling, for forward, isotropic and backward lobes;
 *   2. the P1 fit of six cone radiances keeps their mean radiance and their first moment
 *      (a quadrature over the sphere, each direction in the cone of its largest grid
 *      component), also through a rotated and stretched grid;
 *   2b. the SH form (crm's nodes): at a node, c(x, w) is the radiance the coefficients give
 *      for light arriving from w (travelling along -w, kernel_sh.h's basis), and between
 *      nodes the trilinear blend, through a rotated and stretched node grid;
 *   3. no bias: with cache "lbl" and with "crm", 16384 samples agree with plain `reference`
 *      (two seeds, the harness's noise measured) on a smoke (g 0.5), a cloud (g 0.7) and a
 *      fire (with emission), every pass, with a 2-3% scaled control that must fail; and
 *      the image means within 0.5%;
 *   3b. crm's cache lowers the noise of VolumeInd on the cloud (two seeds each, with and
 *      without): its radiance follows the light's direction, where a B of the wrong sign
 *      makes it noisier than no cache (docs/methods/reference.md);
 *   4. VolumeDir with the cache is the plain path tracer's bit for bit (same seed): the
 *      cache's terms are all VolumeInd;
 *   5. errors: a cache naming a method that cannot serve (one that scatters once, reference
 *      itself), `survival` without a cache, the cache with a refracting medium and with
 *      several volumes (lbl and crm). */
#include "test_common.h"
#include "test_render_util.h"
#include "method_vs_reference.h"
#include "kernel/kernel_radiance_cache.h"
#include "kernel/kernel_phase.h"
#include "kernel/kernel_rng.h"
#include "kernel/kernel_sh.h"
#include "src/common/fibonacci_sphere.h"
#include "src/lighting/radiance_cache.h"
#include "vsd/compare.h"
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static void test_phase_mean(void)
{
    static const float g_values[3] = {0.7f, 0.0f, -0.4f};
    const float f[VSD_CACHE_FLOATS] = {1.0f, 2.0f, 0.5f, 0.3f, -0.2f, 0.1f, 0.05f, 0.4f, -0.3f, -0.25f, 0.1f, 0.2f};
    const vsd_f3 d = f3_normalize(f3(0.3f, -0.5f, 0.8f));
    int k;
    for (k = 0; k < 3; k++) {
        const float g = g_values[k];
        vsd_rng rng = vsd_rng_init(11u, (uint32_t)k, 0u);
        vsd_f3 mean = vsd_cache_phase_mean(f, d, g);
        double sum[3] = {0, 0, 0};
        const int n = 400000;
        int i;
        for (i = 0; i < n; i++) {
            float pdf;
            vsd_f3 w = vsd_hg_sample(d, g, vsd_rng_float(&rng), vsd_rng_float(&rng), &pdf);
            vsd_f3 c = vsd_cache_radiance(f, w);
            sum[0] += c.x, sum[1] += c.y, sum[2] += c.z;
        }
        /* the Monte Carlo mean's error: |B| (at most 0.5) / sqrt(n) ~ 8e-4 */
        CHECK_MSG(fabs(sum[0] / n - mean.x) < 3e-3 && fabs(sum[1] / n - mean.y) < 3e-3 && fabs(sum[2] / n - mean.z) < 3e-3,
                  "g %g: the phase mean of c is (%.4f %.4f %.4f), m gives (%.4f %.4f %.4f)", (double)g, sum[0] / n,
                  sum[1] / n, sum[2] / n, (double)mean.x, (double)mean.y, (double)mean.z);
    }
}

/* The fit of one cell's cones through world_to_grid w2g: mean and first moment, both
 * integrated over the sphere in world directions. */
static void check_fit(const char *what, const float w2g[12])
{
    float cones[18];
    int32_t cell_record = 0;
    float pos[4] = {0, 0, 0, 0};
    vsd_record_grid rg;
    vsd_radiance_cache cache;
    char err[256] = "";
    double mean_fit = 0, mean_cones = 0, m_fit[3] = {0, 0, 0}, m_cones[3] = {0, 0, 0};
    const int n = 200000;
    int i, a;
    for (i = 0; i < 6; i++)
        for (a = 0; a < 3; a++) cones[3 * i + a] = (float)(0.2 + 0.1 * i + 0.3 * a + (i == 1 ? 0.9 : 0.0));
    memset(&rg, 0, sizeof rg);
    rg.res[0] = rg.res[1] = rg.res[2] = 1;
    memcpy(rg.world_to_grid.m, w2g, sizeof rg.world_to_grid.m);
    rg.cell_record = &cell_record;
    rg.record_pos = pos;
    rg.count = 1;
    CHECK(vsd_radiance_cache_from_records(&rg, cones, NULL, &cache, err, sizeof err) == VSD_OK);
    if (!cache.k.p1) return;
    for (i = 0; i < n; i++) {
        /* w: a world direction of travel; its cone is its largest component in grid axes */
        double p[3];
        vsd_f3 w, q;
        float qa[3], fit;
        vsd_fibonacci_point(i, n, p);
        w = f3((float)p[0], (float)p[1], (float)p[2]);
        q = f3_normalize(vsd_affine_vector(&rg.world_to_grid, w));
        qa[0] = q.x, qa[1] = q.y, qa[2] = q.z;
        int axis = 0, cone;
        for (a = 1; a < 3; a++)
            if (fabsf(qa[a]) > fabsf(qa[axis])) axis = a;
        cone = 2 * axis + (qa[axis] < 0.0f);
        /* green channel; light travelling along w arrives from -w */
        fit = vsd_cache_radiance(cache.k.p1, f3_scale(w, -1.0f)).y;
        mean_fit += fit / n;
        mean_cones += cones[3 * cone + 1] / n;
        m_fit[0] += fit * w.x / n, m_fit[1] += fit * w.y / n, m_fit[2] += fit * w.z / n;
        m_cones[0] += cones[3 * cone + 1] * w.x / n, m_cones[1] += cones[3 * cone + 1] * w.y / n;
        m_cones[2] += cones[3 * cone + 1] * w.z / n;
    }
    CHECK_MSG(fabs(mean_fit - mean_cones) < 1e-4 * mean_cones, "%s: mean radiance %.6f, the cones' %.6f", what, mean_fit,
              mean_cones);
    for (a = 0; a < 3; a++)
        CHECK_MSG(fabs(m_fit[a] - m_cones[a]) < 2e-3 * (fabs(mean_cones) + 1e-6),
                  "%s: first moment %c %.5f, the cones' %.5f", what, "xyz"[a], m_fit[a], m_cones[a]);
    vsd_radiance_cache_free(&cache);
}

static void test_fit(void)
{
    const float identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    /* world_to_grid: a rotation by 30 degrees about z and 20 about x, cells of 0.5 world
     * units. (A grid stretched per axis maps the cube's faces to cones of unequal solid
     * angle in the world; the fit weighs the six alike, as lbl's lattice does.) */
    const float c = 0.8660254f, s = 0.5f, cx = 0.9396926f, sx = 0.3420201f;
    const float rotated[12] = {2 * c, 2 * s, 0, 0.3f, -2 * s * cx, 2 * c * cx, 2 * sx, 0, 2 * s * sx, -2 * c * sx, 2 * cx, 1};
    check_fit("grid = world", identity);
    check_fit("rotated grid", rotated);
}

/* The SH form on a 2x3x2 node grid rotated and stretched in the world: every node's
 * coefficients random; at random points between the nodes, for directions spread over
 * the sphere, c(x, w) against the coefficients' radiance along -w, blended trilinearly
 * (a B of the wrong sign is off by 1.3, the nodes half a cell off would be too). */
static void test_sh_fit(void)
{
    const int32_t res[3] = {2, 3, 2};
    const float c = 0.8660254f, s = 0.5f;
    /* node -> world: 30 degrees about z, nodes 0.7 x 1.3 x 0.4 world units apart, offset */
    const vsd_affine n2w = {{0.7f * c, -1.3f * s, 0.0f, 2.0f, 0.7f * s, 1.3f * c, 0.0f, -1.0f, 0.0f, 0.0f, 0.4f, 0.5f}};
    float sh[12 * 12];
    vsd_radiance_cache cache;
    vsd_rng rng = vsd_rng_init(5u, 1u, 0u);
    char err[256] = "";
    double worst = 0.0;
    int i, k;
    for (i = 0; i < 12 * 12; i++) sh[i] = 2.0f * vsd_rng_float(&rng) - 0.5f;
    CHECK(vsd_radiance_cache_from_sh(res, &n2w, sh, &cache, err, sizeof err) == VSD_OK);
    if (!cache.k.p1) return;
    for (k = 0; k < 200; k++) {
        /* a point in node space (inside the grid), its nodes' weights, and a direction */
        const float q[3] = {vsd_rng_float(&rng) * 1.0f, vsd_rng_float(&rng) * 2.0f, vsd_rng_float(&rng) * 1.0f};
        double p[3], want = 0.0;
        float f[VSD_CACHE_FLOATS], y[4];
        vsd_f3 w, x;
        int corner;
        vsd_fibonacci_point(k, 200, p);
        w = f3((float)p[0], (float)p[1], (float)p[2]);
        vsd_sh_eval_f(2, f3_scale(w, -1.0f), y);
        for (corner = 0; corner < 8; corner++) {
            int a = (int)q[0] + (corner & 1), b = (int)q[1] + ((corner >> 1) & 1), e = (int)q[2] + ((corner >> 2) & 1);
            double wt = ((corner & 1) ? q[0] - (int)q[0] : 1.0 - (q[0] - (int)q[0])) *
                        (((corner >> 1) & 1) ? q[1] - (int)q[1] : 1.0 - (q[1] - (int)q[1])) *
                        (((corner >> 2) & 1) ? q[2] - (int)q[2] : 1.0 - (q[2] - (int)q[2]));
            const float *L = sh + ((size_t)((e * res[1] + b) * res[0] + a) * 3 + 2) * 4;   /* blue */
            if (wt == 0.0) continue;
            want += wt * (L[0] * y[0] + L[1] * y[1] + L[2] * y[2] + L[3] * y[3]);
        }
        x = vsd_affine_point(&n2w, f3(q[0], q[1], q[2]));
        vsd_cache_eval(&cache.k, x, f);
        if (fabs(vsd_cache_radiance(f, w).z - want) > worst) worst = fabs(vsd_cache_radiance(f, w).z - want);
    }
    CHECK_MSG(worst < 2e-5, "the SH cache's radiance is off the coefficients' by up to %.3g", worst);
    vsd_radiance_cache_free(&cache);
}

/* No bias, per pass, through the harness: measured when this was written (24x14, 2 x 16384
 * spp plain against 16384 with the cache, seed 3), error / noise of the plain mean:
 *   smoke64 g 0.5  Combined 0.0032 / 0.0022, VolumeDir 0.0084 / 0.0075, VolumeInd 0.0091 / 0.0055
 *   cloud256       Combined 0.0026 / 0.0021, VolumeDir 0.0074 / 0.0045, VolumeInd 0.0043 / 0.0036
 *   fire96         Combined 0.0036 / 0.0016, VolumeDir 0.0038 / 0.0063, VolumeInd 0.0135 / 0.0080
 * each error what the two renders' noise adds up to (the cached render's own is ~1.4x the
 * mean's). The tolerances sit at 3x the largest noise; a pass scaled by 0.98 (Combined) or
 * 0.95 must fail them. The image means (printed) are the sharper check: within 0.5%. */
#define TOL_COMBINED 0.008
#define TOL_DIR 0.025
#define TOL_IND 0.026
static void check_unbiased(const char *what, const mvr_scene *scene, const char *const *ov, int nov, const double tol[3])
{
    static const vsd_pass passes[3] = {VSD_PASS_COMBINED, VSD_PASS_VOLUME_DIR, VSD_PASS_VOLUME_IND};
    static const double control[3] = {0.98, 0.95, 0.95};
    static const char *const caches[2] = {"lbl", "crm"};
    const char *all[16];
    mvr_refs refs;
    int i, k;
    for (i = 0; i < nov; i++) all[i] = ov[i];
    if (!mvr_render_references(scene, ov, nov, 16384, &refs)) {
        mvr_refs_free(&refs);
        return;
    }
    all[nov] = "render.method=reference";
    all[nov + 1] = "render.samples=16384";
    all[nov + 2] = "render.seed=3";
    for (k = 0; k < 2; k++) {
        vsd_framebuffer *cached;
        char label[128], cache[64];
        snprintf(label, sizeof label, "%s, cache=%s", what, caches[k]);
        snprintf(cache, sizeof cache, "render.options.cache=%s", caches[k]);
        all[nov + 3] = cache;
        cached = mvr_render(scene, all, nov + 4, NULL, NULL);
        CHECK_MSG(cached != NULL, "%s: reference with the cache did not render", label);
        if (cached) {
            for (i = 0; i < 3; i++) {
                double ratio = test_pass_sum(cached, passes[i]) / test_pass_sum(refs.mean, passes[i]);
                mvr_check(label, cached, &refs, passes[i], tol[i], control[i]);
                printf("%s pass %d: the image's mean is %.5f x plain reference's\n", label, i, ratio);
                CHECK_MSG(fabs(ratio - 1.0) < 0.005, "%s pass %d: the image's mean is %.4f x plain reference's", label,
                          i, ratio);
            }
        }
        vsd_framebuffer_destroy(cached);
    }
    mvr_refs_free(&refs);
}

/* VolumeInd's noise (relative RMSE of two seeds' difference over 4x4 blocks) on cloud256
 * at 160x90, 16 spp, plain against crm's cache. Measured when written: 0.1949 plain, 0.1573
 * with the cache (0.81x), 0.2023 with B's sign flipped (noisier than no cache); the bound
 * asks for at least 8% less noise. */
static double ind_noise(const mvr_scene *scene, const char *cache)
{
    const char *ov[] = {"film.width=160", "film.height=90", "render.method=reference", "render.samples=16",
                        "render.seed=1", cache};
    vsd_framebuffer *a = mvr_render(scene, ov, 6, NULL, NULL), *b;
    double noise = -1.0;
    ov[4] = "render.seed=2";
    b = mvr_render(scene, ov, 6, NULL, NULL);
    CHECK_MSG(a && b, "cloud256 with %s did not render", cache);
    if (a && b) CHECK(vsd_block_rel_rmse(a->pass[VSD_PASS_VOLUME_IND], b->pass[VSD_PASS_VOLUME_IND], a->width, a->height, 3,
                                         3, 4, &noise, NULL, 0) == VSD_OK);
    vsd_framebuffer_destroy(a);
    vsd_framebuffer_destroy(b);
    return noise;
}

static void test_crm_cache_lowers_noise(void)
{
    const mvr_scene cloud = {"scenes/cloud256_sunset.json", NULL, NULL, NULL, 1};
    double plain = ind_noise(&cloud, "render.options.cache=none"), cached = ind_noise(&cloud, "render.options.cache=crm");
    printf("cloud256 VolumeInd noise at 160x90, 16 spp: plain %.4f, crm's cache %.4f\n", plain, cached);
    CHECK_MSG(plain > 0.0 && cached > 0.0 && cached < 0.92 * plain,
              "crm's cache takes VolumeInd's noise from %.4f to %.4f (at most 0.92x expected)", plain, cached);
}

static void test_no_bias(void)
{
    const char *smoke_ov[] = {"film.width=24", "film.height=14", "frames.start=24", "frames.end=24",
                              "medium.anisotropy=0.5"};
    const char *cloud_ov[] = {"film.width=24", "film.height=14"};
    const char *fire_ov[] = {"film.width=24", "film.height=14", "frames.start=48", "frames.end=48"};
    const mvr_scene smoke = {"scenes/smoke64_sunset.json", NULL, NULL, NULL, 24};
    const mvr_scene cloud = {"scenes/cloud256_sunset.json", NULL, NULL, NULL, 1};
    const mvr_scene fire = {"scenes/fire96_studio.json", NULL, NULL, NULL, 48};
    const double tol[3] = {TOL_COMBINED, TOL_DIR, TOL_IND};
    check_unbiased("smoke64 g 0.5", &smoke, smoke_ov, 5, tol);
    check_unbiased("cloud256", &cloud, cloud_ov, 2, tol);
    check_unbiased("fire96", &fire, fire_ov, 4, tol);
}

static void test_volume_dir_unchanged(void)
{
    const char *plain_ov[] = {"film.width=24", "film.height=14", "render.method=reference", "render.samples=16",
                              "medium.anisotropy=0.6"};
    const char *cache_ov[] = {"film.width=24", "film.height=14", "render.method=reference", "render.samples=16",
                              "medium.anisotropy=0.6", "render.options.cache=lbl"};
    const mvr_scene smoke = {"scenes/smoke64_sunset.json", NULL, NULL, NULL, 1};
    vsd_framebuffer *plain = mvr_render(&smoke, plain_ov, 5, NULL, NULL), *cached = mvr_render(&smoke, cache_ov, 6, NULL, NULL);
    CHECK(plain && cached);
    if (plain && cached) {
        size_t n = test_pass_floats(plain, VSD_PASS_VOLUME_DIR);
        CHECK_MSG(memcmp(plain->pass[VSD_PASS_VOLUME_DIR], cached->pass[VSD_PASS_VOLUME_DIR], n * sizeof(float)) == 0,
                  "VolumeDir with the cache differs from plain reference's (max rel. %.3g)",
                  test_max_rel_diff(cached, plain, VSD_PASS_VOLUME_DIR));
        CHECK_MSG(test_max_rel_diff(cached, plain, VSD_PASS_VOLUME_IND) > 0.0, "VolumeInd did not change at all");
    }
    vsd_framebuffer_destroy(plain);
    vsd_framebuffer_destroy(cached);
}

/* The scene (file or JSON) with ov is refused with an error containing both needles. */
static void expect_error(const char *file, const char *json, const char *const *ov, int nov, const char *needle1,
                         const char *needle2)
{
    vsd_scene sc;
    char err[1024];
    if (!(file ? test_load_scene(file, ov, nov, &sc) : test_parse_scene(json, ov, nov, &sc))) return;
    test_expect_render_error(&sc, NULL, 0, err, sizeof err);
    CHECK_CONTAINS(err, needle1);
    CHECK_CONTAINS(err, needle2);
}

static void test_errors(void)
{
    const char *shgrid[] = {"render.method=reference", "render.options.cache=shgrid", "film.width=8", "film.height=8"};
    const char *constellation[] = {"render.method=reference", "render.options.cache=constellation", "film.width=8",
                                   "film.height=8"};
    const char *self[] = {"render.method=reference", "render.options.cache=reference", "film.width=8", "film.height=8"};
    const char *survival[] = {"render.method=reference", "render.options.survival=0.5"};
    const char *ior[] = {"render.method=reference", "render.options.cache=lbl", "medium.ior=1.33", "film.width=8",
                         "film.height=8"};
    const char *two[] = {"render.method=reference", "render.options.cache=lbl", "film.width=8", "film.height=8"};
    const char *two_crm[] = {"render.method=reference", "render.options.cache=crm", "film.width=8", "film.height=8"};
    /* two copies of the smoke side by side */
    const char *json = "{\"version\": 1, \"volumes\": ["
                       "{\"file\": \"" VSD_SHARED_DATA "/smoke64/fluid_data_####.vdb\", \"medium\": {\"density\": 8}},"
                       "{\"file\": \"" VSD_SHARED_DATA "/smoke64/fluid_data_####.vdb\", "
                       "\"matrix\": [1,0,0,3, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"medium\": {\"density\": 8}}], "
                       "\"environment\": {\"file\": \"" VSD_SHARED_DATA "/env/sunset.exr\"}, "
                       "\"camera\": {\"position\": [1.5, -12, 1], \"look_at\": [1.5, 0, 1], \"up\": [0, 0, 1]}, "
                       "\"frames\": {\"start\": 24, \"end\": 24}, "
                       "\"render\": {\"method\": \"reference\", \"samples\": 1}}";
    expect_error("scenes/smoke64_sunset.json", NULL, shgrid, 4, "render.options.cache", "shgrid");
    expect_error("scenes/smoke64_sunset.json", NULL, self, 4, "render.options.cache", "reference");
    expect_error("scenes/smoke64_sunset.json", NULL, constellation, 4, "render.options.cache", "constellation");
    expect_error("scenes/smoke64_sunset.json", NULL, survival, 2, "survival", "cache");
    expect_error("scenes/smoke64_sunset.json", NULL, ior, 5, "render.options.cache", "refracting");
    expect_error(NULL, json, two, 4, "render.options.cache", "one volume");
    expect_error(NULL, json, two_crm, 4, "crm's cache", "one volume");
}

int main(void)
{
    test_phase_mean();
    test_fit();
    test_sh_fit();
    test_errors();
    test_crm_cache_lowers_noise();
    test_volume_dir_unchanged();
    test_no_bias();
    return test_finish("test_reference_cache");
}
