/* Method `crm` (Zhou et al. 2008, compensated ray marching), end to end through
 * vsd_renderer:
 *   1. real data (smoke64_sunset frame 24) against a near-converged `reference`: Combined,
 *      VolumeDir and VolumeInd within tolerances measured here, VolumeInd carrying the
 *      reference's share of the light, and negative controls (multiple scattering removed,
 *      albedo 0) that the same tolerances must reject;
 *   2. a homogeneous ball under a uniform environment against `reference`, and invariance of
 *      crm's image under a rotation of that environment;
 *   3. the RBF fit's disk cache (vsd_render_options.cache_dir), counted through
 *      stats.method_info: fit, hit with a bit-identical image, refit after truncation and
 *      after a flipped byte;
 *   4. interactive edits in one renderer (camera, environment rotation, medium density and
 *      albedo reuse the fit; a new frame fits), matching a fresh renderer;
 *   5. option errors naming the key;
 *   6. an empty density grid;
 *   7. emission scattered once is VolumeDir, as in `reference` and Cycles: fire96 frame 48
 *      in a black world, where all scattered light is emission's, VolumeDir and VolumeInd
 *      each against the reference's (all of it in VolumeInd, as crm did before, scores
 *      VolumeDir 1.0).
 *   8. the successive orders scatter with the medium's phase (`orders_phase: "hg"`): a
 *      forward-scattering ball (g 0.7) with the sunset map's sun behind it, VolumeInd
 *      against `reference`; the orders taken isotropic after the first, the control, must
 *      fail the same tolerance.
 * Every part prints what it measured; the tolerances below quote those measurements. */
#define _POSIX_C_SOURCE 200809L
#include "test_common.h"
#include "test_render_util.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#include "vsd/compare.h"
#include "src/common/clock.h"
#include <dirent.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#define SMOKE "scenes/smoke64_sunset.json"
/* crm options that keep the test fast without changing what it tests: 200 RBFs and at most
 * 500 L-BFGS iterations fit frame 24 in ~1.5 s instead of ~10 s (800 / 3000). crm's
 * lighting does not come from the RBFs (single scattering and the successive orders run on
 * a node grid of the voxel density, and the residual hash restores the density the RBFs
 * miss in the view march): at 96x54 (1 ray per pixel) the small fit changes Combined,
 * VolumeDir and VolumeInd against the reference by < 0.001 (measured 0.0476 / 0.0711 /
 * 0.1716 with 200 / 500, 0.0476 / 0.0713 / 0.1713 with the defaults). */
#define CRM_FAST "render.options.rbf_count=200", "render.options.fit_iterations=500"
/* 2 x 2 view rays per pixel where crm is compared with the reference: the reference
 * averages over each pixel's area, and at these small films one ray through the pixel's
 * centre adds silhouette aliasing that says nothing about the lighting (on the ball
 * Transmittance rel. RMSE 0.018 with 1 ray, 0.0034 with 2 x 2, 0.0021 with 4 x 4; the
 * view pass stays ~0.1 s). On smoke64, VolumeDir goes 0.071 -> 0.096 -> 0.091 with 1, 2 x 2
 * and 4 x 4 rays: the single centre ray's aliasing happens to hide part of the error. */
#define CRM_AREA "render.options.pixel_samples=2"

/* Tolerances (rel. RMSE after 4 x 4 block averages, as `vsd compare`), measured with the
 * options above on this build's CPU path.
 * smoke64_sunset frame 24 at 96x54 against reference 1024 spp (seed 1):
 *   noise of the reference (seed 7 vs seed 1): Combined 0.0145, VolumeDir 0.0324,
 *     VolumeInd 0.0403 (so each reference carries about 0.010 / 0.023 / 0.028); with the
 *     map read by linear interpolation (2026-12-02) 0.0139 / 0.0335 / 0.0402, so VolumeDir's
 *     tolerance moved from 0.10 to 0.11 to stay above 3x the noise;
 *   crm: Combined 0.0315, VolumeDir 0.0557, VolumeInd 0.1100, Transmittance 0.0011 (before
 *     the node grid's box-filtered density and 1-voxel spacing on small volumes: 0.0503,
 *     0.0957, 0.1716);
 *   negative controls on Combined: multiple scattering removed 0.657, halved 0.349,
 *     albedo 0 1.31.
 * The tolerances are ~1.4-1.8x the measured errors, above 3x the noise (checked below, with
 * the noise of each run), and the Combined one 7x below the nearest control. */
#define TOL_COMBINED 0.045
#define TOL_DIR 0.11
#define TOL_IND 0.16
/* The ball at 32x32 against reference 2048 spp: noise Combined 0.0057, VolumeDir 0.0091,
 * VolumeInd 0.0111; crm Combined 0.0271, VolumeDir 0.0168, VolumeInd 0.0640,
 * Transmittance 0.0034 (totals VolumeDir 0.999, VolumeInd 0.983); controls: multiple
 * removed 0.600, halved 0.307, albedo 0 1.003. Tolerances ~1.4-1.8x the errors, above 3x
 * the noise, 7x below the nearest control. */
#define BALL_TOL_COMBINED 0.04
#define BALL_TOL_DIR 0.03
#define BALL_TOL_IND 0.09

/* ------------------------------------------------------------------------ helpers */














/* Remove the files of a flat folder and the folder; a missing folder is fine. */
static void remove_dir(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char path[2048];
    if (!d) return;
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        unlink(path);
    }
    closedir(d);
    rmdir(dir);
}

/* Apply `how` to every regular file of dir: 't' truncates it to half its size, 'f' flips
 * the bits of the byte in the middle, 0 leaves it. Returns the number of files; *bytes gets
 * their total size before. */
static int damage_files(const char *dir, char how, long *bytes)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char path[2048];
    int count = 0;
    *bytes = 0;
    if (!d) return 0;
    while ((e = readdir(d)) != NULL) {
        struct stat sb;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (stat(path, &sb) != 0 || !S_ISREG(sb.st_mode)) continue;
        *bytes += (long)sb.st_size;
        if (how == 't') {
            CHECK(truncate(path, sb.st_size / 2) == 0);
        } else if (how == 'f') {
            FILE *f = fopen(path, "r+b");
            int c;
            CHECK(f != NULL);
            if (!f) continue;
            fseek(f, (long)sb.st_size / 2, SEEK_SET);
            c = fgetc(f);
            fseek(f, (long)sb.st_size / 2, SEEK_SET);
            fputc(c ^ 0xff, f);
            fclose(f);
        }
        count++;
    }
    closedir(d);
    return count;
}




/* -------------------------------------------- 1 + 3: real data, and the fit cache */

static void test_real_data_and_cache(void)
{
    const int W = 96, H = 54;
    const char *ref_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54",
                            "render.method=reference", "render.samples=1024", "render.seed=1"};
    const char *ref2_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54",
                             "render.method=reference", "render.samples=1024", "render.seed=7"};
    const char *crm_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54",
                            "render.method=crm", CRM_FAST, CRM_AREA};
    const char *cache = NULL;
    char cache_dir[2048];
    vsd_scene ref_sc, ref2_sc, crm_sc;
    vsd_framebuffer *ref = NULL, *ref2 = NULL, *crm = NULL, *again = NULL;
    vsd_render_stats s1, s2, s3;
    double t0 = vsd_clock_seconds();
    if (!test_load_scene(SMOKE, ref_ov, 7, &ref_sc) || !test_load_scene(SMOKE, ref2_ov, 7, &ref2_sc) ||
        !test_load_scene(SMOKE, crm_ov, 8, &crm_sc))
        return;
    snprintf(cache_dir, sizeof cache_dir, "%s", test_tmp("crm_fit_cache"));
    remove_dir(cache_dir);
    cache = cache_dir;

    ref = test_render_fresh(&ref_sc, NULL, NULL, NULL, 24, NULL);
    ref2 = test_render_fresh(&ref2_sc, NULL, NULL, NULL, 24, NULL);
    /* the crm render under test is also the cache's first renderer (part 3) */
    crm = test_render_fresh(&crm_sc, cache, NULL, NULL, 24, &s1);
    if (!ref || !ref2 || !crm) goto done;
    printf("[1] reference 2 x 1024 spp + crm at %dx%d: %.1fs\n", W, H, vsd_clock_seconds() - t0);
    printf("    crm info: %s\n", s1.method_info);
    {
        static const vsd_pass passes[3] = {VSD_PASS_COMBINED, VSD_PASS_VOLUME_DIR, VSD_PASS_VOLUME_IND};
        double noise[3], e[3], ref_share, crm_share;
        int k;
        for (k = 0; k < 3; k++) {
            noise[k] = test_rel_err(ref2, ref, passes[k]);
            e[k] = test_rel_err(crm, ref, passes[k]);
        }
        ref_share = test_pass_sum(ref, VSD_PASS_VOLUME_IND) / test_pass_sum(ref, VSD_PASS_VOLUME_DIR);
        crm_share = test_pass_sum(crm, VSD_PASS_VOLUME_IND) / test_pass_sum(crm, VSD_PASS_VOLUME_DIR);
        printf("    noise (seed 7 vs seed 1): Combined %.4f VolumeDir %.4f VolumeInd %.4f\n", noise[0], noise[1],
               noise[2]);
        printf("    crm vs reference:         Combined %.4f VolumeDir %.4f VolumeInd %.4f; Transmittance %.4f\n", e[0],
               e[1], e[2], test_rel_err(crm, ref, VSD_PASS_TRANSMITTANCE));
        printf("    VolumeInd / VolumeDir: reference %.3f, crm %.3f; crm / reference totals: VolumeDir %.3f, VolumeInd %.3f\n",
               ref_share, crm_share, test_pass_sum(crm, VSD_PASS_VOLUME_DIR) / test_pass_sum(ref, VSD_PASS_VOLUME_DIR),
               test_pass_sum(crm, VSD_PASS_VOLUME_IND) / test_pass_sum(ref, VSD_PASS_VOLUME_IND));
        /* tolerances and the measurements behind them: TOL_* at the top */
        CHECK_MSG(e[0] < TOL_COMBINED, "Combined rel. RMSE %.4f >= %.3f", e[0], TOL_COMBINED);
        CHECK_MSG(e[1] < TOL_DIR, "VolumeDir rel. RMSE %.4f >= %.3f", e[1], TOL_DIR);
        CHECK_MSG(e[2] < TOL_IND, "VolumeInd rel. RMSE %.4f >= %.3f", e[2], TOL_IND);
        CHECK_MSG(test_rel_err(crm, ref, VSD_PASS_TRANSMITTANCE) < 0.01, "Transmittance");
        /* the tolerances sit well above the reference's own noise ... */
        CHECK_MSG(TOL_COMBINED > 3 * noise[0] && TOL_DIR > 3 * noise[1] && TOL_IND > 3 * noise[2],
                  "noise floor too close to the tolerances: %.4f %.4f %.4f", noise[0], noise[1], noise[2]);
        /* ... and below what broken lighting gives */
        test_check_pass_sum("smoke64", crm);
        test_check_controls("smoke64", crm, ref, TOL_COMBINED);
        /* multiple scattering is really there: VolumeInd carries about the reference's
         * share of the scattered light */
        CHECK_MSG(crm_share > 0.5, "VolumeInd is only %.3f of VolumeDir", crm_share);
        CHECK_MSG(crm_share > 0.8 * ref_share && crm_share < 1.25 * ref_share,
                  "VolumeInd/VolumeDir: crm %.3f, reference %.3f (measured 0.895 and 0.927)", crm_share, ref_share);
    }

    /* ---- 2b. sky "pixels": the map per HEALPix pixel for the single scattering (src/render/
     * env_healpix.h) instead of its SH, the same tolerances (the fit comes from the cache) */
    {
        const char *px_ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54",
                               "render.method=crm", CRM_FAST, CRM_AREA, "render.options.sky=pixels"};
        vsd_scene px_sc;
        vsd_framebuffer *px = NULL;
        if (test_load_scene(SMOKE, px_ov, 9, &px_sc) && (px = test_render_fresh(&px_sc, cache, NULL, NULL, 24, NULL))) {
            double c = test_rel_err(px, ref, VSD_PASS_COMBINED), d = test_rel_err(px, ref, VSD_PASS_VOLUME_DIR);
            printf("[2b] sky \"pixels\": Combined %.4f VolumeDir %.4f (against the SH sky's %.4f / %.4f)\n", c, d,
                   test_rel_err(crm, ref, VSD_PASS_COMBINED), test_rel_err(crm, ref, VSD_PASS_VOLUME_DIR));
            CHECK_MSG(c < TOL_COMBINED && d < TOL_DIR, "sky pixels: Combined %.4f, VolumeDir %.4f", c, d);
            CHECK_MSG(test_rel_err(px, crm, VSD_PASS_VOLUME_DIR) > 1e-4, "sky pixels changed nothing");
        }
        vsd_framebuffer_destroy(px);
    }

    /* ---- 3. the fit cache, counted: first renderer fitted and wrote it */
    {
        vsd_render_stats s4, s5;
        vsd_framebuffer *fb3 = NULL, *fb4 = NULL, *fb5 = NULL;
        long bytes = 0, bytes_after = 0;
        int files;
        double t1 = vsd_clock_seconds();
        CHECK_NEAR(test_info(&s1, "fits_run"), 1, 0);
        CHECK_NEAR(test_info(&s1, "fit_cached"), 0, 0);
        CHECK(test_info(&s1, "fit_evaluations") > 0);
        CHECK_NEAR(test_info(&s1, "rbfs"), 200, 0);
        files = damage_files(cache, 0, &bytes);
        CHECK_MSG(files == 1 && bytes > 0, "cache after the first fit: %d files, %ld bytes", files, bytes);
        /* a second renderer (new object) on the same folder loads the fit */
        again = test_render_fresh(&crm_sc, cache, NULL, NULL, 24, &s2);
        CHECK(again != NULL);
        CHECK_NEAR(test_info(&s2, "fit_cached"), 1, 0);
        CHECK_NEAR(test_info(&s2, "fit_evaluations"), 0, 0);
        CHECK_NEAR(test_info(&s2, "fits_run"), 0, 0);
        CHECK_NEAR(test_info(&s2, "rbfs"), 200, 0);
        CHECK_NEAR(test_info(&s2, "fit_rel_error"), test_info(&s1, "fit_rel_error"), 1e-4 * test_info(&s1, "fit_rel_error"));
        CHECK_MSG(test_identical(again, crm), "cached fit: image differs (Combined max rel. diff %g)",
                  again ? test_max_rel_diff(again, crm, VSD_PASS_COMBINED) : -1.0);
        /* truncated files do not load: a third renderer refits, overwrites, same image */
        CHECK(damage_files(cache, 't', &bytes) == 1);
        fb3 = test_render_fresh(&crm_sc, cache, NULL, NULL, 24, &s3);
        CHECK_NEAR(test_info(&s3, "fit_cached"), 0, 0);
        CHECK_NEAR(test_info(&s3, "fits_run"), 1, 0);
        CHECK(test_info(&s3, "fit_evaluations") > 0);
        CHECK_MSG(test_identical(fb3, crm), "refit after truncation: image differs (Combined max rel. diff %g)",
                  fb3 ? test_max_rel_diff(fb3, crm, VSD_PASS_COMBINED) : -1.0);
        files = damage_files(cache, 0, &bytes_after);
        CHECK_MSG(files == 1 && bytes_after == bytes, "cache after the refit: %d files, %ld bytes (was %ld)", files,
                  bytes_after, bytes);
        /* the rewritten file loads again */
        fb4 = test_render_fresh(&crm_sc, cache, NULL, NULL, 24, &s4);
        CHECK_NEAR(test_info(&s4, "fit_cached"), 1, 0);
        CHECK_NEAR(test_info(&s4, "fits_run"), 0, 0);
        CHECK(test_identical(fb4, crm));
        /* one flipped byte in the RBFs fails the checksum: refit, same image */
        CHECK(damage_files(cache, 'f', &bytes) == 1);
        fb5 = test_render_fresh(&crm_sc, cache, NULL, NULL, 24, &s5);
        CHECK_NEAR(test_info(&s5, "fit_cached"), 0, 0);
        CHECK_NEAR(test_info(&s5, "fits_run"), 1, 0);
        CHECK(test_identical(fb5, crm));
        printf("[3] cache file %ld bytes; second renderer fit_cached=%g fit_evaluations=%g fits_run=%g; after truncation "
               "fit_cached=%g fits_run=%g; after a flipped byte fit_cached=%g fits_run=%g; %.1fs\n",
               bytes, test_info(&s2, "fit_cached"), test_info(&s2, "fit_evaluations"), test_info(&s2, "fits_run"),
               test_info(&s3, "fit_cached"), test_info(&s3, "fits_run"), test_info(&s5, "fit_cached"), test_info(&s5, "fits_run"),
               vsd_clock_seconds() - t1);
        vsd_framebuffer_destroy(fb3);
        vsd_framebuffer_destroy(fb4);
        vsd_framebuffer_destroy(fb5);
    }
done:
    vsd_framebuffer_destroy(ref);
    vsd_framebuffer_destroy(ref2);
    vsd_framebuffer_destroy(crm);
    vsd_framebuffer_destroy(again);
}

/* ------------------------------------------------------ 4: edits in one renderer */

/* Copy of every pass of fb into *keep (created or resized as needed). */
static void keep_copy(const vsd_framebuffer *fb, vsd_framebuffer **keep)
{
    int p;
    if (!*keep || (*keep)->width != fb->width || (*keep)->height != fb->height) {
        vsd_framebuffer_destroy(*keep);
        *keep = NULL;
        CHECK(vsd_framebuffer_create(fb->width, fb->height, keep, NULL, 0) == VSD_OK);
        if (!*keep) return;
    }
    for (p = 0; p < VSD_PASS_COUNT; p++)
        memcpy((*keep)->pass[p], fb->pass[p], test_pass_floats(fb, (vsd_pass)p) * sizeof(float));
}

/* Give the renderer the edited scene and render frame 24: no fit is run for it (fits_run
 * stays where it was) and the image changes (so the edit was seen). */
static void edit_and_render(vsd_renderer *r, const vsd_scene *sc, const char *what, vsd_framebuffer **fb,
                            vsd_framebuffer **before, double *fits, double *marches, int expect_march)
{
    vsd_render_stats st;
    char err[1024] = "";
    double now;
    CHECK_MSG(vsd_renderer_set_scene(r, sc, err, sizeof err) == VSD_OK, "%s: %s", what, err);
    if (!test_render(r, 24, fb, &st)) return;
    now = test_info(&st, "fits_run");
    CHECK_MSG(now == *fits, "%s refitted the unchanged grid (fits_run %g -> %g): %s", what, *fits, now,
              st.method_info);
    *fits = now;
    /* the nodes' transmittance toward the sky is kept unless the density or a smaller
     * density scale needs it marched again (crm_node_single.h); counted, not timed */
    now = test_info(&st, "transmittance_marches");
    CHECK_MSG(now == *marches + expect_march, "%s: transmittance marched %g times, expected %g: %s", what,
              now - *marches, (double)expect_march, st.method_info);
    *marches = now;
    CHECK_MSG(test_max_rel_diff(*fb, *before, VSD_PASS_COMBINED) > 1e-2, "%s did not change the image", what);
    keep_copy(*fb, before);
}

static void test_edits(void)
{
    const char *ov[] = {"frames.start=24", "frames.end=25", "film.width=48", "film.height=27",
                        "render.method=crm", CRM_FAST};
    vsd_scene sc;
    vsd_renderer *r;
    vsd_framebuffer *fb = NULL, *prev = NULL, *fresh = NULL;
    vsd_render_stats st;
    double t0 = vsd_clock_seconds(), fits = 1, marches = 1;
    if (!test_load_scene(SMOKE, ov, 7, &sc)) return;
    r = test_make_renderer(&sc, NULL);   /* no disk cache: every fit is counted */
    if (!r) return;
    if (!test_render(r, 24, &fb, &st)) goto done;
    CHECK_NEAR(test_info(&st, "fits_run"), 1, 0);
    CHECK_NEAR(test_info(&st, "fit_cached"), 0, 0);
    CHECK_NEAR(test_info(&st, "transmittance_marches"), 1, 0);
    keep_copy(fb, &prev);
    /* the same scene again: the same image, bit for bit */
    if (test_render(r, 24, &fb, &st)) {
        CHECK_MSG(test_identical(fb, prev), "an unchanged scene rendered twice differs");
        CHECK_NEAR(test_info(&st, "fits_run"), 1, 0);
    }
    sc.camera.matrix[3] += 0.2;   /* camera moved along x */
    edit_and_render(r, &sc, "camera change", &fb, &prev, &fits, &marches, 0);
    sc.environment.rotation_z = 1.3f;   /* the sunset's sun moves */
    edit_and_render(r, &sc, "environment rotation", &fb, &prev, &fits, &marches, 0);
    /* the renderer's frame stage runs again on a density change; the grid is the same. A
     * smaller scale than the marches stopped for marches again; a larger one reuses them */
    sc.medium.density = 5.0f;   /* the scene's is 8 */
    edit_and_render(r, &sc, "medium.density decrease", &fb, &prev, &fits, &marches, 1);
    sc.medium.density = 12.0f;
    edit_and_render(r, &sc, "medium.density increase", &fb, &prev, &fits, &marches, 0);
    fresh = test_render_fresh(&sc, NULL, NULL, NULL, 24, NULL);
    if (fresh) {
        /* the kept marches (run for density 5) went on past where a fresh one stops
         * (optical depth 7 at density 12), so the two differ by at most the light beyond
         * e^-7 < 1e-3 */
        double d = test_max_rel_diff(prev, fresh, VSD_PASS_COMBINED);
        printf("[4] density increase, kept transmittance vs fresh renderer: Combined max rel. diff %.3g\n", d);
        CHECK_MSG(d <= 1e-3, "kept transmittance differs from a fresh march: %g", d);
        vsd_framebuffer_destroy(fresh);
        fresh = NULL;
    }
    /* back to the scale the marches ran for: reused, and exact again (checked below) */
    sc.medium.density = 5.0f;
    edit_and_render(r, &sc, "medium.density back", &fb, &prev, &fits, &marches, 0);
    sc.medium.albedo[0] = 0.9f;
    sc.medium.albedo[1] = 0.7f;
    sc.medium.albedo[2] = 0.5f;
    edit_and_render(r, &sc, "medium.albedo change", &fb, &prev, &fits, &marches, 0);
    CHECK_MSG(fits == 1, "%g fits for one grid across camera, environment and medium edits", fits);
    /* what the edited renderer shows is what a fresh renderer shows for the edited scene
     * (the fresh one fits anew: without a cache folder nothing is shared; measured 0 when
     * the fit is reused, 0.0036 when the density change refits) */
    fresh = test_render_fresh(&sc, NULL, NULL, NULL, 24, NULL);
    if (fresh) {
        double d = test_max_rel_diff(prev, fresh, VSD_PASS_COMBINED);
        printf("[4] edited renderer vs fresh renderer: Combined max rel. diff %.3g\n", d);
        CHECK_MSG(d <= 1e-5, "edited renderer differs from a fresh one: %g", d);
    }
    /* a new frame fits (coherently, from frame 24's RBFs) */
    if (test_render(r, 25, &fb, &st)) {
        CHECK_MSG(test_info(&st, "fits_run") == fits + 1, "frame 25 (fits_run was %g): %s", fits, st.method_info);
        CHECK_NEAR(test_info(&st, "fit_cached"), 0, 0);
        CHECK(test_info(&st, "fit_evaluations") > 0);
    }
    printf("[4] edits: %.1fs; frame 25: %s\n", vsd_clock_seconds() - t0, st.method_info);
done:
    vsd_framebuffer_destroy(fb);
    vsd_framebuffer_destroy(prev);
    vsd_framebuffer_destroy(fresh);
    vsd_renderer_destroy(r);
}

/* ------------------------------------------ 2: homogeneous ball, uniform environment */

static void test_ball(void)
{
    const char *ref_ov[] = {"render.method=reference", "render.samples=2048", "render.seed=1"};
    const char *ref2_ov[] = {"render.method=reference", "render.samples=2048", "render.seed=5"};
    const char *crm_ov[] = {CRM_FAST, CRM_AREA};
    vsd_volume *vol = test_ball_volume();
    vsd_scene ref_sc, ref2_sc, crm_sc;
    vsd_framebuffer *ref = NULL, *ref2 = NULL, *crm = NULL;
    vsd_renderer *r = NULL;
    vsd_render_stats st;
    double t0 = vsd_clock_seconds();
    CHECK(vol != NULL);
    if (!vol || !test_parse_scene(test_ball_json, ref_ov, 3, &ref_sc) || !test_parse_scene(test_ball_json, ref2_ov, 3, &ref2_sc) ||
        !test_parse_scene(test_ball_json, crm_ov, 3, &crm_sc))
        goto done;
    ref = test_render_fresh(&ref_sc, NULL, vol, NULL, 1, NULL);
    ref2 = test_render_fresh(&ref2_sc, NULL, vol, NULL, 1, NULL);
    r = test_make_renderer(&crm_sc, NULL);
    if (!r || !ref || !ref2) goto done;
    vsd_renderer_use_volumes(r, vol, NULL);
    if (!test_render(r, 1, &crm, &st)) goto done;
    printf("    ball crm info: %s\n", st.method_info);
    {
        static const vsd_pass passes[3] = {VSD_PASS_COMBINED, VSD_PASS_VOLUME_DIR, VSD_PASS_VOLUME_IND};
        double noise[3], e[3];
        int k;
        for (k = 0; k < 3; k++) {
            noise[k] = test_rel_err(ref2, ref, passes[k]);
            e[k] = test_rel_err(crm, ref, passes[k]);
        }
        printf("[2] ball: noise Combined %.4f VolumeDir %.4f VolumeInd %.4f; crm Combined %.4f VolumeDir %.4f "
               "VolumeInd %.4f; VolumeInd/VolumeDir reference %.3f crm %.3f\n",
               noise[0], noise[1], noise[2], e[0], e[1], e[2],
               test_pass_sum(ref, VSD_PASS_VOLUME_IND) / test_pass_sum(ref, VSD_PASS_VOLUME_DIR),
               test_pass_sum(crm, VSD_PASS_VOLUME_IND) / test_pass_sum(crm, VSD_PASS_VOLUME_DIR));
        CHECK_MSG(e[0] < BALL_TOL_COMBINED, "ball Combined %.4f", e[0]);
        CHECK_MSG(e[1] < BALL_TOL_DIR, "ball VolumeDir %.4f", e[1]);
        CHECK_MSG(e[2] < BALL_TOL_IND, "ball VolumeInd %.4f", e[2]);
        CHECK_MSG(BALL_TOL_COMBINED > 3 * noise[0] && BALL_TOL_DIR > 3 * noise[1] && BALL_TOL_IND > 3 * noise[2],
                  "ball: noise floor too close to the tolerances: %.4f %.4f %.4f", noise[0], noise[1], noise[2]);
        {
            /* albedo 0.9 at optical radius 3: more light scattered several times than once
             * (measured VolumeInd / VolumeDir 1.386 reference, 1.424 crm) */
            double rs = test_pass_sum(ref, VSD_PASS_VOLUME_IND) / test_pass_sum(ref, VSD_PASS_VOLUME_DIR);
            double cs = test_pass_sum(crm, VSD_PASS_VOLUME_IND) / test_pass_sum(crm, VSD_PASS_VOLUME_DIR);
            CHECK_MSG(cs > 0.8 * rs && cs < 1.25 * rs, "ball VolumeInd/VolumeDir: crm %.3f, reference %.3f", cs, rs);
        }
        printf("    ball Transmittance: crm %.4f, noise %.4f; crm / reference totals: VolumeDir %.3f, VolumeInd %.3f\n",
               test_rel_err(crm, ref, VSD_PASS_TRANSMITTANCE), test_rel_err(ref2, ref, VSD_PASS_TRANSMITTANCE),
               test_pass_sum(crm, VSD_PASS_VOLUME_DIR) / test_pass_sum(ref, VSD_PASS_VOLUME_DIR),
               test_pass_sum(crm, VSD_PASS_VOLUME_IND) / test_pass_sum(ref, VSD_PASS_VOLUME_IND));
        CHECK_MSG(test_rel_err(crm, ref, VSD_PASS_TRANSMITTANCE) < 0.01, "ball Transmittance");
        test_check_pass_sum("ball", crm);
        test_check_controls("ball", crm, ref, BALL_TOL_COMBINED);
    }
    /* a uniform environment has no direction: rotating it changes nothing (here the
     * lighting stage runs again in the same renderer, and no refit) */
    {
        vsd_framebuffer *rot = NULL;
        char err[1024];
        crm_sc.environment.rotation_z = 2.1f;
        CHECK(vsd_renderer_set_scene(r, &crm_sc, err, sizeof err) == VSD_OK);
        if (test_render(r, 1, &rot, &st)) {
            double d = fmax(test_max_rel_diff(rot, crm, VSD_PASS_COMBINED),
                            fmax(test_max_rel_diff(rot, crm, VSD_PASS_VOLUME_DIR), test_max_rel_diff(rot, crm, VSD_PASS_VOLUME_IND)));
            printf("[2] ball: environment rotated by 2.1 rad: max rel. diff %.3g; %.1fs\n", d, vsd_clock_seconds() - t0);
            CHECK_MSG(d < 1e-5, "rotating a uniform environment changed crm's image by %g", d);
            CHECK_NEAR(test_info(&st, "fits_run"), 1, 0);
        }
        /* albedo 0, same renderer: no scattered light at all, the same extinction (the
         * transmittance bit for bit), and still no refit */
        crm_sc.medium.albedo[0] = crm_sc.medium.albedo[1] = crm_sc.medium.albedo[2] = 0.0f;
        CHECK(vsd_renderer_set_scene(r, &crm_sc, err, sizeof err) == VSD_OK);
        if (test_render(r, 1, &rot, &st)) {
            double mx = 0;
            size_t i, n = test_pass_floats(rot, VSD_PASS_VOLUME_DIR);
            for (i = 0; i < n; i++)
                mx = fmax(mx, fabs(rot->pass[VSD_PASS_VOLUME_DIR][i]) + fabs(rot->pass[VSD_PASS_VOLUME_IND][i]));
            printf("[2] ball at albedo 0: largest VolumeDir + VolumeInd %g\n", mx);
            /* exactly 0 but for crm's log-interpolation floor (CRM_LOG_FLOOR, 1e-12 of
             * single scattering where every node is dark; measured 1e-12) */
            CHECK_MSG(mx < 1e-9, "albedo 0: scattered light %g", mx);
            CHECK(memcmp(rot->pass[VSD_PASS_TRANSMITTANCE], crm->pass[VSD_PASS_TRANSMITTANCE],
                         test_pass_floats(rot, VSD_PASS_TRANSMITTANCE) * sizeof(float)) == 0);
            CHECK_NEAR(test_info(&st, "fits_run"), 1, 0);
        }
        vsd_framebuffer_destroy(rot);
    }
done:
    vsd_renderer_destroy(r);
    vsd_framebuffer_destroy(ref);
    vsd_framebuffer_destroy(ref2);
    vsd_framebuffer_destroy(crm);
    vsd_volume_destroy(vol);
}

/* ------------------------------------------------------------------- 5: options */

static void test_options(void)
{
    const char *bad[] = {"render.options.nope=1", "render.options.multiple=\"nope\"", "render.options.single=\"x\"",
                         "render.options.rbf_count=5000", "render.options.fit_iterations=5",
                         "render.options.directions=100", "render.options.orders=65", "render.options.step=-1"};
    const char *msg[] = {"render.options.nope", "render.options.multiple", "render.options.single",
                         "render.options.rbf_count", "render.options.fit_iterations", "render.options.directions",
                         "render.options.orders", "render.options.step"};
    int i, n = (int)(sizeof bad / sizeof bad[0]);
    for (i = 0; i < n; i++) {
        const char *ov[2] = {"render.method=crm", bad[i]};
        vsd_scene sc;
        vsd_renderer *r = NULL;
        char err[1024] = "";
        vsd_status st;
        if (!test_parse_scene("{\"version\":1,\"volume\":{\"file\":\"x.vdb\"}}", ov, 2, &sc)) continue;
        st = vsd_renderer_create(&sc, NULL, &r, err, sizeof err);
        CHECK_MSG(st != VSD_OK && r == NULL, "%s accepted", bad[i]);
        CHECK_CONTAINS(err, msg[i]);
        vsd_renderer_destroy(r);
    }
    /* and through set_scene on a live renderer */
    {
        const char *ok[1] = {"render.method=crm"}, *nope[2] = {"render.method=crm", "render.options.multiple=\"nope\""};
        vsd_scene sc, sc2;
        vsd_renderer *r = NULL;
        char err[1024] = "";
        if (test_parse_scene("{\"version\":1,\"volume\":{\"file\":\"x.vdb\"}}", ok, 1, &sc) &&
            test_parse_scene("{\"version\":1,\"volume\":{\"file\":\"x.vdb\"}}", nope, 2, &sc2)) {
            CHECK(vsd_renderer_create(&sc, NULL, &r, err, sizeof err) == VSD_OK);
            if (r) {
                CHECK(vsd_renderer_set_scene(r, &sc2, err, sizeof err) != VSD_OK);
                CHECK_CONTAINS(err, "render.options.multiple");
            }
            vsd_renderer_destroy(r);
        }
    }
}

/* --------------------------------------------------------------- 6: empty grid */

static void test_empty(void)
{
    int32_t dims[3] = {16, 16, 16}, lo[3] = {0, 0, 0};
    double m[16] = {0.1, 0, 0, 0, 0, 0.1, 0, 0, 0, 0, 0.1, 0, 0, 0, 0, 1};
    float *v = calloc(16 * 16 * 16, sizeof(float));
    vsd_volume *vol = NULL;
    vsd_scene sc;
    vsd_framebuffer *fb = NULL;
    vsd_render_stats st;
    const char *ov[] = {"render.method=crm"};
    const char *json = "{\"version\":1,\"volume\":{\"file\":\"memory.vdb\"},\"environment\":{\"color\":[1,1,1]},"
                       "\"camera\":{\"position\":[0.8,-4,0.8],\"look_at\":[0.8,0.8,0.8],\"up\":[0,0,1]},"
                       "\"film\":{\"width\":16,\"height\":16}}";
    CHECK(v && vsd_volume_create_dense(v, dims, lo, m, &vol, NULL, 0) == VSD_OK);
    free(v);
    if (!vol || !test_parse_scene(json, ov, 1, &sc)) {
        vsd_volume_destroy(vol);
        return;
    }
    remove_dir(test_tmp("crm_empty_cache"));
    fb = test_render_fresh(&sc, test_tmp("crm_empty_cache"), vol, NULL, 1, &st);
    if (fb) {
        int i, n = 16 * 16 * 3;
        double tmin = 1, dmax = 0, imax = 0, amax = 0;
        for (i = 0; i < n; i++) {
            tmin = fmin(tmin, fb->pass[VSD_PASS_TRANSMITTANCE][i]);
            dmax = fmax(dmax, fabs(fb->pass[VSD_PASS_VOLUME_DIR][i]));
            imax = fmax(imax, fabs(fb->pass[VSD_PASS_VOLUME_IND][i]));
        }
        for (i = 0; i < 16 * 16; i++) amax = fmax(amax, fabs(fb->pass[VSD_PASS_COMBINED][4 * i + 3]));
        printf("[6] empty grid: min Transmittance %g, max VolumeDir %g, VolumeInd %g, alpha %g; %s\n", tmin, dmax, imax,
               amax, st.method_info);
        CHECK(tmin == 1.0);
        CHECK(dmax == 0.0);
        CHECK(imax == 0.0);
        CHECK(amax == 0.0);
        CHECK_NEAR(test_info(&st, "fits_run"), 0, 0);
        CHECK_NEAR(test_info(&st, "rbfs"), 0, 0);
        {
            long bytes = 0;
            CHECK_MSG(damage_files(test_tmp("crm_empty_cache"), 0, &bytes) == 0, "an empty grid wrote a fit to the cache");
        }
    }
    vsd_framebuffer_destroy(fb);
    vsd_volume_destroy(vol);
    remove_dir(test_tmp("crm_empty_cache"));
}

/* fire96 in a black world at 64x36 against 256 spp: measured crm VolumeDir 0.161 and VolumeInd
 * 0.222, means 0.983 / 0.983 */
static void test_emission_split(void) { test_check_emission_split("[7]", "crm", 0.4, 0.5, 0.2, 0.25); }

/* ------------------------------------------ 8: the phase on the successive orders */
/* The ball of part 2 at g 0.7, albedo 0.95, in the sunset map turned so the sun is behind
 * it, 32x32 against reference 1024 spp: measured VolumeInd 0.063 with the phase on the
 * orders, 0.468 isotropic after the first (means 180 / 124 / reference 183), noise 0.020.
 * (Map turned by 0 / 1.57 / 4.71 rad: 0.060 / 0.081 / 0.150 against 0.268 / 0.240 / 0.631.) */
#define TOL_ORDERS_PHASE 0.10
static void test_orders_phase(void)
{
    static const char uniform[] = "\"environment\":{\"color\":[1,1,1]}";
    char json[2048];
    const char *at = strstr(test_ball_json, uniform);
#define BACKLIT "environment.rotation_z=3.14", "medium.anisotropy=0.7", "medium.albedo=[0.95,0.95,0.95]"
    const char *ref_ov[] = {BACKLIT, "render.method=reference", "render.samples=1024", "render.seed=1"};
    const char *ref2_ov[] = {BACKLIT, "render.method=reference", "render.samples=1024", "render.seed=5"};
    const char *hg_ov[] = {BACKLIT, "render.method=crm", CRM_FAST, CRM_AREA, "render.options.orders_phase=hg"};
    const char *iso_ov[] = {BACKLIT, "render.method=crm", CRM_FAST, CRM_AREA, "render.options.orders_phase=isotropic"};
#undef BACKLIT
    vsd_volume *vol = test_ball_volume();
    vsd_scene sc[4];
    vsd_framebuffer *ref = NULL, *ref2 = NULL, *hg = NULL, *iso = NULL;
    /* a volume that failed to build fails the part, as every setup step here does */
    CHECK(vol != NULL);
    /* the ball of part 2 in the sunset map instead of the uniform one */
    CHECK(at != NULL);
    if (!at) goto done;
    snprintf(json, sizeof json, "%.*s\"environment\":{\"file\":\"%s\"}%s", (int)(at - test_ball_json), test_ball_json,
             test_data("env/sunset.exr"), at + strlen(uniform));
    if (!vol || !test_parse_scene(json, ref_ov, 6, &sc[0]) || !test_parse_scene(json, ref2_ov, 6, &sc[1]) ||
        !test_parse_scene(json, hg_ov, 8, &sc[2]) || !test_parse_scene(json, iso_ov, 8, &sc[3]))
        goto done;
    ref = test_render_fresh(&sc[0], NULL, vol, NULL, 1, NULL);
    ref2 = test_render_fresh(&sc[1], NULL, vol, NULL, 1, NULL);
    hg = test_render_fresh(&sc[2], NULL, vol, NULL, 1, NULL);
    iso = test_render_fresh(&sc[3], NULL, vol, NULL, 1, NULL);
    if (ref && ref2 && hg && iso) {
        double e = test_rel_err(hg, ref, VSD_PASS_VOLUME_IND), c = test_rel_err(iso, ref, VSD_PASS_VOLUME_IND);
        double noise = test_rel_err(ref2, ref, VSD_PASS_VOLUME_IND);
        printf("[8] ball in the sunset map, g 0.7: VolumeInd with the phase on the orders %.4f, isotropic orders %.4f, "
               "reference noise %.4f (means %.4g / %.4g / %.4g)\n",
               e, c, noise, test_pass_sum(hg, VSD_PASS_VOLUME_IND), test_pass_sum(iso, VSD_PASS_VOLUME_IND),
               test_pass_sum(ref, VSD_PASS_VOLUME_IND));
        CHECK_MSG(e < TOL_ORDERS_PHASE, "VolumeInd with the phase on the orders %.4f >= %.2f", e, TOL_ORDERS_PHASE);
        CHECK_MSG(c > TOL_ORDERS_PHASE, "isotropic orders (%.4f) pass the tolerance the phase must meet", c);
        CHECK_MSG(TOL_ORDERS_PHASE > 3 * noise, "reference noise %.4f too close to the tolerance", noise);
    }
done:
    vsd_framebuffer_destroy(ref);
    vsd_framebuffer_destroy(ref2);
    vsd_framebuffer_destroy(hg);
    vsd_framebuffer_destroy(iso);
    vsd_volume_destroy(vol);
}

int main(void)
{
    double t0 = vsd_clock_seconds();
    test_emission_split();
    test_options();
    test_empty();
    test_ball();
    test_edits();
    test_real_data_and_cache();
    test_orders_phase();
    printf("test_crm: %.1fs\n", vsd_clock_seconds() - t0);
    return test_finish("test_crm");
}
