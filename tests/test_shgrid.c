/* Method `shgrid` (Delalandre et al. 2013): the closed-form thin homogeneous box under a
 * uniform environment, the same box under a sky with a small sun (the extracted-lights
 * extension against the paper's pure SH), agreement with `reference` single scattering
 * within the 5% target on two data sets,
 * error decreasing with grid resolution and SH order, the record-grid cache across views
 * and environment rotations, and option validation. */
#include "test_common.h"
#include "test_render_util.h"
#include "method_vs_reference.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#include "vsd/compare.h"
#include "vsd/sh.h"
#include <stdlib.h>

static int load_scene(const char *json, const char *const *ov, int nov, vsd_scene *sc)
{
    char err[1024];
    vsd_status st = vsd_scene_parse(json, "", ov, nov, sc, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "scene: %s", err);
    return st == VSD_OK;
}

static vsd_framebuffer *render_mem(const vsd_scene *sc, const vsd_volume *vol, const vsd_env *env)
{
    return test_render_in_memory(sc, vol, env, 0);
}

/* E_2(x) = integral_0^1 exp(-x/mu) dmu, by Gauss-Legendre. */
static double expint2(double x, const double *gx, const double *gw, int n)
{
    double s = 0;
    int i;
    for (i = 0; i < n; i++) {
        double mu = 0.5 * (gx[i] + 1);
        s += 0.5 * gw[i] * exp(-x / mu);
    }
    return s;
}

/* A slab, homogeneous across, lit by a uniform environment L with albedo 1 and g = 0: at
 * vertical optical depth t of a slab of optical thickness D, the in-scattered radiance is
 * (L/2)(E_2(t) + E_2(D - t)), so the single scattering seen along the normal is
 *   L_ss = (L/2) integral_0^D e^{-t} (E_2(t) + E_2(D - t)) dt
 * whatever the density profile across the slab (only optical depth enters). The box is
 * 2 x 2 wide and 0.1 thick (20:1), so its finite width changes the escape paths only for
 * grazing directions whose slab transmittance is already ~e^{-10 tau}. */
/* The slab of the thin-box tests: 2 x 2 x 0.1 world units, optical thickness 0.5 across. */
static const char *const slab_json =
    "{\"version\":1,\"volume\":{\"file\":\"memory.vdb\"},"
    "\"medium\":{\"density\":5.0,\"albedo\":[1,1,1],\"anisotropy\":0},"
    "\"camera\":{\"type\":\"orthographic\",\"ortho_scale\":0.4,\"position\":[1,1,5],\"look_at\":[1,1,0],\"up\":[0,1,0]},"
    "\"film\":{\"width\":8,\"height\":8},\"render\":{\"method\":\"shgrid\"}}";
static const double slab_tau = 5.0 * 10 * 0.01;

static vsd_volume *slab_volume(void)
{
    const int nx = 40, nz = 12;
    int32_t dims[3] = {40, 40, 12}, lo[3] = {0, 0, 0};
    double m[16] = {0.05, 0, 0, 0, 0, 0.05, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 1};
    float *v = calloc((size_t)nx * nx * nz, sizeof(float));
    vsd_volume *vol = NULL;
    int x, y, z;
    for (z = 1; z <= 10; z++)
        for (y = 0; y < nx; y++)
            for (x = 0; x < nx; x++) v[((size_t)z * nx + y) * nx + x] = 1.0f;
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &vol, NULL, 0) == VSD_OK);
    free(v);
    return vol;
}

/* Closed form of the uniform-environment slab (radiance L, optical thickness D), see
 * test_thin_box. */
static double slab_uniform_tau(double L, double D)
{
    double gx[200], gw[200], expect = 0;
    int i;
    vsd_sh_gauss_legendre(200, gx, gw);
    for (i = 0; i < 200; i++) {
        double t = 0.5 * D * (gx[i] + 1);
        expect += 0.5 * D * gw[i] * exp(-t) * 0.5 * L * (expint2(t, gx, gw, 200) + expint2(D - t, gx, gw, 200));
    }
    return expect;
}

static double slab_uniform(double L) { return slab_uniform_tau(L, slab_tau); }

/* Mean green VolumeDir over the 8x8 film of the slab scene with the given overrides. */
static double slab_render(const vsd_volume *vol, const vsd_env *env, const char *const *ov, int nov)
{
    vsd_scene sc;
    vsd_framebuffer *fb;
    double got = 0;
    int i;
    if (!load_scene(slab_json, ov, nov, &sc)) return -1;
    fb = render_mem(&sc, vol, env);
    if (!fb) return -1;
    for (i = 0; i < 64; i++) got += fb->pass[VSD_PASS_VOLUME_DIR][3 * i + 1] / 64;
    vsd_framebuffer_destroy(fb);
    return got;
}

static void test_thin_box(void)
{
    float one[3] = {1, 1, 1};
    vsd_volume *vol = slab_volume();
    vsd_env *env = NULL;
    double D = slab_tau, expect = slab_uniform(1.0);
    CHECK(vsd_env_create_uniform(one, 64, 32, &env, NULL, 0) == VSD_OK);
    {
        const char *grids[] = {"render.options.grid=8", "render.options.grid=32"};
        double got[2] = {0, 0};
        int gi;
        for (gi = 0; gi < 2; gi++) got[gi] = slab_render(vol, env, grids + gi, 1);
        printf("thin box (tau %.2f): closed form %.5f, shgrid grid 8: %.5f (%+.2f%%), grid 32: %.5f (%+.2f%%)\n", D,
               expect, got[0], 100 * (got[0] / expect - 1), got[1], 100 * (got[1] / expect - 1));
        /* grid 32 puts 16 cells across the slab, grid 8 four; the uniform map has only a
         * y0 coefficient (and no texel above light_threshold, so no light is extracted), so
         * the error is the 192-direction HEALPix rule for T's y0 and the record
         * interpolation, not SH truncation (measured -0.8% and +0.3%) */
        CHECK_MSG(fabs(got[1] / expect - 1) < 0.02, "grid 32: %g vs closed form %g", got[1], expect);
        CHECK_MSG(fabs(got[0] / expect - 1) < 0.06, "grid 8: %g vs closed form %g", got[0], expect);
    }
    vsd_volume_destroy(vol);
    vsd_env_destroy(env);
}

/* The extension (render.options.lights): the slab under a uniform sky of radiance 1 plus a
 * small sun (4 texels of radiance 5000 at 45 degrees from the zenith, 256 x 128 map). Seen
 * along the normal, each sun texel of irradiance E = L_s * solid angle at cosine mu adds
 *   E/(4 pi) integral_0^D e^{-t} e^{-t/mu} dt = E/(4 pi) (1 - e^{-D(1+1/mu)}) / (1 + 1/mu)
 * to the uniform-sky closed form. With the sun taken out of the SH the method must meet
 * this within the record grid's error; the paper's pure form (lights=0) keeps the sun in an
 * order-3 SH and is printed beside it. */
static double sun_closed_form(double D, int W, int H, int r0, int c0)
{
    double sun = 0;
    int r, c;
    for (r = r0; r < r0 + 2; r++)
        for (c = c0; c < c0 + 2; c++) {
            double th0 = M_PI * r / H, th1 = M_PI * (r + 1) / H, dom = 2 * M_PI / W * (cos(th0) - cos(th1));
            double mu = cos(0.5 * (th0 + th1)), k = 1 + 1 / mu;
            sun += 5000.0 * dom / (4 * M_PI) * (1 - exp(-D * k)) / k;
        }
    return sun;
}

static void test_sun_box(void)
{
    const int W = 256, H = 128, r0 = 31, c0 = 100;
    float one[3] = {1, 1, 1};
    vsd_volume *vol = slab_volume();
    vsd_env *env = NULL;
    double D = slab_tau, expect = slab_uniform(1.0), sun = sun_closed_form(D, W, H, r0, c0), got, pure;
    int r, c;
    CHECK(vsd_env_create_uniform(one, W, H, &env, NULL, 0) == VSD_OK);
    if (!env) return;
    for (r = r0; r < r0 + 2; r++)
        for (c = c0; c < c0 + 2; c++) {
            int ch;
            for (ch = 0; ch < 3; ch++) env->rgb[3 * (r * W + c) + ch] = 5001.0f;   /* sky 1 + sun 5000 */
        }
    {
        const char *ov_ext[1] = {"render.options.grid=32"};
        const char *ov_pure[2] = {"render.options.grid=32", "render.options.lights=0"};
        got = slab_render(vol, env, ov_ext, 1);
        pure = slab_render(vol, env, ov_pure, 2);
    }
    printf("sun box: closed form %.5f (sun %.5f), shgrid with lights %.5f (%+.2f%%), pure SH (lights=0) %.5f (%+.2f%%)\n",
           expect + sun, sun, got, 100 * (got / (expect + sun) - 1), pure, 100 * (pure / (expect + sun) - 1));
    CHECK_MSG(fabs(got / (expect + sun) - 1) < 0.02, "sun box with lights: %g vs closed form %g", got, expect + sun);
    vsd_volume_destroy(vol);
    vsd_env_destroy(env);
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

static double dir_error(const vsd_framebuffer *a, const vsd_framebuffer *ref, int w, int h)
{
    double e = 1;
    CHECK(vsd_block_rel_rmse(a->pass[VSD_PASS_VOLUME_DIR], ref->pass[VSD_PASS_VOLUME_DIR], w, h, 3, 3, 4, &e, NULL, 0) == VSD_OK);
    return e;
}

/* shgrid's VolumeDir (default settings) against reference single scattering at 48x27
 * through the harness (common/method_vs_reference.h): the mean of two 2048 spp seeds, its
 * noise (half their difference) measured in the same run and under a third of the
 * tolerance, the pass scaled by 0.9 as the control that must fail. The tolerance is the
 * issue's 5% target on the raw error against that mean (it was 5% on a noise-corrected
 * estimate, with 5% + the pair's difference on the raw one). Measured 2026-12-03: smoke64
 * 0.0339 (noise of the mean 0.0104, 3x 0.031; noise-corrected 0.032), fire96 0.0327 (noise
 * 0.0082; 0.032); controls 0.196 / 0.162 (3.6-4.0% at 64x36 against 8192 spp references:
 * docs/methods/shgrid.md). shgrid renders 2x2
 * rays per pixel here: the reference averages over each pixel's area, and at 48x27 one
 * point sample per pixel adds about 8% of silhouette aliasing that says nothing about the
 * lighting this test is about (the default, 1 ray, is measured at real film sizes by
 * bench/tte). The references render with medium.emission_strength 0: the reference's
 * VolumeDir also holds emission scattered once (as Cycles'), which a single-scattering
 * method does not compute, and shgrid's VolumeDir does not depend on emission. */
#define SH_TOL 0.05
typedef struct dataset { const char *scene; int frame; } dataset;

static void test_against_reference(void)
{
    const dataset sets[] = {
        {"scenes/smoke64_sunset.json", 24},
        {"scenes/fire96_studio.json", 48},
    };
    const char *labels[2] = {"smoke64 shgrid", "fire96 shgrid"};
    int si;
    for (si = 0; si < 2; si++) {
        char fr[2][32];
        const char *ref_ov[5], *sh_ov[6];
        const mvr_scene sc = {sets[si].scene, NULL, NULL, NULL, sets[si].frame};
        mvr_refs refs;
        vsd_framebuffer *sh;
        snprintf(fr[0], sizeof fr[0], "frames.start=%d", sets[si].frame);
        snprintf(fr[1], sizeof fr[1], "frames.end=%d", sets[si].frame);
        ref_ov[0] = sh_ov[0] = fr[0];
        ref_ov[1] = sh_ov[1] = fr[1];
        ref_ov[2] = sh_ov[2] = "film.width=48";
        ref_ov[3] = sh_ov[3] = "film.height=27";
        ref_ov[4] = "medium.emission_strength=0";
        sh_ov[4] = "render.method=shgrid";
        sh_ov[5] = "render.options.pixel_samples=2";
        if (!mvr_render_references(&sc, ref_ov, 5, 2048, &refs)) {
            mvr_refs_free(&refs);
            continue;
        }
        sh = mvr_render(&sc, sh_ov, 6, NULL, NULL);
        CHECK(sh != NULL);
        if (sh) {
            mvr_result r = mvr_check(labels[si], sh, &refs, VSD_PASS_VOLUME_DIR, SH_TOL, 0.9);
            double et = mvr_error(sh, &refs, VSD_PASS_TRANSMITTANCE);
            printf("    %s: VolumeDir noise-corrected sqrt(error^2 - noise^2) %.4f, Transmittance %.4f\n", labels[si],
                   sqrt(fmax(0.0, r.err * r.err - r.noise * r.noise)), et);
            CHECK_MSG(et < 0.02, "%s: Transmittance rel. RMSE %.4f", labels[si], et);
        }
        mvr_refs_free(&refs);
        vsd_framebuffer_destroy(sh);
    }
}

/* Error against a shgrid-independent answer (raymarch, 128 fixed lights, the same view
 * quadrature: noise-free) as the grid is refined (default settings) and the SH order
 * raised. The order sweep uses the paper's pure SH form (lights=0): with the bright texels
 * taken out, the order only shapes the smooth remainder and the error sits at the answer's
 * own level at every order. Each step may not raise the error by more than 0.015: the
 * answer itself is off by about 2% (raymarch at 256 vs 1024 lights differ by 2.1% on this
 * view), and with 192 directions band 3 is slightly aliased. Over the whole range the
 * error must fall clearly. */
static void test_convergence(void)
{
    const char *base[] = {"frames.start=24", "frames.end=24", "film.width=32", "film.height=18",
                          "environment.file=../env/studio.exr"};
    const char *ov[9];
    vsd_framebuffer *truth, *fb;
    const char *grids[] = {"render.options.grid=4", "render.options.grid=8", "render.options.grid=16", "render.options.grid=32"};
    const char *orders[] = {"render.options.order=1", "render.options.order=2", "render.options.order=3", "render.options.order=4"};
    double eg[4], eo[4];
    int i;
    for (i = 0; i < 5; i++) ov[i] = base[i];
    ov[5] = "render.method=raymarch";
    ov[6] = "render.options.lights=128";
    truth = render_file("scenes/smoke64_sunset.json", ov, 7, 24);
    if (!truth) return;
    ov[5] = "render.method=shgrid";
    for (i = 0; i < 4; i++) {
        ov[6] = grids[i];
        ov[7] = "render.options.order=4";
        fb = render_file("scenes/smoke64_sunset.json", ov, 8, 24);
        eg[i] = fb ? dir_error(fb, truth, 32, 18) : 1;
        vsd_framebuffer_destroy(fb);
        ov[6] = orders[i];
        ov[7] = "render.options.grid=32";
        ov[8] = "render.options.lights=0";
        fb = render_file("scenes/smoke64_sunset.json", ov, 9, 24);
        eo[i] = fb ? dir_error(fb, truth, 32, 18) : 1;
        vsd_framebuffer_destroy(fb);
    }
    printf("error vs grid 4/8/16/32 (order 4): %.4f %.4f %.4f %.4f\n", eg[0], eg[1], eg[2], eg[3]);
    printf("error vs order 1/2/3/4 (grid 32, lights=0): %.4f %.4f %.4f %.4f\n", eo[0], eo[1], eo[2], eo[3]);
    for (i = 1; i < 4; i++) {
        CHECK_MSG(eg[i] <= eg[i - 1] + 0.015, "grid step %d: %.4f after %.4f", i, eg[i], eg[i - 1]);
        CHECK_MSG(eo[i] <= eo[i - 1] + 0.015, "order step %d: %.4f after %.4f", i, eo[i], eo[i - 1]);
    }
    CHECK_MSG(eg[3] < 0.2 * eg[0], "grid refinement: %.4f -> %.4f", eg[0], eg[3]);
    CHECK_MSG(eo[3] < 0.5 * eo[0], "order: %.4f -> %.4f", eo[0], eo[3]);
    vsd_framebuffer_destroy(truth);
}

/* The record grid is the per-frame cache: a new camera re-renders without preparing, and
 * an environment rotation only re-projects the lighting. Both give exactly the image a
 * fresh renderer gives. */
static void test_cache(void)
{
    const char *ov[6] = {"frames.start=24", "frames.end=24", "film.width=32", "film.height=18",
                         "render.method=shgrid", "render.options.grid=16"};
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL, *fresh;
    vsd_render_stats st1, st2, st3;
    char err[1024];
    vsd_status st = vsd_scene_load(test_data("scenes/smoke64_sunset.json"), ov, 6, &sc, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "%s", err);
    if (st) return;
    st = vsd_renderer_create(&sc, NULL, &r, err, sizeof err);
    if (!st) st = vsd_renderer_render(r, 24, &fb, &st1, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "%s", err);
    if (st) { vsd_renderer_destroy(r); return; }
    /* new view */
    sc.camera.matrix[3] += 0.3;
    CHECK(vsd_renderer_set_scene(r, &sc, err, sizeof err) == VSD_OK);
    CHECK(vsd_renderer_render(r, 24, &fb, &st2, err, sizeof err) == VSD_OK);
    CHECK_MSG(st2.prepare_seconds < 0.01 + 0.05 * st1.prepare_seconds, "new view re-prepared: %.3fs (first %.3fs)",
              st2.prepare_seconds, st1.prepare_seconds);
    /* rotate the environment */
    sc.environment.rotation_z = 1.1f;
    CHECK(vsd_renderer_set_scene(r, &sc, err, sizeof err) == VSD_OK);
    CHECK(vsd_renderer_render(r, 24, &fb, &st3, err, sizeof err) == VSD_OK);
    printf("cache: prepare %.3fs first, %.4fs new view, %.4fs env rotation\n", st1.prepare_seconds, st2.prepare_seconds,
           st3.prepare_seconds);
    CHECK_MSG(st3.prepare_seconds < 0.5 * st1.prepare_seconds, "rotation redid the record grid: %.3fs", st3.prepare_seconds);
    {
        vsd_renderer *r2 = NULL;
        fresh = NULL;
        CHECK(vsd_renderer_create(&sc, NULL, &r2, err, sizeof err) == VSD_OK);
        if (r2) CHECK(vsd_renderer_render(r2, 24, &fresh, NULL, err, sizeof err) == VSD_OK);
        if (fresh) {
            double md = 0, mx = 0;
            int i;
            for (i = 0; i < 32 * 18 * 3; i++) {
                md = fmax(md, fabs(fresh->pass[VSD_PASS_VOLUME_DIR][i] - fb->pass[VSD_PASS_VOLUME_DIR][i]));
                mx = fmax(mx, fabs(fresh->pass[VSD_PASS_VOLUME_DIR][i]));
            }
            /* the cached path rotates the map's SH, the fresh one too: identical up to rounding */
            CHECK_MSG(md <= 1e-5 * mx, "cached vs fresh: max difference %g (max %g)", md, mx);
        }
        vsd_framebuffer_destroy(fresh);
        vsd_renderer_destroy(r2);
    }
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
}

static void test_options(void)
{
    const char *bad[] = {"render.options.directions=100", "render.options.order=9", "render.options.grid=1",
                         "render.options.interpolation=\"cubic\"", "render.options.form=\"x\"", "render.options.probes=-1",
                         "render.options.nope=1", "render.options.lights=65", "render.options.lights=2.5",
                         "render.options.light_threshold=0.5"};
    const char *msg[] = {"directions", "order", "grid", "interpolation", "form", "probes", "unknown option",
                         "render.options.lights", "render.options.lights", "light_threshold"};
    int i;
    for (i = 0; i < 10; i++) {
        const char *ov[2] = {"render.method=shgrid", bad[i]};
        vsd_scene sc;
        vsd_renderer *r = NULL;
        char err[1024] = "";
        if (!load_scene("{\"version\":1,\"volume\":{\"file\":\"x.vdb\"}}", ov, 2, &sc)) continue;
        CHECK(vsd_renderer_create(&sc, NULL, &r, err, sizeof err) != VSD_OK);
        CHECK_CONTAINS(err, msg[i]);
        vsd_renderer_destroy(r);
    }
}

/* view_bake (issue 32): with an anisotropic phase the CPU view bakes each record's SH and
 * lights' term toward the camera once per view, the phase at the camera-to-record
 * direction instead of each ray's. smoke64 frame 24 at g 0.6 (the RGB records) and 96x54:
 * the two forms agree within 0.5% (measured 2026-12-06: Combined 0.00019, VolumeDir
 * 0.00078). The control: baked at g -0.6, which is the phase at g 0.6 toward the opposite
 * direction (HG(-g, cos) = HG(g, -cos)), i.e. a bake that looked the wrong way, is off the
 * per-ray view by 5.1 (bound: above 0.05). With an orthographic camera every ray looks
 * along the camera's axis, which is then the bake's direction for every record: the two
 * views must agree bit for bit (while in perspective they must not: the bake ran). */
static void test_view_bake(void)
{
    const char *base[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54", "render.method=shgrid",
                          "medium.anisotropy=0.6", "render.options.view_bake=false"};
    const char *flipped[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54",
                             "render.method=shgrid", "medium.anisotropy=-0.6"};
    vsd_framebuffer *ray = render_file("scenes/smoke64_sunset.json", base, 7, 24);
    vsd_framebuffer *baked = render_file("scenes/smoke64_sunset.json", base, 6, 24);
    vsd_framebuffer *back = render_file("scenes/smoke64_sunset.json", flipped, 6, 24);
    if (ray && baked && back) {
        double c = test_rel_err(baked, ray, VSD_PASS_COMBINED), d = test_rel_err(baked, ray, VSD_PASS_VOLUME_DIR);
        double b = test_rel_err(back, ray, VSD_PASS_VOLUME_DIR);
        printf("[view_bake] g 0.6, baked against per ray: Combined %.5f, VolumeDir %.5f; g -0.6 baked: %.4f\n", c, d, b);
        CHECK_MSG(c < 0.005 && d < 0.005, "baked view off the per-ray view: Combined %.4f, VolumeDir %.4f", c, d);
        CHECK_MSG(b > 0.05, "the phase turned round changed VolumeDir by only %.4f: the check cannot fail", b);
        /* and the bake ran: in perspective its directions are not the rays' (else the
           orthographic identity below would say nothing) */
        CHECK_MSG(!test_identical(baked, ray), "perspective: baked and per ray bit for bit equal: no bake ran");
    }
    vsd_framebuffer_destroy(ray);
    vsd_framebuffer_destroy(baked);
    vsd_framebuffer_destroy(back);
    {
        const char *ortho[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54",
                               "render.method=shgrid", "medium.anisotropy=0.6", "camera.type=orthographic",
                               "camera.ortho_scale=2.5", "render.options.view_bake=false"};
        vsd_framebuffer *o_ray = render_file("scenes/smoke64_sunset.json", ortho, 9, 24);
        vsd_framebuffer *o_baked = render_file("scenes/smoke64_sunset.json", ortho, 8, 24);
        if (o_ray && o_baked) {
            printf("[view_bake] orthographic: baked and per ray %s\n",
                   test_identical(o_ray, o_baked) ? "bit for bit the same" : "DIFFER");
            CHECK_MSG(test_identical(o_ray, o_baked), "orthographic camera: the baked view differs from the per-ray one");
            CHECK_MSG(test_pass_sum(o_baked, VSD_PASS_VOLUME_DIR) > 0.0, "orthographic view: no light at all");
        }
        vsd_framebuffer_destroy(o_ray);
        vsd_framebuffer_destroy(o_baked);
    }
}

int main(void)
{
    test_options();
    test_view_bake();
    test_thin_box();
    test_sun_box();
    test_cache();
    test_against_reference();
    test_convergence();
    return test_finish("test_shgrid");
}
