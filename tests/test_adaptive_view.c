/* test_adaptive_view.c — adaptive view sampling (src/method/adaptive_view.c), through lbl,
 * shgrid and constellation (the record grid's view) on the homogeneous ball (its silhouette
 * is a hard edge) and crm on smoke64:
 *   1. at 256x256 the automatic spacing is 4 (a voxel covers ~9 pixels) and the image is
 *      within 1% (Combined, alpha) of tracing every pixel, while under half the pixels are
 *      traced, and for lbl fewer than when a flagged block was traced whole (0.224 of the
 *      pixels; the halving, adaptive_view.c: 0.204); view_spacing 1 traces every pixel and
 *      reports nothing;
 *   2. every anchor pixel is bit for bit the traced one, and a huge threshold (interpolate
 *      everything) fails the 1% bound: the threshold is what keeps the silhouette;
 *   3. odd sizes (1x1, 5x3, 7x1, 1x6, 9x9) with spacing 4 forced render every pixel: anchors
 *      exact, every value finite, alpha in [0, 1] (at these sizes a forced spacing can miss
 *      the ball between anchors: that is what the automatic spacing prevents);
 *   4. the automatic spacing is 1 at the low resolutions the other tests use (96x54);
 *   5. a kept renderer's view after another view is a fresh renderer's bit for bit, every
 *      pass, adaptive (spacing 4) and traced (spacing 1), the ball growing and shrinking on
 *      the film: neither the film nor the view's sums are cleared between views (the
 *      adaptive view writes every pixel and reads back only the sums it wrote), so a stale
 *      pixel or sum would show here. */
#include "test_common.h"
#include "test_render_util.h"
#include <math.h>
#include <stdio.h>
#include <string.h>

static vsd_framebuffer *ball_by(const char *method, const vsd_volume *vol, int w, int h, const char *spacing,
                                const char *threshold, vsd_render_stats *st)
{
    char ws[64], hs[64], ms[64];
    const char *ov[] = {ms, ws, hs, spacing, threshold};
    vsd_scene sc;
    snprintf(ms, sizeof ms, "render.method=%s", method);
    snprintf(ws, sizeof ws, "film.width=%d", w);
    snprintf(hs, sizeof hs, "film.height=%d", h);
    if (!test_parse_scene(test_ball_json, ov, threshold ? 5 : 4, &sc)) return NULL;
    return test_render_fresh(&sc, NULL, vol, NULL, 1, st);
}

static vsd_framebuffer *ball(const vsd_volume *vol, int w, int h, const char *spacing, const char *threshold,
                             vsd_render_stats *st)
{
    return ball_by("lbl", vol, w, h, spacing, threshold, st);
}

/* every pixel at (multiple of s or the last, multiple of s or the last) equal in every pass */
static int anchors_equal(const vsd_framebuffer *a, const vsd_framebuffer *b, int s)
{
    int x, y, p;
    for (y = 0; y < a->height; y++)
        for (x = 0; x < a->width; x++) {
            if (!((x % s == 0 || x == a->width - 1) && (y % s == 0 || y == a->height - 1))) continue;
            for (p = 0; p < VSD_PASS_COUNT; p++) {
                int ch = vsd_pass_channels((vsd_pass)p), c;
                for (c = 0; c < ch; c++) {
                    size_t i = ((size_t)y * a->width + x) * ch + c;
                    if (memcmp(&a->pass[p][i], &b->pass[p][i], sizeof(float)) != 0) return 0;
                }
            }
        }
    return 1;
}

/* max |a - b| over alpha, and the block relative error of Combined */
static void errors(const vsd_framebuffer *a, const vsd_framebuffer *b, double *combined, double *alpha_max)
{
    size_t i, n = (size_t)a->width * a->height;
    *alpha_max = 0.0;
    for (i = 0; i < n; i++)
        *alpha_max = fmax(*alpha_max, fabs(a->pass[VSD_PASS_COMBINED][4 * i + 3] - b->pass[VSD_PASS_COMBINED][4 * i + 3]));
    *combined = test_rel_err_planes(a->pass[VSD_PASS_COMBINED], b->pass[VSD_PASS_COMBINED], a->width, a->height, 4);
}

static void test_ball(const vsd_volume *vol, const char *method)
{
    vsd_render_stats st_auto, st_full, st_all;
    vsd_framebuffer *full = ball_by(method, vol, 256, 256, "render.options.view_spacing=1", NULL, &st_full);
    vsd_framebuffer *adapt = ball_by(method, vol, 256, 256, "render.options.view_spacing=0", NULL, &st_auto);
    vsd_framebuffer *loose = ball_by(method, vol, 256, 256, "render.options.view_spacing=4",
                                     "render.options.view_threshold=1", &st_all);
    double e, amax, adapt_amax;
    if (!full || !adapt || !loose) goto done;
    printf("[1] %s, ball 256x256: %s\n", method, st_auto.method_info);
    CHECK_MSG(test_info(&st_auto, "view_spacing") == 4, "automatic spacing %g, expected 4",
              test_info(&st_auto, "view_spacing"));
    CHECK_MSG(test_info(&st_auto, "view_traced") < 0.5, "traced %g of the pixels", test_info(&st_auto, "view_traced"));
    CHECK_MSG(strcmp(method, "lbl") || test_info(&st_auto, "view_traced") < 0.215,
              "lbl traced %g of the pixels: no fewer than whole flagged blocks (0.224)", test_info(&st_auto, "view_traced"));
    CHECK_MSG(!strstr(st_full.method_info, "view_traced"), "view_spacing 1 reported adaptive sampling: %s",
              st_full.method_info);
    errors(adapt, full, &e, &amax);
    adapt_amax = amax;
    printf("    adaptive against every pixel traced: Combined %.5f, alpha at most %.4f off\n", e, amax);
    CHECK_MSG(e < 0.01, "%s: Combined %.4f", method, e);
    CHECK_MSG(test_rel_err(adapt, full, VSD_PASS_VOLUME_DIR) < 0.01 &&
                  (strcmp(method, "lbl") || test_rel_err(adapt, full, VSD_PASS_VOLUME_IND) < 0.01),
              "%s: VolumeDir / VolumeInd off by more than 1%%", method);
    CHECK_MSG(anchors_equal(adapt, full, 4), "%s: an anchor pixel differs from the traced one", method);
    errors(loose, full, &e, &amax);
    printf("[2] threshold 1 (everything interpolated): Combined %.5f, alpha at most %.4f off, traced %g\n", e, amax,
           test_info(&st_all, "view_traced"));
    /* (the silhouette's alpha: lbl 0.0185 against 0.109, shgrid and constellation, whose
       blocks are traced on their single scattering alone, 0.029 against 0.109) */
    CHECK_MSG(e > 0.01 && amax > 3 * adapt_amax,
              "%s: interpolating every block still passed (%.4f, alpha %.4f): the test cannot fail", method, e, amax);
done:
    vsd_framebuffer_destroy(full);
    vsd_framebuffer_destroy(adapt);
    vsd_framebuffer_destroy(loose);
}

static void test_odd_sizes(const vsd_volume *vol)
{
    static const int sizes[][2] = {{1, 1}, {5, 3}, {7, 1}, {1, 6}, {9, 9}};
    size_t k;
    printf("[3] odd sizes with spacing 4\n");
    for (k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        vsd_framebuffer *full = ball(vol, sizes[k][0], sizes[k][1], "render.options.view_spacing=1", NULL, NULL);
        vsd_framebuffer *adapt = ball(vol, sizes[k][0], sizes[k][1], "render.options.view_spacing=4", NULL, NULL);
        if (full && adapt) {
            size_t q, n = (size_t)sizes[k][0] * sizes[k][1];
            int finite = 1;
            for (q = 0; q < 4 * n; q++) finite &= isfinite(adapt->pass[VSD_PASS_COMBINED][q]) &&
                                            (q % 4 != 3 || (adapt->pass[VSD_PASS_COMBINED][q] >= 0.0f &&
                                                            adapt->pass[VSD_PASS_COMBINED][q] <= 1.0f));
            printf("    %dx%d: anchors %s, values %s\n", sizes[k][0], sizes[k][1],
                   anchors_equal(adapt, full, 4) ? "exact" : "DIFFER", finite ? "finite" : "NOT FINITE");
            CHECK_MSG(anchors_equal(adapt, full, 4), "%dx%d: an anchor differs", sizes[k][0], sizes[k][1]);
            CHECK_MSG(finite, "%dx%d: a value is not finite or alpha is outside [0, 1]", sizes[k][0], sizes[k][1]);
        }
        vsd_framebuffer_destroy(full);
        vsd_framebuffer_destroy(adapt);
    }
}

static void test_auto_low_res(void)
{
    const char *ov[] = {"frames.start=24", "frames.end=24", "film.width=96", "film.height=54", "render.method=crm"};
    vsd_scene sc;
    vsd_render_stats st;
    vsd_framebuffer *fb;
    if (!test_load_scene("scenes/smoke64_sunset.json", ov, 5, &sc)) return;
    fb = test_render_fresh(&sc, NULL, NULL, NULL, 24, &st);
    printf("[4] smoke64 at 96x54 with crm: %s\n", fb ? st.method_info : "-");
    CHECK_MSG(fb && !strstr(st.method_info, "view_traced"), "adaptive sampling at 96x54: %s", st.method_info);
    vsd_framebuffer_destroy(fb);
}

/* the ball from the test scene's camera, or closer and from the side (its silhouette
 * elsewhere on the film) */
static int ball_view(int near, const char *spacing, vsd_scene *sc)
{
    const char *ov[] = {"render.method=lbl", "film.width=160", "film.height=120", spacing,
                        "camera.position=[-3,-2.5,1.4]", "camera.ortho_scale=1.2"};
    return test_parse_scene(test_ball_json, ov, near ? 6 : 4, sc);
}

static void test_kept_renderer(const vsd_volume *vol)
{
    static const char *const spacings[] = {"render.options.view_spacing=4", "render.options.view_spacing=1"};
    size_t k;
    int order;
    for (k = 0; k < 2; k++)
        for (order = 0; order < 2; order++) {
            vsd_scene first, second;
            vsd_renderer *r;
            vsd_framebuffer *kept = NULL, *fresh = NULL;
            char err[256] = "";
            if (!ball_view(order, spacings[k], &first) || !ball_view(!order, spacings[k], &second)) continue;
            fresh = test_render_fresh(&second, NULL, vol, NULL, 1, NULL);
            if ((r = test_make_renderer(&first, NULL))) {
                vsd_renderer_use_volume(r, 0, vol, NULL, NULL);
                if (test_render(r, 1, &kept, NULL)) {
                    CHECK_MSG(vsd_renderer_set_scene(r, &second, err, sizeof err) == VSD_OK, "set_scene: %s", err);
                    test_render(r, 1, &kept, NULL);
                }
                vsd_renderer_destroy(r);
            }
            printf("[5] %s, the ball %s: the kept renderer's second view %s the fresh one's\n", spacings[k],
                   order ? "shrinking" : "growing", kept && fresh && test_identical(kept, fresh) ? "is" : "is NOT");
            CHECK_MSG(kept && fresh && test_identical(kept, fresh), "%s: a kept renderer's view differs from a fresh one's",
                      spacings[k]);
            vsd_framebuffer_destroy(kept);
            vsd_framebuffer_destroy(fresh);
        }
}

int main(void)
{
    vsd_volume *vol = test_ball_volume();
    if (vol) {
        test_ball(vol, "lbl");
        test_ball(vol, "shgrid");
        test_ball(vol, "constellation");
        test_odd_sizes(vol);
        test_kept_renderer(vol);
    }
    vsd_volume_destroy(vol);
    test_auto_low_res();
    return test_finish("test_adaptive_view");
}
