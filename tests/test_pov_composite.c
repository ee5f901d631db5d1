/* `vsd composite` (service/pipeline/composite.h): premultiplied over, per pixel by depth
 * where both sides have one, the passes carried, and the errors on bad input. */
#include "test_common.h"
#include "composite.h"
#include "vsd/image.h"
#include <stdlib.h>
#include <string.h>

#define W 4
#define H 3

/* A volume: pixel i has alpha i/(n-1), colour premultiplied, depth 2 + i, passes set. */
static vsd_framebuffer *make_volume(void)
{
    vsd_framebuffer *fb = NULL;
    int i, c, n = W * H;
    CHECK(vsd_framebuffer_create(W, H, &fb, NULL, 0) == VSD_OK);
    for (i = 0; i < n; i++) {
        float a = (float)i / (n - 1);
        for (c = 0; c < 3; c++) fb->pass[VSD_PASS_COMBINED][4 * i + c] = a * (0.2f + 0.3f * c);
        fb->pass[VSD_PASS_COMBINED][4 * i + 3] = a;
        for (c = 0; c < 3; c++) {
            fb->pass[VSD_PASS_VOLUME_DIR][3 * i + c] = 0.1f * a;
            fb->pass[VSD_PASS_VOLUME_IND][3 * i + c] = 0.05f * a;
            fb->pass[VSD_PASS_EMIT][3 * i + c] = 0.01f * i;
            fb->pass[VSD_PASS_TRANSMITTANCE][3 * i + c] = 1 - a;
        }
        fb->pass[VSD_PASS_DEPTH][i] = i == 0 ? VSD_DEPTH_EMPTY : 2.0f + i;
    }
    return fb;
}

static void check_over(void)
{
    vsd_framebuffer *vol = make_volume(), *out = NULL;
    float r[W * H], g[W * H], b[W * H], a[W * H], z[W * H];
    vsd_plate pl = {r, g, b, a, NULL};
    long wins = -1;
    int i, c;
    for (i = 0; i < W * H; i++) r[i] = 0.5f, g[i] = 0.25f, b[i] = 1.0f, a[i] = 1.0f, z[i] = 6.5f;
    CHECK(vsd_framebuffer_create(W, H, &out, NULL, 0) == VSD_OK);
    /* no depth on the plate: over everywhere */
    vsd_composite_over(vol, VSD_PASS_ALL, &pl, out, &wins);
    CHECK(wins == 0);
    for (i = 0; i < W * H; i++) {
        const float *v = vol->pass[VSD_PASS_COMBINED] + 4 * i, *o = out->pass[VSD_PASS_COMBINED] + 4 * i;
        const float p[4] = {r[i], g[i], b[i], a[i]};
        for (c = 0; c < 4; c++) CHECK_NEAR(o[c], v[c] + (1 - v[3]) * p[c], 1e-6);
        CHECK_NEAR(out->pass[VSD_PASS_VOLUME_DIR][3 * i], vol->pass[VSD_PASS_VOLUME_DIR][3 * i], 0);
        CHECK_NEAR(out->pass[VSD_PASS_DEPTH][i], vol->pass[VSD_PASS_DEPTH][i], 0);
    }
    /* with depth 6.5: pixels whose volume depth (2 + i) is farther, i >= 5, and the empty
     * pixel 0, show the plate; the volume passes vanish there */
    pl.depth = z;
    vsd_composite_over(vol, VSD_PASS_ALL, &pl, out, &wins);
    CHECK(wins == 1 + (W * H - 5));
    for (i = 0; i < W * H; i++) {
        const float *o = out->pass[VSD_PASS_COMBINED] + 4 * i, *v = vol->pass[VSD_PASS_COMBINED] + 4 * i;
        int plate_front = i == 0 || i >= 5;
        if (plate_front) {
            CHECK_NEAR(o[0], r[i], 0);
            CHECK_NEAR(o[3], 1, 0);
            CHECK_NEAR(out->pass[VSD_PASS_VOLUME_DIR][3 * i], 0, 0);
            CHECK_NEAR(out->pass[VSD_PASS_TRANSMITTANCE][3 * i], 1, 0);
            CHECK_NEAR(out->pass[VSD_PASS_DEPTH][i], 6.5, 0);
        } else {
            CHECK_NEAR(o[1], v[1] + (1 - v[3]) * g[i], 1e-6);
            CHECK_NEAR(out->pass[VSD_PASS_DEPTH][i], 2.0 + i, 0);
            CHECK_NEAR(out->pass[VSD_PASS_EMIT][3 * i], 0.01f * i, 0);
        }
    }
    /* a volume without Depth: no depth decision, plate depth passed on as min */
    vsd_composite_over(vol, VSD_PASS_ALL & ~VSD_PASS_BIT(VSD_PASS_DEPTH), &pl, out, &wins);
    CHECK(wins == 0);
    CHECK_NEAR(out->pass[VSD_PASS_COMBINED][4 * 11 + 3], 1.0, 1e-6);
    CHECK_NEAR(out->pass[VSD_PASS_DEPTH][3], 6.5, 0);
    vsd_framebuffer_destroy(out);
    vsd_framebuffer_destroy(vol);
}

static void write(const char *path, const vsd_framebuffer *fb, const char *layer, unsigned mask)
{
    vsd_exr_write_options o;
    char err[512];
    memset(&o, 0, sizeof o);
    o.layer = layer;
    o.pass_mask = mask;
    CHECK_MSG(vsd_exr_write(path, fb, &o, err, sizeof err) == VSD_OK, "%s", err);
}

static void check_files(void)
{
    char vpath[1100], ppath[1100], opath[1100], spath[1100], err[2048];
    vsd_framebuffer *vol = make_volume(), *plate = NULL, *small = NULL;
    vsd_composite_report rep;
    vsd_exr_image *img = NULL;
    int i;
    snprintf(vpath, sizeof vpath, "%s", test_tmp("comp_vol.exr"));
    snprintf(ppath, sizeof ppath, "%s", test_tmp("comp_plate.exr"));
    snprintf(opath, sizeof opath, "%s", test_tmp("comp_out.exr"));
    snprintf(spath, sizeof spath, "%s", test_tmp("comp_small.exr"));
    write(vpath, vol, "ViewLayer", 0);
    CHECK(vsd_framebuffer_create(W, H, &plate, NULL, 0) == VSD_OK);
    for (i = 0; i < W * H; i++) {
        plate->pass[VSD_PASS_COMBINED][4 * i] = 0.7f;
        plate->pass[VSD_PASS_COMBINED][4 * i + 3] = 1.0f;
        plate->pass[VSD_PASS_DEPTH][i] = 6.5f;
    }
    /* a plate that is itself a render: Plate.Combined and Plate.Depth.Z */
    write(ppath, plate, "Plate", VSD_PASS_BIT(VSD_PASS_COMBINED) | VSD_PASS_BIT(VSD_PASS_DEPTH));
    CHECK_MSG(vsd_composite_files(vpath, ppath, opath, NULL, &rep, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(rep.by_depth == 1 && rep.plate_wins == 8);
    CHECK(strcmp(rep.layer, "ViewLayer") == 0);
    CHECK_MSG(vsd_exr_read(opath, &img, err, sizeof err) == VSD_OK, "%s", err);
    if (img) {
        const float *r = vsd_exr_channel(img, "ViewLayer.Combined.R"), *z = vsd_exr_channel(img, "ViewLayer.Depth.Z");
        const float *t = vsd_exr_channel(img, "ViewLayer.Transmittance.G");
        CHECK(r && z && t && vsd_exr_channel(img, "ViewLayer.VolumeDir.B") && vsd_exr_channel(img, "ViewLayer.Emit.R"));
        if (r && z && t) {
            /* pixel 2: volume in front (depth 4 < 6.5) */
            float a = 2.0f / 11;
            CHECK_NEAR(r[2], a * 0.2f + (1 - a) * 0.7f, 1e-6);
            CHECK_NEAR(z[2], 4.0, 0);
            CHECK_NEAR(r[7], 0.7, 1e-6);
            CHECK_NEAR(t[7], 1.0, 0);
        }
        vsd_exr_image_destroy(img);
    }
    /* --no-depth: over everywhere */
    {
        vsd_composite_options o = {NULL, 1};
        CHECK_MSG(vsd_composite_files(vpath, ppath, opath, &o, &rep, err, sizeof err) == VSD_OK, "%s", err);
        CHECK(rep.by_depth == 0 && rep.plate_wins == 0);
    }
    /* errors */
    CHECK(vsd_framebuffer_create(W + 1, H, &small, NULL, 0) == VSD_OK);
    write(spath, small, "ViewLayer", 0);
    CHECK(vsd_composite_files(vpath, spath, opath, NULL, &rep, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "image sizes differ");
    CHECK_CONTAINS(err, "5x3");
    write(spath, vol, "ViewLayer", VSD_PASS_BIT(VSD_PASS_DEPTH));  /* no Combined: neither volume nor plate */
    CHECK(vsd_composite_files(spath, ppath, opath, NULL, &rep, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "no Combined pass");
    CHECK_CONTAINS(err, "ViewLayer.Depth.Z");
    CHECK(vsd_composite_files(vpath, spath, opath, NULL, &rep, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "no R, G, B channels");
    CHECK(vsd_composite_files(vpath, test_tmp("missing.exr"), opath, NULL, &rep, err, sizeof err) != VSD_OK);
    CHECK_CONTAINS(err, "missing.exr");
    CHECK(rep.output_error == 0);
    CHECK(vsd_composite_files(vpath, ppath, "/nonexistent-dir/out.exr", NULL, &rep, err, sizeof err) != VSD_OK);
    CHECK(rep.output_error == 1);
    vsd_framebuffer_destroy(small);
    vsd_framebuffer_destroy(plate);
    vsd_framebuffer_destroy(vol);
}

int main(void)
{
    check_over();
    check_files();
    return test_finish("test_pov_composite");
}
