/* test_refraction.c — bent rays (issue 14, `medium.ior`), kernel/kernel_refract.h and the
 * path tracer's use of them:
 *   1. a ray through a linear index field n = n0 + a y, launched along x, follows the
 *      analytic solution of the ray equation, y = (n0 / a)(cosh(a x / n0) - 1);
 *   2. through a sphere of constant n with a smoothed boundary, the path tracer's bent
 *      tracker leaves with the deviation Snell's law gives a sphere, 2 (theta_i - theta_t);
 *      and through vsd_refraction_build's field of a voxel ball, within its staircase;
 *   3. the bent trackers with n = 1 everywhere (the grid stepped through, never bending)
 *      estimate the same transmittance as the straight ones, within the noise;
 *   4. end to end: `reference` with ior 1.33 on a nearly transparent ball against a map
 *      changes the background seen through the ball and leaves every pixel whose ray misses
 *      the index grid bit for bit as with ior 1; `lbl`'s bent view rays match it, and lbl
 *      without refraction (the control) does not. */
#include "test_common.h"
#include "test_render_util.h"
#include "src/grids/refraction.h"
#include "src/render/kernel_setup.h"
#include "methods/reference/reference_kernel.h"
#include "vsd/vdbio.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846
/* lbl (4 x 4 rays per pixel) against reference (256 spp) through the refracting thin ball
 * at 32x32: measured Combined 0.0085; lbl without refraction 0.347 */
#define LBL_REFRACT_TOL 0.03

static void test_parabola(void)
{
    /* 96 x 64 x 4 cells of 1/32 world unit; n = n0 + a (y - y0) */
    const int32_t nx = 96, ny = 64, nz = 4;
    const float n0 = 1.2f, a = 0.3f, y0 = 0.5f, cell = 1.0f / 32.0f;
    float *ng = malloc(sizeof(float) * 4 * nx * ny * nz);
    vsd_krefract r;
    vsd_f3 x, v, d;
    double worst = 0.0, rise_end = (n0 / a) * (cosh(a * 2.0 / n0) - 1.0);
    int i, j, k, s;
    if (!ng) return;
    for (k = 0; k < nz; k++)
        for (j = 0; j < ny; j++)
            for (i = 0; i < nx; i++) {
                float *c = ng + 4 * (((size_t)k * ny + j) * nx + i), y = (j + 0.5f) * cell;
                c[0] = n0 + a * (y - y0);
                c[1] = 0.0f;
                c[2] = a;
                c[3] = 0.0f;
            }
    memset(&r, 0, sizeof r);
    r.ng = ng;
    r.dims[0] = nx;
    r.dims[1] = ny;
    r.dims[2] = nz;
    r.world_to_grid.m[0] = r.world_to_grid.m[5] = r.world_to_grid.m[10] = 32.0f;
    r.step = cell / 8.0f;
    r.max_steps = 100000;
    x = f3(0.25f, y0, 2.0f * cell);
    d = f3(1.0f, 0.0f, 0.0f);
    v = f3_scale(d, n0);
    for (s = 1; s <= 2 * 8 * 32; s++) {   /* two world units */
        vsd_refract_step(&r, &x, &v, &d, r.step);
        if (s % 64 == 0) {
            double xs = x.x - 0.25, want = (n0 / a) * (cosh(a * xs / n0) - 1.0), got = x.y - y0;
            double e = fabs(got - want) / rise_end;   /* of the whole rise: Euler's O(h) lag */
            if (e > worst) worst = e;
        }
    }
    printf("[1] linear index field over 2 world units: rise %.5f (analytic %.5f), worst error %.4f of the rise\n",
           x.y - y0, (n0 / a) * (cosh(a * (x.x - 0.25) / n0) - 1.0), worst);
    CHECK_MSG(worst < 0.01, "the ray leaves the analytic curve by %.4f", worst);
    free(ng);
}

/* A sphere of n = ior with a smooth boundary, written analytically into an index grid:
 * n = 1 + (ior - 1) (1 - tanh((r - R) / w)) / 2, grad n exact; 64^3 cells of 1/32. */
static float *smooth_sphere(float ior, float R, float w, vsd_krefract *r)
{
    const int32_t N = 64;
    const float cell = 1.0f / 32.0f, c0 = 1.0f;
    float *ng = malloc(sizeof(float) * 4 * N * N * N);
    int i, j, k;
    if (!ng) return NULL;
    for (k = 0; k < N; k++)
        for (j = 0; j < N; j++)
            for (i = 0; i < N; i++) {
                float x = (i + 0.5f) * cell - c0, y = (j + 0.5f) * cell - c0, z = (k + 0.5f) * cell - c0;
                float rr = sqrtf(x * x + y * y + z * z) + 1e-9f, ch = coshf((rr - R) / w);
                float s = 0.5f * (1.0f - tanhf((rr - R) / w)), ds = -0.5f / (w * ch * ch);
                float *c = ng + 4 * (((size_t)k * N + j) * N + i);
                c[0] = 1.0f + (ior - 1.0f) * s;
                c[1] = (ior - 1.0f) * ds * x / rr;
                c[2] = (ior - 1.0f) * ds * y / rr;
                c[3] = (ior - 1.0f) * ds * z / rr;
            }
    memset(r, 0, sizeof *r);
    r->ng = ng;
    r->dims[0] = r->dims[1] = r->dims[2] = N;
    r->world_to_grid.m[0] = r->world_to_grid.m[5] = r->world_to_grid.m[10] = 32.0f;
    r->step = cell / 4.0f;
    r->max_steps = 100000;
    return ng;
}

static double snell_deviation(double b_over_r, double ior)
{
    double ti = asin(b_over_r), tt = asin(sin(ti) / ior);
    return 2.0 * (ti - tt);
}

static void test_snell(void)
{
    const float ior = 1.33f, R = 0.6f;
    const double fractions[4] = {0.2, 0.4, 0.6, 0.8};
    vsd_kernel_data kd;
    vsd_krefract r;
    vsd_rng rng = vsd_rng_init(1, 2, 3);
    float *ng = smooth_sphere(ior, R, 0.03f, &r);
    int i;
    memset(&kd, 0, sizeof kd);   /* no density: the tracker only bends */
    if (!ng) return;
    for (i = 0; i < 4; i++) {
        double want = snell_deviation(fractions[i], ior), got;
        vsd_f3 exit, o = f3(-0.5f, (float)(1.0 + fractions[i] * R), 1.0f);
        float tr = vsd_bent_ratio_track(&kd, &r, o, f3(1.0f, 0.0f, 0.0f), &rng, &exit);
        got = atan2(-exit.y, exit.x);   /* entering above the centre, bent down toward the axis */
        printf("[2] smooth sphere, impact %.1f R: deviation %.3f deg, Snell %.3f deg\n", fractions[i], got * 180.0 / PI_D,
               want * 180.0 / PI_D);
        CHECK_MSG(fabs(got - want) < 0.04 * want + 0.2 * PI_D / 180.0, "impact %.1f R: %.3f deg, Snell %.3f deg",
                  fractions[i], got * 180.0 / PI_D, want * 180.0 / PI_D);
        CHECK(tr == 1.0f);
    }
    free(ng);
}

/* The same through vsd_refraction_build's field of the test ball (n = ior where the
 * density is > 0, a Gaussian of one cell): its surface is a 12-voxel staircase (voxels
 * within 12 of the centre are in, so the smoothed n is halfway 12 voxels out), whose facets
 * tilt the local normal; measured 0.0-3.0 degrees above Snell (18% at the smallest angle),
 * so 12% + 1.5 degrees. */
static void test_snell_built(void)
{
    const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const float ior = 1.33f;
    const double centre = 15.5 / 16.0, radius = 12.0 / 16.0, fractions[4] = {0.2, 0.4, 0.6, 0.75};
    vsd_kernel_data kd;
    vsd_refraction_field f;
    vsd_volume *vol = test_ball_volume();
    vsd_rng rng = vsd_rng_init(1, 2, 3);
    int i;
    memset(&kd, 0, sizeof kd);
    memset(&f, 0, sizeof f);
    if (!vol) return;
    CHECK(vsd_kvolume_setup(&kd.density, vol, ident, 0.0f, NULL, 0) == VSD_OK);
    CHECK(vsd_refraction_build(&kd.density, NULL, NULL, VSD_IOR_CONSTANT, ior, 1.0f, 128, &f, NULL, 0) == VSD_OK);
    CHECK_NEAR(f.n_max, ior, 1e-3);
    for (i = 0; i < 4 && f.k.ng; i++) {
        double want = snell_deviation(fractions[i], ior), got;
        vsd_f3 exit, o = f3(-1.0f, (float)(centre + fractions[i] * radius), (float)centre);
        vsd_bent_ratio_track(&kd, &f.k, o, f3(1.0f, 0.0f, 0.0f), &rng, &exit);
        got = atan2(-exit.y, exit.x);
        printf("    built ball (grid %dx%dx%d), impact %.2f R: deviation %.3f deg, Snell %.3f deg\n", f.k.dims[0],
               f.k.dims[1], f.k.dims[2], fractions[i], got * 180.0 / PI_D, want * 180.0 / PI_D);
        CHECK_MSG(fabs(got - want) < 0.12 * want + 1.5 * PI_D / 180.0, "built ball, impact %.2f R: %.3f deg, Snell %.3f deg", fractions[i],
                  got * 180.0 / PI_D, want * 180.0 / PI_D);
    }
    vsd_refraction_free(&f);
    vsd_volume_destroy(vol);
}

/* n = 1 everywhere: the bent trackers step through the grid without bending and must
 * estimate the straight trackers' transmittance (different random numbers: within the
 * noise) and leave with the same direction. */
static void test_unbent(void)
{
    const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    vsd_kernel_data kd;
    vsd_refraction_field f;
    vsd_volume *vol = test_ball_volume();
    vsd_rng a = vsd_rng_init(11, 0, 0), b = vsd_rng_init(12, 0, 0);
    double sa = 0.0, sb = 0.0, sa2 = 0.0, sb2 = 0.0, worst_dir = 0.0;
    const int n = 20000;
    int i;
    memset(&kd, 0, sizeof kd);
    if (!vol) return;
    CHECK(vsd_kvolume_setup(&kd.density, vol, ident, 2.0f, NULL, 0) == VSD_OK);
    CHECK(vsd_refraction_build(&kd.density, NULL, NULL, VSD_IOR_CONSTANT, 1.0f, 1.0f, 128, &f, NULL, 0) == VSD_OK);
    for (i = 0; i < n && f.k.ng; i++) {
        vsd_f3 o = f3(-1.0f, 0.6f + 0.7f * (float)i / n, 0.97f), d = f3_normalize(f3(1.0f, 0.1f, 0.05f)), exit;
        float ta = vsd_ratio_track(&kd.density, o, d, VSD_INF, &a);
        float tb = vsd_bent_ratio_track(&kd, &f.k, o, d, &b, &exit);
        sa += ta;
        sa2 += (double)ta * ta;
        sb += tb;
        sb2 += (double)tb * tb;
        worst_dir = fmax(worst_dir, sqrtf(f3_dot(f3_sub(exit, d), f3_sub(exit, d))));
    }
    {
        double ma = sa / n, mb = sb / n, se = sqrt((sa2 / n - ma * ma + sb2 / n - mb * mb) / n);
        printf("[3] n = 1: mean transmittance straight %.5f, bent %.5f (standard error %.5f), direction change %.2g\n",
               ma, mb, se, worst_dir);
        CHECK_MSG(fabs(ma - mb) < 4.0 * se, "straight %.5f vs bent %.5f, se %.5f", ma, mb, se);
        CHECK(worst_dir < 1e-5);
    }
    vsd_refraction_free(&f);
    vsd_volume_destroy(vol);
}

static void test_render_background(void)
{
    const char *ov_flat[] = {"render.method=reference", "render.samples=16", "medium.density=0.05",
                             "film.transparent=false", "camera.ortho_scale=4"};
    const char *ov_bent[] = {"render.method=reference", "render.samples=16", "medium.density=0.05",
                             "film.transparent=false", "camera.ortho_scale=4", "medium.ior=1.33"};
    const char *ov_bent_hi[] = {"render.method=reference", "render.samples=256", "medium.density=0.05",
                                "film.transparent=false", "camera.ortho_scale=4", "medium.ior=1.33"};
    vsd_scene bent_hi_sc;
    const char *uniform = "\"environment\":{\"color\":[1,1,1]}", *at = strstr(test_ball_json, uniform);
    char json[4096];
    vsd_scene flat_sc, bent_sc;
    vsd_volume *vol = test_ball_volume();
    vsd_framebuffer *flat = NULL, *bent = NULL;
    /* the ball's scene with the sunset map instead of its uniform white */
    CHECK(at != NULL);
    if (!at) return;
    snprintf(json, sizeof json, "%.*s\"environment\":{\"file\":\"%s\"}%s", (int)(at - test_ball_json), test_ball_json,
             test_data("env/sunset.exr"), at + strlen(uniform));
    if (!vol || !test_parse_scene(json, ov_flat, 5, &flat_sc) || !test_parse_scene(json, ov_bent, 6, &bent_sc)) {
        vsd_volume_destroy(vol);
        return;
    }
    flat = test_render_fresh(&flat_sc, NULL, vol, NULL, 1, NULL);
    bent = test_render_fresh(&bent_sc, NULL, vol, NULL, 1, NULL);
    if (flat && bent) {
        /* pixels whose rays miss the index grid (the ball's box, 0 to 2, plus a margin of 4
         * voxels: 1.22-1.28 from the centre): the orthographic camera looks along +y at the
         * ball's centre, 4 world units wide */
        int x, y, same = 0, outside = 0, changed = 0, centre = 0;
        for (y = 0; y < 32; y++)
            for (x = 0; x < 32; x++) {
                double wx = (x + 0.5) / 32.0 * 4.0 - 2.0, wz = 2.0 - (y + 0.5) / 32.0 * 4.0;
                const float *p = flat->pass[VSD_PASS_COMBINED] + 4 * (y * 32 + x);
                const float *q = bent->pass[VSD_PASS_COMBINED] + 4 * (y * 32 + x);
                double diff = fabs(p[0] - q[0]) + fabs(p[1] - q[1]) + fabs(p[2] - q[2]), mag = p[0] + p[1] + p[2];
                if (fabs(wx) > 1.35 || fabs(wz) > 1.35) {
                    outside++;
                    same += diff == 0.0;
                } else if (wx * wx + wz * wz < 0.4 * 0.4) {
                    centre++;
                    changed += diff > 0.05 * mag;
                }
            }
        printf("[4] ior 1.33 vs 1: %d of %d pixels outside the index grid identical, %d of %d inside the ball's "
               "middle changed by more than 5%%\n", same, outside, changed, centre);
        CHECK_MSG(outside > 0 && same == outside, "%d of %d pixels outside the grid differ", outside - same, outside);
        CHECK_MSG(centre > 0 && changed > centre / 2, "only %d of %d pixels through the ball changed", changed, centre);
    }
    /* lbl through the same refracting ball: its bent view rays against the path tracer's
     * (Combined, mostly the background seen through the ball), and lbl without refraction as
     * the control that must fail the same tolerance */
    if (flat && bent) {
        /* 4 x 4 rays per pixel: through the lens the map varies within a pixel, and the
         * reference averages over the pixel too */
        const char *lbl_ov[] = {"render.method=lbl", "render.options.pixel_samples=4", "medium.density=0.05",
                                "film.transparent=false", "camera.ortho_scale=4", "medium.ior=1.33"};
        vsd_scene lbl_sc, lbl1_sc;
        vsd_framebuffer *lbl = NULL, *lbl1 = NULL;
        if (test_parse_scene(json, lbl_ov, 6, &lbl_sc) && test_parse_scene(json, lbl_ov, 5, &lbl1_sc)) {
            lbl = test_render_fresh(&lbl_sc, NULL, vol, NULL, 1, NULL);
            lbl1 = test_render_fresh(&lbl1_sc, NULL, vol, NULL, 1, NULL);
        }
        if (lbl && lbl1) {
            vsd_framebuffer *ref = test_parse_scene(json, ov_bent_hi, 6, &bent_hi_sc)
                                       ? test_render_fresh(&bent_hi_sc, NULL, vol, NULL, 1, NULL)
                                       : NULL;
            double e = ref ? test_rel_err(lbl, ref, VSD_PASS_COMBINED) : 1.0;
            double e1 = ref ? test_rel_err(lbl1, ref, VSD_PASS_COMBINED) : 0.0;
            vsd_framebuffer_destroy(ref);
            printf("    lbl vs reference, ior 1.33: Combined %.4f; lbl without refraction: %.4f (tolerance %.3f)\n", e,
                   e1, LBL_REFRACT_TOL);
            CHECK_MSG(e < LBL_REFRACT_TOL, "lbl with refraction: %.4f", e);
            CHECK_MSG(e1 > LBL_REFRACT_TOL, "the control (no refraction) passes: %.4f", e1);
        }
        vsd_framebuffer_destroy(lbl);
        vsd_framebuffer_destroy(lbl1);
    }
    vsd_framebuffer_destroy(flat);
    vsd_framebuffer_destroy(bent);
    vsd_volume_destroy(vol);
}

/* The index from grids (volume.ior_grid, medium.ior_from): a grid of n gives the ball of
 * the constant form; Blender's temperature gives Gladstone-Dale's index relative to the
 * ambient air; an n below 1 is an error naming the grid and a voxel; through the renderer,
 * medium.ior with a grid is an error naming both, and a missing grid names it. */
static void test_ior_grids(void)
{
    const double ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    vsd_volume *ball = test_ball_volume(), *ngrid = NULL;
    vsd_kernel_data kd;
    vsd_kvolume src;
    vsd_refraction_field f;
    float *v = calloc(32 * 32 * 32, sizeof *v);
    const int32_t dims[3] = {32, 32, 32}, lo[3] = {0, 0, 0};
    const double m[16] = {1.0 / 16, 0, 0, 0, 0, 1.0 / 16, 0, 0, 0, 0, 1.0 / 16, 0, 0, 0, 0, 1};
    char err[512] = "";
    int i;
    memset(&kd, 0, sizeof kd);
    if (!ball || !v) goto done;
    CHECK(vsd_kvolume_setup(&kd.density, ball, ident, 1.0f, NULL, 0) == VSD_OK);
    /* n = 1.33 where the ball is, 0 (background) elsewhere */
    for (i = 0; i < 32 * 32 * 32; i++) v[i] = vsd_volume_voxel(ball, i % 32, (i / 32) % 32, i / 1024) > 0.0f ? 1.33f : 0.0f;
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &ngrid, NULL, 0) == VSD_OK);
    if (!ngrid) goto done;
    CHECK(vsd_kvolume_setup(&src, ngrid, ident, 1.0f, NULL, 0) == VSD_OK);
    CHECK(vsd_refraction_build(&kd.density, &src, "n", VSD_IOR_GRID, 1.0f, 1.0f, 128, &f, err, sizeof err) == VSD_OK);
    {
        vsd_refraction_field c;
        double worst = 0.0;
        size_t k, cells;
        CHECK(vsd_refraction_build(&kd.density, NULL, NULL, VSD_IOR_CONSTANT, 1.33f, 1.0f, 128, &c, NULL, 0) == VSD_OK);
        cells = (size_t)c.k.dims[0] * c.k.dims[1] * c.k.dims[2];
        CHECK(memcmp(c.k.dims, f.k.dims, sizeof c.k.dims) == 0);
        for (k = 0; f.k.ng && c.k.ng && k < 4 * cells && memcmp(c.k.dims, f.k.dims, sizeof c.k.dims) == 0; k++)
            worst = fmax(worst, fabs(f.k.ng[k] - c.k.ng[k]));
        printf("[5] a grid of n = 1.33 over the ball vs the constant form: largest difference %.3g\n", worst);
        CHECK(worst < 1e-6);
        vsd_refraction_free(&c);
    }
    vsd_refraction_free(&f);
    /* temperature 1 in the ball: T = 1293 K, n - 1 relative to ambient air */
    for (i = 0; i < 32 * 32 * 32; i++) v[i] = v[i] > 0.0f ? 1.0f : 0.0f;
    vsd_volume_destroy(ngrid);
    ngrid = NULL;
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &ngrid, NULL, 0) == VSD_OK);
    if (!ngrid) goto done;
    CHECK(vsd_kvolume_setup(&src, ngrid, ident, 1.0f, NULL, 0) == VSD_OK);
    CHECK(vsd_refraction_build(&kd.density, &src, "temperature", VSD_IOR_TEMPERATURE, 1.0f, 1.0f, 128, &f, err,
                               sizeof err) == VSD_OK);
    if (f.k.ng) {
        vsd_f3 g;
        float centre = vsd_refract_eval(&f.k, f3(15.5f / 16, 15.5f / 16, 15.5f / 16), &g);
        float outside = vsd_refract_eval(&f.k, f3(-5.0f, 0.0f, 0.0f), &g);
        double want = 1.0 - 2.9e-4 * (1.0 - 293.0 / 1293.0);
        printf("    temperature 1 (1293 K): n %.8f at the centre (Gladstone-Dale %.8f), %.8f outside\n", centre, want,
               outside);
        CHECK_NEAR(centre, want, 1e-6);
        CHECK(outside == 1.0f);
    }
    vsd_refraction_free(&f);
    /* n below 1 */
    for (i = 0; i < 32 * 32 * 32; i++) v[i] = v[i] > 0.0f ? 0.8f : 0.0f;
    vsd_volume_destroy(ngrid);
    ngrid = NULL;
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &ngrid, NULL, 0) == VSD_OK);
    if (!ngrid) goto done;
    CHECK(vsd_kvolume_setup(&src, ngrid, ident, 1.0f, NULL, 0) == VSD_OK);
    CHECK(vsd_refraction_build(&kd.density, &src, "n_field", VSD_IOR_GRID, 1.0f, 1.0f, 128, &f, err, sizeof err) ==
          VSD_ERR_INVALID);
    printf("    n below 1: %s\n", err);
    CHECK_CONTAINS(err, "volume.ior_grid 'n_field': n = 0.8 below 1 at index (");
    CHECK(f.k.ng == NULL);
    /* through the renderer */
    {
        const char *both[] = {"frames.start=24", "frames.end=24", "film.width=8", "film.height=8", "render.samples=1",
                              "medium.ior=1.2", "volume.ior_grid=density"};
        const char *missing[] = {"frames.start=24", "frames.end=24", "film.width=8", "film.height=8",
                                 "render.samples=1", "volume.ior_grid=no_such_grid"};
        vsd_scene sc;
        vsd_renderer *r = NULL;
        vsd_framebuffer *fb = NULL;
        vsd_render_stats st;
        vsd_render_options o;
        memset(&o, 0, sizeof o);
        if (test_load_scene("scenes/smoke64_sunset.json", both, 7, &sc) &&
            vsd_renderer_create(&sc, &o, &r, err, sizeof err) == VSD_OK) {
            CHECK(vsd_renderer_render(r, 24, &fb, &st, err, sizeof err) == VSD_ERR_INVALID);
            printf("    ior and a grid: %s\n", err);
            CHECK_CONTAINS(err, "medium.ior (1.2) and the grid 'density'");
        }
        vsd_renderer_destroy(r);
        r = NULL;
        if (test_load_scene("scenes/smoke64_sunset.json", missing, 6, &sc) &&
            vsd_renderer_create(&sc, &o, &r, err, sizeof err) == VSD_OK) {
            CHECK(vsd_renderer_render(r, 24, &fb, &st, err, sizeof err) == VSD_ERR_NOT_FOUND);
            printf("    a missing grid: %s\n", err);
            CHECK_CONTAINS(err, "'no_such_grid'");
        }
        vsd_renderer_destroy(r);
        vsd_framebuffer_destroy(fb);
    }
done:
    free(v);
    vsd_volume_destroy(ngrid);
    vsd_volume_destroy(ball);
}

/* n of air at normalised temperature v (T = 293 K + 1000 K v): Gladstone-Dale, n - 1 =
 * 2.9e-4 T0 / T, relative to the ambient air at T0 = 293 K (refraction.h), in double. */
static double haze_n(const vsd_kvolume *kv, vsd_f3 p)
{
    double v = vsd_kvolume_at(kv, p), t = 293.0 + 1000.0 * (v > 0.0 ? v : 0.0);
    return 1.0 - 2.9e-4 * (1.0 - 293.0 / t);
}

/* The optical path of the straight ray o + s d, s in [t0, t1], by the midpoint rule. */
static double haze_path(const vsd_kvolume *kv, vsd_f3 o, vsd_f3 d, double t0, double t1, double ds)
{
    int k, steps = (int)ceil((t1 - t0) / ds);
    double h = (t1 - t0) / steps, s = 0.0;
    for (k = 0; k < steps; k++) s += haze_n(kv, f3_madd(o, d, (float)(t0 + (k + 0.5) * h))) - 1.0;
    return s * h;
}

/* The paraxial deflection of a ray through a weak index field: delta = grad_perp of the
 * optical path along the straight ray (n ~ 1), by central differences of +-h across it. */
static void haze_deflection(const vsd_kvolume *kv, vsd_f3 o, vsd_f3 d, double t0, double t1, double h,
                            double out[3])
{
    vsd_f3 e1 = fabsf(d.z) < 0.9f ? f3(-d.y, d.x, 0.0f) : f3(0.0f, -d.z, d.y), e2;
    double l1 = sqrt((double)f3_dot(e1, e1)), g1, g2;
    e1 = f3_scale(e1, (float)(1.0 / l1));
    e2 = f3(d.y * e1.z - d.z * e1.y, d.z * e1.x - d.x * e1.z, d.x * e1.y - d.y * e1.x);
    g1 = (haze_path(kv, f3_madd(o, e1, (float)h), d, t0, t1, 0.5 * h) -
          haze_path(kv, f3_madd(o, e1, (float)-h), d, t0, t1, 0.5 * h)) / (2.0 * h);
    g2 = (haze_path(kv, f3_madd(o, e2, (float)h), d, t0, t1, 0.5 * h) -
          haze_path(kv, f3_madd(o, e2, (float)-h), d, t0, t1, 0.5 * h)) / (2.0 * h);
    out[0] = g1 * e1.x + g2 * e2.x;
    out[1] = g1 * e1.y + g2 * e2.y;
    out[2] = g1 * e1.z + g2 * e2.z;
}

/* The traced deflections against the paraxial ones on fire96 frame 48 (5964 rays): measured
 * slope 0.869, correlation 0.967. Below 1 because the field's n is the mean over k^3 voxels
 * smoothed by a Gaussian of one cell (refraction.h), which flattens the finest gradients the
 * paraxial integral of the raw temperature sees. Bounds 0.80-0.95 and 0.93: a Gladstone-Dale
 * coefficient 10% off (slope ~0.78 or ~0.96) or a field that bends the wrong way fails. */
#define HAZE_SLOPE_LO 0.80
#define HAZE_SLOPE_HI 0.95
#define HAZE_CORR 0.93
/* Heat haze on real data: fire96 frame 48's temperature grid (medium.ior_from =
 * "temperature"), the scene's own camera at 480x270. Each pixel's view ray is traced
 * through the field with and without bending; the angle between the two exit directions
 * over the angle a pixel spans is the background's displacement in pixels. Gladstone-Dale
 * gives |n - 1| below 2.2e-4 for the hottest air, so a flame a world unit across displaces
 * the background by a fraction of a pixel: it moves, by less than 2 pixels, and by how much:
 * on every 4th pixel of every 4th row the traced deflection is regressed on the paraxial
 * one, grad_perp of the optical path integral of Gladstone-Dale's n along the straight ray,
 * computed here from the temperature grid itself (haze_deflection). */
static void test_heat_haze(void)
{
    const char *ov[] = {"frames.start=48", "frames.end=48", "film.width=480", "film.height=270",
                        "medium.ior_from=temperature"};
    vsd_scene sc;
    vsd_volume *temp = NULL;
    vsd_grid_select sel = {"temperature", -1};
    vsd_kvolume kv;
    vsd_kernel_data kd;
    vsd_refraction_field f;
    char path[2048], err[1024] = "";
    double worst = 0.0, sum = 0.0, pixel, cell, gp = 0.0, pp = 0.0, gg = 0.0, pred_sum = 0.0;
    int x, y, moved = 0, n = 0, npred = 0;
    memset(&kd, 0, sizeof kd);
    memset(&f, 0, sizeof f);
    if (!test_load_scene("scenes/fire96_studio.json", ov, 5, &sc)) return;
    CHECK(vsd_frame_path(sc.volumes[0].file, 48, path, sizeof path, err, sizeof err) == VSD_OK);
    CHECK_MSG(vsd_vdb_load(path, sel, &temp, err, sizeof err) == VSD_OK, "%s", err);
    if (!temp) return;
    CHECK(vsd_kvolume_setup(&kv, temp, sc.volumes[0].matrix, 1.0f, NULL, 0) == VSD_OK);
    CHECK(vsd_refraction_build(&kv, &kv, "temperature", VSD_IOR_TEMPERATURE, 1.0f, 1.0f, 128, &f, err, sizeof err) ==
          VSD_OK);
    vsd_kcamera_setup(&kd.camera, &sc);
    pixel = 2.0 * kd.camera.tan_half_fov / 480.0;   /* radians per pixel near the centre */
    cell = 2.0 * f.k.step;                            /* the field's smallest cell edge */
    for (y = 0; y < 270 && f.k.ng; y += 2)
        for (x = 0; x < 480; x += 2) {
            vsd_f3 o, d, d0, v, g;
            float t0, t1;
            int steps = 0;
            vsd_camera_ray(&kd.camera, x, y, 0.5f, 0.5f, &o, &d);
            d0 = d;
            if (!vsd_refract_clip(&f.k, o, d, &t0, &t1)) continue;
            o = f3_madd(o, d, t0 + 1e-3f * f.k.step);
            v = f3_scale(d, vsd_refract_eval(&f.k, o, &g));
            while (vsd_refract_inside(&f.k, o) && steps++ < f.k.max_steps) vsd_refract_step(&f.k, &o, &v, &d, f.k.step);
            {
                double c = f3_dot(d, d0), a = acos(c > 1.0 ? 1.0 : c) / pixel;
                worst = fmax(worst, a);
                sum += a;
                n++;
                moved += a > 0.01;
            }
            /* the paraxial deflection, from Gladstone-Dale on the temperature itself: on
             * every 4th pixel of every 4th row */
            if (x % 4 == 0 && y % 4 == 0) {
                double pred[3], got[3];
                int k;
                vsd_camera_ray(&kd.camera, x, y, 0.5f, 0.5f, &o, &d0);
                haze_deflection(&kv, o, d0, t0, t1, cell, pred);
                for (k = 0; k < 3; k++) got[k] = (k == 0 ? d.x - d0.x : k == 1 ? d.y - d0.y : d.z - d0.z);
                for (k = 0; k < 3; k++) {
                    gp += got[k] * pred[k];
                    pp += pred[k] * pred[k];
                    gg += got[k] * got[k];
                }
                pred_sum += sqrt(pred[0] * pred[0] + pred[1] * pred[1] + pred[2] * pred[2]) / pixel;
                npred++;
            }
        }
    printf("[6] fire96 frame 48 heat haze at 480x270: %d rays through the field, displacement mean %.4f px, "
           "largest %.3f px, %d rays moved by more than 0.01 px\n", n, n ? sum / n : 0.0, worst, moved);
    CHECK(n > 0 && moved > 0 && worst < 2.0);
    {
        /* by how much: the traced deflections against the paraxial ones, regressed over
         * npred rays: slope = sum got.pred / sum pred^2, correlation = sum got.pred /
         * sqrt(sum got^2 sum pred^2) */
        double slope = pp > 0 ? gp / pp : 0.0, corr = pp > 0 && gg > 0 ? gp / sqrt(pp * gg) : 0.0;
        printf("    against Gladstone-Dale's paraxial deflection (n - 1 = 2.9e-4 (293 K / T - 1), grad_perp of the "
               "optical path): %d rays, predicted mean %.4f px, slope %.4f, correlation %.4f\n",
               npred, npred ? pred_sum / npred : 0.0, slope, corr);
        CHECK_MSG(slope > HAZE_SLOPE_LO && slope < HAZE_SLOPE_HI,
                  "heat haze: the traced deflection is %.3f x the paraxial one (expected %.2f to %.2f)", slope,
                  HAZE_SLOPE_LO, HAZE_SLOPE_HI);
        CHECK_MSG(corr > HAZE_CORR, "heat haze: traced and paraxial deflections correlate by %.3f only", corr);
    }
    vsd_refraction_free(&f);
    vsd_volume_destroy(temp);
}

/* Two in-memory copies of the ball as volumes 0 and 1 (`volumes` JSON array contents), the
 * orthographic camera of [4] looking along +y; NULL with a failed CHECK on an error. */
static vsd_framebuffer *render_two_balls(const vsd_volume *ball, const char *volumes, int two, const char *method)
{
    char json[2048];
    vsd_scene sc;
    vsd_renderer *r;
    vsd_framebuffer *fb = NULL;
    snprintf(json, sizeof json,
             "{\"version\":1,\"volumes\":[%s],\"environment\":{\"file\":\"%s\"},"
             "\"camera\":{\"type\":\"orthographic\",\"ortho_scale\":4,\"position\":[0.96875,-4,0.96875],"
             "\"look_at\":[0.96875,0.96875,0.96875],\"up\":[0,0,1]},"
             "\"film\":{\"width\":32,\"height\":32,\"transparent\":false},"
             "\"render\":{\"method\":\"%s\",\"samples\":16}}",
             volumes, test_data("env/sunset.exr"), method);
    if (!test_parse_scene(json, NULL, 0, &sc) || !(r = test_make_renderer(&sc, NULL))) return NULL;
    vsd_renderer_use_volume(r, 0, ball, NULL, NULL);
    if (two) vsd_renderer_use_volume(r, 1, ball, NULL, NULL);
    if (!test_render(r, 1, &fb, NULL)) {
        vsd_framebuffer_destroy(fb);
        fb = NULL;
    }
    vsd_renderer_destroy(r);
    return fb;
}

#define THIN_BALL(ior) "{\"file\":\"memory.vdb\",\"medium\":{\"density\":0.05,\"albedo\":[0.9,0.9,0.9],\"ior\":" ior "}}"
/* the same ball 3 units behind (along the camera's +y) */
#define BALL_BEHIND(density) \
    "{\"file\":\"memory.vdb\",\"matrix\":[1,0,0,0, 0,1,0,3, 0,0,1,0, 0,0,0,1]," \
    "\"medium\":{\"density\":" density ",\"albedo\":[0.9,0.9,0.9]}}"

/* A refracting volume among others (issue 30): reference bends every volume's rays through
 * the one refracting volume's field.
 *   - an empty volume 0 and the refracting ball as volume 1 render bit for bit as the ball
 *     alone: the field is volume 1's, and the bent paths track every volume (the empty one
 *     draws no random numbers);
 *   - a dense ball behind the refracting one is still seen through it: the transmittance
 *     through the lens's middle stays that of the dense ball (with the bent paths tracking
 *     volume 1 alone it would be the thin ball's, ~0.9);
 *   - two refracting volumes, and lbl with a refracting volume among others, are errors
 *     naming them. */
static void test_among_volumes(void)
{
    vsd_volume *ball = test_ball_volume();
    vsd_framebuffer *alone, *pair, *behind, *behind_flat;
    if (!ball) return;
    alone = render_two_balls(ball, THIN_BALL("1.33"), 0, "reference");
    pair = render_two_balls(ball, BALL_BEHIND("0") "," THIN_BALL("1.33"), 1, "reference");
    CHECK(alone && pair);
    if (alone && pair) CHECK_MSG(test_identical(alone, pair), "an empty volume 0 changed the refracting ball's image");
    behind = render_two_balls(ball, BALL_BEHIND("4") "," THIN_BALL("1.33"), 1, "reference");
    behind_flat = render_two_balls(ball, BALL_BEHIND("4") "," THIN_BALL("1"), 1, "reference");
    CHECK(behind && behind_flat);
    if (behind && behind_flat) {
        double t = 0, t_flat = 0;
        int x, y, n = 0;
        for (y = 0; y < 32; y++)
            for (x = 0; x < 32; x++) {
                double wx = (x + 0.5) / 32.0 * 4.0 - 2.0, wz = 2.0 - (y + 0.5) / 32.0 * 4.0;
                if (wx * wx + wz * wz >= 0.3 * 0.3) continue;
                t += behind->pass[VSD_PASS_TRANSMITTANCE][3 * (y * 32 + x)];
                t_flat += behind_flat->pass[VSD_PASS_TRANSMITTANCE][3 * (y * 32 + x)];
                n++;
            }
        t /= n, t_flat /= n;
        printf("[among volumes] T through the lens's middle onto the dense ball: %.4f (ior 1: %.4f)\n", t, t_flat);
        CHECK_MSG(t < 0.5 && fabs(t - t_flat) < 0.1, "T through the refracting ball %.4f, without refraction %.4f", t,
                  t_flat);
    }
    {
        char json[2048];
        const char *const cases[2][3] = {
            {BALL_BEHIND("4") "," THIN_BALL("1.33"), "lbl", "reference renders a refracting volume among others"},
            {"{\"file\":\"memory.vdb\",\"medium\":{\"ior\":1.2}}," THIN_BALL("1.33"), "reference",
             "volumes[0] and volumes[1] both refract"}};
        int k;
        const vsd_volume *const both[2] = {ball, ball};
        for (k = 0; k < 2; k++) {
            vsd_scene sc;
            char err[1024];
            snprintf(json, sizeof json, "{\"version\":1,\"volumes\":[%s],\"environment\":{\"color\":[1,1,1]},"
                     "\"render\":{\"method\":\"%s\",\"samples\":1}}", cases[k][0], cases[k][1]);
            if (!test_parse_scene(json, NULL, 0, &sc)) continue;
            test_expect_render_error(&sc, both, 2, err, sizeof err);
            CHECK_CONTAINS(err, cases[k][2]);
        }
    }
    vsd_framebuffer_destroy(alone);
    vsd_framebuffer_destroy(pair);
    vsd_framebuffer_destroy(behind);
    vsd_framebuffer_destroy(behind_flat);
    vsd_volume_destroy(ball);
}

int main(void)
{
    test_among_volumes();
    test_parabola();
    test_snell();
    test_snell_built();
    test_unbent();
    test_render_background();
    test_ior_grids();
    test_heat_haze();
    return test_finish("test_refraction");
}
