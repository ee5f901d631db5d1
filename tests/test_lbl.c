/* test_lbl.c — method `lbl` (Bernabei et al. 2012, without refraction yet) end to end:
 *   1. smoke64 frame 24 against `reference` (2 x 1024 spp: the noise floor is measured, and
 *      the tolerances must sit above 3x it), Combined / VolumeDir / VolumeInd, with the
 *      negative controls failing the same Combined tolerance;
 *   2. the homogeneous ball under a uniform map against `reference`, the same way;
 *   3. a lighting edit (environment rotation) solves from the last lattice state: fewer
 *      steps than a cold solve, and the image of a fresh renderer of the edited scene within
 *      the diffusion's own tolerance;
 *   4. option errors and an empty grid;
 *   5. emission scattered once is VolumeDir, as in `reference` and Cycles: fire96 frame 48
 *      in a black world, where all scattered light is emission's, VolumeDir and VolumeInd
 *      each against the reference's (putting it all in VolumeInd, as lbl did before, scores
 *      VolumeDir 1.0).
 *   6. marching and diffusion overlapped in rounds of a ray history (option `history`): the
 *      ball under the map and a point, a spot and a sun, the same image as marching first
 *      (VolumeDir to float rounding, VolumeInd to the diffusion's tolerance), in several
 *      rounds with 8 lattice steps each.
 *   7. the phase on the lattice (collisions, first scattering, readout) in a
 *      forward-scattering ball (g 0.7) lit by a sun from behind in a black world: VolumeInd
 *      against `reference`; the paper's isotropic lattice, the control, must fail.
 * The tolerances are ~1.5x the errors measured when this was written (printed on every run). */
#include "test_common.h"
#include "test_render_util.h"
#include "src/common/clock.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SMOKE "scenes/smoke64_sunset.json"
/* smoke64 frame 24 at 96x54: measured lbl Combined 0.036, VolumeDir 0.034, VolumeInd 0.107
 * against reference 1024 spp (noise 0.014 / 0.034 / 0.040; 0.0335 for VolumeDir since the
 * map is read with linear interpolation); VolumeDir's tolerance is set by the noise (3x),
 * as test_crm's. (Before the box-shaped cells, the exact deposit and the surface escape:
 * 0.042 / 0.034 / 0.140.) */
#define TOL_COMBINED 0.055
#define TOL_DIR 0.11
#define TOL_IND 0.16
/* the ball at 32x32: measured lbl Combined 0.018, VolumeDir 0.037, VolumeInd 0.022 (before:
 * 0.032 / 0.037 / 0.070); VolumeInd's tolerance is 3x the reference noise (0.011) */
#define BALL_TOL_COMBINED 0.03
#define BALL_TOL_DIR 0.05
#define BALL_TOL_IND 0.04
/* the backlit ball (part 7): measured VolumeInd 0.116 with the phase (reference noise 0.031),
 * 1.04 with the paper's isotropic lattice (its mean 4.5x too dark) */
#define TOL_READOUT 0.17

static void compare(const char *what, const vsd_framebuffer *lbl, const vsd_framebuffer *ref,
                    const vsd_framebuffer *ref2, const double tol[3])
{
    static const vsd_pass passes[3] = {VSD_PASS_COMBINED, VSD_PASS_VOLUME_DIR, VSD_PASS_VOLUME_IND};
    static const char *const names[3] = {"Combined", "VolumeDir", "VolumeInd"};
    int k;
    for (k = 0; k < 3; k++) {
        double e = test_rel_err(lbl, ref, passes[k]), noise = test_rel_err(ref2, ref, passes[k]);
        printf("    %s %s: lbl %.4f, reference noise %.4f, tolerance %.3f\n", what, names[k], e, noise, tol[k]);
        CHECK_MSG(e < tol[k], "%s %s: %.4f >= %.3f", what, names[k], e, tol[k]);
        CHECK_MSG(tol[k] > 3.0 * noise, "%s %s: noise %.4f too close to the tolerance %.3f", what, names[k], noise,
                  tol[k]);
    }
    test_check_pass_sum(what, lbl);
    test_check_controls(what, lbl, ref, tol[0]);
}

static void test_smoke(void)
{
    const char *ref_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54",
                            "render.method=reference", "render.samples=1024", "render.seed=1"};
    const char *ref2_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54",
                             "render.method=reference", "render.samples=1024", "render.seed=7"};
    const char *lbl_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54", "render.method=lbl"};
    const double tol[3] = {TOL_COMBINED, TOL_DIR, TOL_IND};
    vsd_scene ref_sc, ref2_sc, lbl_sc;
    vsd_framebuffer *ref = NULL, *ref2 = NULL, *lbl = NULL;
    vsd_render_stats st;
    double t0 = vsd_clock_seconds();
    if (!test_load_scene(SMOKE, ref_ov, 7, &ref_sc) || !test_load_scene(SMOKE, ref2_ov, 7, &ref2_sc) ||
        !test_load_scene(SMOKE, lbl_ov, 5, &lbl_sc))
        return;
    ref = test_render_fresh(&ref_sc, NULL, NULL, NULL, 24, NULL);
    ref2 = test_render_fresh(&ref2_sc, NULL, NULL, NULL, 24, NULL);
    lbl = test_render_fresh(&lbl_sc, NULL, NULL, NULL, 24, &st);
    printf("[1] smoke64 frame 24, 96x54: %.1fs; lbl: %s\n", vsd_clock_seconds() - t0, lbl ? st.method_info : "-");
    if (ref && ref2 && lbl) {
        CHECK_MSG(test_info(&st, "diffusion_converged") == 1, "the diffusion did not converge: %s", st.method_info);
        compare("smoke64", lbl, ref, ref2, tol);
    }
    vsd_framebuffer_destroy(ref);
    vsd_framebuffer_destroy(ref2);
    vsd_framebuffer_destroy(lbl);
}

static void test_ball(void)
{
    const char *ref_ov[] = {"render.method=reference", "render.samples=2048", "render.seed=1"};
    const char *ref2_ov[] = {"render.method=reference", "render.samples=2048", "render.seed=5"};
    const char *lbl_ov[] = {"render.method=lbl"};
    const double tol[3] = {BALL_TOL_COMBINED, BALL_TOL_DIR, BALL_TOL_IND};
    vsd_volume *vol = test_ball_volume();
    vsd_scene ref_sc, ref2_sc, lbl_sc;
    vsd_framebuffer *ref = NULL, *ref2 = NULL, *lbl = NULL;
    if (!vol || !test_parse_scene(test_ball_json, ref_ov, 3, &ref_sc) ||
        !test_parse_scene(test_ball_json, ref2_ov, 3, &ref2_sc) || !test_parse_scene(test_ball_json, lbl_ov, 1, &lbl_sc)) {
        vsd_volume_destroy(vol);
        return;
    }
    ref = test_render_fresh(&ref_sc, NULL, vol, NULL, 1, NULL);
    ref2 = test_render_fresh(&ref2_sc, NULL, vol, NULL, 1, NULL);
    lbl = test_render_fresh(&lbl_sc, NULL, vol, NULL, 1, NULL);
    printf("[2] homogeneous ball, uniform map\n");
    if (ref && ref2 && lbl) compare("ball", lbl, ref, ref2, tol);
    vsd_framebuffer_destroy(ref);
    vsd_framebuffer_destroy(ref2);
    vsd_framebuffer_destroy(lbl);
    vsd_volume_destroy(vol);
}

static void test_edit(void)
{
    const char *ov[] = {"frames.start=24", "frames.end=24", "film.width=48", "film.height=27", "render.method=lbl"};
    vsd_scene sc;
    vsd_renderer *r;
    vsd_framebuffer *fb = NULL, *fresh = NULL;
    vsd_render_stats st;
    char err[1024] = "";
    double cold_steps, warm_steps;
    if (!test_load_scene(SMOKE, ov, 5, &sc) || !(r = test_make_renderer(&sc, NULL))) return;
    if (!test_render(r, 24, &fb, &st)) goto done;
    cold_steps = test_info(&st, "diffusion_steps");
    sc.environment.rotation_z += 0.5f;
    CHECK(vsd_renderer_set_scene(r, &sc, err, sizeof err) == VSD_OK);
    if (!test_render(r, 24, &fb, &st)) goto done;
    warm_steps = test_info(&st, "diffusion_steps");
    fresh = test_render_fresh(&sc, NULL, NULL, NULL, 24, NULL);
    printf("[3] environment rotation: diffusion steps cold %g, warm %g\n", cold_steps, warm_steps);
    CHECK_MSG(warm_steps < cold_steps, "the warm start took %g steps, the cold solve %g", warm_steps, cold_steps);
    if (fresh) {
        /* both stop at the probes' 1e-3 relative change: VolumeInd agrees to about that */
        double d = test_rel_err(fb, fresh, VSD_PASS_VOLUME_IND), c = test_rel_err(fb, fresh, VSD_PASS_VOLUME_DIR);
        printf("    warm vs fresh renderer: VolumeInd %.5f, VolumeDir %.5f\n", d, c);
        CHECK_MSG(d < 0.01, "warm-started VolumeInd differs from a fresh solve by %.4f", d);
        CHECK_MSG(c < 1e-6, "VolumeDir differs from a fresh renderer by %g", c);
    }
done:
    vsd_framebuffer_destroy(fb);
    vsd_framebuffer_destroy(fresh);
    vsd_renderer_destroy(r);
}

static void expect_option_error(const char *opt, const char *needle)
{
    const char *ov[] = {"frames.start=24", "frames.end=24", "render.method=lbl", opt};
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_render_options o;
    char err[1024] = "";
    if (!test_load_scene(SMOKE, ov, 4, &sc)) return;
    memset(&o, 0, sizeof o);
    CHECK_MSG(vsd_renderer_create(&sc, &o, &r, err, sizeof err) != VSD_OK, "%s accepted", opt);
    CHECK_CONTAINS(err, needle);
    vsd_renderer_destroy(r);
}

static void test_options_and_empty(void)
{
    const int32_t dims[3] = {8, 8, 8}, lo[3] = {0, 0, 0};
    float zeros[512] = {0};
    const char *ov[] = {"render.method=lbl"};
    vsd_volume *empty = NULL;
    vsd_scene sc;
    vsd_framebuffer *fb;
    expect_option_error("render.options.lights=65", "render.options.lights");
    expect_option_error("render.options.cells=2", "render.options.cells");
    expect_option_error("render.options.ray_spacing=2", "render.options.ray_spacing");
    expect_option_error("render.options.no_such=1", "no_such");
    /* an empty grid renders the background only */
    CHECK(vsd_volume_create_dense(zeros, dims, lo, NULL, &empty, NULL, 0) == VSD_OK);
    if (empty && test_parse_scene(test_ball_json, ov, 1, &sc) && (fb = test_render_fresh(&sc, NULL, empty, NULL, 1, NULL))) {
        size_t i, n = (size_t)fb->width * fb->height;
        double tmin = 1.0, vmax = 0.0;
        for (i = 0; i < n; i++) {
            tmin = fmin(tmin, fb->pass[VSD_PASS_TRANSMITTANCE][i]);
            vmax = fmax(vmax, fb->pass[VSD_PASS_VOLUME_DIR][3 * i] + fb->pass[VSD_PASS_VOLUME_IND][3 * i]);
        }
        printf("[4] empty grid: min Transmittance %g, max scattered %g\n", tmin, vmax);
        CHECK(tmin == 1.0 && vmax == 0.0);
        vsd_framebuffer_destroy(fb);
    }
    vsd_volume_destroy(empty);
}

/* fire96 in a black world at 64x36 against 256 spp: measured lbl VolumeDir 0.102 and VolumeInd
 * 0.203, means +0.2% / +3.7% (before the surface escape: 0.144 / 0.393, +2.9% / +11.1%; with
 * cell_light "faces": 0.216 / 0.339, +5.5% / +9.0%) */
static void test_emission_split(void) { test_check_emission_split("[5]", "lbl", 0.16, 0.3, 0.1, 0.1); }

static void test_history(void)
{
#define LIGHTS                                                                                                         \
    "lights=[{\"type\":\"point\",\"power\":300,\"position\":[3,-1,2.5]},"                                          \
    "{\"type\":\"spot\",\"power\":600,\"position\":[-1.5,1,1],\"direction\":[1,0,0.1],\"spot_size\":0.6,"     \
    "\"spot_blend\":0.3},{\"type\":\"sun\",\"strength\":2,\"direction\":[0.3,0.4,-0.866]}]"
    const char *seq_ov[] = {LIGHTS, "render.method=lbl", "render.options.history=0"};
    const char *ov[] = {LIGHTS, "render.method=lbl", "render.options.history=4"};
#undef LIGHTS
    vsd_volume *vol = test_ball_volume();
    vsd_scene seq_sc, sc;
    vsd_framebuffer *seq = NULL, *fb = NULL;
    vsd_render_stats st;
    if (!vol || !test_parse_scene(test_ball_json, seq_ov, 3, &seq_sc) || !test_parse_scene(test_ball_json, ov, 3, &sc))
        goto done;
    seq = test_render_fresh(&seq_sc, NULL, vol, NULL, 1, NULL);
    fb = test_render_fresh(&sc, NULL, vol, NULL, 1, &st);
    if (seq && fb) {
        double rounds = test_info(&st, "history_rounds"), during = test_info(&st, "history_steps");
        double dir = test_rel_err(fb, seq, VSD_PASS_VOLUME_DIR), ind = test_rel_err(fb, seq, VSD_PASS_VOLUME_IND);
        printf("[6] ray history of 4 steps: %g rounds, %g lattice steps during the march; against marching first: "
               "VolumeDir %.2g, VolumeInd %.2g\n",
               rounds, during, dir, ind);
        CHECK_MSG(rounds >= 4 && during == 8 * rounds, "%g rounds, %g lattice steps during them", rounds, during);
        CHECK_MSG(dir < 1e-4, "VolumeDir moved by %.3g with the overlap", dir);
        /* both solves stop at the probes' 1e-3 relative change still to come */
        CHECK_MSG(ind < 0.01, "VolumeInd differs from marching first by %.4f", ind);
    }
done:
    vsd_framebuffer_destroy(seq);
    vsd_framebuffer_destroy(fb);
    vsd_volume_destroy(vol);
}

static void test_readout(void)
{
#define BACKLIT "environment.color=[0,0,0]", "medium.anisotropy=0.7", "medium.albedo=[0.95,0.95,0.95]", \
        "lights=[{\"type\":\"sun\",\"strength\":3,\"direction\":[0.3,-0.9,0.3]}]"
    const char *ref_ov[] = {BACKLIT, "render.method=reference", "render.samples=1024", "render.seed=1"};
    const char *ref2_ov[] = {BACKLIT, "render.method=reference", "render.samples=1024", "render.seed=5"};
    const char *phase_ov[] = {BACKLIT, "render.method=lbl", "render.options.readout=phase"};
    const char *iso_ov[] = {BACKLIT, "render.method=lbl", "render.options.readout=isotropic",
                            "render.options.lattice_phase=isotropic"};
#undef BACKLIT
    vsd_volume *vol = test_ball_volume();
    vsd_scene sc[4];
    vsd_framebuffer *ref = NULL, *ref2 = NULL, *phase = NULL, *iso = NULL;
    if (!vol || !test_parse_scene(test_ball_json, ref_ov, 7, &sc[0]) || !test_parse_scene(test_ball_json, ref2_ov, 7, &sc[1]) ||
        !test_parse_scene(test_ball_json, phase_ov, 6, &sc[2]) || !test_parse_scene(test_ball_json, iso_ov, 7, &sc[3]))
        goto done;
    ref = test_render_fresh(&sc[0], NULL, vol, NULL, 1, NULL);
    ref2 = test_render_fresh(&sc[1], NULL, vol, NULL, 1, NULL);
    phase = test_render_fresh(&sc[2], NULL, vol, NULL, 1, NULL);
    iso = test_render_fresh(&sc[3], NULL, vol, NULL, 1, NULL);
    if (ref && ref2 && phase && iso) {
        double e = test_rel_err(phase, ref, VSD_PASS_VOLUME_IND), c = test_rel_err(iso, ref, VSD_PASS_VOLUME_IND);
        double noise = test_rel_err(ref2, ref, VSD_PASS_VOLUME_IND);
        printf("[7] backlit ball, g 0.7: VolumeInd with the phase %.4f, the paper's isotropic lattice %.4f, reference noise %.4f "
               "(means %.4g / %.4g / %.4g)\n",
               e, c, noise, test_pass_sum(phase, VSD_PASS_VOLUME_IND), test_pass_sum(iso, VSD_PASS_VOLUME_IND),
               test_pass_sum(ref, VSD_PASS_VOLUME_IND));
        CHECK_MSG(e < TOL_READOUT, "VolumeInd with the phase %.4f >= %.2f", e, TOL_READOUT);
        CHECK_MSG(c > TOL_READOUT, "the isotropic lattice (%.4f) passes the tolerance the phase must meet", c);
        CHECK_MSG(TOL_READOUT > 3 * noise, "reference noise %.4f too close to the tolerance", noise);
    }
done:
    vsd_framebuffer_destroy(ref);
    vsd_framebuffer_destroy(ref2);
    vsd_framebuffer_destroy(phase);
    vsd_framebuffer_destroy(iso);
    vsd_volume_destroy(vol);
}

int main(void)
{
    test_readout();
    test_history();
    test_emission_split();
    test_smoke();
    test_ball();
    test_edit();
    test_options_and_empty();
    return test_finish("test_lbl");
}
