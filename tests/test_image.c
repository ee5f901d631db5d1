/* test_image: render passes, multilayer EXR write/read (OpenEXR C API writer, C++ reader),
 * temp-file + rename, and the OpenColorIO preview PNG.
 *
 * `test_image --write-sample PATH` writes the small known EXR that
 * tests/blender_exr_passes.py loads in Blender (values from sample_value()). */
#define _POSIX_C_SOURCE 200809L
#include "test_common.h"
#include "vsd/image.h"
#include "src/image/imageio_internal.h"
#include <dirent.h>
#include <errno.h>
#include <png.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#define BLENDER_CONFIG "/usr/share/blender/datafiles/colormanagement/config.ocio"

static char g_err[2048];

/* ---- helpers ------------------------------------------------------------------------- */

static const char *tmp_path(const char *name) { return test_tmp_in("image", name); }

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Number of leftover temporary files ("*.tmp-*") in the test folder. */
static int stray_tmp_files(void)
{
    char dir[2048];
    snprintf(dir, sizeof dir, "%s/image", VSD_TEST_TMP);
    DIR *d = opendir(dir);
    int n = 0;
    for (struct dirent *e; d && (e = readdir(d));)
        if (strstr(e->d_name, ".tmp-")) {
            fprintf(stderr, "stray temporary file %s/%s\n", dir, e->d_name);
            n++;
        }
    if (d)
        closedir(d);
    return n;
}

static long file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : -1;
}

/* A value per pass/channel/pixel that differs everywhere and is not representable in half,
 * so the float round trip proves exactness and the half one proves rounding only. */
static float pattern(int p, int c, int x, int y)
{
    return (float)(p + 1) * 0.7310585f + (float)c * 0.1234567f + (float)x * 0.0103f +
           (float)y * 1.01f + 1e-4f * (float)((x * 7 + y * 13) % 11);
}

/* The Blender sample: dyadic fractions, exact in half and float, and easy to recompute in
 * Python (tests/blender_exr_passes.py has the same formula). */
static float sample_value(int p, int c, int x, int y)
{
    if (p == VSD_PASS_DEPTH)
        return 2.0f + (float)x + 10.0f * (float)y;
    return 0.125f * (float)(p + 1) + 0.03125f * (float)c + 0.0078125f * (float)x +
           0.001953125f * (float)y;
}

static vsd_framebuffer *make_fb(int w, int h, float (*f)(int, int, int, int))
{
    vsd_framebuffer *fb = NULL;
    if (vsd_framebuffer_create(w, h, &fb, g_err, sizeof g_err) != VSD_OK)
        return NULL;
    for (int p = 0; p < VSD_PASS_COUNT; p++) {
        int nc = vsd_pass_channels((vsd_pass)p);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                for (int c = 0; c < nc; c++)
                    fb->pass[p][((size_t)y * (size_t)w + (size_t)x) * (size_t)nc + (size_t)c] =
                        f(p, c, x, y);
    }
    return fb;
}

/* ---- passes and framebuffer ------------------------------------------------------------ */

static void test_pass_names(void)
{
    static const char *names[] = {"Combined", "VolumeDir", "VolumeInd", "Emit",
                                  "Transmittance", "Depth"};
    static const int chans[] = {4, 3, 3, 3, 3, 1};
    for (int p = 0; p < VSD_PASS_COUNT; p++) {
        CHECK(strcmp(vsd_pass_name((vsd_pass)p), names[p]) == 0);
        CHECK(vsd_pass_channels((vsd_pass)p) == chans[p]);
        CHECK(vsd_pass_from_name(names[p]) == (vsd_pass)p);
    }
    CHECK(vsd_pass_from_name("combined") == VSD_PASS_COUNT); /* Blender's names are exact */
    CHECK(vsd_pass_from_name("Volume") == VSD_PASS_COUNT);
    CHECK(vsd_pass_from_name(NULL) == VSD_PASS_COUNT);
    CHECK(strcmp(vsd_pass_name(VSD_PASS_COUNT), "") == 0);
}

static void test_framebuffer(void)
{
    vsd_framebuffer *fb = NULL;
    CHECK(vsd_framebuffer_create(5, 3, &fb, g_err, sizeof g_err) == VSD_OK);
    if (!fb)
        return;
    CHECK(fb->width == 5 && fb->height == 3);
    for (int p = 0; p < VSD_PASS_COUNT; p++)
        for (int i = 0; i < 15 * vsd_pass_channels((vsd_pass)p); i++)
            CHECK(fb->pass[p][i] == (p == VSD_PASS_DEPTH ? VSD_DEPTH_EMPTY : 0.0f));
    fb->pass[VSD_PASS_EMIT][7] = 3.0f;
    fb->pass[VSD_PASS_DEPTH][2] = 1.5f;
    vsd_framebuffer_clear(fb);
    CHECK(fb->pass[VSD_PASS_EMIT][7] == 0.0f);
    CHECK(fb->pass[VSD_PASS_DEPTH][2] == VSD_DEPTH_EMPTY);
    vsd_framebuffer_destroy(fb);

    fb = (vsd_framebuffer *)1;
    CHECK(vsd_framebuffer_create(0, 3, &fb, g_err, sizeof g_err) == VSD_ERR_INVALID);
    CHECK(fb == NULL);
    CHECK_CONTAINS(g_err, "0 x 3");
    CHECK(vsd_framebuffer_create(100000, 100000, &fb, g_err, sizeof g_err) == VSD_ERR_INVALID);
    vsd_framebuffer_destroy(NULL);
}

/* ---- EXR ------------------------------------------------------------------------------ */

static const char *const all_channels[] = {
    "ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B",
    "ViewLayer.Combined.A", "ViewLayer.VolumeDir.R", "ViewLayer.VolumeDir.G",
    "ViewLayer.VolumeDir.B", "ViewLayer.VolumeInd.R", "ViewLayer.VolumeInd.G",
    "ViewLayer.VolumeInd.B", "ViewLayer.Emit.R", "ViewLayer.Emit.G", "ViewLayer.Emit.B",
    "ViewLayer.Transmittance.R", "ViewLayer.Transmittance.G", "ViewLayer.Transmittance.B",
    "ViewLayer.Depth.Z"};

/* Every channel of every pass read back equals what was written: exactly for float, to
 * half's rounding (relative 2^-11) for half; Depth is always float. */
static void check_passes_named(const vsd_exr_image *img, const vsd_framebuffer *fb, const char *layer,
                               int half, const char *const *names)
{
    const char *ids;
    for (int p = 0; p < VSD_PASS_COUNT; p++) {
        ids = vsd_pass_chan_ids((vsd_pass)p);
        int nc = vsd_pass_channels((vsd_pass)p);
        for (int c = 0; c < nc; c++) {
            char name[256];
            snprintf(name, sizeof name, "%s.%s.%c", layer, names ? names[p] : vsd_pass_name((vsd_pass)p), ids[c]);
            const float *plane = vsd_exr_channel(img, name);
            CHECK_MSG(plane != NULL, "channel %s missing", name);
            int bad = 0;
            for (int i = 0; plane && i < fb->width * fb->height && bad < 3; i++) {
                float want = fb->pass[p][(size_t)i * (size_t)nc + (size_t)c];
                double tol = half && p != VSD_PASS_DEPTH ? fabs(want) * 4.9e-4 + 6e-8 : 0.0;
                if (!(fabs(plane[i] - want) <= tol)) {
                    bad++;
                    CHECK_MSG(0, "%s pixel %d: read %.9g, wrote %.9g", name, i, plane[i], want);
                }
            }
        }
    }
}

static void check_passes(const vsd_exr_image *img, const vsd_framebuffer *fb, const char *layer,
                         int half)
{
    check_passes_named(img, fb, layer, half, NULL);
}

static void test_roundtrip(int half)
{
    const int w = 37, h = 21; /* not a multiple of ZIP's 16-row chunks */
    vsd_framebuffer *fb = make_fb(w, h, pattern);
    CHECK(fb != NULL);
    if (!fb)
        return;
    vsd_exr_write_options opt = {0};
    opt.half = half;
    const char *path = tmp_path(half ? "roundtrip_half.exr" : "roundtrip_float.exr");
    CHECK_MSG(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    vsd_exr_image *img = NULL;
    CHECK_MSG(vsd_exr_read(path, &img, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    if (img) {
        CHECK(img->width == w && img->height == h);
        CHECK(img->channel_count == 17);
        for (size_t i = 0; i < sizeof all_channels / sizeof *all_channels; i++)
            CHECK_MSG(vsd_exr_channel(img, all_channels[i]) != NULL, "%s", all_channels[i]);
        CHECK(vsd_exr_channel(img, "R") == NULL);
        check_passes(img, fb, "ViewLayer", half);
        if (half) /* 1.01*20 + ... is not a half value: rounding happened, so it is half */
            CHECK(vsd_exr_channel(img, "ViewLayer.Emit.R")[w * h - 1] !=
                  fb->pass[VSD_PASS_EMIT][(size_t)(w * h - 1) * 3]);
    }
    vsd_exr_image_destroy(img);
    vsd_framebuffer_destroy(fb);
}

/* Half the rows of every pass zero (an empty background), half the pattern. */
static float background_pattern(int p, int c, int x, int y)
{
    return y % 8 < 4 ? 0.0f : pattern(p, c, x, y);
}

/* output.compression: every one lossless, bit for bit; "none" stores every float as is (the
 * file at least as large as the raw channels), ZIP and RLE less where a background repeats;
 * the names the scene file uses map to the writer's values and back. */
static void test_compressions(void)
{
    const int w = 37, h = 21;
    long raw = (long)w * h * 17 * (long)sizeof(float), size[VSD_EXR_COMPRESSION_COUNT];
    vsd_framebuffer *fb = make_fb(w, h, background_pattern);
    if (!fb)
        return;
    for (int c = 0; c < VSD_EXR_COMPRESSION_COUNT; c++) {
        vsd_exr_write_options opt = {0};
        char file[64];
        vsd_exr_image *img = NULL;
        const char *name = vsd_exr_compression_name((vsd_exr_compression)c);
        CHECK_MSG(vsd_exr_compression_from_name(name) == (vsd_exr_compression)c, "compression %d is named %s", c, name);
        snprintf(file, sizeof file, "compressed_%s.exr", name);
        opt.compression = (vsd_exr_compression)c;
        CHECK_MSG(vsd_exr_write(tmp_path(file), fb, &opt, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
        size[c] = file_size(tmp_path(file));
        CHECK_MSG(vsd_exr_read(tmp_path(file), &img, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
        if (img) {
            CHECK(img->width == w && img->height == h && img->channel_count == 17);
            check_passes(img, fb, "ViewLayer", 0);
        }
        vsd_exr_image_destroy(img);
    }
    CHECK(vsd_exr_compression_from_name("lz4") == VSD_EXR_COMPRESSION_COUNT);
    CHECK_MSG(size[VSD_EXR_NONE] >= raw && size[VSD_EXR_ZIP] < size[VSD_EXR_NONE] &&
              size[VSD_EXR_RLE] < size[VSD_EXR_NONE], "none %ld bytes, zip %ld, rle %ld, raw channels %ld",
              size[VSD_EXR_NONE], size[VSD_EXR_ZIP], size[VSD_EXR_RLE], raw);
    {
        vsd_exr_write_options bad = {0};
        bad.compression = VSD_EXR_COMPRESSION_COUNT;
        CHECK(vsd_exr_write(tmp_path("bad_compression.exr"), fb, &bad, g_err, sizeof g_err) == VSD_ERR_INVALID);
        CHECK_CONTAINS(g_err, "unknown compression");
    }
    vsd_framebuffer_destroy(fb);
}

/* The chunks are encoded on several threads and written in order: the bytes do not depend
 * on the thread count (1, 2, 3, 32: more threads than ZIP's 16-row chunks), for every
 * compression, on a height that is no multiple of a chunk. */
static void test_encode_threads(void)
{
    vsd_framebuffer *fb = make_fb(61, 203, background_pattern);
    static const int threads[] = {2, 3, 32};
    if (!fb)
        return;
    for (int c = 0; c < VSD_EXR_COMPRESSION_COUNT; c++) {
        vsd_exr_write_options opt = {0};
        unsigned char *one = NULL;
        size_t one_len = 0;
        opt.compression = (vsd_exr_compression)c;
        opt.threads = 1;
        CHECK_MSG(vsd_exr_encode(fb, &opt, &one, &one_len, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
        for (int t = 0; t < 3; t++) {
            unsigned char *many = NULL;
            size_t len = 0;
            opt.threads = threads[t];
            CHECK_MSG(vsd_exr_encode(fb, &opt, &many, &len, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
            CHECK_MSG(one && many && len == one_len && memcmp(one, many, len) == 0,
                      "%s with %d threads: %zu bytes, with one %zu%s", vsd_exr_compression_name(opt.compression),
                      threads[t], len, one_len, len == one_len ? " (contents differ)" : "");
            free(many);
        }
        free(one);
    }
    vsd_framebuffer_destroy(fb);
}

/* vsd_exr_encode: the bytes vsd_exr_write puts in the file, byte for byte, for ZIP, none
 * and RLE, float and half, a pass subset under another layer with header attributes;
 * and its input errors as vsd_exr_write's. */
static void test_encode_in_memory(void)
{
    vsd_framebuffer *fb = make_fb(53, 29, pattern);
    static const vsd_exr_attr attrs[] = {{"vsd/method", "lbl"}, {"vsd/frame", "12"}};
    if (!fb)
        return;
    for (int k = 0; k < 6; k++) {
        vsd_exr_write_options opt = {0};
        unsigned char *bytes = NULL, *file = NULL;
        size_t len = 0;
        long size = 0;
        const char *path = tmp_path("encoded.exr");
        opt.compression = (vsd_exr_compression)(k % 3);
        opt.half = k >= 3;
        if (k == 5) {
            opt.layer = "RenderLayer.001";
            opt.pass_mask = (1u << VSD_PASS_COMBINED) | (1u << VSD_PASS_DEPTH);
            opt.attrs = attrs;
            opt.attr_count = 2;
        }
        CHECK_MSG(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
        CHECK_MSG(vsd_exr_encode(fb, &opt, &bytes, &len, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
        file = test_read_file(path, &size);
        CHECK_MSG(file && bytes && (long)len == size && memcmp(file, bytes, len) == 0,
                  "case %d: %zu bytes in memory, %ld in the file, %s", k, len, size,
                  file && bytes && (long)len == size ? "contents differ" : "sizes differ");
        free(file);
        free(bytes);
    }
    {
        unsigned char *bytes = (unsigned char *)"x";
        size_t len = 1;
        vsd_exr_write_options bad = {0};
        const char *names[VSD_PASS_COUNT] = {0};
        CHECK(vsd_exr_encode(NULL, NULL, &bytes, &len, g_err, sizeof g_err) == VSD_ERR_INVALID);
        CHECK(bytes == NULL && len == 0);
        names[VSD_PASS_EMIT] = "Emission.001";
        bad.pass_names = names;
        CHECK(vsd_exr_encode(fb, &bad, &bytes, &len, g_err, sizeof g_err) == VSD_ERR_INVALID);
        CHECK_CONTAINS(g_err, "Emission.001");
    }
    vsd_framebuffer_destroy(fb);
}

/* A subset of passes under a user layer name with a dot (Blender's "ViewLayer.001"), and
 * an empty Depth (the 1e10 marker must survive). Names longer than EXR's classic 31
 * characters need the long-names flag. */
static void test_mask_and_layer(void)
{
    vsd_framebuffer *fb = make_fb(8, 5, pattern);
    if (!fb)
        return;
    fb->pass[VSD_PASS_DEPTH][3] = VSD_DEPTH_EMPTY;
    vsd_exr_write_options opt = {0};
    opt.layer = "RenderLayer.001";
    opt.pass_mask = VSD_PASS_BIT(VSD_PASS_COMBINED) | VSD_PASS_BIT(VSD_PASS_DEPTH);
    opt.half = 1;
    const char *path = tmp_path("mask.exr");
    CHECK_MSG(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    vsd_exr_image *img = NULL;
    CHECK_MSG(vsd_exr_read(path, &img, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    if (img) {
        CHECK(img->channel_count == 5);
        CHECK(vsd_exr_channel(img, "RenderLayer.001.Combined.A") != NULL);
        const float *z = vsd_exr_channel(img, "RenderLayer.001.Depth.Z");
        CHECK(z && z[3] == VSD_DEPTH_EMPTY && z[4] == fb->pass[VSD_PASS_DEPTH][4]);
        CHECK(vsd_exr_channel(img, "RenderLayer.001.Emit.R") == NULL);
    }
    vsd_exr_image_destroy(img);

    opt.layer = "A view layer with a name longer than thirty-one characters";
    opt.pass_mask = VSD_PASS_BIT(VSD_PASS_TRANSMITTANCE);
    CHECK_MSG(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    img = NULL;
    CHECK_MSG(vsd_exr_read(path, &img, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    if (img) {
        CHECK(img->channel_count == 3);
        CHECK(vsd_exr_channel(img, "A view layer with a name longer than thirty-one "
                                   "characters.Transmittance.G") != NULL);
    }
    vsd_exr_image_destroy(img);

    opt.layer = NULL;
    opt.pass_mask = 1u << VSD_PASS_COUNT;
    CHECK(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_ERR_INVALID);
    vsd_framebuffer_destroy(fb);
}

/* Passes under another Blender version's names (5.0: "Volume Direct", "Volume Indirect",
 * "Emission"): every pixel reads back under the new name, none under the old, and a name
 * that would break "<layer>.<pass>.<channel>" or repeat another pass's is refused. */
static void test_renamed_passes(void)
{
    vsd_framebuffer *fb = make_fb(9, 7, pattern);
    if (!fb)
        return;
    const char *names[VSD_PASS_COUNT] = {NULL, "Volume Direct", "Volume Indirect", "Emission", "", NULL};
    const char *want[VSD_PASS_COUNT] = {"Combined", "Volume Direct", "Volume Indirect", "Emission",
                                        "Transmittance", "Depth"};
    vsd_exr_write_options opt = {0};
    opt.pass_names = names;
    const char *path = tmp_path("renamed.exr");
    CHECK_MSG(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    vsd_exr_image *img = NULL;
    CHECK_MSG(vsd_exr_read(path, &img, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    if (img) {
        CHECK(img->channel_count == 17);
        check_passes_named(img, fb, "ViewLayer", 0, want);
        CHECK(vsd_exr_channel(img, "ViewLayer.VolumeDir.R") == NULL);
        CHECK(vsd_exr_channel(img, "ViewLayer.Emit.G") == NULL);
    }
    vsd_exr_image_destroy(img);

    names[VSD_PASS_EMIT] = "Emit.v2";
    CHECK(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_ERR_INVALID);
    CHECK_MSG(strstr(g_err, "EXR pass name for Emit: \"Emit.v2\" contains '.'") != NULL, "%s", g_err);
    names[VSD_PASS_EMIT] = "Volume Direct";
    CHECK(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_ERR_INVALID);
    CHECK_MSG(strstr(g_err, "EXR passes VolumeDir and Emit both named \"Volume Direct\"") != NULL, "%s", g_err);
    /* ... unless one of the two is not written */
    opt.pass_mask = VSD_PASS_BIT(VSD_PASS_COMBINED) | VSD_PASS_BIT(VSD_PASS_EMIT);
    CHECK_MSG(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    opt.pass_mask = 0;
    names[VSD_PASS_EMIT] = "0123456789012345678901234567890123456789012345678901234567890123"; /* 64 */
    CHECK(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_ERR_INVALID);
    CHECK_MSG(strstr(g_err, "EXR pass name for Emit: longer than 63 characters") != NULL, "%s", g_err);
    vsd_framebuffer_destroy(fb);
}

static void test_attributes(void)
{
    vsd_framebuffer *fb = make_fb(4, 4, pattern);
    if (!fb)
        return;
    vsd_exr_attr attrs[] = {{"vsd/method", "shgrid"},
                            {"vsd/parameters", "{\"samples\": 64, \"density\": 10.5}"},
                            {"vsd/render_seconds", "1.25"},
                            {"vsd/an_attribute_name_longer_than_31_chars", "long"},
                            {"vsd/empty", ""}};
    vsd_exr_write_options opt = {0};
    opt.attrs = attrs;
    opt.attr_count = 5;
    const char *path = tmp_path("attrs.exr");
    CHECK_MSG(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_OK, "%s", g_err);
    char value[256];
    for (int i = 0; i < 5; i++) {
        CHECK_MSG(vsd_exr_read_attr(path, attrs[i].name, value, sizeof value, g_err,
                                    sizeof g_err) == VSD_OK, "%s", g_err);
        CHECK(strcmp(value, attrs[i].value) == 0);
    }
    CHECK(vsd_exr_read_attr(path, "vsd/version", value, sizeof value, g_err, sizeof g_err) ==
          VSD_OK);
    CHECK(strcmp(value, VSD_VERSION_STRING) == 0);
    CHECK(vsd_exr_read_attr(path, "vsd/nope", value, sizeof value, g_err, sizeof g_err) ==
          VSD_ERR_NOT_FOUND);
    CHECK_CONTAINS(g_err, "vsd/nope");
    CHECK(vsd_exr_read_attr(path, "compression", value, sizeof value, g_err, sizeof g_err) ==
          VSD_ERR_TYPE);
    CHECK(vsd_exr_read_attr(path, "vsd/parameters", value, 8, g_err, sizeof g_err) ==
          VSD_ERR_INVALID);

    vsd_exr_attr bad[] = {{"", "x"}};
    opt.attrs = bad;
    opt.attr_count = 1;
    CHECK(vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) == VSD_ERR_INVALID);
    vsd_framebuffer_destroy(fb);
}

/* The temporary file is renamed into place; a failure leaves neither the temporary nor a
 * partial file, and an existing file is replaced whole. */
static void test_temp_and_write_errors(void)
{
    vsd_framebuffer *fb = make_fb(16, 9, pattern);
    if (!fb)
        return;
    const char *missing = tmp_path("no/such/folder/out.exr");
    CHECK(vsd_exr_write(missing, fb, NULL, g_err, sizeof g_err) == VSD_ERR_IO);
    CHECK_CONTAINS(g_err, missing);
    CHECK_CONTAINS(g_err, "No such file or directory");
    CHECK(!file_exists(tmp_path("no")));

    const char *path = tmp_path("replace.exr");
    CHECK(vsd_exr_write(path, fb, NULL, g_err, sizeof g_err) == VSD_OK);
    fb->pass[VSD_PASS_COMBINED][0] = 42.0f;
    CHECK(vsd_exr_write(path, fb, NULL, g_err, sizeof g_err) == VSD_OK);
    vsd_exr_image *img = NULL;
    CHECK(vsd_exr_read(path, &img, g_err, sizeof g_err) == VSD_OK);
    CHECK(img && vsd_exr_channel(img, "ViewLayer.Combined.R")[0] == 42.0f);
    vsd_exr_image_destroy(img);
    CHECK(vsd_exr_write(NULL, fb, NULL, g_err, sizeof g_err) == VSD_ERR_INVALID);
    CHECK(vsd_exr_write(path, NULL, NULL, g_err, sizeof g_err) == VSD_ERR_INVALID);
    CHECK(stray_tmp_files() == 0);
    vsd_framebuffer_destroy(fb);
}

static void test_read_errors(void)
{
    vsd_exr_image *img = (vsd_exr_image *)1;
    char missing[2048];
    snprintf(missing, sizeof missing, "%s", tmp_path("missing.exr"));
    CHECK(vsd_exr_read(missing, &img, g_err, sizeof g_err) == VSD_ERR_IO);
    CHECK(img == NULL);
    CHECK_CONTAINS(g_err, missing);

    const char *text = tmp_path("not_an_image.exr");
    FILE *f = fopen(text, "w");
    if (f) {
        fputs("this is not an EXR file\n", f);
        fclose(f);
    }
    CHECK(vsd_exr_read(text, &img, g_err, sizeof g_err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(g_err, text);
    CHECK_CONTAINS(g_err, "not an OpenEXR file");

    /* Cut a real file in half: the header parses, the pixels run out. */
    vsd_framebuffer *fb = make_fb(64, 64, pattern);
    const char *whole = tmp_path("whole.exr"), *cut = tmp_path("truncated.exr");
    CHECK(fb && vsd_exr_write(whole, fb, NULL, g_err, sizeof g_err) == VSD_OK);
    test_copy_prefix(whole, cut, (size_t)file_size(whole) / 2);
    CHECK(vsd_exr_read(cut, &img, g_err, sizeof g_err) == VSD_ERR_FORMAT);
    CHECK(img == NULL);
    CHECK_CONTAINS(g_err, cut);
    test_copy_prefix(whole, cut, 40); /* inside the header */
    CHECK(vsd_exr_read(cut, &img, g_err, sizeof g_err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(g_err, cut);
    char value[64];
    CHECK(vsd_exr_read_attr(cut, "vsd/version", value, sizeof value, g_err, sizeof g_err) ==
          VSD_ERR_FORMAT);
    CHECK(vsd_exr_read_attr(missing, "x", value, sizeof value, g_err, sizeof g_err) ==
          VSD_ERR_IO);
    vsd_framebuffer_destroy(fb);
}

/* ---- preview PNG ---------------------------------------------------------------------- */

/* Read an 8-bit RGBA PNG (caller frees), or NULL. */
static unsigned char *read_png(const char *path, int *w, int *h)
{
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path))
        return NULL;
    img.format = PNG_FORMAT_RGBA;
    unsigned char *px = malloc(PNG_IMAGE_SIZE(img));
    if (px && !png_image_finish_read(&img, NULL, px, 0, NULL)) {
        free(px);
        return NULL;
    }
    *w = (int)img.width;
    *h = (int)img.height;
    return px;
}

/* 3x1: opaque 18% grey, the same grey at half coverage (premultiplied), and empty. */
static vsd_framebuffer *grey_fb(void)
{
    vsd_framebuffer *fb = NULL;
    if (vsd_framebuffer_create(3, 1, &fb, g_err, sizeof g_err) != VSD_OK)
        return NULL;
    float px[12] = {0.18f, 0.18f, 0.18f, 1.0f, 0.09f, 0.09f, 0.09f, 0.5f, 0, 0, 0, 0};
    memcpy(fb->pass[VSD_PASS_COMBINED], px, sizeof px);
    return fb;
}

static void test_preview_standard(vsd_framebuffer *fb)
{
    char note[1024];
    const char *path = tmp_path("preview_standard.png");
    vsd_preview_options opt = {0};
    opt.view = "Standard";
    CHECK_MSG(vsd_preview_write_png(path, fb, &opt, note, sizeof note, g_err, sizeof g_err) ==
              VSD_OK, "%s", g_err);
    CHECK_CONTAINS(note, "OCIO config " BLENDER_CONFIG);
    CHECK_CONTAINS(note, "display sRGB, view Standard");
    int w = 0, h = 0;
    unsigned char *px = read_png(path, &w, &h);
    CHECK(px && w == 3 && h == 1);
    if (px) {
        /* sRGB OETF(0.18) = 0.4614 -> 117.7 */
        for (int c = 0; c < 3; c++) {
            CHECK_NEAR(px[c], 118, 1);
            CHECK_NEAR(px[4 + c], 118, 1); /* un-premultiplied before the view */
        }
        CHECK(px[3] == 255);
        CHECK_NEAR(px[7], 128, 1);
        CHECK(px[11] == 0);
    }
    free(px);

    /* The default view of Blender's config is Standard; exposure +1 stop brightens. */
    opt.view = NULL;
    opt.exposure = 1.0f;
    CHECK(vsd_preview_write_png(path, fb, &opt, note, sizeof note, g_err, sizeof g_err) ==
          VSD_OK);
    CHECK_CONTAINS(note, "view Standard");
    px = read_png(path, &w, &h);
    CHECK(px && px[0] > 140); /* sRGB(0.36) = 0.63 -> 161 */
    free(px);
}

static void test_preview_views(vsd_framebuffer *fb)
{
    char note[1024] = "";
    const char *path = tmp_path("preview_filmic.png");
    vsd_preview_options opt = {0};
    opt.view = "Filmic";
    CHECK_MSG(vsd_preview_write_png(path, fb, &opt, note, sizeof note, g_err, sizeof g_err) ==
              VSD_OK, "%s", g_err);
    CHECK_CONTAINS(note, "view Filmic");
    int w, h;
    unsigned char *px = read_png(path, &w, &h);
    CHECK(px && px[0] != 118 && px[0] > 60); /* Filmic maps 0.18 differently from sRGB */
    free(px);

    opt.view = "Bogus";
    CHECK(vsd_preview_write_png(tmp_path("bogus.png"), fb, &opt, note, sizeof note, g_err,
                                sizeof g_err) == VSD_ERR_NOT_FOUND);
    CHECK_CONTAINS(g_err, "Bogus");
    CHECK_CONTAINS(g_err, "Standard, Filmic");
    CHECK(!file_exists(tmp_path("bogus.png")));
    opt.view = NULL;
    opt.display = "NoSuchDisplay";
    CHECK(vsd_preview_write_png(tmp_path("bogus.png"), fb, &opt, note, sizeof note, g_err,
                                sizeof g_err) == VSD_ERR_NOT_FOUND);
    CHECK_CONTAINS(g_err, "sRGB");
    CHECK(vsd_preview_write_png(tmp_path("no/folder/p.png"), fb, NULL, note, sizeof note, g_err,
                                sizeof g_err) == VSD_ERR_IO);
}

/* $OCIO naming a missing file is an error (decision: the user asked for that config, and
 * silently falling back would render with the wrong view transform); with no $OCIO and no
 * Blender config, the plain sRGB transfer function is used and the note says so. */
static void test_preview_config_choice(vsd_framebuffer *fb)
{
    char note[1024];
    const char *path = tmp_path("preview_fallback.png");
    unlink(path);
    setenv("OCIO", "/nonexistent/config.ocio", 1);
    CHECK(vsd_preview_write_png(path, fb, NULL, note, sizeof note, g_err, sizeof g_err) ==
          VSD_ERR_IO);
    CHECK_CONTAINS(g_err, "/nonexistent/config.ocio");
    CHECK(!file_exists(path));

    setenv("OCIO", BLENDER_CONFIG, 1);
    CHECK(vsd_preview_write_png(path, fb, NULL, note, sizeof note, g_err, sizeof g_err) ==
          VSD_OK);
    CHECK_CONTAINS(note, "($OCIO)");

    unsetenv("OCIO");
    static const char *const none[] = {"/nonexistent/*/config.ocio", NULL};
    const char *const *saved = vsd_ocio_blender_candidates;
    vsd_ocio_blender_candidates = none;
    CHECK_MSG(vsd_preview_write_png(path, fb, NULL, note, sizeof note, g_err, sizeof g_err) ==
              VSD_OK, "%s", g_err);
    CHECK_CONTAINS(note, "plain sRGB");
    int w, h;
    unsigned char *px = read_png(path, &w, &h);
    CHECK(px && abs(px[0] - 118) <= 1 && abs(px[4] - 118) <= 1);
    free(px);
    vsd_preview_options opt = {0};
    opt.view = "Filmic";
    CHECK(vsd_preview_write_png(path, fb, &opt, note, sizeof note, g_err, sizeof g_err) ==
          VSD_ERR_NOT_FOUND);
    CHECK_CONTAINS(g_err, "Filmic");
    vsd_ocio_blender_candidates = saved;
}

static void test_preview(void)
{
    if (!file_exists(BLENDER_CONFIG)) {
        fprintf(stderr, "Blender's OCIO config is not installed: preview tests skipped\n");
        return;
    }
    unsetenv("OCIO"); /* the default choice: Blender's config */
    vsd_framebuffer *fb = grey_fb();
    CHECK(fb != NULL);
    if (!fb)
        return;
    test_preview_standard(fb);
    test_preview_views(fb);
    test_preview_config_choice(fb);
    CHECK(stray_tmp_files() == 0);
    vsd_framebuffer_destroy(fb);
}

/* ---- Blender sample --------------------------------------------------------------------- */

static int write_sample(const char *path)
{
    vsd_framebuffer *fb = make_fb(6, 4, sample_value);
    vsd_exr_attr attr = {"vsd/method", "sample"};
    vsd_exr_write_options opt = {0};
    opt.attrs = &attr;
    opt.attr_count = 1;
    vsd_status s = fb ? vsd_exr_write(path, fb, &opt, g_err, sizeof g_err) : VSD_ERR_NOMEM;
    vsd_framebuffer_destroy(fb);
    if (s != VSD_OK) {
        fprintf(stderr, "test_image --write-sample: %s\n", g_err);
        return 1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--write-sample") == 0)
        return write_sample(argv[2]);
    if (mkdir(tmp_path(""), 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "cannot create %s\n", tmp_path(""));
        return 1;
    }
    test_pass_names();
    test_framebuffer();
    test_roundtrip(0);
    test_roundtrip(1);
    test_compressions();
    test_encode_threads();
    test_encode_in_memory();
    test_mask_and_layer();
    test_renamed_passes();
    test_attributes();
    test_temp_and_write_errors();
    test_read_errors();
    test_preview();
    return test_finish("test_image");
}
