/* test_env: environment maps — the five maps in ../shared/data/env, hand-made RGBE files
 * (flat and run-length encoded) with known pixels, error reporting, colour-space conversion
 * through Blender's OpenColorIO config, and uniform maps. */
#define _POSIX_C_SOURCE 200809L
#include "test_common.h"
#include "vsd/env.h"
#include "vsd/image.h"
#include "src/image/imageio_internal.h"
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#define BLENDER_CONFIG "/usr/share/blender/datafiles/colormanagement/config.ocio"

static char g_err[2048];

static const char *tmp_path(const char *name) { return test_tmp_in("env", name); }

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        fwrite(data, 1, n, f);
        fclose(f);
    }
}

static double channel_mean(const vsd_env *env, int c)
{
    double s = 0;
    size_t n = (size_t)env->width * (size_t)env->height;
    for (size_t i = 0; i < n; i++)
        s += env->rgb[3 * i + (size_t)c];
    return s / (double)n;
}

/* Radiance's decoding, as Blender does it: (mantissa + 0.5) * 2^(e - 136), 0 when e == 0. */
static float rgbe_value(unsigned m, unsigned e)
{
    return e ? ((float)m + 0.5f) * ldexpf(1.0f, (int)e - 136) : 0.0f;
}

/* ---- the shared data maps --------------------------------------------------------------- */

static vsd_env *load_ok(const char *path, const char *colorspace)
{
    vsd_env *env = NULL;
    CHECK_MSG(vsd_env_load(path, colorspace, &env, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    return env;
}

static void test_data_maps(void)
{
    static const char *const maps[] = {"env/sunset.exr", "env/studio.exr", "env/forest.exr",
                                       "env/interior.hdr", "env/StinsonBeach.hdr"};
    for (int m = 0; m < 5; m++) {
        vsd_env *env = load_ok(test_data(maps[m]), NULL);
        if (!env)
            continue;
        CHECK_MSG(env->width == 1024 && env->height == 512, "%s: %d x %d", maps[m], env->width,
                  env->height);
        CHECK(strcmp(env->file, test_data(maps[m])) == 0);
        size_t n = (size_t)env->width * (size_t)env->height * 3, bad = 0;
        for (size_t i = 0; i < n; i++)
            bad += !(env->rgb[i] >= 0.0f && env->rgb[i] < 1e6f);
        CHECK_MSG(bad == 0, "%s: %zu values not finite and >= 0", maps[m], bad);
        for (int c = 0; c < 3; c++) {
            double mean = channel_mean(env, c);
            CHECK_MSG(mean > 0.05 && mean < 5.0, "%s: implausible mean %g", maps[m], mean);
        }
        vsd_env_destroy(env);
    }
}

/* DWAB decoding agrees with OpenImageIO: expected means are the "Stats Avg" lines of
 * `oiiotool env/<name>.exr --printstats` (OpenImageIO 2.4, Debian 12), 6 digits. */
static void test_dwab_means(void)
{
    static const struct {
        const char *file;
        double avg[3];
    } ref[] = {{"env/forest.exr", {0.510292, 0.546371, 0.627810}},
               {"env/studio.exr", {0.229647, 0.259988, 0.278698}},
               {"env/sunset.exr", {0.404053, 0.416061, 0.573106}}};
    for (int m = 0; m < 3; m++) {
        vsd_env *env = load_ok(test_data(ref[m].file), NULL);
        for (int c = 0; env && c < 3; c++)
            CHECK_NEAR(channel_mean(env, c), ref[m].avg[c], 1e-3 * ref[m].avg[c]);
        vsd_env_destroy(env);
    }
}

/* DWA's lossy round-off leaves slightly negative texels in forest.exr (oiiotool
 * --printstats: Min B = -0.001554); the raw reader keeps them, the environment sets them
 * to 0 (radiance cannot be negative). */
static void test_negative_clamp(void)
{
    vsd_exr_image *img = NULL;
    CHECK(vsd_exr_read(test_data("env/forest.exr"), &img, g_err, sizeof g_err) == VSD_OK);
    vsd_env *env = load_ok(test_data("env/forest.exr"), NULL);
    const float *b = img ? vsd_exr_channel(img, "B") : NULL;
    CHECK(b != NULL);
    size_t neg = 0, n = img ? (size_t)img->width * (size_t)img->height : 0;
    for (size_t i = 0; b && env && i < n; i++) {
        if (b[i] < 0.0f) {
            neg++;
            CHECK(env->rgb[3 * i + 2] == 0.0f);
        } else if (env->rgb[3 * i + 2] != b[i]) {
            CHECK_MSG(0, "forest.exr B[%zu]: env %g, exr %g", i, env->rgb[3 * i + 2], b[i]);
            break;
        }
    }
    CHECK(neg > 0);
    vsd_exr_image_destroy(img);
    vsd_env_destroy(env);
}

/* interior.hdr, pixel x=100, y=200 (from the top): `oiiotool interior.hdr --cut 1x1+100+200
 * -o px.exr; oiiotool --info -v --dumpdata px.exr` prints 0.6171875 0.5 0.4375, i.e.
 * mantissas 158, 128, 112 at exponent 128 without Radiance's +0.5. Blender 3.4 (img.pixels
 * of the same file) gives 0.619140625 0.501953125 0.439453125 = (m + 0.5)/256, which vsd
 * matches. The means are oiiotool's Stats Avg, 1% apart for the same +0.5. */
static void test_hdr_reference(void)
{
    vsd_env *env = load_ok(test_data("env/interior.hdr"), NULL);
    if (env) {
        const float *px = env->rgb + (200 * 1024 + 100) * 3;
        CHECK(px[0] == 0.619140625f && px[1] == 0.501953125f && px[2] == 0.439453125f);
        static const double avg[3] = {1.079475, 0.952310, 0.810255};
        for (int c = 0; c < 3; c++)
            CHECK_NEAR(channel_mean(env, c), avg[c], 1e-2 * avg[c]);
    }
    vsd_env_destroy(env);
    env = load_ok(test_data("env/StinsonBeach.hdr"), NULL);
    static const double avg_sb[3] = {0.255317, 0.270537, 0.303034};
    for (int c = 0; env && c < 3; c++)
        CHECK_NEAR(channel_mean(env, c), avg_sb[c], 1e-2 * avg_sb[c]);
    vsd_env_destroy(env);
}

/* ---- hand-made RGBE files ---------------------------------------------------------------- */

/* Known RGBE quadruple for pixel (x, y): varied mantissas and exponents, some e = 0. */
static void pixel_rgbe(int x, int y, unsigned char q[4])
{
    q[0] = (unsigned char)(10 + 17 * x + 3 * y);
    q[1] = (unsigned char)(x < 8 ? 77 : 200); /* a run in G for RLE */
    q[2] = (unsigned char)(255 - 9 * x);
    q[3] = (unsigned char)((x + y) % 7 == 6 ? 0 : 120 + x + y);
}

static void check_pixels(const vsd_env *env, int w, int h)
{
    CHECK(env->width == w && env->height == h);
    int bad = 0;
    for (int y = 0; y < h && env->width == w && env->height == h; y++)
        for (int x = 0; x < w; x++) {
            unsigned char q[4];
            pixel_rgbe(x, y, q);
            for (int c = 0; c < 3 && bad < 3; c++) {
                float got = env->rgb[((size_t)y * (size_t)w + (size_t)x) * 3 + (size_t)c];
                if (got != rgbe_value(q[c], q[3])) {
                    bad++;
                    CHECK_MSG(0, "pixel (%d,%d) channel %d: got %.9g want %.9g", x, y, c, got,
                              rgbe_value(q[c], q[3]));
                }
            }
        }
}

/* New-style RLE of one component: a run for repeated bytes, literals otherwise. */
static size_t rle_component(const unsigned char *vals, int w, unsigned char *out)
{
    size_t n = 0;
    for (int x = 0; x < w;) {
        int run = 1;
        while (x + run < w && run < 127 && vals[x + run] == vals[x])
            run++;
        if (run >= 3) {
            out[n++] = (unsigned char)(128 + run);
            out[n++] = vals[x];
            x += run;
        } else {
            int lit = 0;
            while (x + lit < w && lit < 128 &&
                   !(x + lit + 2 < w && vals[x + lit] == vals[x + lit + 1] &&
                     vals[x + lit] == vals[x + lit + 2]))
                lit++;
            out[n++] = (unsigned char)lit;
            memcpy(out + n, vals + x, (size_t)lit);
            n += (size_t)lit;
            x += lit;
        }
    }
    return n;
}

/* A w x h RGBE file; rows whose bit is set in rle_rows are run-length encoded. */
static size_t make_rgbe(unsigned char *buf, const char *header, int w, int h, unsigned rle_rows)
{
    size_t n = (size_t)sprintf((char *)buf, "%s", header);
    n += (size_t)sprintf((char *)buf + n, "-Y %d +X %d\n", h, w);
    for (int y = 0; y < h; y++) {
        unsigned char comp[4][64], q[4];
        for (int x = 0; x < w; x++) {
            pixel_rgbe(x, y, q);
            for (int c = 0; c < 4; c++)
                comp[c][x] = q[c];
        }
        if (rle_rows & (1u << y)) {
            unsigned char start[4] = {2, 2, (unsigned char)(w >> 8), (unsigned char)(w & 255)};
            memcpy(buf + n, start, 4);
            n += 4;
            for (int c = 0; c < 4; c++)
                n += rle_component(comp[c], w, buf + n);
        } else {
            for (int x = 0; x < w; x++)
                for (int c = 0; c < 4; c++)
                    buf[n++] = comp[c][x];
        }
    }
    return n;
}

static void test_rgbe_own(void)
{
    unsigned char buf[8192];
    const char *hdr = "#?RADIANCE\n# made by test_env\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=2.0\n\n";
    struct {
        const char *name, *header;
        int w, h;
        unsigned rle;
    } cases[] = {
        {"flat5.hdr", hdr, 5, 3, 0},             /* narrower than 8: always flat */
        {"flat20.hdr", "#?RGBE\n\n", 20, 2, 0},  /* wide but written flat */
        {"rle40.hdr", hdr, 40, 4, 0xF},          /* every row run-length encoded */
        {"mixed.hdr", hdr, 33, 3, 0x5},          /* rows 0, 2 RLE, row 1 flat */
    };
    for (int k = 0; k < 4; k++) {
        size_t n = make_rgbe(buf, cases[k].header, cases[k].w, cases[k].h, cases[k].rle);
        const char *path = tmp_path(cases[k].name);
        write_bytes(path, buf, n);
        vsd_env *env = load_ok(path, NULL);
        if (env)
            check_pixels(env, cases[k].w, cases[k].h);
        vsd_env_destroy(env);
    }
}

static void expect_fail(const char *path, vsd_status want, const char *needle)
{
    vsd_env *env = (vsd_env *)1;
    vsd_status s = vsd_env_load(path, NULL, &env, g_err, sizeof g_err);
    CHECK_MSG(s == want, "%s: status %s, want %s (%s)", path, vsd_status_str(s),
              vsd_status_str(want), g_err);
    CHECK(env == NULL);
    CHECK_CONTAINS(g_err, path);
    CHECK_CONTAINS(g_err, needle);
}

static void test_rgbe_errors(void)
{
    unsigned char buf[8192];
    size_t n = make_rgbe(buf, "#?RADIANCE\n\n", 40, 4, 0xF);
    const char *path = tmp_path("bad.hdr");

    write_bytes(path, buf, n - 7);
    expect_fail(path, VSD_ERR_FORMAT, "truncated");

    unsigned char wrongw[8192];
    memcpy(wrongw, buf, n);
    size_t first = strlen("#?RADIANCE\n\n-Y 4 +X 40\n");
    wrongw[first + 3] = 41; /* scanline 0 claims 41 pixels */
    write_bytes(path, wrongw, n);
    expect_fail(path, VSD_ERR_FORMAT, "width 41");

    memcpy(wrongw, buf, n);
    wrongw[first + 4] = 0; /* a zero-length run */
    write_bytes(path, wrongw, n);
    expect_fail(path, VSD_ERR_FORMAT, "corrupt");

    const char *flipped = "#?RADIANCE\n\n+Y 4 +X 40\n";
    write_bytes(path, flipped, strlen(flipped));
    expect_fail(path, VSD_ERR_UNSUPPORTED, "+Y 4 +X 40");

    const char *xyze = "#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\1\1\1\200";
    write_bytes(path, xyze, strlen(xyze) + 1);
    expect_fail(path, VSD_ERR_UNSUPPORTED, "xyze");

    const char *endless = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n";
    write_bytes(path, endless, strlen(endless));
    expect_fail(path, VSD_ERR_FORMAT, "header");

    const char *nosize = "#?RADIANCE\n\nhello\n";
    write_bytes(path, nosize, strlen(nosize));
    expect_fail(path, VSD_ERR_FORMAT, "resolution");
}

/* ---- errors on real files -------------------------------------------------------------- */

static void test_load_errors(void)
{
    expect_fail(tmp_path("missing.exr"), VSD_ERR_IO, "No such file");
    const char *text = tmp_path("notes.exr");
    write_bytes(text, "just some text\n", 15);
    expect_fail(text, VSD_ERR_FORMAT, "not an environment image");
    const char *empty = tmp_path("empty.hdr");
    write_bytes(empty, "", 0);
    expect_fail(empty, VSD_ERR_FORMAT, "empty");

    const char *cut_exr = tmp_path("cut.exr");
    test_copy_prefix(test_data("env/studio.exr"), cut_exr, 50000);
    expect_fail(cut_exr, VSD_ERR_FORMAT, "truncated");
    const char *cut_hdr = tmp_path("cut.hdr");
    test_copy_prefix(test_data("env/interior.hdr"), cut_hdr, 700000);
    expect_fail(cut_hdr, VSD_ERR_FORMAT, "truncated");

    /* an EXR without colour channels */
    vsd_framebuffer *fb = NULL;
    CHECK(vsd_framebuffer_create(4, 2, &fb, g_err, sizeof g_err) == VSD_OK);
    vsd_exr_write_options opt = {0};
    opt.pass_mask = VSD_PASS_BIT(VSD_PASS_DEPTH);
    const char *depth = tmp_path("depth_only.exr");
    CHECK(fb && vsd_exr_write(depth, fb, &opt, g_err, sizeof g_err) == VSD_OK);
    expect_fail(depth, VSD_ERR_FORMAT, "no R, G, B");
    vsd_framebuffer_destroy(fb);
}

/* ---- colour spaces ------------------------------------------------------------------------ */

/* An EXR whose Combined pass is 0.5 everywhere; the environment loader takes a multilayer
 * render's Combined pass when there are no plain R, G, B channels. */
static const char *half_grey_exr(void)
{
    static char path[2048];
    snprintf(path, sizeof path, "%s", tmp_path("grey.exr"));
    vsd_framebuffer *fb = NULL;
    CHECK(vsd_framebuffer_create(8, 4, &fb, g_err, sizeof g_err) == VSD_OK);
    for (int i = 0; fb && i < 8 * 4 * 4; i++)
        fb->pass[VSD_PASS_COMBINED][i] = (i % 4 == 3) ? 1.0f : 0.5f;
    vsd_exr_write_options opt = {0};
    opt.pass_mask = VSD_PASS_BIT(VSD_PASS_COMBINED);
    CHECK(fb && vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_OK);
    vsd_framebuffer_destroy(fb);
    return path;
}

static void test_colorspace(void)
{
    struct stat st;
    if (stat(BLENDER_CONFIG, &st) != 0) {
        fprintf(stderr, "Blender's OCIO config is not installed: colour-space tests skipped\n");
        return;
    }
    setenv("OCIO", BLENDER_CONFIG, 1);
    const char *path = half_grey_exr();
    vsd_env *env = load_ok(path, NULL);
    CHECK(env && env->width == 8 && env->height == 4 && env->rgb[0] == 0.5f);
    vsd_env_destroy(env);
    env = load_ok(path, "Linear"); /* Blender's scene_linear: identity */
    CHECK(env && env->rgb[0] == 0.5f && env->rgb[95] == 0.5f);
    vsd_env_destroy(env);
    env = load_ok(path, "scene_linear"); /* role names work too */
    CHECK(env && env->rgb[1] == 0.5f);
    vsd_env_destroy(env);
    env = load_ok(path, "sRGB"); /* sRGB EOTF(0.5) = 0.2140 */
    for (int i = 0; env && i < 8 * 4 * 3; i++)
        CHECK_NEAR(env->rgb[i], 0.214, 1e-3);
    vsd_env_destroy(env);

    env = (vsd_env *)1;
    CHECK(vsd_env_load(path, "NoSuchSpace", &env, g_err, sizeof g_err) == VSD_ERR_NOT_FOUND);
    CHECK(env == NULL);
    CHECK_CONTAINS(g_err, "NoSuchSpace");
    CHECK_CONTAINS(g_err, "Linear, Raw");
    CHECK_CONTAINS(g_err, path);

    setenv("OCIO", "/nonexistent/config.ocio", 1);
    CHECK(vsd_env_load(path, "sRGB", &env, g_err, sizeof g_err) == VSD_ERR_IO);
    CHECK_CONTAINS(g_err, "/nonexistent/config.ocio");
    env = load_ok(path, NULL); /* no conversion asked: no config needed */
    vsd_env_destroy(env);

    unsetenv("OCIO");
    static const char *const none[] = {"/nonexistent/*/config.ocio", NULL};
    const char *const *saved = vsd_ocio_blender_candidates;
    vsd_ocio_blender_candidates = none;
    /* no config at all: vsd's built-in config still knows sRGB (it used to be an error) */
    env = load_ok(path, "sRGB");
    CHECK(env && fabsf(env->rgb[0] - 0.214f) < 1e-3f);
    vsd_env_destroy(env);
    env = (vsd_env *)1;
    CHECK(vsd_env_load(path, "AgX Base sRGB", &env, g_err, sizeof g_err) == VSD_ERR_NOT_FOUND);
    CHECK(env == NULL);
    CHECK_CONTAINS(g_err, "'AgX Base sRGB'");
    CHECK_CONTAINS(g_err, "built-in");
    vsd_ocio_blender_candidates = saved;
}

/* Blender 4.x/5.x working spaces (issue 28, finding 5): the map is converted from its space
 * to the working space the scene names, in vsd's built-in config where the installed one
 * (Debian's Blender 3.4) lacks the names. Expected values: the published matrices, column
 * "red" of BT.709 -> BT.2020 (ITU-R BT.2087) and of ACES AP1 -> BT.709. */
static void test_working_space(void)
{
    float red[3] = {1, 0, 0};
    CHECK(vsd_ocio_convert(NULL, "Linear Rec.709", "Linear Rec.2020", red, 1, g_err, sizeof g_err) == VSD_OK);
    CHECK_NEAR(red[0], 0.6274, 5e-4);
    CHECK_NEAR(red[1], 0.0691, 5e-4);
    CHECK_NEAR(red[2], 0.0164, 5e-4);
    float cg[3] = {1, 0, 0};
    CHECK(vsd_ocio_convert(NULL, "ACEScg", "Linear Rec.709", cg, 1, g_err, sizeof g_err) == VSD_OK);
    CHECK_NEAR(cg[0], 1.7051, 1e-3);
    CHECK_NEAR(cg[1], -0.1303, 1e-3);
    CHECK_NEAR(cg[2], -0.0240, 1e-3);
    float rt[3] = {0.3f, 0.6f, 0.1f};
    CHECK(vsd_ocio_convert(NULL, "Linear Rec.709", "ACEScg", rt, 1, g_err, sizeof g_err) == VSD_OK);
    CHECK(vsd_ocio_convert(NULL, "ACEScg", "Linear Rec.709", rt, 1, g_err, sizeof g_err) == VSD_OK);
    CHECK_NEAR(rt[0], 0.3, 1e-5);
    CHECK_NEAR(rt[1], 0.6, 1e-5);
    CHECK_NEAR(rt[2], 0.1, 1e-5);

    /* through vsd_env_load with the scene's pair: grey stays grey between D65 spaces */
    const char *path = half_grey_exr();
    char conv[300];
    vsd_env_conversion("sRGB", "Linear Rec.2020", conv, sizeof conv);
    vsd_env *env = load_ok(path, conv);
    CHECK(env && fabsf(env->rgb[0] - 0.214f) < 1e-3f && fabsf(env->rgb[2] - 0.214f) < 1e-3f);
    vsd_env_destroy(env);
    vsd_env_conversion("", "ACEScg", conv, sizeof conv);
    CHECK(conv[0] == '\0'); /* a map already in the working space is not touched */
    vsd_env_conversion("Linear Rec.709", "NoSuchWorkingSpace", conv, sizeof conv);
    env = (vsd_env *)1;
    CHECK(vsd_env_load(path, conv, &env, g_err, sizeof g_err) == VSD_ERR_NOT_FOUND);
    CHECK(env == NULL);
    CHECK_CONTAINS(g_err, "'NoSuchWorkingSpace'");
    CHECK_CONTAINS(g_err, path);
}

static void test_uniform(void)
{
    const float rgb[3] = {0.25f, 1.0f, 4.0f};
    vsd_env *env = NULL;
    CHECK(vsd_env_create_uniform(rgb, 16, 8, &env, g_err, sizeof g_err) == VSD_OK);
    if (env) {
        CHECK(env->width == 16 && env->height == 8);
        for (int i = 0; i < 16 * 8; i++)
            CHECK(env->rgb[3 * i] == 0.25f && env->rgb[3 * i + 1] == 1.0f &&
                  env->rgb[3 * i + 2] == 4.0f);
    }
    vsd_env_destroy(env);
    CHECK(vsd_env_create_uniform(rgb, 0, 8, &env, g_err, sizeof g_err) == VSD_ERR_INVALID);
    const float neg[3] = {0.0f, -1.0f, 0.0f};
    CHECK(vsd_env_create_uniform(neg, 4, 2, &env, g_err, sizeof g_err) == VSD_ERR_INVALID);
    CHECK(env == NULL);
    vsd_env_destroy(NULL);
}

int main(void)
{
    if (mkdir(tmp_path(""), 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "cannot create %s\n", tmp_path(""));
        return 1;
    }
    test_data_maps();
    test_dwab_means();
    test_negative_clamp();
    test_hdr_reference();
    test_rgbe_own();
    test_rgbe_errors();
    test_load_errors();
    test_colorspace();
    test_working_space();
    test_uniform();
    return test_finish("test_env");
}
