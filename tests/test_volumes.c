/* test_volumes.c — scenes with several volumes (issue 30): the overlap rules against
 * single volumes they must equal, volumes shadowing each other, per-volume frames and
 * caches, and the errors of what does not render several volumes yet.
 *
 * Overlap as Cycles does it: extinction and scattering add, emission adds, the phase is the
 * scattering-weighted mixture. Two volumes on the same grid and transform therefore equal
 * one volume with the summed density, and a scattering volume overlapping a pure absorber
 * equals one volume whose albedo is the scattering fraction. Transmittance along a ray
 * through two volumes is the product of each one's. */
#include "test_common.h"
#include "vsd/vdbio.h"
#include "test_render_util.h"
#include "method_vs_reference.h"
#include "vsd/render.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SMOKE VSD_SHARED_DATA "/smoke64/fluid_data_####.vdb"
#define FIRE VSD_SHARED_DATA "/fire96/fluid_data_####.vdb"
#define SUNSET VSD_SHARED_DATA "/env/sunset.exr"
#define CLOUD VSD_SHARED_DATA "/cloud/cloud128.vdb"
#define STUDIO VSD_SHARED_DATA "/env/studio.exr"
#define FILM "\"film\": {\"width\": 64, \"height\": 36, \"transparent\": true}, "
#define CAMERA "\"camera\": {\"position\": [1.0, -3.9745, 1.8771], \"look_at\": [1.0, 1.0, 1.0], \"up\": [0, 0, 1], " \
               "\"fov\": 0.7}, "
#define ENV "\"environment\": {\"file\": \"" SUNSET "\"}, "

/* The scene around `volumes` (a JSON array's contents) at frame `frame`. */
static char *scene_json(const char *volumes, int frame)
{
    size_t n = strlen(volumes) + 1024;
    char *s = malloc(n);
    snprintf(s, n,
             "{\"version\": 1, \"volumes\": [%s], " ENV CAMERA FILM
             "\"render\": {\"method\": \"reference\", \"samples\": 16}, \"frames\": {\"start\": %d, \"end\": %d}}",
             volumes, frame, frame);
    return s;
}

/* Tolerances: each beside the measurement it rests on (64x36; 2-core VM, 2026-12-03). */
#define SUM_SPP 2048
#define TOL_SUM_COMBINED 0.045     /* 512 spp: error 0.0315, noise 0.0196: hence 2048 spp */
#define TOL_SUM_T 0.01             /* 512 spp: error 0.0008, noise 0.0007 */
#define MIX_SPP 1024
#define TOL_MIX 0.04               /* 512 spp: Combined error 0.0178 (noise 0.0095), Emit 0.0250 (0.0143) */
#define TOL_PRODUCT_T 0.03         /* 2048 spp: 512 gave error 0.0109, noise 0.0116 */

/* Two volumes on one grid with densities 3 and 5 render as one of density 8. */
static void test_summed_density(void)
{
    char *one = scene_json("{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 8}}", 11);
    char *two = scene_json("{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 3}}, "
                           "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 5}}", 11);
    mvr_scene s1 = {.json = one, .frame = 11}, s2 = {.json = two, .frame = 11};
    mvr_refs refs;
    const char *ov[] = {"render.samples=2048"};
    if (mvr_render_references(&s1, NULL, 0, SUM_SPP, &refs)) {
        vsd_framebuffer *fb = mvr_render(&s2, ov, 1, NULL, NULL);
        CHECK(fb != NULL);
        if (fb) {
            mvr_check("density 3 + 5 vs 8", fb, &refs, VSD_PASS_COMBINED, TOL_SUM_COMBINED, 0.8);
            mvr_check("density 3 + 5 vs 8", fb, &refs, VSD_PASS_TRANSMITTANCE, TOL_SUM_T, 0.8);
        }
        vsd_framebuffer_destroy(fb);
        mvr_refs_free(&refs);
    }
    free(one);
    free(two);
}

/* A scattering volume (density 4, albedo 0.9/0.6/0.3, g 0.5, emission 2) overlapping a pure
 * absorber on the same grid (density 2, albedo 0, emission 3) is one volume of density 6,
 * albedo 0.6/0.4/0.2 (the scattering fraction), g 0.5 (the absorber has no lobe to mix)
 * and emission 5: the albedo and phase mixture and the emission sum in one check. */
static void test_material_mixture(void)
{
    char *one = scene_json("{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 6, "
                           "\"albedo\": [0.6, 0.4, 0.2], \"anisotropy\": 0.5, \"emission_strength\": 5}}",
                           48);
    char *two = scene_json("{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 4, "
                           "\"albedo\": [0.9, 0.6, 0.3], \"anisotropy\": 0.5, \"emission_strength\": 2}}, "
                           "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 2, "
                           "\"albedo\": [0, 0, 0], \"anisotropy\": -0.7, \"emission_strength\": 3}}",
                           48);
    mvr_scene s1 = {.json = one, .frame = 48}, s2 = {.json = two, .frame = 48};
    mvr_refs refs;
    const char *ov[] = {"render.samples=1024"};
    if (mvr_render_references(&s1, NULL, 0, MIX_SPP, &refs)) {
        vsd_framebuffer *fb = mvr_render(&s2, ov, 1, NULL, NULL);
        CHECK(fb != NULL);
        if (fb) {
            mvr_check("scatterer + absorber vs mixture", fb, &refs, VSD_PASS_COMBINED, TOL_MIX, 0.8);
            mvr_check("scatterer + absorber vs mixture", fb, &refs, VSD_PASS_EMIT, TOL_MIX, 0.8);
        }
        vsd_framebuffer_destroy(fb);
        mvr_refs_free(&refs);
    }
    free(one);
    free(two);
}

/* raymarch, lbl, shgrid, constellation and crm are deterministic: where two volumes' grids coincide they must
 * give the single volume's image to float rounding (sums of the same samples in another
 * order). For raymarch also the scatterer + absorber mixture with its emission; for lbl,
 * whose parts each light the group with their own material (docs/design-notes.md, "Several
 * volumes"), two halves of one material, the flame's emission split between them, and the
 * scatterer + absorber (each cell of a part's lattice scatters with the mixture's albedo,
 * the absorber's lobe weighs nothing: albedo 0); shgrid's
 * parts march their records through both halves (the product form: g = 0.4);
 * constellation's cached shadows cross their own half by the paper's rays and the other
 * by a plain march (the same voxel step), whose product is the whole's transmittance; crm's
 * parts put every volume's medium on their nodes (crm_parts.h), so halves are exact, and
 * the scatterer + absorber's multiple scattering too (the orders scatter each node's mixed
 * albedo); its single scattering is exact at the nodes, but the view blends each part's in
 * log space between them (crm_kernel.h), and a sum of geometric blends is not the blend of
 * the sum: measured 9.1e-4 on VolumeDir (2.6e-4 Combined), the case's own bound 2e-3. */
static void test_deterministic_exact(void)
{
    static const char *const raymarch[] = {"render.method=raymarch", "render.options.lights=16"};
    static const char *const lbl[] = {"render.method=lbl", "render.options.cells=32"};
    static const char *const shgrid[] = {"render.method=shgrid", "render.options.grid=32"};
    static const char *const constellation[] = {"render.method=constellation", "render.options.lights=16"};
    static const char *const crm[] = {"render.method=crm", "render.options.node_spacing=2"};
    struct { const char *method, *what, *one, *two; int frame; const char *const *ov; double tol; } cases[] = {
        {"raymarch", "density 3 + 5 vs 8", "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 8}}",
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 3}}, {\"file\": \"" SMOKE "\", \"medium\": {\"density\": 5}}",
         11, raymarch, 0},
        {"raymarch", "scatterer + absorber vs mixture",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 6, \"albedo\": [0.6, 0.4, 0.2], "
         "\"anisotropy\": 0.5, \"emission_strength\": 5}}",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 4, \"albedo\": [0.9, 0.6, 0.3], "
         "\"anisotropy\": 0.5, \"emission_strength\": 2}}, {\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", "
         "\"medium\": {\"density\": 2, \"albedo\": [0, 0, 0], \"anisotropy\": -0.7, \"emission_strength\": 3}}",
         48, raymarch, 0},
        {"lbl", "density 3 + 5 vs 8", "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 8, \"anisotropy\": 0.4}}",
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 3, \"anisotropy\": 0.4}}, "
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 5, \"anisotropy\": 0.4}}",
         11, lbl, 0},
        {"lbl", "emission 2 + 3 vs 5",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 6, \"albedo\": [0.9, 0.6, 0.3], "
         "\"emission_strength\": 5}}",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 4, \"albedo\": [0.9, 0.6, 0.3], "
         "\"emission_strength\": 2}}, {\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", "
         "\"medium\": {\"density\": 2, \"albedo\": [0.9, 0.6, 0.3], \"emission_strength\": 3}}",
         48, lbl, 0},
        {"lbl", "scatterer + absorber vs mixture",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 6, \"albedo\": [0.6, 0.4, 0.2], "
         "\"anisotropy\": 0.5, \"emission_strength\": 5}}",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 4, \"albedo\": [0.9, 0.6, 0.3], "
         "\"anisotropy\": 0.5, \"emission_strength\": 2}}, {\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", "
         "\"medium\": {\"density\": 2, \"albedo\": [0, 0, 0], \"anisotropy\": -0.7, \"emission_strength\": 3}}",
         48, lbl, 0},
        {"shgrid", "density 3 + 5 vs 8", "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 8, \"anisotropy\": 0.4}}",
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 3, \"anisotropy\": 0.4}}, "
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 5, \"anisotropy\": 0.4}}",
         11, shgrid, 0},
        {"constellation", "density 3 + 5 vs 8",
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 8, \"anisotropy\": 0.4}}",
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 3, \"anisotropy\": 0.4}}, "
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 5, \"anisotropy\": 0.4}}",
         11, constellation, 0},
        {"crm", "density 3 + 5 vs 8", "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 8, \"anisotropy\": 0.4}}",
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 3, \"anisotropy\": 0.4}}, "
         "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 5, \"anisotropy\": 0.4}}",
         11, crm, 0},
        {"crm", "emission 2 + 3 vs 5",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 6, \"albedo\": [0.9, 0.6, 0.3], "
         "\"emission_strength\": 5}}",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 4, \"albedo\": [0.9, 0.6, 0.3], "
         "\"emission_strength\": 2}}, {\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", "
         "\"medium\": {\"density\": 2, \"albedo\": [0.9, 0.6, 0.3], \"emission_strength\": 3}}",
         48, crm, 0},
        {"crm", "scatterer + absorber vs mixture",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 6, \"albedo\": [0.6, 0.4, 0.2], "
         "\"emission_strength\": 5}}",
         "{\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 4, \"albedo\": [0.9, 0.6, 0.3], "
         "\"emission_strength\": 2}}, {\"file\": \"" FIRE "\", \"emission_grid\": \"flame\", "
         "\"medium\": {\"density\": 2, \"albedo\": [0, 0, 0], \"emission_strength\": 3}}",
         48, crm, 2e-3},
    };
    static const vsd_pass passes[] = {VSD_PASS_COMBINED, VSD_PASS_VOLUME_DIR, VSD_PASS_VOLUME_IND, VSD_PASS_EMIT,
                                      VSD_PASS_TRANSMITTANCE};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char *j1 = scene_json(cases[c].one, cases[c].frame), *j2 = scene_json(cases[c].two, cases[c].frame);
        vsd_scene s1, s2;
        int ms = !strcmp(cases[c].method, "lbl") || !strcmp(cases[c].method, "crm"), emits = strstr(cases[c].one, "flame") != NULL;
        CHECK(test_parse_scene(j1, cases[c].ov, 2, &s1) && test_parse_scene(j2, cases[c].ov, 2, &s2));
        vsd_framebuffer *f1 = test_render_fresh(&s1, NULL, NULL, NULL, cases[c].frame, NULL);
        vsd_framebuffer *f2 = test_render_fresh(&s2, NULL, NULL, NULL, cases[c].frame, NULL);
        CHECK(f1 && f2);
        for (size_t p = 0; f1 && f2 && p < sizeof passes / sizeof passes[0]; p++) {
            double diff = test_max_rel_diff(f2, f1, passes[p]), sum = test_pass_sum(f1, passes[p]);
            int expect_zero = (passes[p] == VSD_PASS_EMIT && !emits) || (passes[p] == VSD_PASS_VOLUME_IND && !ms);
            printf("%s %s, %s: max relative difference %.2e (pass sum %.4g)\n", cases[c].method, cases[c].what,
                   vsd_pass_name(passes[p]), diff, sum);
            CHECK(diff < (cases[c].tol > 0 ? cases[c].tol : 1e-4));
            CHECK(expect_zero ? sum == 0 : sum > 0);
        }
        vsd_framebuffer_destroy(f1), vsd_framebuffer_destroy(f2);
        free(j1), free(j2);
    }
}

/* The issue-30 scene (tests/cycles/test_cycles_crosscheck.c "volumes") from its smoke on: the
 * smoke overlapping the fire's top, the cloud above, the map, camera and a 96x54 film. */
#define ISSUE30_SMOKE_CLOUD_REST \
    "{\"file\": \"" SMOKE "\", \"grid\": \"density\", \"frame_offset\": -24, " \
    "\"matrix\": [1,0,0,0.7, 0,1,0,0, 0,0,1,0.5, 0,0,0,1], " \
    "\"medium\": {\"density\": 12.0, \"albedo\": [0.9, 0.85, 0.8], \"anisotropy\": 0.3}}, " \
    "{\"file\": \"" CLOUD "\", \"grid\": \"density\", \"matrix\": [1,0,0,1.2, 0,1,0,1.0, 0,0,1,3.4, 0,0,0,1], " \
    "\"medium\": {\"density\": 3.0, \"albedo\": [0.97, 0.97, 0.97], \"anisotropy\": 0.6}}], " \
    "\"environment\": {\"file\": \"" STUDIO "\"}, " \
    "\"camera\": {\"position\": [-2.9, -10.2, 2.3], \"look_at\": [1.2, 1.0, 1.9], \"up\": [0, 0, 1], \"fov\": 0.7}, " \
    "\"film\": {\"width\": 96, \"height\": 54, \"transparent\": true}, " \
    "\"render\": {\"method\": \"reference\", \"samples\": 16}, \"frames\": {\"start\": 48, \"end\": 48}}"

/* lbl on the issue's three-volume scene (the Cycles cross-check's "volumes": a fire, a smoke
 * overlapping it, a cloud above them; tests/cycles/test_cycles_crosscheck.c) against
 * `reference`, 96x54 with 4x4 rays per pixel (the volumes are a few pixels wide: one ray
 * per pixel centre puts Emit 17 % off at the edges). Measured (2-core VM, 2026-12-04) with
 * `vsd compare` against 8192 spp: Combined (RGB) 0.089 (0.096 without delta-M on the
 * lattice, 0.127 before the groups sent each other light, lbl_exchange.h; 0.163 before the
 * lattice took each cell's mixed albedo), VolumeDir 0.087, VolumeInd 0.146 (0.225 before
 * the exchange), Emit 0.022, Transmittance 0.0005; lbl
 * alone on each volume (128x72): fire 0.067, smoke 0.132, cloud 0.179. The issue's target,
 * 12 %, is met; what is left is lbl's single-volume accuracy on the cloud (docs/methods/
 * lbl.md, "Several volumes"). This harness scores Combined with its alpha (RGBA, as every
 * mvr check): 0.057 here (0.060 without delta-M, 0.080 without the exchange), against the mean
 * of 2 x 2048 spp (noise 0.009). The tolerances keep what was measured, with a margin for
 * the noise; Combined's fails lbl without the exchange. */
#define LBL3_SPP 2048
#define TOL_LBL3_COMBINED 0.075
#define TOL_LBL3_EMIT 0.08     /* error 0.027; the flame is a few pixels: 2 x 2048 spp leave noise 0.023 */
#define TOL_LBL3_T 0.005
/* crm on the same scene and references (its parts, crm_parts.h): measured (RGBA, this
 * harness) Combined 0.059, Emit and Transmittance as lbl's (the same march); `vsd compare`
 * RGB against 8192 spp: Combined 0.094, VolumeDir 0.075, VolumeInd 0.166, with each part's
 * node grid over its group and the volumes near it (the fire, the smoke and the cloud 0.1 m
 * above it light each other: the smoke's top was 20-50% dark under the cloud) and delta-M
 * only where a grid holds one phase. Before: 0.092 here (`vsd compare` 0.147 / 0.054 / 0.269)
 * with grids over the media-overlap groups, 0.096 (0.154 / 0.049 / 0.280) with grids over
 * each volume's own box. crm alone on each volume (96x54, 4096 spp): fire 0.029, smoke
 * 0.047, cloud 0.158 Combined (the cloud at g 0.6; 0.020 at g 0). The tolerance is 1.35x the
 * error, below the 0.092 of the grids over the overlap groups. */
#define TOL_CRM3_COMBINED 0.08
/* `method` on the scene with 4x4 rays per pixel (the volumes are a few pixels wide); what
 * gets "<label> <method>" for the harness's lines. */
static vsd_framebuffer *render_method(const mvr_scene *sc, const char *method, const char *label, char *what,
                                      size_t what_len, vsd_render_stats *stats)
{
    char set[64];
    const char *ov[] = {set, "render.options.pixel_samples=4"};
    snprintf(set, sizeof set, "render.method=%s", method);
    snprintf(what, what_len, "%s %s", label, method);
    vsd_framebuffer *fb = mvr_render(sc, ov, 2, NULL, stats);
    CHECK_MSG(fb != NULL, "%s did not render", what);
    return fb;
}

static void test_three_volumes(void)
{
    const char *json =
        "{\"version\": 1, \"volumes\": ["
        "{\"file\": \"" FIRE "\", \"grid\": \"density\", \"emission_grid\": \"flame\", \"medium\": {\"density\": 6.0, "
        "\"albedo\": [0.6, 0.6, 0.6], \"anisotropy\": 0.0, \"emission_color\": [1.0, 0.4, 0.08], \"emission_strength\": 8.0}}, "
        ISSUE30_SMOKE_CLOUD_REST;
    mvr_scene sc = {.json = json, .frame = 48};
    mvr_refs refs;
    /* the cloud's media do not meet the smoke's: lbl's two groups (src/grids/volume_groups.h);
     * crm's parts are one per volume */
    struct { const char *method, *info; double tol; } cases[] = {
        {"lbl", "volumes=3 groups=2", TOL_LBL3_COMBINED}, {"crm", "volumes=3", TOL_CRM3_COMBINED}};
    if (!mvr_render_references(&sc, NULL, 0, LBL3_SPP, &refs)) return;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char what[96];
        vsd_render_stats stats;
        vsd_framebuffer *fb = render_method(&sc, cases[c].method, "three volumes", what, sizeof what, &stats);
        if (fb) {
            printf("%s: %s\n", what, stats.method_info);
            CHECK_CONTAINS(stats.method_info, cases[c].info);
            mvr_check(what, fb, &refs, VSD_PASS_COMBINED, cases[c].tol, 0.7);
            mvr_check(what, fb, &refs, VSD_PASS_EMIT, TOL_LBL3_EMIT, 0.8);
            mvr_check(what, fb, &refs, VSD_PASS_TRANSMITTANCE, TOL_LBL3_T, 0.8);
        }
        vsd_framebuffer_destroy(fb);
    }
    mvr_refs_free(&refs);
}

/* lbl's light between near groups (lbl_exchange.h) carries only what the other groups
 * send: beside a pure absorber (albedo 0, no emission) the cloud's image is the one without
 * the exchange (`exchange: false`) to float rounding, though the groups are near and each
 * part takes the other in; with a scattering smoke the exchange moves the cloud's light. */
#define TOL_ABSORBER_SENDS_NOTHING 1e-5
static void test_lbl_exchange_absorber(void)
{
    static const char *const albedo[] = {"0", "0.9"};
    for (int k = 0; k < 2; k++) {
        char volumes[1024];
        snprintf(volumes, sizeof volumes,
                 "{\"file\": \"" SMOKE "\", \"frame_offset\": -24, \"matrix\": [1,0,0,0.7, 0,1,0,0, 0,0,1,0.5, 0,0,0,1], "
                 "\"medium\": {\"density\": 12.0, \"albedo\": [%s, %s, %s]}}, "
                 "{\"file\": \"" CLOUD "\", \"matrix\": [1,0,0,1.2, 0,1,0,1.0, 0,0,1,3.4, 0,0,0,1], "
                 "\"medium\": {\"density\": 3.0, \"albedo\": [0.97, 0.97, 0.97], \"anisotropy\": 0.6}}",
                 albedo[k], albedo[k], albedo[k]);
        char *json = scene_json(volumes, 48);
        const char *on[] = {"render.method=lbl", "camera.position=[-2.9,-10.2,2.3]", "camera.look_at=[1.2,1.0,1.9]"};
        const char *off[] = {"render.method=lbl", "camera.position=[-2.9,-10.2,2.3]", "camera.look_at=[1.2,1.0,1.9]",
                             "render.options.exchange=false"};
        vsd_scene a, b;
        vsd_framebuffer *with = NULL, *without = NULL;
        CHECK(test_parse_scene(json, on, 3, &a) && test_parse_scene(json, off, 4, &b));
        with = test_render_fresh(&a, NULL, NULL, NULL, 48, NULL);
        without = test_render_fresh(&b, NULL, NULL, NULL, 48, NULL);
        CHECK(with && without);
        if (with && without) {
            double d = test_max_rel_diff(with, without, VSD_PASS_COMBINED);
            printf("lbl, cloud beside a smoke of albedo %s: exchange on against off, Combined max rel. diff %.3g\n",
                   albedo[k], d);
            if (k == 0)
                CHECK_MSG(d < TOL_ABSORBER_SENDS_NOTHING, "an absorber sent light: %g", d);
            else
                CHECK_MSG(d > 0.01, "the scattering smoke's light did not reach the cloud (%g)", d);
        }
        vsd_framebuffer_destroy(with), vsd_framebuffer_destroy(without);
        free(json);
    }
}

/* crm's grids cover the volumes, not the box between them (issue 30): two copies of a smoke
 * 100 m apart are not near (vsd_volumes_near), so each part's node grid is its own volume's,
 * together twice the nodes of the smoke alone; 1.4 m apart (about 0.4 m between their
 * boxes, each about 1 m wide) they are near and each grid spans both, so they light each
 * other (crm_parts.h). The node counts are the method's figures. */
static double crm_nodes(const char *volumes)
{
    char *json = scene_json(volumes, 11);
    const char *ov[] = {"render.method=crm", "film.width=16", "film.height=9"};
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    vsd_render_stats st;
    double nodes = -1.0;
    if (test_parse_scene(json, ov, 3, &sc) && (r = test_make_renderer(&sc, NULL)) && test_render(r, 11, &fb, &st)) {
        const char *at = strstr(st.method_info, "nodes=");
        int a = 0, b = 1, c = 1;
        if (at && sscanf(at, "nodes=%dx%dx%d", &a, &b, &c) >= 1) nodes = (double)a * b * c;
        printf("crm nodes: %s\n", st.method_info);
    }
    CHECK_MSG(nodes > 0, "crm rendered no node count");
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
    free(json);
    return nodes;
}

static void test_crm_far_volumes_own_grids(void)
{
    const char *one = "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 6}}";
    char two[1024];
    double alone = crm_nodes(one), far, near;
    snprintf(two, sizeof two, "%s, {\"file\": \"" SMOKE "\", \"matrix\": [1,0,0,%s, 0,1,0,0, 0,0,1,0, 0,0,0,1], "
             "\"medium\": {\"density\": 6}}", one, "100");
    far = crm_nodes(two);
    snprintf(two, sizeof two, "%s, {\"file\": \"" SMOKE "\", \"matrix\": [1,0,0,%s, 0,1,0,0, 0,0,1,0, 0,0,0,1], "
             "\"medium\": {\"density\": 6}}", one, "1.4");
    near = crm_nodes(two);
    printf("crm nodes: one smoke %.0f, two 100 m apart %.0f, two 1.4 m apart %.0f\n", alone, far, near);
    CHECK_MSG(far == 2.0 * alone, "two far copies: %.0f nodes, not twice one copy's %.0f", far, alone);
    CHECK_MSG(near > 1.5 * far, "two near copies: %.0f nodes, their grids do not span each other (far: %.0f)", near,
              far);
}

/* The single-scattering record-grid methods on two volumes that shadow each other (the
 * three-volume scene's smoke and the cloud above it; no flame, whose light these methods do
 * not scatter): VolumeDir against `reference` (their Combined lacks the multiple scattering
 * by design). Measured (96x54, 4x4 rays per pixel, `vsd compare` against 4096 spp, 2-core
 * VM 2026-12-04): shgrid 0.052, constellation 0.106 (0.066 and 0.137 on the smoke and the
 * cloud alone at 128x72). */
#define SS2_SPP 2048
#define TOL_SS2_SHGRID 0.08
#define TOL_SS2_CONSTELLATION 0.14
static void test_single_scattering_two_volumes(void)
{
    const char *json =
        "{\"version\": 1, \"volumes\": ["
        ISSUE30_SMOKE_CLOUD_REST;
    mvr_scene sc = {.json = json, .frame = 48};
    mvr_refs refs;
    struct { const char *method; double tol; } cases[] = {{"shgrid", TOL_SS2_SHGRID},
                                                          {"constellation", TOL_SS2_CONSTELLATION}};
    if (!mvr_render_references(&sc, NULL, 0, SS2_SPP, &refs)) return;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char what[96];
        vsd_render_stats stats;
        vsd_framebuffer *fb = render_method(&sc, cases[c].method, "smoke + cloud", what, sizeof what, &stats);
        if (fb) {
            CHECK_CONTAINS(stats.method_info, "volumes=2 groups=2");
            mvr_check(what, fb, &refs, VSD_PASS_VOLUME_DIR, cases[c].tol, 0.8);
            mvr_check(what, fb, &refs, VSD_PASS_TRANSMITTANCE, TOL_LBL3_T, 0.8);
        }
        vsd_framebuffer_destroy(fb);
    }
    mvr_refs_free(&refs);
}

/* Green channel of the Transmittance pass, w x h. */
static float *transmittance(const vsd_framebuffer *fb)
{
    size_t n = (size_t)fb->width * fb->height;
    float *t = malloc(n * sizeof *t);
    const float *p = fb->pass[VSD_PASS_TRANSMITTANCE];
    int ch = vsd_pass_channels(VSD_PASS_TRANSMITTANCE);
    for (size_t i = 0; i < n; i++) t[i] = p[i * ch + 1];
    return t;
}

/* The smoke and a copy of it 1.5 m further along +y (behind it from the camera) and 0.25 m
 * to the side: where both cover a pixel, its transmittance is the product of each one's. */
static void test_transmittance_product(void)
{
    const char *a = "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 6}}";
    const char *b = "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 6}, "
                    "\"matrix\": [1,0,0,0.25, 0,1,0,1.5, 0,0,1,0, 0,0,0,1]}";
    char both_list[1024];
    snprintf(both_list, sizeof both_list, "%s, %s", a, b);
    char *ja = scene_json(a, 11), *jb = scene_json(b, 11), *jab = scene_json(both_list, 11);
    const char *ov1[] = {"render.samples=2048", "render.seed=1"}, *ov2[] = {"render.samples=2048", "render.seed=7"};
    mvr_scene sa = {.json = ja, .frame = 11}, sb = {.json = jb, .frame = 11}, sab = {.json = jab, .frame = 11};
    vsd_framebuffer *fa = mvr_render(&sa, ov1, 2, NULL, NULL), *fb = mvr_render(&sb, ov1, 2, NULL, NULL);
    vsd_framebuffer *f1 = mvr_render(&sab, ov1, 2, NULL, NULL), *f2 = mvr_render(&sab, ov2, 2, NULL, NULL);
    CHECK(fa && fb && f1 && f2);
    if (fa && fb && f1 && f2) {
        int w = fa->width, h = fa->height;
        size_t n = (size_t)w * h;
        float *ta = transmittance(fa), *tb = transmittance(fb), *t1 = transmittance(f1), *t2 = transmittance(f2);
        float *prod = malloc(n * sizeof *prod), *mean = malloc(n * sizeof *mean), *none = malloc(n * sizeof *none);
        double covered = 0;
        for (size_t i = 0; i < n; i++) {
            prod[i] = ta[i] * tb[i];
            mean[i] = 0.5f * (t1[i] + t2[i]);
            none[i] = ta[i];   /* control: the second volume not shadowing at all */
            covered += (ta[i] < 0.9f && tb[i] < 0.9f);
        }
        /* 1 - T is the signal: compare absorbed fractions, so empty pixels do not dilute it */
        for (size_t i = 0; i < n; i++) {
            prod[i] = 1 - prod[i];
            mean[i] = 1 - mean[i];
            none[i] = 1 - none[i];
            t1[i] = 1 - t1[i];
        }
        double err = test_rel_err_planes(mean, prod, w, h, 1);
        double noise = test_rel_err_planes(t1, mean, w, h, 1);
        double control = test_rel_err_planes(none, prod, w, h, 1);
        printf("two volumes in a row, 1 - T: error %.4f, noise %.4f (3x %.4f), tolerance %.3f, control %.4f, "
               "%.0f pixels behind both\n",
               err, noise, 3 * noise, TOL_PRODUCT_T, control, covered);
        CHECK(covered > 50);
        CHECK(err < TOL_PRODUCT_T);
        CHECK(TOL_PRODUCT_T >= 3 * noise);
        CHECK(control >= TOL_PRODUCT_T);
        free(ta), free(tb), free(t1), free(t2), free(prod), free(mean), free(none);
    }
    vsd_framebuffer_destroy(fa), vsd_framebuffer_destroy(fb), vsd_framebuffer_destroy(f1), vsd_framebuffer_destroy(f2);
    free(ja), free(jb), free(jab);
}

/* frame_offset: volume frame = scene frame + offset, each volume its own; and a change to
 * volumes[1] alone reaches the image through the renderer's caches. */
static void test_frames_and_caches(void)
{
    char *shifted = scene_json("{\"file\": \"" SMOKE "\", \"frame_offset\": 3}, "
                               "{\"file\": \"" SMOKE "\", \"frame_offset\": -2, \"medium\": {\"density\": 2}}",
                               10);
    char *plain = scene_json("{\"file\": \"" SMOKE "\"}, {\"file\": \"" SMOKE "\", \"medium\": {\"density\": 2}}", 13);
    vsd_scene a, b;
    CHECK(test_parse_scene(shifted, NULL, 0, &a));
    const char *set_b[] = {"volumes.1.file=" VSD_SHARED_DATA "/smoke64/fluid_data_0008.vdb"};
    CHECK(test_parse_scene(plain, set_b, 1, &b));
    vsd_framebuffer *fa = test_render_fresh(&a, NULL, NULL, NULL, 10, NULL);
    vsd_framebuffer *fb = test_render_fresh(&b, NULL, NULL, NULL, 13, NULL);
    CHECK(fa && fb && test_identical(fa, fb));   /* frames 13 and 8, by offsets or by files */

    /* one renderer: frame 10, then volumes[1]'s density changed, against a fresh renderer */
    vsd_renderer *r = test_make_renderer(&a, NULL);
    vsd_framebuffer *first = NULL, *second = NULL;
    CHECK(r && test_render(r, 10, &first, NULL));
    vsd_scene a2 = a;
    a2.volumes[1].medium.density = 7;
    char err[512];
    CHECK(vsd_renderer_set_scene(r, &a2, err, sizeof err) == VSD_OK);
    CHECK(test_render(r, 10, &second, NULL));
    vsd_framebuffer *fresh = test_render_fresh(&a2, NULL, NULL, NULL, 10, NULL);
    CHECK(first && second && fresh && !test_identical(first, second) && test_identical(second, fresh));
    vsd_framebuffer_destroy(first), vsd_framebuffer_destroy(second), vsd_framebuffer_destroy(fresh);
    vsd_framebuffer_destroy(fa), vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
    free(shifted), free(plain);
}

/* `live` (a renderer that was handed an edit or a new frame) against `fresh` (a new
 * renderer of the same scene and frame): bit for bit, but lbl, whose lattice starts from the
 * last solve (converged to its tolerance: within 1e-3); and the change moved the image away
 * from `before`. `what` names the change in the log. */
static void check_live_as_fresh(const char *method, const char *what, const vsd_framebuffer *before,
                                const vsd_framebuffer *live, const vsd_framebuffer *fresh)
{
    double d;
    CHECK(before && live && fresh);
    if (!before || !live || !fresh) return;
    d = test_max_rel_diff(live, fresh, VSD_PASS_COMBINED);
    printf("%s, %s: against a fresh renderer Combined max rel. diff %.3g (the change moved it by %.3g)\n", method,
           what, d, test_max_rel_diff(live, before, VSD_PASS_COMBINED));
    if (strcmp(method, "lbl") == 0)
        CHECK_MSG(d < 1e-3, "lbl, %s: the live renderer differs from a fresh one by %g", what, d);
    else
        CHECK_MSG(test_identical(live, fresh), "%s, %s: the live renderer differs from a fresh one (%g)", method, what,
                  d);
    CHECK_MSG(!test_identical(before, live), "%s, %s: the image did not change", method, what);
}

/* A renderer on scene a at `frame`, then handed b (an edit), against a fresh renderer on b
 * (check_live_as_fresh); returns their Combined max rel. difference, -1 where a render failed. */
static double edit_live_and_fresh(const char *method, const char *what, const vsd_scene *a, const vsd_scene *b,
                                  int frame)
{
    char err[512];
    double d = -1.0;
    vsd_renderer *r = test_make_renderer(a, NULL);
    vsd_framebuffer *first = NULL, *second = NULL, *fresh = NULL;
    CHECK(r && test_render(r, frame, &first, NULL));
    CHECK(r && vsd_renderer_set_scene(r, b, err, sizeof err) == VSD_OK);
    CHECK(r && test_render(r, frame, &second, NULL));
    fresh = test_render_fresh(b, NULL, NULL, NULL, frame, NULL);
    check_live_as_fresh(method, what, first, second, fresh);
    if (second && fresh) d = test_max_rel_diff(second, fresh, VSD_PASS_COMBINED);
    vsd_framebuffer_destroy(first), vsd_framebuffer_destroy(second), vsd_framebuffer_destroy(fresh);
    vsd_renderer_destroy(r);
    return d;
}

/* Two volumes under render.method `method` at `frame`: volumes[0] the smoke64 sequence at
 * density 6, volumes[1] the file `file1` moved by `x` along x with the medium `medium1`
 * (a JSON object). */
static int two_volumes(const char *method, const char *file1, const char *x, const char *medium1, int frame,
                       vsd_scene *out)
{
    char set[64], volumes[1024], *json;
    const char *ov[] = {set};
    int ok;
    snprintf(set, sizeof set, "render.method=%s", method);
    snprintf(volumes, sizeof volumes,
             "{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 6}}, "
             "{\"file\": \"%s\", \"matrix\": [1,0,0,%s, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"medium\": %s}",
             file1, x, medium1);
    json = scene_json(volumes, frame);
    ok = test_parse_scene(json, ov, 1, out);
    free(json);
    return ok;
}

/* A material edit of one volume (albedo, anisotropy: the lighting stage only) in a live
 * renderer shows what a fresh renderer shows, for every method that keeps lighting grids
 * over several volumes: two overlapping volumes (one group, whose grids mix their
 * materials) with different albedos. Bit for bit, but lbl: its lattice starts from the
 * last solve (warm start, converged to its tolerance; tests/test_lbl.c part 2), measured
 * 7.6e-5 here. lbl kept the group's mixed albedo from the frame stage before 2026-12-04:
 * 0.227 (fixed: lbl_prepare_lighting mixes it). */
static void test_material_edits(void)
{
    static const char *const methods[] = {"lbl", "crm", "shgrid", "constellation"};
    char *two = scene_json("{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 6, \"albedo\": [0.9, 0.8, 0.7]}}, "
                           "{\"file\": \"" SMOKE "\", \"matrix\": [1,0,0,0.3, 0,1,0,0, 0,0,1,0.2, 0,0,0,1], "
                           "\"medium\": {\"density\": 4, \"albedo\": [0.3, 0.5, 0.9]}}",
                           11);
    for (size_t m = 0; m < sizeof methods / sizeof methods[0]; m++) {
        char method[64];
        const char *ov[] = {method};
        vsd_scene a, b;
        snprintf(method, sizeof method, "render.method=%s", methods[m]);
        CHECK(test_parse_scene(two, ov, 1, &a));
        b = a;
        b.volumes[1].medium.albedo[0] = 0.95f;
        b.volumes[1].medium.albedo[2] = 0.1f;
        b.volumes[1].medium.anisotropy = 0.5f;
        edit_live_and_fresh(methods[m], "volumes[1]'s albedo and anisotropy edited", &a, &b, 11);
    }
    free(two);

    /* The same edit where both volumes share one lobe (g 0.5), so lbl's lattice solves
     * delta-M's scaled medium, whose per-cell extinction takes the group's mixed albedo:
     * volumes[1]'s albedo moves the scaled medium of volumes[0]'s part too, and with it that
     * part's surface escape (lbl_escape.h). A cache of the escape keyed on the part's own
     * albedo kept the old one (5a8b79c): the live renderer differed from a fresh one by
     * 4.3e-4, within the 1e-3 above but 13x the warm start's own 3.4e-5. */
    {
        char *same_lobe = scene_json("{\"file\": \"" SMOKE "\", \"medium\": {\"density\": 6, \"albedo\": [0.9, 0.8, 0.7], "
                                     "\"anisotropy\": 0.5}}, "
                                     "{\"file\": \"" SMOKE "\", \"matrix\": [1,0,0,0.3, 0,1,0,0, 0,0,1,0.2, 0,0,0,1], "
                                     "\"medium\": {\"density\": 4, \"albedo\": [0.3, 0.5, 0.9], \"anisotropy\": 0.5}}",
                                     11);
        const char *ov[] = {"render.method=lbl"};
        vsd_scene a, b;
        double d;
        CHECK(test_parse_scene(same_lobe, ov, 1, &a));
        b = a;
        b.volumes[1].medium.albedo[0] = b.volumes[1].medium.albedo[1] = b.volumes[1].medium.albedo[2] = 0.99f;
        d = edit_live_and_fresh("lbl", "one lobe, delta-M: volumes[1]'s albedo edited", &a, &b, 11);
        /* the warm start alone: 3.4e-5 here (7.7e-5 above); the stale escape was 4.3e-4 */
        CHECK_MSG(d >= 0.0 && d < 2e-4, "lbl, one lobe: the live renderer differs from a fresh one by %g (its escape kept?)",
                  d);
        free(same_lobe);
    }

    /* Volumes whose media do not meet (two groups): an albedo edit of volumes[1] re-lights
     * its part only (src/method/method_parts.h, "relit" in the method's figures), and the
     * image is still a fresh renderer's; a map rotation re-lights both. crm's parts mix
     * every volume in their box, so it re-lights both for any material edit; so does lbl
     * where the groups are near (1.6 m apart), since each takes the other's light in at its
     * lattice's faces (lbl_exchange.h), but not 40 m apart. */
    static const struct { const char *method, *x, *after_edit; } relight[] = {
        {"lbl", "40", "relit=1"}, {"lbl", "1.6", "relit=2"}, {"shgrid", "1.6", "relit=1"}};
    for (size_t m = 0; m < sizeof relight / sizeof relight[0]; m++) {
        char err[512];
        vsd_scene a, b, c;
        vsd_render_stats st;
        CHECK(two_volumes(relight[m].method, SMOKE, relight[m].x, "{\"density\": 4, \"albedo\": [0.3, 0.5, 0.9]}", 11,
                          &a));
        b = a;
        b.volumes[1].medium.albedo[0] = 0.95f;
        c = b;
        c.environment.rotation_z = 1.0f;
        vsd_renderer *r = test_make_renderer(&a, NULL);
        vsd_framebuffer *fb = NULL, *fresh = NULL;
        CHECK(r && test_render(r, 11, &fb, &st));
        CHECK_CONTAINS(st.method_info, "groups=2");
        CHECK_CONTAINS(st.method_info, "relit=2");
        CHECK(r && vsd_renderer_set_scene(r, &b, err, sizeof err) == VSD_OK);
        CHECK(r && test_render(r, 11, &fb, &st));
        printf("%s, two groups %s m apart, volumes[1]'s albedo edited: %s\n", relight[m].method, relight[m].x,
               st.method_info);
        CHECK_CONTAINS(st.method_info, relight[m].after_edit);
        fresh = test_render_fresh(&b, NULL, NULL, NULL, 11, NULL);
        CHECK(fb && fresh);
        if (fb && fresh) {
            double d = test_max_rel_diff(fb, fresh, VSD_PASS_COMBINED);
            printf("    against a fresh renderer: Combined max rel. diff %.3g\n", d);
            CHECK_MSG(d < (strcmp(relight[m].method, "lbl") == 0 ? 1e-3 : 1e-6), "%s: %g", relight[m].method, d);
        }
        CHECK(r && vsd_renderer_set_scene(r, &c, err, sizeof err) == VSD_OK);
        CHECK(r && test_render(r, 11, &fb, &st));
        CHECK_CONTAINS(st.method_info, "relit=2");
        vsd_framebuffer_destroy(fb), vsd_framebuffer_destroy(fresh);
        vsd_renderer_destroy(r);
    }
}

/* A new frame of one volume prepares again only the parts whose frame stage reads it
 * (src/method/method_parts.h, "reframed" in the method's figures): volumes[0] follows the
 * sequence, volumes[1] is one file. lbl's part reads its group (apart: its own volume;
 * overlapping: both), constellation's its own volume, shgrid's every volume (its records'
 * transmittance marches through all). Every part is lit again (shadows reach across), and
 * the image is a fresh renderer's: bit for bit, but lbl, whose lattice starts from the last
 * solve (converged to its tolerance). */
static void test_frame_of_one_volume(void)
{
    static const struct { const char *method, *x, *reframed; } cases[] = {
        {"lbl", "40", "reframed=1"}, {"lbl", "0.5", "reframed=2"},
        {"constellation", "0.5", "reframed=1"}, {"shgrid", "40", "reframed=2"}};
    for (size_t m = 0; m < sizeof cases / sizeof cases[0]; m++) {
        vsd_scene a;
        vsd_render_stats st;
        char what[96];
        CHECK(two_volumes(cases[m].method, VSD_SHARED_DATA "/smoke64/fluid_data_0008.vdb", cases[m].x,
                          "{\"density\": 4}", 10, &a));
        vsd_renderer *r = test_make_renderer(&a, NULL);
        vsd_framebuffer *first = NULL, *second = NULL, *fresh = NULL;
        CHECK(r && test_render(r, 10, &first, &st));
        CHECK_CONTAINS(st.method_info, "reframed=2");
        CHECK(r && test_render(r, 11, &second, &st));
        printf("%s, volumes[1] at x %s m, frame 10 -> 11 (volumes[0] only): %s\n", cases[m].method, cases[m].x,
               st.method_info);
        CHECK_CONTAINS(st.method_info, cases[m].reframed);
        CHECK_CONTAINS(st.method_info, "relit=2");
        fresh = test_render_fresh(&a, NULL, NULL, NULL, 11, NULL);
        snprintf(what, sizeof what, "volumes[1] at x %s m, frame 10 -> 11", cases[m].x);
        check_live_as_fresh(cases[m].method, what, first, second, fresh);
        vsd_framebuffer_destroy(first), vsd_framebuffer_destroy(second), vsd_framebuffer_destroy(fresh);
        vsd_renderer_destroy(r);
    }
}

/* vsd_scene_frame_hash covers every volume (core/src/render/frame_output_check.c): the
 * fields and medium of volumes[1], its frame_offset and the file it reads change the hash
 * that `vsd render --continue` compares; warn_above (a warning only) does not; a scene of
 * one volume hashes the same in either form. Needs: #include "vsd/render.h", "vsd/scene.h". */
static void frame_hash_of(const char *json, const char *const *ov, int nov, int frame, char hex[33])
{
    vsd_scene *sc = malloc(sizeof *sc);
    char err[1024];
    hex[0] = '\0';
    CHECK(sc != NULL);
    if (!sc) return;
    vsd_status st = vsd_scene_parse(json, "", ov, nov, sc, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "scene: %s", err);
    if (st == VSD_OK) {
        st = vsd_scene_frame_hash(sc, frame, hex, err, sizeof err);
        CHECK_MSG(st == VSD_OK, "hash: %s", err);
    }
    free(sc);
}

static void test_frame_hash_volumes(void)
{
    char one[2048], one_list[2048], two[4096], base[33], h[33];
    char smoke[1024];
    snprintf(smoke, sizeof smoke, "%s", VSD_SHARED_DATA "/smoke64/fluid_data_####.vdb");
    snprintf(one, sizeof one, "{\"version\":1,\"volume\":{\"file\":\"%s\"},\"medium\":{\"density\":4}}", smoke);
    snprintf(one_list, sizeof one_list, "{\"version\":1,\"volumes\":[{\"file\":\"%s\",\"medium\":{\"density\":4}}]}", smoke);
    snprintf(two, sizeof two,
             "{\"version\":1,\"volumes\":[{\"file\":\"%s\",\"medium\":{\"density\":4}},"
             "{\"file\":\"%s\",\"medium\":{\"density\":2}}]}", smoke, smoke);
    frame_hash_of(one, NULL, 0, 3, base);
    frame_hash_of(one_list, NULL, 0, 3, h);
    CHECK_MSG(!strcmp(base, h), "one volume, two forms: %s %s", base, h);
    frame_hash_of(two, NULL, 0, 3, base);
    CHECK(strlen(base) == 32);
    frame_hash_of(one, NULL, 0, 3, h);
    CHECK_MSG(strcmp(base, h) != 0, "a second volume leaves the hash at %s", h);
    const char *density[] = {"volumes.1.medium.density=3"};
    frame_hash_of(two, density, 1, 3, h);
    CHECK_MSG(strcmp(base, h) != 0, "volumes[1].medium.density 2 -> 3 leaves the hash at %s", h);
    const char *offset[] = {"volumes.1.frame_offset=1"}; /* reads fluid_data_0004.vdb */
    frame_hash_of(two, offset, 1, 3, h);
    CHECK_MSG(strcmp(base, h) != 0, "volumes[1].frame_offset leaves the hash at %s", h);
    const char *warn[] = {"volumes.1.warn_above=5"};
    frame_hash_of(two, warn, 1, 3, h);
    CHECK_MSG(!strcmp(base, h), "volumes[1].warn_above changes the hash: %s %s", base, h);
}

/* What cannot render several volumes says so, by name, before any work. */
static void test_errors(void)
{
    char *two = scene_json("{\"file\": \"" SMOKE "\"}, {\"file\": \"" SMOKE "\", \"medium\": {\"density\": 2}}", 11);
    vsd_scene sc;
    vsd_renderer *r = NULL;
    char err[1024] = "";
    vsd_render_options o = {.threads = 2};

    /* crm's default renders several volumes; its fitted forms (one volume's RBFs) do not */
    const char *crm[] = {"render.method=crm", "render.options.view_density=\"compensated\""};
    CHECK(test_parse_scene(two, crm, 2, &sc));
    CHECK(vsd_renderer_create(&sc, &o, &r, err, sizeof err) == VSD_ERR_UNSUPPORTED);
    CHECK_CONTAINS(err, "volumes: the scene has 2 volumes; crm's fitted forms (view_density \"compensated\" or \"eq8\", "
                        "single \"sh\", multiple \"rbf\") render one volume; its default path renders several");
    vsd_renderer_destroy(r);
    r = NULL;

    /* the voxel limit counts the volumes together, from the files, before loading: each of
     * the two halves fits, the two do not */
    {
        char path[1024], err2[1024];
        vsd_grid_info info;
        vsd_grid_select sel = {"density", -1};
        vsd_render_options lo = {.threads = 2};
        snprintf(path, sizeof path, "%s", VSD_SHARED_DATA "/smoke64/fluid_data_0011.vdb");
        CHECK(vsd_vdb_select_info(path, sel, &info, err2, sizeof err2) == VSD_OK);
        lo.max_voxels = info.active_voxels + 1;
        CHECK(test_parse_scene(two, NULL, 0, &sc));
        CHECK(vsd_renderer_create(&sc, &lo, &r, err, sizeof err) == VSD_OK);
        vsd_framebuffer *lfb = NULL;
        if (r) CHECK(vsd_renderer_render(r, 11, &lfb, NULL, err, sizeof err) == VSD_ERR_NOMEM);
        printf("two volumes over the voxel limit: %s\n", err);
        CHECK_CONTAINS(err, "volumes: the scene's density grids hold");
        CHECK_CONTAINS(err, "(volumes[1] ");
        CHECK_CONTAINS(err, "the limit is");
        vsd_framebuffer_destroy(lfb);
        vsd_renderer_destroy(r);
        r = NULL;
        /* one of them alone renders under the same limit */
        char *one = scene_json("{\"file\": \"" SMOKE "\"}", 11);
        CHECK(test_parse_scene(one, NULL, 0, &sc));
        CHECK(vsd_renderer_create(&sc, &lo, &r, err, sizeof err) == VSD_OK);
        lfb = NULL;
        if (r) CHECK(vsd_renderer_render(r, 11, &lfb, NULL, err, sizeof err) == VSD_OK);
        vsd_framebuffer_destroy(lfb);
        vsd_renderer_destroy(r);
        r = NULL;
        free(one);
    }

    vsd_framebuffer *fb = NULL;
    const char *missing[] = {"volumes.1.file=" VSD_TEST_TMP "/no_such_####.vdb"};
    CHECK(test_parse_scene(two, missing, 1, &sc));
    CHECK(vsd_renderer_create(&sc, &o, &r, err, sizeof err) == VSD_OK);
    if (r) CHECK(vsd_renderer_render(r, 11, &fb, NULL, err, sizeof err) != VSD_OK);
    CHECK_CONTAINS(err, "volumes[1] (" VSD_TEST_TMP "/no_such_####.vdb): ");
    CHECK_CONTAINS(err, "no_such_0011.vdb");
    vsd_renderer_destroy(r);
    r = NULL;

    /* one refracting volume among others: reference bends every ray through it
     * (test_refraction); lbl refuses it by name, and two refracting volumes are refused */
    const char *ior[] = {"volumes.1.medium.ior=1.3", "render.method=lbl"};
    CHECK(test_parse_scene(two, ior, 2, &sc));
    CHECK(vsd_renderer_create(&sc, &o, &r, err, sizeof err) == VSD_ERR_UNSUPPORTED);
    CHECK_CONTAINS(err, "volumes[1].medium: refraction");
    CHECK_CONTAINS(err, "'lbl'");
    vsd_renderer_destroy(r);
    r = NULL;
    const char *ior2[] = {"volumes.0.medium.ior=1.2", "volumes.1.medium.ior=1.3", "render.method=reference"};
    CHECK(test_parse_scene(two, ior2, 3, &sc));
    CHECK(vsd_renderer_create(&sc, &o, &r, err, sizeof err) == VSD_ERR_UNSUPPORTED);
    CHECK_CONTAINS(err, "volumes[0] and volumes[1] both refract");
    vsd_renderer_destroy(r);
    vsd_framebuffer_destroy(fb);
    free(two);
}

int main(void)
{
    test_errors();
    test_frame_hash_volumes();
    test_frames_and_caches();
    test_material_edits();
    test_frame_of_one_volume();
    test_deterministic_exact();
    test_transmittance_product();
    test_summed_density();
    test_material_mixture();
    test_three_volumes();
    test_lbl_exchange_absorber();
    test_crm_far_volumes_own_grids();
    test_single_scattering_two_volumes();
    return test_finish("test_volumes");
}
