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
 * The comparisons with `reference` go through common/method_vs_reference.h; the tolerances
 * are ~1.5x the errors measured when this was written (printed on every run). */
#include "test_common.h"
#include "test_render_util.h"
#include "method_vs_reference.h"
#include "src/common/clock.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SMOKE "scenes/smoke64_sunset.json"
/* Through the harness (common/method_vs_reference.h): lbl against the mean of two reference
 * seeds, its noise (half their difference) measured in the same run and under a third of
 * each tolerance, controls that must fail. Measured 2026-12-03 on the CPU path.
 * smoke64 frame 24 at 96x54, 2 x 1024 spp: lbl Combined 0.0364, VolumeDir 0.0342, VolumeInd
 * 0.1071; noise of the mean 0.0070 / 0.0168 / 0.0201 (3x: 0.021 / 0.050 / 0.060); controls
 * on Combined 0.651 / 0.320 / 1.312. VolumeDir's tolerance was 0.11, set by 3x the two seeds'
 * difference against one of them (2x the mean's noise); now 1.6x its error. (Before the
 * box-shaped cells, the exact deposit and the surface escape: 0.042 / 0.034 / 0.140.) */
#define TOL_COMBINED 0.055
#define TOL_DIR 0.055
#define TOL_IND 0.16
/* the ball at 32x32, 2 x 2048 spp: lbl Combined 0.0172, VolumeDir 0.0351, VolumeInd 0.0229
 * (before: 0.032 / 0.037 / 0.070); noise of the mean 0.0028 / 0.0058 / 0.0061; controls on
 * Combined 0.599 / 0.300 / 1.003. VolumeInd's tolerance was 0.04 (3x the old noise 0.011),
 * now 1.5x its error. */
#define BALL_TOL_COMBINED 0.03
#define BALL_TOL_DIR 0.05
#define BALL_TOL_IND 0.035
/* the backlit ball (part 7), 2 x 1024 spp: VolumeInd 0.1295 with the phase and the first
 * flight (lbl_first_flight.h; its mean 0.92x the reference's; noise of the mean 0.0196, 3x
 * 0.059), 1.041 with the paper's isotropic lattice (its mean 4.5x too dark). The lattice's
 * first leg along the axes had 0.0806 here, but 8.5-22.8% where the first flight has 3.6-6.7%
 * on the low-albedo and thin smokes (docs/methods/lbl.md, "The first flight"): the cone's
 * births spread by solid angle over its vectors carry a sun's forward lobe sideways. Spread by
 * the lights' phase instead (tried): 0.1157 here, but cloud256 10.7% against 9.4%. It was
 * 0.1135 while delta-M's lattice let light escape its surface as the unscaled medium would
 * (lbl_escape.h, "The escape through the scaled medium"). */
#define TOL_READOUT 0.14

/* scale of the pass-scaled control per pass (Combined, VolumeDir, VolumeInd) */
static const double control_scale[3] = {0.8, 0.8, 0.7};

static void compare(const char *what, const vsd_framebuffer *lbl, const mvr_refs *refs, const double tol[3])
{
    static const vsd_pass passes[3] = {VSD_PASS_COMBINED, VSD_PASS_VOLUME_DIR, VSD_PASS_VOLUME_IND};
    int k;
    for (k = 0; k < 3; k++) mvr_check(what, lbl, refs, passes[k], tol[k], control_scale[k]);
    mvr_check_scattering_controls(what, lbl, refs, tol[0]);
}

static void test_smoke(void)
{
    const char *base_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54"};
    const char *lbl_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54", "render.method=lbl"};
    const double tol[3] = {TOL_COMBINED, TOL_DIR, TOL_IND};
    const mvr_scene smoke = {SMOKE, NULL, NULL, NULL, 24};
    mvr_refs refs;
    vsd_framebuffer *lbl = NULL;
    vsd_render_stats st;
    double t0 = vsd_clock_seconds();
    if (!mvr_render_references(&smoke, base_ov, 4, 1024, &refs)) {
        mvr_refs_free(&refs);
        return;
    }
    lbl = mvr_render(&smoke, lbl_ov, 5, NULL, &st);
    printf("[1] smoke64 frame 24, 96x54: %.1fs; lbl: %s\n", vsd_clock_seconds() - t0, lbl ? st.method_info : "-");
    CHECK(lbl != NULL);
    if (lbl) {
        CHECK_MSG(test_info(&st, "diffusion_converged") == 1, "the diffusion did not converge: %s", st.method_info);
        compare("smoke64 lbl", lbl, &refs, tol);
    }
    mvr_refs_free(&refs);
    vsd_framebuffer_destroy(lbl);
}

static void test_ball(void)
{
    const char *lbl_ov[] = {"render.method=lbl"};
    const double tol[3] = {BALL_TOL_COMBINED, BALL_TOL_DIR, BALL_TOL_IND};
    vsd_volume *vol = test_ball_volume();
    mvr_scene ball = {NULL, NULL, NULL, NULL, 1};
    mvr_refs refs;
    vsd_framebuffer *lbl = NULL;
    memset(&refs, 0, sizeof refs);
    ball.json = test_ball_json;
    ball.vol = vol;
    CHECK(vol != NULL);
    if (vol && mvr_render_references(&ball, NULL, 0, 2048, &refs)) {
        lbl = mvr_render(&ball, lbl_ov, 1, NULL, NULL);
        printf("[2] homogeneous ball, uniform map\n");
        CHECK(lbl != NULL);
        if (lbl) compare("ball lbl", lbl, &refs, tol);
    }
    mvr_refs_free(&refs);
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
    /* a density edit re-lights on the kept frame stage (density_in_lighting): the image a
       fresh renderer of the edited scene gives */
    vsd_framebuffer_destroy(fresh);
    fresh = NULL;
    sc.volumes[0].medium.density *= 1.25f;
    CHECK(vsd_renderer_set_scene(r, &sc, err, sizeof err) == VSD_OK);
    if (!test_render(r, 24, &fb, &st)) goto done;
    printf("[3b] density x1.25: frame stage %s, lighting stage %s\n", st.reframed ? "ran" : "kept",
           st.relit ? "ran" : "kept");
    CHECK_MSG(!st.reframed && st.relit, "a density edit: reframed %d, relit %d (want 0, 1)", st.reframed, st.relit);
    fresh = test_render_fresh(&sc, NULL, NULL, NULL, 24, NULL);
    if (fresh) {
        double d = test_rel_err(fb, fresh, VSD_PASS_VOLUME_IND), c = test_rel_err(fb, fresh, VSD_PASS_VOLUME_DIR);
        printf("    against a fresh renderer: VolumeInd %.5f, VolumeDir %.2g\n", d, c);
        CHECK_MSG(d < 0.01, "VolumeInd after a density edit differs from a fresh solve by %.4f", d);
        CHECK_MSG(c < 1e-6, "VolumeDir after a density edit differs from a fresh renderer by %g", c);
    }
    /* density 0 empties every cell: a frame stage of its own (the cells' emptiness is the
       frame's) */
    sc.volumes[0].medium.density = 0.0f;
    CHECK(vsd_renderer_set_scene(r, &sc, err, sizeof err) == VSD_OK);
    if (!test_render(r, 24, &fb, &st)) goto done;
    CHECK_MSG(st.reframed, "density 0 kept the frame stage of a non-empty medium");
    {
        const size_t k = (size_t)fb->width * fb->height * 3;
        float most = 0.0f;
        for (size_t i = 0; i < k; i++) most = fmaxf(most, fb->pass[VSD_PASS_VOLUME_DIR][i]);
        CHECK_MSG(most == 0.0f, "density 0 still scatters: VolumeDir up to %g", most);
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
    /* (a ray history marches the paper's rays: so does the sequential solve it is held to) */
    const char *seq_ov[] = {LIGHTS, "render.method=lbl", "render.options.history=0", "render.options.light_march=rays"};
    const char *ov[] = {LIGHTS, "render.method=lbl", "render.options.history=4"};
#undef LIGHTS
    vsd_volume *vol = test_ball_volume();
    vsd_scene seq_sc, sc;
    vsd_framebuffer *seq = NULL, *fb = NULL;
    vsd_render_stats st;
    if (!vol || !test_parse_scene(test_ball_json, seq_ov, 4, &seq_sc) || !test_parse_scene(test_ball_json, ov, 3, &sc))
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
    const char *ref_ov[] = {BACKLIT};
    const char *phase_ov[] = {BACKLIT, "render.method=lbl", "render.options.readout=phase"};
    const char *iso_ov[] = {BACKLIT, "render.method=lbl", "render.options.readout=isotropic",
                            "render.options.lattice_phase=isotropic"};
#undef BACKLIT
    vsd_volume *vol = test_ball_volume();
    mvr_scene ball = {NULL, NULL, NULL, NULL, 1};
    mvr_refs refs;
    vsd_framebuffer *phase = NULL, *iso = NULL;
    memset(&refs, 0, sizeof refs);
    ball.json = test_ball_json;
    ball.vol = vol;
    CHECK(vol != NULL);
    if (!vol || !mvr_render_references(&ball, ref_ov, 4, 1024, &refs)) goto done;
    phase = mvr_render(&ball, phase_ov, 6, NULL, NULL);
    iso = mvr_render(&ball, iso_ov, 7, NULL, NULL);
    CHECK(phase && iso);
    if (phase && iso) {
        double c;
        printf("[7] backlit ball, g 0.7 (VolumeInd means: phase %.4g, isotropic lattice %.4g, reference %.4g)\n",
               test_pass_sum(phase, VSD_PASS_VOLUME_IND), test_pass_sum(iso, VSD_PASS_VOLUME_IND),
               test_pass_sum(refs.mean, VSD_PASS_VOLUME_IND));
        mvr_check("backlit ball lbl", phase, &refs, VSD_PASS_VOLUME_IND, TOL_READOUT, 0.7);
        /* the control this part names: the paper's isotropic lattice */
        c = mvr_check_control("backlit ball lbl", "the paper's isotropic lattice", iso->pass[VSD_PASS_VOLUME_IND], &refs,
                              VSD_PASS_VOLUME_IND, TOL_READOUT);
        printf("    the paper's isotropic lattice: VolumeInd %.4f (tolerance %.2f)\n", c, TOL_READOUT);
    }
done:
    mvr_refs_free(&refs);
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
