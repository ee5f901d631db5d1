/* The POV-Ray camera and volume placement match vsd pixel for pixel (docs/povray.md).
 *
 * A small, dense, hard-edged box of voxels under a rotated, scaled, translated
 * volume.matrix is rendered by vsd (reference, transparent film: alpha = coverage) and by
 * POV-Ray from the exported camera .inc, twice: (a) as a plain POV-Ray box written here
 * independently of the exporter (the field's support, index [lo-1, hi+1], through the
 * grid and object transforms and the documented axis swap <x, z, y>), and (b) as the
 * exported df3 media .inc. POV-Ray runs without antialiasing, so each of its pixels is
 * the pixel centre's ray: in or out. vsd's pixels average rays over the pixel.
 *
 * Criterion, per pixel: where vsd's alpha is > 0.75 POV-Ray's must be > 0.5, and where
 * vsd's is < 0.25 POV-Ray's must be < 0.5 (a centre inside a straight edge means more than
 * half the pixel covered; the band 0.25..0.75 allows for 64-sample noise and the box's
 * corners); and the masks (alpha > 0.5) have the same bounding box to within one pixel.
 * A camera off by one pixel, a mirrored axis or a wrong aspect rule fails hundreds of
 * pixels. Cases: perspective landscape, perspective portrait (the fov spans the larger
 * side), orthographic. Exit 77 when `povray` is not installed. */
#include "test_common.h"
#include "test_render_util.h"
#include "pov_camera.h"
#include "pov_export.h"
#include "vsd/image.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* 200x120x80 voxels of 0.005: the trilinear ramp at the faces (one voxel, 0.0075 world
 * after the 1.5 scale) is a quarter pixel or less, so the field's opaque silhouette lies
 * within 1/8 pixel of the voxels' cells, the box POV-Ray draws; and the bricks hold little
 * empty space (delta tracking pays for the empty part of a dense brick in null
 * collisions). */
#define NX 200
#define NY 120
#define NZ 80
static const int32_t LO[3] = {16, -40, 32};
static const double I2W[16] = {0.005, 0, 0, -0.03, 0, 0.005, 0, 0.2, 0, 0, 0.005, 0.14, 0, 0, 0, 1};

static vsd_volume *box_volume(void)
{
    static float v[NX * NY * NZ];  /* static: 7.7 MB */
    const int32_t dims[3] = {NX, NY, NZ};
    vsd_volume *vol = NULL;
    int i;
    char err[256];
    for (i = 0; i < NX * NY * NZ; i++) v[i] = 1.0f;
    CHECK_MSG(vsd_volume_create_dense(v, dims, LO, I2W, &vol, err, sizeof err) == VSD_OK, "%s", err);
    return vol;
}

static void mul(const double a[16], const double b[16], double c[16])
{
    int i, j, k;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) {
            c[i * 4 + j] = 0;
            for (k = 0; k < 4; k++) c[i * 4 + j] += a[i * 4 + k] * b[k * 4 + j];
        }
}

/* POV-Ray scene: the exported camera, then either the exported volume or our own box. */
static int write_pov(const char *dir, const vsd_scene *sc)
{
    char path[1200];
    double m[16];
    FILE *f;
    snprintf(path, sizeof path, "%s/t.pov", dir);
    if (!(f = fopen(path, "w"))) return 0;
    mul(sc->volumes[0].matrix, I2W, m);  /* index -> Blender world */
    fprintf(f, "#version 3.7;\nglobal_settings { assumed_gamma 1 }\n#include \"cam_camera.inc\"\n"
               "background { rgbt <0, 0, 0, 1> }\n"
               "#ifdef (use_media)\n  #include \"cam_0001.inc\"\n  object { vsd_volume }\n#else\n");
    /* the voxels' cells, index [lo - 1/2, hi + 1/2]: the middle of the field's one-voxel ramp */
    fprintf(f, "  box { <%g, %g, %g>, <%g, %g, %g> pigment { rgb 1 } finish { ambient 1 diffuse 0 }\n", LO[0] - 0.5,
            LO[1] - 0.5, LO[2] - 0.5, LO[0] + NX - 0.5, LO[1] + NY - 0.5, LO[2] + NZ - 0.5);
    /* POV-Ray's matrix takes the columns of our column-vector matrix, then the translation */
    fprintf(f, "    matrix <%.17g, %.17g, %.17g, %.17g, %.17g, %.17g, %.17g, %.17g, %.17g, %.17g, %.17g, %.17g>\n",
            m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10], m[3], m[7], m[11]);
    fprintf(f, "    matrix <1, 0, 0,  0, 0, 1,  0, 1, 0,  0, 0, 0>  // Blender (x, y, z) -> POV-Ray <x, z, y>\n"
               "  }\n#end\n");
    return fclose(f) == 0;
}

static float *pov_alpha(const char *dir, int w, int h, int media)
{
    char cmd[2000], err[512], path[1200];
    vsd_exr_image *img = NULL;
    float *a = NULL;
    snprintf(cmd, sizeof cmd,
             "cd '%s' && rm -f t.exr && povray t.pov +W%d +H%d +FE +UA -A -D -GA +Ot.exr %s > povray.log 2>&1", dir,
             w, h, media ? "Declare=use_media=1" : "");
    if (system(cmd) != 0) {
        CHECK_MSG(0, "povray failed: see %s/povray.log", dir);
        return NULL;
    }
    snprintf(path, sizeof path, "%s/t.exr", dir);
    if (vsd_exr_read(path, &img, err, sizeof err) != VSD_OK) {
        CHECK_MSG(0, "%s", err);
        return NULL;
    }
    CHECK(img->width == w && img->height == h);
    if (vsd_exr_channel(img, "A") && img->width == w && img->height == h) {
        a = malloc(sizeof(float) * (size_t)w * h);
        memcpy(a, vsd_exr_channel(img, "A"), sizeof(float) * (size_t)w * h);
    } else
        CHECK_MSG(0, "no A channel in POV-Ray's EXR");
    vsd_exr_image_destroy(img);
    return a;
}

static void bbox(const float *a, int w, int h, int stride, int off, int b[4])
{
    int x, y;
    b[0] = w, b[1] = h, b[2] = -1, b[3] = -1;
    for (y = 0; y < h; y++)
        for (x = 0; x < w; x++)
            if (a[((size_t)y * w + x) * stride + off] > 0.5f) {
                if (x < b[0]) b[0] = x;
                if (y < b[1]) b[1] = y;
                if (x > b[2]) b[2] = x;
                if (y > b[3]) b[3] = y;
            }
}

static void compare(const char *what, const vsd_framebuffer *fb, const float *pov)
{
    int w = fb->width, h = fb->height, x, y, bad = 0, partial = 0, half_diff = 0, bv[4], bp[4], c;
    for (y = 0; y < h; y++)
        for (x = 0; x < w; x++) {
            float v = fb->pass[VSD_PASS_COMBINED][((size_t)y * w + x) * 4 + 3], p = pov[(size_t)y * w + x];
            if ((v > 0.75f && p < 0.5f) || (v < 0.25f && p > 0.5f)) {
                if (bad < 5) fprintf(stderr, "  %s: pixel (%d, %d): vsd alpha %.3f, POV-Ray %.3f\n", what, x, y, v, p);
                bad++;
            }
            if (v > 0.02f && v < 0.98f) partial++;
            if ((v > 0.5f) != (p > 0.5f)) half_diff++;
        }
    bbox(fb->pass[VSD_PASS_COMBINED], w, h, 4, 3, bv);
    bbox(pov, w, h, 1, 0, bp);
    printf("%s: %dx%d, %d edge pixels (vsd alpha 0.02..0.98), %d differ at 0.5, %d break the criterion; "
           "bbox vsd %d,%d-%d,%d POV-Ray %d,%d-%d,%d\n",
           what, w, h, partial, half_diff, bad, bv[0], bv[1], bv[2], bv[3], bp[0], bp[1], bp[2], bp[3]);
    CHECK_MSG(bad == 0, "%s: %d pixels disagree", what, bad);
    CHECK_MSG(bv[2] > bv[0] + 3 && bv[3] > bv[1] + 3, "%s: the box is not in view", what);
    for (c = 0; c < 4; c++) CHECK_MSG(abs(bv[c] - bp[c]) <= 1, "%s: bounding boxes differ (%d)", what, c);
}

static void run_case(const char *what, const char *camera, int w, int h, const vsd_volume *vol)
{
    char json[2048], err[512], dir[1100];
    vsd_scene sc;
    vsd_framebuffer *fb;
    vsd_pov_export_report rep;
    float *pov;
    FILE *f;
    /* volume.matrix: rotate 30 deg about z and 20 deg about x, scale 1.5, move */
    snprintf(json, sizeof json,
             "{\"version\":1,\"volume\":{\"file\":\"memory.vdb\",\"matrix\":["
             "1.299038,-0.75,0,0.4, 0.704769,1.220697,-0.513030,-0.3, 0.256515,0.444297,1.409539,0.2, 0,0,0,1]},"
             "\"medium\":{\"density\":2000,\"albedo\":[0,0,0]},\"environment\":{\"color\":[1,1,1]},"
             "\"camera\":%s,\"film\":{\"width\":%d,\"height\":%d,\"transparent\":true},"
             "\"render\":{\"method\":\"reference\",\"samples\":64,\"device\":\"cpu\"}}",
             camera, w, h);
    if (!test_parse_scene(json, NULL, 0, &sc)) return;
    snprintf(dir, sizeof dir, "%s", test_tmp("pov_camera"));
    CHECK_MSG(vsd_pov_prepare_dir(dir, err, sizeof err) == VSD_OK, "%s", err);
    {
        char path[1200];
        snprintf(path, sizeof path, "%s/cam_camera.inc", dir);
        f = fopen(path, "w");
        CHECK(f != NULL);
        if (!f) return;
        vsd_pov_write_camera(f, &sc);
        fclose(f);
    }
    memset(&rep, 0, sizeof rep);
    CHECK_MSG(vsd_pov_export_frame(&sc, 1, vol, NULL, dir, "cam", &rep, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(write_pov(dir, &sc));
    fb = test_render_fresh(&sc, NULL, vol, NULL, 1, NULL);
    CHECK(fb != NULL);
    if (!fb) return;
    {
        char label[128];
        snprintf(label, sizeof label, "%s, POV-Ray box", what);
        if ((pov = pov_alpha(dir, w, h, 0))) compare(label, fb, pov);
        free(pov);
        snprintf(label, sizeof label, "%s, exported df3 media", what);
        if ((pov = pov_alpha(dir, w, h, 1))) compare(label, fb, pov);
        free(pov);
    }
    vsd_framebuffer_destroy(fb);
}

int main(void)
{
    vsd_volume *vol;
    if (system("command -v povray > /dev/null 2>&1") != 0) {
        printf("povray not installed: skipped\n");
        return 77;
    }
    vol = box_volume();
    if (!vol) return test_finish("test_pov_camera");
    run_case("perspective 96x64",
             "{\"position\":[2.6,-2.2,2.1],\"look_at\":[0.75,0.35,0.9],\"up\":[0,0,1],\"fov\":0.9}", 96, 64, vol);
    run_case("perspective portrait 48x80",
             "{\"position\":[-1.8,-2.5,1.5],\"look_at\":[0.75,0.35,0.9],\"up\":[0,0,1],\"fov\":0.8}", 48, 80, vol);
    run_case("orthographic 72x54",
             "{\"type\":\"orthographic\",\"ortho_scale\":2.6,\"position\":[0.5,-3,3],\"look_at\":[0.75,0.35,0.9],"
             "\"up\":[0,0,1]}",
             72, 54, vol);
    vsd_volume_destroy(vol);
    return test_finish("test_pov_camera");
}
