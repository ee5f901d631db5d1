/* method_vs_reference.c — the method-vs-reference harness (method_vs_reference.h). */
#include "method_vs_reference.h"
#include "test_common.h"
#include "test_render_util.h"
#include "vsd/compare.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { MVR_MAX_OV = 32 };

static int load(const mvr_scene *s, const char *const *ov, int nov, vsd_scene *sc)
{
    return s->file ? test_load_scene(s->file, ov, nov, sc) : test_parse_scene(s->json, ov, nov, sc);
}

vsd_framebuffer *mvr_render(const mvr_scene *s, const char *const *ov, int nov, const char *cache_dir,
                            vsd_render_stats *stats)
{
    vsd_scene sc;
    if (!load(s, ov, nov, &sc)) return NULL;
    return test_render_fresh(&sc, cache_dir, s->vol, s->env, s->frame, stats);
}

int mvr_render_references(const mvr_scene *s, const char *const *ov, int nov, int spp, mvr_refs *refs)
{
    static const char *const seeds[2] = {"render.seed=1", "render.seed=7"};
    const char *all[MVR_MAX_OV + 3];
    char samples[64];
    char err[256] = "";
    int k, i;
    memset(refs, 0, sizeof *refs);
    refs->spp = spp;
    CHECK(nov <= MVR_MAX_OV);
    if (nov > MVR_MAX_OV) return 0;
    snprintf(samples, sizeof samples, "render.samples=%d", spp);
    for (i = 0; i < nov; i++) all[i] = ov[i];
    all[nov] = "render.method=reference";
    all[nov + 1] = samples;
    for (k = 0; k < 2; k++) {
        vsd_framebuffer *fb;
        all[nov + 2] = seeds[k];
        fb = mvr_render(s, all, nov + 3, NULL, NULL);
        CHECK_MSG(fb != NULL, "reference (%s) did not render", seeds[k]);
        if (!fb) return 0;
        if (k == 0) refs->a = fb;
        else refs->b = fb;
    }
    CHECK(vsd_framebuffer_create(refs->a->width, refs->a->height, &refs->mean, err, sizeof err) == VSD_OK);
    if (!refs->mean) return 0;
    for (k = 0; k < VSD_PASS_COUNT; k++) {
        size_t n = test_pass_floats(refs->a, (vsd_pass)k), j;
        for (j = 0; j < n; j++) refs->mean->pass[k][j] = 0.5f * (refs->a->pass[k][j] + refs->b->pass[k][j]);
    }
    return 1;
}

void mvr_refs_free(mvr_refs *refs)
{
    vsd_framebuffer_destroy(refs->a);
    vsd_framebuffer_destroy(refs->b);
    vsd_framebuffer_destroy(refs->mean);
    memset(refs, 0, sizeof *refs);
}

static double rel_planes(const float *img, const mvr_refs *refs, vsd_pass p)
{
    double e = 1e9;
    int ch = vsd_pass_channels(p);
    char err[256] = "";
    CHECK_MSG(vsd_block_rel_rmse(img, refs->mean->pass[p], refs->mean->width, refs->mean->height, ch, ch, 4, &e, err,
                                 sizeof err) == VSD_OK,
              "%s: %s", vsd_pass_name(p), err);
    return e;
}

double mvr_error(const vsd_framebuffer *img, const mvr_refs *refs, vsd_pass p)
{
    return rel_planes(img->pass[p], refs, p);
}

double mvr_noise(const mvr_refs *refs, vsd_pass p) { return rel_planes(refs->a->pass[p], refs, p); }

mvr_result mvr_check(const char *what, const vsd_framebuffer *method, const mvr_refs *refs, vsd_pass p, double tol,
                     double control_scale)
{
    mvr_result r;
    size_t n = test_pass_floats(method, p), i;
    float *ctl = malloc(n * sizeof *ctl);
    int ch = vsd_pass_channels(p);
    memset(&r, 0, sizeof r);
    r.tol = tol;
    r.err = mvr_error(method, refs, p);
    r.noise = mvr_noise(refs, p);
    r.control = 0;
    if (ctl) {
        /* the pass scaled, alpha (Combined's 4th channel) kept */
        for (i = 0; i < n; i++) ctl[i] = ch == 4 && i % 4 == 3 ? method->pass[p][i] : (float)control_scale * method->pass[p][i];
        r.control = rel_planes(ctl, refs, p);
        free(ctl);
    }
    printf("    [mvr] %s %s: error %.4f, reference noise %.4f (2 x %d spp; 3x = %.4f), tolerance %.3f, "
           "control x%.2f %.4f\n",
           what, vsd_pass_name(p), r.err, r.noise, refs->spp, 3.0 * r.noise, tol, control_scale, r.control);
    CHECK_MSG(r.err < tol, "%s %s: error %.4f >= tolerance %.3f (reference noise %.4f)", what, vsd_pass_name(p), r.err,
              tol, r.noise);
    CHECK_MSG(tol >= 3.0 * r.noise,
              "%s %s: tolerance %.3f below 3x the reference noise %.4f: the check would score the reference's noise",
              what, vsd_pass_name(p), tol, r.noise);
    CHECK_MSG(r.control >= tol, "%s %s cannot fail: control (pass x%.2f) scores %.4f, under the tolerance %.3f", what,
              vsd_pass_name(p), control_scale, r.control, tol);
    r.ok = r.err < tol && tol >= 3.0 * r.noise && r.control >= tol;
    return r;
}

double mvr_check_control(const char *what, const char *control, const float *planes, const mvr_refs *refs, vsd_pass p,
                         double tol)
{
    double e = rel_planes(planes, refs, p);
    CHECK_MSG(e >= tol, "%s %s cannot fail: control \"%s\" scores %.4f, under the tolerance %.3f", what,
              vsd_pass_name(p), control, e, tol);
    return e;
}

void mvr_check_scattering_controls(const char *what, const vsd_framebuffer *method, const mvr_refs *refs, double tol)
{
    static const float keep_ind[3] = {0.0f, 0.5f, -1.0f}; /* -1: no scattered light at all */
    static const char *const names[3] = {"no multiple scattering", "half the multiple scattering", "albedo 0"};
    size_t n = (size_t)method->width * method->height;
    float *img = malloc(n * 4 * sizeof(float));
    double e[3] = {0, 0, 0};
    int k;
    test_check_pass_sum(what, method);
    CHECK(img != NULL);
    if (!img) return;
    for (k = 0; k < 3; k++) {
        test_scattering_control(method, keep_ind[k], img);
        e[k] = mvr_check_control(what, names[k], img, refs, VSD_PASS_COMBINED, tol);
    }
    free(img);
    printf("    [mvr] %s controls, Combined: no multiple %.4f, half multiple %.4f, albedo 0 %.4f (tolerance %.3f)\n",
           what, e[0], e[1], e[2], tol);
}
