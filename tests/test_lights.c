/* test_lights.c — the scene's extra lights (lights[]: sun, point, spot; kernel/kernel_lights.h):
 *   1. `reference`'s single scattering (VolumeDir) from each light type in a thin
 *      homogeneous box, black world, against a quadrature of the single-scattering integral
 *      written here from the definitions (Cycles' units: a sun's strength is irradiance, a
 *      point's power P is P / 4pi W/sr, a sphere light of radius r has radiance I / (pi r^2),
 *      a spot is a point times the cosine to its axis smoothed over spot_blend, or without
 *      the cosine with spot_cosine false, as Cycles 4.2+ shapes it);
 *   2. `lbl` against `reference` with a point light, a spot and a sun over the homogeneous
 *      ball (single and multiple scattering), black world;
 *   3. moving a light in a renderer re-runs the lighting: the image equals a fresh render of
 *      the moved scene;
 *   4. the errors: a method that does not render lights names the ones that do; lights
 *      through a refracting medium are refused. */
#include "test_common.h"
#include "test_render_util.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846

/* The box [0,2]^3 of density 1 (32^3 voxels of 1/16; the trilinear ramp at the faces is
 * half a voxel wide on each side of them, so its integral is that of the sharp box). */
static vsd_volume *box_volume(void)
{
    int32_t dims[3] = {32, 32, 32}, lo[3] = {0, 0, 0};
    double m[16] = {1.0 / 16, 0, 0, 1.0 / 32, 0, 1.0 / 16, 0, 1.0 / 32, 0, 0, 1.0 / 16, 1.0 / 32, 0, 0, 0, 1};
    float *v = malloc(32 * 32 * 32 * sizeof *v);
    vsd_volume *vol = NULL;
    int i;
    if (!v) return NULL;
    for (i = 0; i < 32 * 32 * 32; i++) v[i] = 1.0f;
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &vol, NULL, 0) == VSD_OK);
    free(v);
    return vol;
}

/* sigma 0.15 (optical depth 0.3 across), albedo 0.8, g 0.3; the camera looks along +y at
 * the middle of the box's -y face, 8x8 pixels over x, z in [0.6, 1.4]. */
#define SIGMA 0.15
#define ALBEDO 0.8
#define G 0.3
static const char *const box_json =
    "{\"version\":1,\"volume\":{\"file\":\"memory.vdb\"},"
    "\"medium\":{\"density\":0.15,\"albedo\":[0.8,0.8,0.8],\"anisotropy\":0.3},"
    "\"environment\":{\"color\":[0,0,0]},"
    "\"camera\":{\"type\":\"orthographic\",\"ortho_scale\":0.8,\"position\":[1,-3,1],"
    "\"look_at\":[1,1,1],\"up\":[0,0,1]},"
    "\"film\":{\"width\":8,\"height\":8},\"render\":{\"method\":\"reference\",\"samples\":4096}}";

/* Length of the segment a -> b inside [0,2]^3. */
static double inside_length(const double a[3], const double b[3])
{
    double t0 = 0.0, t1 = 1.0, d[3];
    int k;
    for (k = 0; k < 3; k++) {
        d[k] = b[k] - a[k];
        if (fabs(d[k]) < 1e-15) {
            if (a[k] < 0.0 || a[k] > 2.0) return 0.0;
            continue;
        }
        {
            double ta = (0.0 - a[k]) / d[k], tb = (2.0 - a[k]) / d[k];
            if (ta > tb) { double s = ta; ta = tb; tb = s; }
            t0 = fmax(t0, ta);
            t1 = fmin(t1, tb);
        }
    }
    return t1 > t0 ? (t1 - t0) * sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) : 0.0;
}

static double hg(double c, double g) { return (1 - g * g) / (4 * PI_D * pow(1 + g * g - 2 * g * c, 1.5)); }

typedef struct test_light {
    int type;             /* 0 sun, 1 point, 2 spot */
    double value;         /* sun strength, point power */
    double pos[3], dir[3];/* dir: the direction the light travels */
    double radius, spot_size, spot_blend;
    int no_cosine;        /* spot: spot_cosine false (Cycles 4.2+): no cosine to the axis */
} test_light;

/* Radiance / pdf toward the light from x (light's direction into *w, distance into *dist),
 * from the definitions above. */
static double light_at(const test_light *l, const double x[3], double w[3], double *dist)
{
    int k;
    if (l->type == 0) {
        for (k = 0; k < 3; k++) w[k] = -l->dir[k];
        *dist = 10.0;   /* beyond the box */
        return l->value;
    } else {
        double c[3], d2 = 0, d, I = l->value / (4 * PI_D), e;
        for (k = 0; k < 3; k++) {
            c[k] = l->pos[k] - x[k];
            d2 += c[k] * c[k];
        }
        d = sqrt(d2);
        for (k = 0; k < 3; k++) w[k] = c[k] / d;
        *dist = d;
        if (l->radius > 0) /* radiance I / (pi r^2) over the solid angle 2 pi (1 - cos max) */
            e = I / (PI_D * l->radius * l->radius) * 2 * PI_D * (1 - sqrt(1 - l->radius * l->radius / d2));
        else
            e = I / d2;
        if (l->type == 2) {
            double cs = -(w[0] * l->dir[0] + w[1] * l->dir[1] + w[2] * l->dir[2]), ca = cos(0.5 * l->spot_size);
            double band = (1 - ca) * l->spot_blend, t = cs - ca;
            double mask = l->no_cosine ? 1.0 : cs;
            if (t <= 0) return 0.0;
            if (t < band) {
                double s = t / band;
                mask *= s * s * (3 - 2 * s);
            }
            e *= mask;
        }
        return e;
    }
}

/* The light reaching x from l times the phase toward the view ray (+y) and the
 * transmittance: for a sphere light, its radiance I / (pi r^2) integrated over 8x8 strata
 * of its cone of directions, each to the sphere's near side. */
static double lit(const test_light *l, const double x[3])
{
    double w[3], dist, q[3], e = light_at(l, x, w, &dist);
    int k, i, j;
    if (e <= 0) return 0.0;
    if (l->type != 0 && l->radius > 0) {
        double d2 = dist * dist, cos_max = sqrt(1 - l->radius * l->radius / d2), L, sum = 0.0, t[3], b[3], n;
        double I = l->value / (4 * PI_D);
        L = I / (PI_D * l->radius * l->radius);
        /* a frame around w */
        t[0] = fabs(w[0]) < 0.9 ? 0 : -w[2];
        t[1] = fabs(w[0]) < 0.9 ? w[2] : 0;
        t[2] = fabs(w[0]) < 0.9 ? -w[1] : w[0];
        n = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
        for (k = 0; k < 3; k++) t[k] /= n;
        b[0] = w[1] * t[2] - w[2] * t[1];
        b[1] = w[2] * t[0] - w[0] * t[2];
        b[2] = w[0] * t[1] - w[1] * t[0];
        for (i = 0; i < 8; i++)
            for (j = 0; j < 8; j++) {
                double ct = 1 - (i + 0.5) / 8 * (1 - cos_max), st = sqrt(1 - ct * ct), ph = 2 * PI_D * (j + 0.5) / 8, v[3];
                double s, hit;
                for (k = 0; k < 3; k++) v[k] = ct * w[k] + st * (cos(ph) * t[k] + sin(ph) * b[k]);
                s = l->radius * l->radius - d2 * (1 - ct * ct);
                hit = dist * ct - sqrt(s > 0 ? s : 0);
                for (k = 0; k < 3; k++) q[k] = x[k] + v[k] * hit;
                sum += hg(v[1], G) * exp(-SIGMA * inside_length(x, q));
            }
        return L * 2 * PI_D * (1 - cos_max) * sum / 64;
    }
    for (k = 0; k < 3; k++) q[k] = x[k] + w[k] * dist;
    /* the view ray travels along +y: the phase's cosine is d . w */
    return e * hg(w[1], G) * exp(-SIGMA * inside_length(x, q));
}

/* VolumeDir of pixel (px, py): the single-scattering integral along the view rays through a
 * 4x4 grid in the pixel, 200 midpoints each along y in [0, 2]. */
static double expected_pixel(const test_light *l, int px, int py)
{
    double sum = 0.0;
    int sx, sy, i;
    for (sy = 0; sy < 4; sy++)
        for (sx = 0; sx < 4; sx++) {
            double x = 0.6 + 0.1 * (px + (sx + 0.5) / 4), z = 1.4 - 0.1 * (py + (sy + 0.5) / 4);
            for (i = 0; i < 200; i++) {
                double y = (i + 0.5) * (2.0 / 200), p[3] = {x, y, z};
                sum += ALBEDO * SIGMA * exp(-SIGMA * y) * lit(l, p) * (2.0 / 200);
            }
        }
    return sum / 16.0;
}

static const char *light_json(const test_light *l, char *buf, size_t n)
{
    if (l->type == 0)
        snprintf(buf, n, "lights=[{\"type\":\"sun\",\"strength\":%g,\"direction\":[%g,%g,%g]}]", l->value, l->dir[0],
                 l->dir[1], l->dir[2]);
    else if (l->type == 1)
        snprintf(buf, n, "lights=[{\"type\":\"point\",\"power\":%g,\"position\":[%g,%g,%g],\"radius\":%g}]", l->value,
                 l->pos[0], l->pos[1], l->pos[2], l->radius);
    else
        snprintf(buf, n,
                 "lights=[{\"type\":\"spot\",\"power\":%g,\"position\":[%g,%g,%g],\"radius\":%g,\"direction\":[%g,%g,%g],"
                 "\"spot_size\":%g,\"spot_blend\":%g,\"spot_cosine\":%s}]",
                 l->value, l->pos[0], l->pos[1], l->pos[2], l->radius, l->dir[0], l->dir[1], l->dir[2], l->spot_size,
                 l->spot_blend, l->no_cosine ? "false" : "true");
    return buf;
}

static void test_single_scattering(void)
{
    /* a point above the box, a sphere light beside it, a spot from the side whose soft cone
     * edge crosses the picture, a sun from an oblique direction */
    const test_light lights[] = {
        {1, 500.0, {1.0, 1.0, 3.0}, {0, 0, 0}, 0.0, 0, 0, 0},
        {1, 500.0, {3.0, 1.2, 1.1}, {0, 0, 0}, 0.6, 0, 0, 0},
        {2, 800.0, {-1.5, 1.0, 1.0}, {1.0, 0.0, 0.0}, 0.0, 0.35, 0.5, 0},
        {0, 3.0, {0, 0, 0}, {0.48, 0.6, -0.64}, 0.0, 0, 0, 0},
        {2, 800.0, {-1.5, 1.0, 1.0}, {1.0, 0.0, 0.0}, 0.0, 1.2, 0.5, 1},
    };
    static const char *const names[] = {"point above", "sphere light (r 0.6) beside", "spot, soft edge", "sun",
                                        "spot, wide, no cosine (4.2+)"};
    vsd_volume *vol = box_volume();
    size_t li;
    if (!vol) return;
    printf("[1] reference's single scattering against the quadrature (box, sigma %.2f, g %.1f)\n", SIGMA, G);
    for (li = 0; li < sizeof lights / sizeof lights[0]; li++) {
        char lj[512];
        const char *ov[2];
        vsd_scene sc;
        vsd_framebuffer *fb;
        double num = 0, den = 0, tot_r = 0, tot_e = 0, worst = 0;
        int x, y;
        ov[0] = light_json(&lights[li], lj, sizeof lj);
        ov[1] = "render.samples=16384";
        if (!test_parse_scene(box_json, ov, 2, &sc)) continue;
        if (!(fb = test_render_fresh(&sc, NULL, vol, NULL, 1, NULL))) continue;
        for (y = 0; y < 8; y++)
            for (x = 0; x < 8; x++) {
                double e = expected_pixel(&lights[li], x, y), r = fb->pass[VSD_PASS_VOLUME_DIR][3 * (y * 8 + x)];
                num += (r - e) * (r - e);
                den += e * e;
                tot_r += r;
                tot_e += e;
                if (e > 0) worst = fmax(worst, fabs(r - e) / e);
                if (getenv("VSD_TEST_VERBOSE")) printf("      (%d,%d) %.5f %.5f\n", x, y, r, e);
            }
        printf("    %-28s mean %.5f, expected %.5f (%+.2f%%), RMS %.2f%%, worst pixel %.1f%%\n", names[li], tot_r / 64,
               tot_e / 64, 100 * (tot_r / tot_e - 1), 100 * sqrt(num / den), 100 * worst);
        CHECK_MSG(tot_e > 0 && fabs(tot_r / tot_e - 1) < 0.01, "%s: mean %.5f, expected %.5f", names[li], tot_r / 64,
                  tot_e / 64);
        /* 16384 spp: per-pixel noise 1-3% (4% at the spot's dim edge) */
        CHECK_MSG(sqrt(num / den) < 0.04, "%s: RMS %.3f", names[li], sqrt(num / den));
        vsd_framebuffer_destroy(fb);
    }
    vsd_volume_destroy(vol);
}

/* lbl against reference over the homogeneous ball (optical radius 3, albedo 0.9) in a black
 * world, lit by a point, a spot and a sun at once. */
static void test_lbl(void)
{
    const char *lights =
        "lights=[{\"type\":\"point\",\"power\":300,\"position\":[3,-1,2.5]},"
        "{\"type\":\"spot\",\"power\":600,\"position\":[-1.5,1,1],\"direction\":[1,0,0.1],\"spot_size\":0.6,"
        "\"spot_blend\":0.3},"
        "{\"type\":\"sun\",\"strength\":2,\"color\":[1,0.8,0.6],\"direction\":[0.3,0.4,-0.866]}]";
    const char *ref_ov[] = {"environment.color=[0,0,0]", lights, "render.method=reference", "render.samples=1024",
                            "render.seed=1"};
    const char *ref2_ov[] = {"environment.color=[0,0,0]", lights, "render.method=reference", "render.samples=1024",
                             "render.seed=9"};
    const char *lbl_ov[] = {"environment.color=[0,0,0]", lights, "render.method=lbl"};
    static const vsd_pass passes[3] = {VSD_PASS_COMBINED, VSD_PASS_VOLUME_DIR, VSD_PASS_VOLUME_IND};
    static const char *const pass_names[3] = {"Combined", "VolumeDir", "VolumeInd"};
    /* measured when written: Combined 0.048, VolumeDir 0.046, VolumeInd 0.108 (reference noise
     * 0.009 / 0.016 / 0.022) */
    const double tol[3] = {0.08, 0.08, 0.15};
    vsd_volume *vol = test_ball_volume();
    vsd_scene ref_sc, ref2_sc, lbl_sc;
    vsd_framebuffer *ref = NULL, *ref2 = NULL, *lbl = NULL;
    int k;
    if (!vol || !test_parse_scene(test_ball_json, ref_ov, 5, &ref_sc) ||
        !test_parse_scene(test_ball_json, ref2_ov, 5, &ref2_sc) || !test_parse_scene(test_ball_json, lbl_ov, 3, &lbl_sc))
        goto done;
    ref = test_render_fresh(&ref_sc, NULL, vol, NULL, 1, NULL);
    ref2 = test_render_fresh(&ref2_sc, NULL, vol, NULL, 1, NULL);
    lbl = test_render_fresh(&lbl_sc, NULL, vol, NULL, 1, NULL);
    if (!ref || !ref2 || !lbl) goto done;
    printf("[2] lbl against reference: ball, point + spot + sun, black world\n");
    for (k = 0; k < 3; k++) {
        double e = test_rel_err(lbl, ref, passes[k]), noise = test_rel_err(ref2, ref, passes[k]);
        printf("    %s: lbl %.4f (means %.4g / %.4g), reference noise %.4f, tolerance %.2f\n", pass_names[k], e,
               test_pass_sum(lbl, passes[k]) / 1024, test_pass_sum(ref, passes[k]) / 1024, noise, tol[k]);
        CHECK_MSG(e < tol[k], "lbl %s: %.4f >= %.2f", pass_names[k], e, tol[k]);
        CHECK_MSG(tol[k] > 3 * noise, "%s: reference noise %.4f too close to the tolerance", pass_names[k], noise);
    }
    test_check_controls("lbl, lights", lbl, ref, tol[0]);
done:
    vsd_framebuffer_destroy(ref);
    vsd_framebuffer_destroy(ref2);
    vsd_framebuffer_destroy(lbl);
    vsd_volume_destroy(vol);
}

/* A moved light is a lighting change: the renderer's next image equals a fresh one. */
static void test_move(void)
{
    const char *ov[] = {"environment.color=[0,0,0]", "render.method=lbl",
                        "lights=[{\"type\":\"point\",\"power\":300,\"position\":[3,-1,2.5]}]"};
    vsd_volume *vol = test_ball_volume();
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL, *fresh = NULL;
    vsd_render_stats st;
    char err[512];
    double before;
    if (!vol || !test_parse_scene(test_ball_json, ov, 3, &sc) || !(r = test_make_renderer(&sc, NULL))) goto done;
    vsd_renderer_use_volume(r, 0, vol, NULL, NULL);
    if (!test_render(r, 1, &fb, &st)) goto done;
    before = test_pass_sum(fb, VSD_PASS_COMBINED);
    sc.lights[0].position[2] = -1.5;   /* from above the ball to below it */
    CHECK(vsd_renderer_set_scene(r, &sc, err, sizeof err) == VSD_OK);
    if (!test_render(r, 1, &fb, &st)) goto done;
    fresh = test_render_fresh(&sc, NULL, vol, NULL, 1, NULL);
    printf("[3] moved point light: Combined sum %.4g -> %.4g, fresh %.4g\n", before, test_pass_sum(fb, VSD_PASS_COMBINED),
           fresh ? test_pass_sum(fresh, VSD_PASS_COMBINED) : -1.0);
    if (fresh) {
        /* the lattice restarts from its last state (a warm start), so the two agree to the
         * diffusion's tolerance, not bit for bit; VolumeDir is the same march */
        double ind = test_rel_err(fb, fresh, VSD_PASS_VOLUME_IND), dir = test_rel_err(fb, fresh, VSD_PASS_VOLUME_DIR);
        double moved = test_rel_err(fb, fresh, VSD_PASS_COMBINED);
        printf("    against a fresh renderer: VolumeInd %.5f, VolumeDir %.2g, Combined %.5f\n", ind, dir, moved);
        CHECK_MSG(ind < 0.01 && dir < 1e-6, "the moved light's image differs from a fresh render");
    }
    CHECK(fabs(test_pass_sum(fb, VSD_PASS_COMBINED) - before) > 0.2 * before);
done:
    vsd_framebuffer_destroy(fb);
    vsd_framebuffer_destroy(fresh);
    vsd_renderer_destroy(r);
    vsd_volume_destroy(vol);
}

static void expect_error(const char *const *ov, int n, const char *needle)
{
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_render_options o;
    char err[1024] = "";
    if (!test_parse_scene(test_ball_json, ov, n, &sc)) return;
    memset(&o, 0, sizeof o);
    CHECK_MSG(vsd_renderer_create(&sc, &o, &r, err, sizeof err) != VSD_OK, "accepted: %s", ov[n - 1]);
    CHECK_CONTAINS(err, needle);
    vsd_renderer_destroy(r);
}

static void test_errors(void)
{
    const char *shgrid[] = {"lights=[{\"type\":\"sun\"}]", "render.method=shgrid"};
    const char *bent[] = {"lights=[{\"type\":\"sun\"}]", "render.method=reference", "medium.ior=1.3"};
    printf("[4] errors\n");
    expect_error(shgrid, 2, "lights: method 'shgrid' does not render extra lights (sun, point, spot); reference, lbl do");
    expect_error(bent, 3, "lights: extra lights through a refracting medium");
}

int main(void)
{
    test_errors();
    test_single_scattering();
    test_move();
    test_lbl();
    return test_finish("test_lights");
}
