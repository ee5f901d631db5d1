/* Scene file v1 contract (docs/scene-file.md): defaults, the three camera forms, every
 * validation message, overrides, path resolution, frame paths, method options, and the
 * shared example scenes in ../shared/data/scenes. */
#define _POSIX_C_SOURCE 200809L /* access(), chdir() */
#include "test_common.h"
#include "vsd/image.h"
#include "vsd/scene.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

/* The smallest valid scene, to which each case adds one section or key. */
#define MIN "\"version\": 1, \"volume\": {\"file\": \"v.vdb\"}"
#define BASE "/base"

static char err[2048];

static vsd_status parse_ov(const char *json, const char *const *ov, int n, vsd_scene *s)
{
    err[0] = '\0';
    return vsd_scene_parse(json, BASE, ov, n, s, err, sizeof err);
}

static vsd_status parse(const char *json, vsd_scene *s)
{
    return parse_ov(json, NULL, 0, s);
}

/* Parse `json` (with overrides) and require status `want` and `needle` in the message. */
static void expect_err_at(int line, const char *json, const char *const *ov, int n, vsd_status want,
                          const char *needle)
{
    vsd_scene s;
    vsd_status st = parse_ov(json, ov, n, &s);
    if (st != want || !strstr(err, needle)) {
        vsd_test_failures++;
        fprintf(stderr, "%s:%d: want %s \"%s\", got %s \"%s\"\n  json: %s\n", __FILE__, line,
                vsd_status_str(want), needle, vsd_status_str(st), err, json);
    }
}
#define EXPECT_ERR(json, want, needle) expect_err_at(__LINE__, json, NULL, 0, want, needle)
#define EXPECT_OV_ERR(json, ov, want, needle) \
    expect_err_at(__LINE__, json, ov, (int)(sizeof ov / sizeof ov[0]), want, needle)

/* `extra` is added to the minimal scene: EXTRA("\"film\": {...}"). */
static const char *with(const char *extra)
{
    static char buf[16384];
    snprintf(buf, sizeof buf, "{" MIN ", %s}", extra);
    return buf;
}

static void check_matrix(const double *got, const double *want, double tol)
{
    for (int i = 0; i < 16; i++)
        CHECK_NEAR(got[i], want[i], tol);
}

static void test_defaults(void)
{
    vsd_scene d;
    vsd_scene_defaults(&d);
    CHECK(d.version == 1);
    CHECK(!strcmp(d.base_dir, ""));
    CHECK(!strcmp(d.volumes[0].file, ""));
    CHECK(!strcmp(d.volumes[0].grid, "density"));
    CHECK(d.volumes[0].grid_index == -1);
    CHECK(!strcmp(d.volumes[0].emission_grid, ""));
    for (int i = 0; i < 16; i++)
        CHECK(d.volumes[0].matrix[i] == (i % 5 == 0 ? 1.0 : 0.0));
    CHECK_NEAR(d.volumes[0].medium.density, 1, 0);
    for (int i = 0; i < 3; i++) {
        CHECK_NEAR(d.volumes[0].medium.albedo[i], 0.8, 1e-7);
        CHECK_NEAR(d.volumes[0].medium.emission_color[i], 1, 0);
        CHECK_NEAR(d.environment.color[i], 0.05, 1e-7);
    }
    CHECK_NEAR(d.volumes[0].medium.anisotropy, 0, 0);
    CHECK_NEAR(d.volumes[0].medium.emission_strength, 0, 0);
    CHECK_NEAR(d.volumes[0].medium.ior, 1, 0);
    CHECK_NEAR(d.volumes[0].warn_above, 1e4, 0);
    CHECK(!strcmp(d.volumes[0].ior_grid, "") && !strcmp(d.volumes[0].medium.ior_from, "none"));
    CHECK(!strcmp(d.environment.file, ""));
    CHECK_NEAR(d.environment.strength, 1, 0);
    CHECK_NEAR(d.environment.rotation_z, 0, 0);
    CHECK(!strcmp(d.environment.colorspace, ""));
    CHECK(!strcmp(d.environment.working_space, ""));
    CHECK(d.light_count == 0);
    CHECK(d.camera.type == VSD_CAMERA_PERSPECTIVE);
    CHECK_NEAR(d.camera.fov, 2 * atan(18.0 / 50.0), 1e-15); /* 50 mm on 36 mm: 39.6 degrees */
    CHECK_NEAR(d.camera.ortho_scale, 7.31429, 1e-5);
    CHECK_NEAR(d.camera.clip_start, 0.1, 1e-12);
    CHECK_NEAR(d.camera.clip_end, 1000, 0);
    CHECK_NEAR(d.camera.matrix[3], 0, 0); /* default camera at (0,-6,1) */
    CHECK_NEAR(d.camera.matrix[7], -6, 0);
    CHECK_NEAR(d.camera.matrix[11], 1, 0);
    CHECK(d.film.width == 640 && d.film.height == 360 && d.film.transparent == 1);
    CHECK(!strcmp(d.render.method, "reference"));
    CHECK(!strcmp(d.render.device, "auto"));
    CHECK(d.render.samples == 64 && d.render.seed == 1 && d.render.threads == 0);
    CHECK(!strcmp(d.render.options_json, "{}"));
    CHECK(d.frames.start == 1 && d.frames.end == 1);
    CHECK(!strcmp(d.output.exr, "out/frame_####.exr"));
    CHECK(d.output.pass_mask == VSD_PASS_ALL);
    CHECK(!strcmp(d.output.layer, "ViewLayer"));
    for (int i = 0; i < VSD_PASS_COUNT; i++)
        CHECK_MSG(!strcmp(d.output.pass_names[i], vsd_pass_name((vsd_pass)i)), "pass %d: %s", i,
                  d.output.pass_names[i]);
    CHECK(d.output.half == 0);
    CHECK(!strcmp(d.output.compression, "zip"));
    CHECK(!strcmp(d.output.preview_png, ""));
    CHECK(!strcmp(d.output.view, ""));

    /* A minimal file gives the same values, with paths resolved against the folder. */
    vsd_scene s;
    CHECK_MSG(parse("{" MIN "}", &s) == VSD_OK, "%s", err);
    CHECK(!strcmp(s.base_dir, BASE));
    CHECK(!strcmp(s.volumes[0].file, BASE "/v.vdb"));
    CHECK(!strcmp(s.output.exr, BASE "/out/frame_####.exr"));
    memcpy(s.volumes[0].file, d.volumes[0].file, sizeof s.volumes[0].file);
    memcpy(s.output.exr, d.output.exr, sizeof s.output.exr);
    memcpy(s.base_dir, d.base_dir, sizeof s.base_dir);
    CHECK(!memcmp(&s, &d, sizeof s));
}

static void test_full_fixture(void)
{
    vsd_scene s;
    char path[2048];
    snprintf(path, sizeof path, "%s/tests/data/scenes/full.json", VSD_SOURCE_DIR);
    vsd_status st = vsd_scene_load(path, NULL, 0, &s, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "%s", err);
    char dir[1900];
    snprintf(dir, sizeof dir, "%s/tests/data/scenes", VSD_SOURCE_DIR);
    CHECK(!strcmp(s.base_dir, dir));
    char want[2100];
    snprintf(want, sizeof want, "%s/vdb/smoke_####.vdb", dir);
    CHECK(!strcmp(s.volumes[0].file, want));
    CHECK(!strcmp(s.volumes[0].grid, "density") && s.volumes[0].grid_index == -1);
    CHECK(!strcmp(s.volumes[0].emission_grid, "flame"));
    CHECK(s.volumes[0].matrix[0] == 2 && s.volumes[0].matrix[3] == 1 && s.volumes[0].matrix[7] == 2 &&
          s.volumes[0].matrix[11] == 3 && s.volumes[0].matrix[10] == 2);
    CHECK_NEAR(s.volumes[0].medium.density, 10, 0);
    CHECK_NEAR(s.volumes[0].medium.albedo[0], 0.9, 1e-6);
    CHECK_NEAR(s.volumes[0].medium.albedo[2], 0.7, 1e-6);
    CHECK_NEAR(s.volumes[0].medium.anisotropy, 0.3, 1e-6);
    CHECK_NEAR(s.volumes[0].medium.emission_color[1], 0.5, 1e-6);
    CHECK_NEAR(s.volumes[0].medium.emission_strength, 2.5, 0);
    CHECK_NEAR(s.volumes[0].medium.ior, 1.33, 1e-6);
    CHECK(!strcmp(s.environment.file, "/abs/sunset.exr"));
    CHECK_NEAR(s.environment.strength, 1.5, 0);
    CHECK_NEAR(s.environment.rotation_z, 0.25, 0);
    CHECK(!strcmp(s.environment.colorspace, "Linear Rec.709"));
    CHECK(!strcmp(s.environment.working_space, "ACEScg"));
    CHECK_NEAR(s.camera.fov, 0.5, 0);
    CHECK_NEAR(s.camera.ortho_scale, 5, 0);
    CHECK_NEAR(s.camera.clip_start, 0.01, 1e-12);
    CHECK_NEAR(s.camera.clip_end, 500, 0);
    CHECK(s.film.width == 320 && s.film.height == 240 && s.film.transparent == 0);
    CHECK(!strcmp(s.render.method, "shgrid") && !strcmp(s.render.device, "cpu"));
    CHECK(s.render.samples == 128 && s.render.seed == 7 && s.render.threads == 4);
    CHECK(s.frames.start == 3 && s.frames.end == 9);
    snprintf(want, sizeof want, "%s/renders/f_###.exr", dir);
    CHECK(!strcmp(s.output.exr, want));
    CHECK(s.output.pass_mask == (VSD_PASS_BIT(VSD_PASS_COMBINED) | VSD_PASS_BIT(VSD_PASS_DEPTH)));
    CHECK(!strcmp(s.output.layer, "RenderLayer"));
    CHECK(s.output.half == 1);
    CHECK(!strcmp(s.output.preview_png, "blob:0123abcd"));
    CHECK(!strcmp(s.output.view, "Filmic"));

    /* Method options: kept as the object the file gave, serialised; each method's table
     * (test_method_options.c) reads them */
    CHECK_MSG(!strcmp(s.render.options_json, "{\"lights\":64,\"mode\":\"kmeans\",\"cache\":true}"), "%s",
              s.render.options_json);
}

/* Form (a): position (0,-6,1) looking at the origin with Z up. By hand: forward
 * f = (0,6,-1)/sqrt(37); right = f x up = (1,0,0); up' = right x f = (0,1,6)/sqrt(37);
 * the camera's +Z column is -f = (0,-6,1)/sqrt(37). */
static void test_camera_look_at(void)
{
    vsd_scene s;
    CHECK_MSG(parse(with("\"camera\": {\"position\": [0,-6,1], \"look_at\": [0,0,0], \"up\": [0,0,1]}"), &s) == VSD_OK,
              "%s", err);
    double r = sqrt(37.0);
    double want[16] = {1, 0, 0, 0, 0, 1 / r, -6 / r, -6, 0, 6 / r, 1 / r, 1, 0, 0, 0, 1};
    check_matrix(s.camera.matrix, want, 1e-12);
    /* The camera's -Z axis points at the target. */
    double dz[3] = {-s.camera.matrix[2], -s.camera.matrix[6], -s.camera.matrix[10]};
    double to[3] = {0 - 0, 0 + 6, 0 - 1};
    double tl = sqrt(37.0);
    for (int i = 0; i < 3; i++)
        CHECK_NEAR(dz[i], to[i] / tl, 1e-12);
    CHECK_NEAR(s.camera.fov, 0.691111, 1e-6); /* default fov */

    /* Default up is +Z; a non-unit up and a target off the axis still give an orthonormal frame. */
    CHECK_MSG(parse(with("\"camera\": {\"position\": [3,-4,2], \"look_at\": [1,1,1], \"up\": [0,0,5], \"fov\": 0.7}"), &s) == VSD_OK,
              "%s", err);
    const double *m = s.camera.matrix;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            double d = m[a] * m[b] + m[4 + a] * m[4 + b] + m[8 + a] * m[8 + b];
            CHECK_NEAR(d, a == b ? 1 : 0, 1e-12);
        }
    CHECK(m[9] > 0); /* camera +Y has a positive world-Z component: not upside down */
    CHECK_NEAR(s.camera.fov, 0.7, 0);
}

/* Forms (b) and (c): a Blender matrix_world (camera at (0,-6,1), rotation_euler (90°,0,0),
 * which looks along +Y). Scale is dropped like Cycles does. */
static void test_camera_matrix(void)
{
    vsd_scene s;
    double want[16] = {1, 0, 0, 0, 0, 0, -1, -6, 0, 1, 0, 1, 0, 0, 0, 1};
    CHECK_MSG(parse(with("\"camera\": {\"matrix\": [1,0,0,0, 0,0,-1,-6, 0,1,0,1, 0,0,0,1], \"fov\": 0.9}"), &s) == VSD_OK,
              "%s", err);
    check_matrix(s.camera.matrix, want, 0);
    CHECK_NEAR(s.camera.fov, 0.9, 0);

    CHECK_MSG(parse(with("\"camera\": {\"matrix\": [2,0,0,0, 0,0,-2,-6, 0,2,0,1, 0,0,0,1], \"lens\": 50}"), &s) == VSD_OK,
              "%s", err);
    check_matrix(s.camera.matrix, want, 1e-15);
    CHECK_NEAR(s.camera.fov, 0.691111, 1e-6);
    CHECK_NEAR(s.camera.fov, 2 * atan(18.0 / 50.0), 1e-15);

    CHECK_MSG(parse(with("\"camera\": {\"matrix\": [1,0,0,0, 0,0,-1,-6, 0,1,0,1, 0,0,0,1], \"lens\": 35, \"sensor_width\": 24}"), &s) == VSD_OK,
              "%s", err);
    CHECK_NEAR(s.camera.fov, 2 * atan(12.0 / 35.0), 1e-15);

    /* lens also works with the look-at form */
    CHECK_MSG(parse(with("\"camera\": {\"position\": [0,-6,1], \"lens\": 25}"), &s) == VSD_OK, "%s", err);
    CHECK_NEAR(s.camera.fov, 2 * atan(18.0 / 25.0), 1e-15);

    CHECK_MSG(parse(with("\"camera\": {\"type\": \"orthographic\"}"), &s) == VSD_OK, "%s", err);
    CHECK(s.camera.type == VSD_CAMERA_ORTHOGRAPHIC);
    CHECK_NEAR(s.camera.ortho_scale, 7.314285755157471, 1e-12);
    CHECK_MSG(parse(with("\"camera\": {\"type\": \"orthographic\", \"ortho_scale\": 3}"), &s) == VSD_OK, "%s", err);
    CHECK_NEAR(s.camera.ortho_scale, 3, 0);
}

static void test_camera_errors(void)
{
    EXPECT_ERR(with("\"camera\": {\"position\": [0,-6,1], \"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}"),
               VSD_ERR_INVALID, "camera.matrix: cannot be combined with camera.position/look_at/up");
    EXPECT_ERR(with("\"camera\": {\"up\": [0,1,0], \"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}"),
               VSD_ERR_INVALID, "camera.matrix: cannot be combined");
    EXPECT_ERR(with("\"camera\": {\"fov\": 0.5, \"lens\": 50}"), VSD_ERR_INVALID,
               "camera.lens: cannot be combined with camera.fov");
    EXPECT_ERR(with("\"camera\": {\"sensor_width\": 24}"), VSD_ERR_INVALID, "camera.sensor_width: needs camera.lens");
    EXPECT_ERR(with("\"camera\": {\"position\": [1,2,3], \"look_at\": [1,2,3]}"), VSD_ERR_INVALID,
               "camera.look_at: equals camera.position");
    EXPECT_ERR(with("\"camera\": {\"position\": [0,0,5], \"look_at\": [0,0,0]}"), VSD_ERR_INVALID,
               "camera.up: is parallel to the view direction");
    EXPECT_ERR(with("\"camera\": {\"up\": [0,0,0]}"), VSD_ERR_INVALID, "camera.up: is the zero vector");
    EXPECT_ERR(with("\"camera\": {\"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0]}"), VSD_ERR_TYPE,
               "camera.matrix: expected 16 numbers");
    EXPECT_ERR(with("\"camera\": {\"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]}"), VSD_ERR_INVALID,
               "camera.matrix: last row must be 0, 0, 0, 1");
    EXPECT_ERR(with("\"camera\": {\"matrix\": [1,0.5,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}"), VSD_ERR_INVALID,
               "camera.matrix: rotation part is sheared");
    EXPECT_ERR(with("\"camera\": {\"fov\": 0}"), VSD_ERR_INVALID, "camera.fov: 0 is out of range (0, 3.14159)");
    EXPECT_ERR(with("\"camera\": {\"fov\": 3.2}"), VSD_ERR_INVALID, "camera.fov: 3.2 is out of range (0, 3.14159)");
    EXPECT_ERR(with("\"camera\": {\"fov\": \"wide\"}"), VSD_ERR_TYPE, "camera.fov: expected number");
    EXPECT_ERR(with("\"camera\": {\"lens\": 0}"), VSD_ERR_INVALID, "camera.lens: 0 is out of range (must be > 0)");
    EXPECT_ERR(with("\"camera\": {\"clip_end\": 0.05}"), VSD_ERR_INVALID,
               "camera.clip_end: 0.05 must be greater than camera.clip_start (0.1)");
    EXPECT_ERR(with("\"camera\": {\"type\": \"fisheye\"}"), VSD_ERR_INVALID,
               "camera.type: \"fisheye\" is not one of \"perspective\", \"orthographic\"");
    EXPECT_ERR(with("\"camera\": {\"fvo\": 0.5}"), VSD_ERR_INVALID,
               "camera.fvo: unknown key (known: type, position, look_at, up, matrix, fov, lens, "
               "sensor_width, ortho_scale, clip_start, clip_end)");
    EXPECT_ERR(with("\"camera\": [1]"), VSD_ERR_TYPE, "camera: expected object");
}

/* Every validation message of docs/scene-file.md, with its status. */
static void test_errors(void)
{
    EXPECT_ERR("{\"version\": 2, \"volume\": {\"file\": \"v.vdb\"}}", VSD_ERR_UNSUPPORTED, "version: expected 1, got 2");
    /* The version wins over everything else in a file of another version. */
    EXPECT_ERR("{\"version\": 2, \"new_section\": {}}", VSD_ERR_UNSUPPORTED, "version: expected 1, got 2");
    EXPECT_ERR("{\"volume\": {\"file\": \"v.vdb\"}}", VSD_ERR_INVALID, "version: required");
    EXPECT_ERR("{\"version\": \"1\", \"volume\": {\"file\": \"v.vdb\"}}", VSD_ERR_TYPE, "version: expected integer");
    EXPECT_ERR(with("\"colour\": 1"), VSD_ERR_INVALID,
               "colour: unknown key (known: version, volumes, environment, lights, camera, film, render, frames, output)");
    EXPECT_ERR("{\"version\": 1}", VSD_ERR_INVALID, "volumes: required (a list of volumes, or one `volume` with its `medium`)");
    EXPECT_ERR("{\"version\": 1, \"volume\": {}}", VSD_ERR_INVALID, "volume.file: required");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"\"}}", VSD_ERR_INVALID, "volume.file: required");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": 3}}", VSD_ERR_TYPE, "volume.file: expected string");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"fiel\": \"v.vdb\"}}", VSD_ERR_INVALID,
               "volume.fiel: unknown key (known: file, grid, emission_grid, matrix, warn_above, ior_grid, frame_offset, medium)");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"a_#_#.vdb\"}}", VSD_ERR_INVALID,
               "volume.file: \"/base/a_#_#.vdb\": more than one run of '#'");
    EXPECT_ERR(with("\"medium\": {\"albedo\": [1, 1]}"), VSD_ERR_TYPE, "medium.albedo: expected 3 numbers");
    EXPECT_ERR(with("\"medium\": {\"albedo\": 0.5}"), VSD_ERR_TYPE, "medium.albedo: expected 3 numbers");
    EXPECT_ERR(with("\"medium\": {\"albedo\": [1, \"a\", 1]}"), VSD_ERR_TYPE, "medium.albedo: expected 3 numbers");
    EXPECT_ERR(with("\"medium\": {\"albedo\": [0.5, 1.5, 0.5]}"), VSD_ERR_INVALID,
               "medium.albedo[1]: 1.5 is out of range 0..1");
    EXPECT_ERR(with("\"medium\": {\"density\": -1}"), VSD_ERR_INVALID,
               "medium.density: -1 is out of range (must be >= 0)");
    EXPECT_ERR(with("\"medium\": {\"density\": 1e999}"), VSD_ERR_INVALID, "medium.density: expected a finite number");
    EXPECT_ERR(with("\"medium\": {\"anisotropy\": 1}"), VSD_ERR_INVALID, "medium.anisotropy: 1 is out of range (-1, 1)");
    EXPECT_ERR(with("\"medium\": {\"anisotropy\": -1}"), VSD_ERR_INVALID, "medium.anisotropy: -1 is out of range (-1, 1)");
    EXPECT_ERR(with("\"medium\": {\"emission_strength\": -2}"), VSD_ERR_INVALID,
               "medium.emission_strength: -2 is out of range (must be >= 0)");
    EXPECT_ERR(with("\"medium\": {\"emission_color\": [1, -0.1, 0]}"), VSD_ERR_INVALID,
               "medium.emission_color[1]: -0.1 is out of range (must be >= 0)");
    EXPECT_ERR(with("\"medium\": {\"ior\": 0}"), VSD_ERR_INVALID, "medium.ior: 0 is out of range (must be > 0)");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"warn_above\": 0}}", VSD_ERR_INVALID,
               "volume.warn_above: 0 is out of range (must be > 0)");
    EXPECT_ERR(with("\"medium\": {\"ior_from\": \"heat\"}"), VSD_ERR_INVALID, "medium.ior_from:");
    EXPECT_ERR(with("\"environment\": {\"strength\": -0.5}"), VSD_ERR_INVALID,
               "environment.strength: -0.5 is out of range (must be >= 0)");
    EXPECT_ERR(with("\"environment\": {\"file\": \"a.exr\", \"color\": [1,1,1]}"), VSD_ERR_INVALID,
               "environment: give either file (an image) or color (uniform), not both");
    EXPECT_ERR(with("\"film\": {\"width\": 100000}"), VSD_ERR_INVALID, "film.width: 100000 is out of range 1..16384");
    EXPECT_ERR(with("\"film\": {\"height\": 0}"), VSD_ERR_INVALID, "film.height: 0 is out of range 1..16384");
    EXPECT_ERR(with("\"film\": {\"width\": 16384, \"height\": 16384}"), VSD_ERR_INVALID,
               "film: 16384x16384 = 268435456 pixels is too many (max 67108864)");
    EXPECT_ERR(with("\"film\": {\"width\": 640.5}"), VSD_ERR_TYPE, "film.width: expected integer");
    EXPECT_ERR(with("\"film\": {\"transparent\": 1}"), VSD_ERR_TYPE, "film.transparent: expected boolean");
    EXPECT_ERR(with("\"render\": {\"samples\": 0}"), VSD_ERR_INVALID, "render.samples: 0 is out of range 1..1000000");
    EXPECT_ERR(with("\"render\": {\"samples\": 1000001}"), VSD_ERR_INVALID,
               "render.samples: 1000001 is out of range 1..1000000");
    EXPECT_ERR(with("\"render\": {\"device\": \"gpu\"}"), VSD_ERR_INVALID,
               "render.device: \"gpu\" is not one of \"auto\", \"cpu\", \"cuda\"");
    EXPECT_ERR(with("\"render\": {\"method\": \"\"}"), VSD_ERR_INVALID, "render.method: must not be empty");
    EXPECT_ERR(with("\"render\": {\"options\": [1]}"), VSD_ERR_TYPE, "render.options: expected object");
    {
        static char big[12000];
        int n = snprintf(big, sizeof big, "\"render\": {\"options\": {\"x\": \"");
        memset(big + n, 'a', 5000);
        strcpy(big + n + 5000, "\"}}");
        EXPECT_ERR(with(big), VSD_ERR_INVALID, "render.options: too long (5008 bytes serialised, max 4095)");
    }
    EXPECT_ERR(with("\"frames\": {\"start\": 5, \"end\": 1}"), VSD_ERR_INVALID, "frames.end: 1 is before frames.start (5)");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"sun\", \"power\": 3}]"), VSD_ERR_INVALID,
               "lights[0].power: a sun light has no 'power' (its strength is in W/m^2)");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"sun\"}, {\"type\": \"point\", \"strength\": 3}]"), VSD_ERR_INVALID,
               "lights[1].strength: a point light has no 'strength' (its power is in watts)");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"point\", \"spot_size\": 1}]"), VSD_ERR_INVALID,
               "lights[0].spot_size: a point light has no 'spot_size'");
    EXPECT_ERR(with("\"lights\": [{\"power\": 3}]"), VSD_ERR_INVALID, "lights[0].type: required");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"area\"}]"), VSD_ERR_INVALID,
               "lights[0].type: \"area\" is not one of \"sun\", \"point\", \"spot\"");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"spot\", \"direction\": [0,0,0]}]"), VSD_ERR_INVALID,
               "lights[0].direction: must not be the zero vector");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"spot\", \"spot_blend\": 2}]"), VSD_ERR_INVALID,
               "lights[0].spot_blend: 2 is out of range 0..1");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"point\", \"power\": -1}]"), VSD_ERR_INVALID,
               "lights[0].power: -1 is out of range (must be >= 0)");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"point\", \"colour\": [1,1,1]}]"), VSD_ERR_INVALID,
               "lights[0].colour: unknown key (known: type, color, strength, power, position, direction, radius, angle, "
               "spot_size, spot_blend, spot_cosine)");
    EXPECT_ERR(with("\"lights\": [{\"type\": \"point\", \"spot_cosine\": false}]"), VSD_ERR_INVALID,
               "lights[0].spot_cosine");
    EXPECT_ERR(with("\"lights\": [3]"), VSD_ERR_TYPE, "lights[0]: expected object");
    {
        char many[2048] = "\"lights\": [";
        int i;
        for (i = 0; i < VSD_MAX_LIGHTS + 1; i++) strcat(many, i ? ", {\"type\": \"sun\"}" : "{\"type\": \"sun\"}");
        strcat(many, "]");
        EXPECT_ERR(with(many), VSD_ERR_UNSUPPORTED, "lights: 17 lights; at most 16 are supported (the environment is the main light)");
    }
    EXPECT_ERR(with("\"lights\": {}"), VSD_ERR_TYPE, "lights: expected array");
    EXPECT_ERR(with("\"output\": {\"passes\": [\"Combined\", \"Foo\"]}"), VSD_ERR_INVALID,
               "output.passes[1]: unknown pass \"Foo\" (known: Combined, VolumeDir, VolumeInd, Emit, Transmittance, Depth)");
    EXPECT_ERR(with("\"output\": {\"passes\": \"Combined\"}"), VSD_ERR_TYPE, "output.passes: expected array of pass names");
    EXPECT_ERR(with("\"output\": {\"passes\": [1]}"), VSD_ERR_TYPE, "output.passes[0]: expected string");
    EXPECT_ERR(with("\"output\": {\"passes\": []}"), VSD_ERR_INVALID, "output.passes: empty");
    EXPECT_ERR(with("\"output\": {\"pass_names\": {\"Foo\": \"Bar\"}}"), VSD_ERR_INVALID,
               "output.pass_names.Foo: unknown pass \"Foo\" (known: Combined, VolumeDir, VolumeInd, Emit, Transmittance, Depth)");
    EXPECT_ERR(with("\"output\": {\"pass_names\": [\"Volume Direct\"]}"), VSD_ERR_TYPE,
               "output.pass_names: expected object");
    EXPECT_ERR(with("\"output\": {\"pass_names\": {\"VolumeDir\": 1}}"), VSD_ERR_TYPE,
               "output.pass_names.VolumeDir: expected string");
    EXPECT_ERR(with("\"output\": {\"pass_names\": {\"VolumeDir\": \"\"}}"), VSD_ERR_INVALID,
               "output.pass_names.VolumeDir: empty name");
    EXPECT_ERR(with("\"output\": {\"pass_names\": {\"Emit\": \"Emission.001\"}}"), VSD_ERR_INVALID,
               "output.pass_names.Emit: \"Emission.001\" contains '.'");
    EXPECT_ERR(with("\"output\": {\"pass_names\": {\"Emit\": \"VolumeDir\"}}"), VSD_ERR_INVALID,
               "output.pass_names: VolumeDir and Emit are both named \"VolumeDir\"");
    EXPECT_ERR(with("\"output\": {\"pass_names\": {\"Depth\": "
                    "\"0123456789012345678901234567890123456789012345678901234567890123\"}}"),
               VSD_ERR_INVALID, "output.pass_names.Depth: longer than 63 characters");
    EXPECT_ERR(with("\"output\": {\"exr\": \"\"}"), VSD_ERR_INVALID, "output.exr: must not be empty");
    EXPECT_ERR(with("\"output\": {\"exr\": \"f_##_##.exr\"}"), VSD_ERR_INVALID, "output.exr: \"/base/f_##_##.exr\": more than one run");
    EXPECT_ERR(with("\"output\": {\"half\": \"yes\"}"), VSD_ERR_TYPE, "output.half: expected boolean");
    EXPECT_ERR(with("\"output\": {\"compression\": \"lz4\"}"), VSD_ERR_INVALID,
               "output.compression: \"lz4\" is not one of \"zip\", \"none\", \"rle\"");
    EXPECT_ERR(with("\"output\": {\"layer\": \"aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\"}"),
               VSD_ERR_INVALID, "output.layer: too long (140 characters, max 127)");
    EXPECT_ERR(with("\"volume\": {}"), VSD_ERR_INVALID, "volume: duplicate key");
    EXPECT_ERR(with("\"camera\": {\"fov\": 0.5, \"fov\": 0.6}"), VSD_ERR_INVALID, "camera.fov: duplicate key");
    EXPECT_ERR(with("\"volume\": 1"), VSD_ERR_INVALID, "volume: duplicate key");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"emission_grid\": 5}}", VSD_ERR_TYPE,
               "volume.emission_grid: expected string or null");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"grid\": -1}}", VSD_ERR_INVALID,
               "volume.grid: -1 is out of range (must be >= 0)");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"grid\": 1.5}}", VSD_ERR_TYPE,
               "volume.grid: expected string (grid name) or integer (grid index)");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"matrix\": [1,0,0,0, 0,0,0,0, 0,0,1,0, 0,0,0,1]}}",
               VSD_ERR_INVALID, "volume.matrix: singular");
    EXPECT_ERR("[1, 2]", VSD_ERR_TYPE, "expected a JSON object at the top level");
    EXPECT_ERR("{\"version\": 1,\n \"volume\": }", VSD_ERR_FORMAT, "line 2, column 12: invalid JSON near ' \"volume\": }'");
    EXPECT_ERR("", VSD_ERR_FORMAT, "line 1, column 1: invalid JSON (unexpected end of text)");
    EXPECT_ERR("{\"version\": 1,\n  \"volume\": {\n", VSD_ERR_FORMAT, "invalid JSON (unexpected end of text)");
    EXPECT_ERR("{\"version\": 1} x", VSD_ERR_FORMAT, "line 1, column 16: invalid JSON near");

    /* A failed parse leaves the caller's struct untouched. */
    vsd_scene s, before;
    memset(&s, 0x5A, sizeof s);
    before = s;
    CHECK(parse(with("\"film\": {\"width\": 0}"), &s) == VSD_ERR_INVALID);
    CHECK(!memcmp(&s, &before, sizeof s));
    /* NULL err buffer is allowed. */
    CHECK(vsd_scene_parse("{}", "", NULL, 0, &s, NULL, 0) == VSD_ERR_INVALID);
}

static void test_values(void)
{
    vsd_scene s;
    CHECK_MSG(parse("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"grid\": 2}}", &s) == VSD_OK, "%s", err);
    CHECK(s.volumes[0].grid_index == 2 && !strcmp(s.volumes[0].grid, ""));
    CHECK_MSG(parse("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"grid\": \"\"}}", &s) == VSD_OK, "%s", err);
    CHECK(s.volumes[0].grid_index == -1 && !strcmp(s.volumes[0].grid, ""));
    CHECK_MSG(parse(with("\"environment\": {\"color\": [0.2, 0.3, 0.4]}"), &s) == VSD_OK, "%s", err);
    CHECK(!strcmp(s.environment.file, ""));
    CHECK_NEAR(s.environment.color[1], 0.3, 1e-7);
    /* null where allowed means the default */
    CHECK_MSG(parse(with("\"environment\": {\"file\": null, \"color\": [1,1,1]}, \"output\": {\"preview_png\": null, \"view\": null}"), &s) == VSD_OK,
              "%s", err);
    CHECK(!strcmp(s.environment.file, "") && !strcmp(s.output.preview_png, ""));
    CHECK_MSG(parse(with("\"lights\": []"), &s) == VSD_OK, "%s", err);
    CHECK(s.light_count == 0);
    /* the three types, with their defaults (docs/scene-file.md) and the direction normalised */
    CHECK_MSG(parse(with("\"lights\": [{\"type\": \"sun\", \"strength\": 3, \"direction\": [0, 3, -4], \"angle\": 0.1},"
                         " {\"type\": \"point\", \"position\": [1, 2, 3], \"color\": [1, 0.5, 0.25]},"
                         " {\"type\": \"spot\", \"power\": 50, \"radius\": 0.1}]"), &s) == VSD_OK, "%s", err);
    CHECK(s.light_count == 3);
    CHECK(s.lights[0].type == VSD_LIGHT_SUN && s.lights[0].strength == 3.0f && s.lights[0].angle == 0.1f);
    CHECK(fabs(s.lights[0].direction[1] - 0.6) < 1e-12 && fabs(s.lights[0].direction[2] + 0.8) < 1e-12);
    CHECK(s.lights[1].type == VSD_LIGHT_POINT && s.lights[1].power == 1000.0f && s.lights[1].position[2] == 3.0 &&
          s.lights[1].color[1] == 0.5f && s.lights[1].radius == 0.0f);
    CHECK(s.lights[2].type == VSD_LIGHT_SPOT && s.lights[2].power == 50.0f && s.lights[2].direction[2] == -1.0 &&
          fabs(s.lights[2].spot_size - 0.785398) < 1e-5 && s.lights[2].spot_blend == 0.15f);
    CHECK_MSG(parse(with("\"frames\": {\"start\": -3, \"end\": -3}"), &s) == VSD_OK, "%s", err);
    CHECK(s.frames.start == -3);
    /* Integers may be written with an exponent or a ".0" */
    CHECK_MSG(parse(with("\"film\": {\"width\": 1.28e3, \"height\": 720.0}"), &s) == VSD_OK, "%s", err);
    CHECK(s.film.width == 1280 && s.film.height == 720);
    /* A byte-order mark is skipped. */
    CHECK_MSG(parse("\xEF\xBB\xBF{" MIN "}", &s) == VSD_OK, "%s", err);
}

static void test_paths(void)
{
    vsd_scene s;
    char e[512];
    CHECK(vsd_scene_parse("{" MIN "}", "", NULL, 0, &s, e, sizeof e) == VSD_OK);
    CHECK(!strcmp(s.volumes[0].file, "v.vdb") && !strcmp(s.output.exr, "out/frame_####.exr"));
    CHECK(vsd_scene_parse("{" MIN "}", NULL, NULL, 0, &s, e, sizeof e) == VSD_OK);
    CHECK(!strcmp(s.volumes[0].file, "v.vdb"));
    CHECK(vsd_scene_parse("{" MIN "}", "/dir/", NULL, 0, &s, e, sizeof e) == VSD_OK);
    CHECK(!strcmp(s.volumes[0].file, "/dir/v.vdb"));
    CHECK(vsd_scene_parse("{" MIN "}", "/", NULL, 0, &s, e, sizeof e) == VSD_OK);
    CHECK(!strcmp(s.volumes[0].file, "/v.vdb"));
    const char *json = "{\"version\": 1, \"volume\": {\"file\": \"/abs/v_####.vdb\"},"
                       "\"environment\": {\"file\": \"blob:9f86d081\"},"
                       "\"output\": {\"exr\": \"../out/#.exr\", \"preview_png\": \"p/prev_####.png\"}}";
    CHECK_MSG(parse(json, &s) == VSD_OK, "%s", err);
    CHECK(!strcmp(s.volumes[0].file, "/abs/v_####.vdb"));
    CHECK(!strcmp(s.environment.file, "blob:9f86d081"));
    CHECK(!strcmp(s.output.exr, BASE "/../out/#.exr"));
    CHECK(!strcmp(s.output.preview_png, BASE "/p/prev_####.png"));

    /* Too long once joined with the folder */
    static char longjson[4096];
    char name[1100];
    memset(name, 'n', 1020);
    name[1020] = '\0';
    snprintf(longjson, sizeof longjson, "{\"version\": 1, \"volume\": {\"file\": \"%s\"}}", name);
    EXPECT_ERR(longjson, VSD_ERR_INVALID, "volume.file: path too long (1026 characters, max 1023)");
}

/* output.pass_names: the EXR layer names for a Blender that renamed its passes (5.0), from
 * the file and from an override (`vsd render --set`); unnamed passes keep vsd's names. */
static void test_pass_names(void)
{
    vsd_scene s;
    const char *json = "{" MIN ", \"output\": {\"pass_names\": {\"VolumeDir\": \"Volume Direct\","
                       " \"VolumeInd\": \"Volume Indirect\", \"Emit\": \"Emission\"}}}";
    CHECK_MSG(parse(json, &s) == VSD_OK, "%s", err);
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_COMBINED], "Combined"));
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_VOLUME_DIR], "Volume Direct"));
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_VOLUME_IND], "Volume Indirect"));
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_EMIT], "Emission"));
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_TRANSMITTANCE], "Transmittance"));
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_DEPTH], "Depth"));
    CHECK(s.output.pass_mask == VSD_PASS_ALL);
    const char *ov[] = {"output.pass_names.Transmittance=Opacity"};
    CHECK_MSG(parse_ov(json, ov, 1, &s) == VSD_OK, "%s", err);
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_TRANSMITTANCE], "Opacity"));
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_EMIT], "Emission"));
    const char *ov_null[] = {"output.pass_names=null"};
    CHECK_MSG(parse_ov(json, ov_null, 1, &s) == VSD_OK, "%s", err);
    CHECK(!strcmp(s.output.pass_names[VSD_PASS_VOLUME_DIR], "VolumeDir"));
}

static void test_overrides(void)
{
    vsd_scene s;
    const char *ov1[] = {"render.samples=256", "render.method=shgrid", "medium.albedo=[0.1, 0.2, 0.3]",
                         "film.transparent=false", "output.preview_png=null", "output.layer=\"Quoted\"",
                         "render.options.lights=64", "render.options.mode=fast",
                         "render.options.nested.deep=1", "film.width=100", "render.seed=3", "render.seed=4",
                         "output.view="};
    CHECK_MSG(parse_ov("{" MIN ", \"output\": {\"preview_png\": \"x.png\"}}", ov1, 13, &s) == VSD_OK, "%s", err);
    CHECK(s.render.samples == 256);
    CHECK(!strcmp(s.render.method, "shgrid"));
    CHECK_NEAR(s.volumes[0].medium.albedo[0], 0.1, 1e-7);
    CHECK_NEAR(s.volumes[0].medium.albedo[2], 0.3, 1e-7);
    CHECK(s.film.transparent == 0);
    CHECK(!strcmp(s.output.preview_png, ""));
    CHECK(!strcmp(s.output.layer, "Quoted"));
    CHECK(!strcmp(s.output.view, ""));
    CHECK(s.film.width == 100 && s.film.height == 360); /* section created by the override */
    CHECK(s.render.seed == 4);                          /* later overrides win */
    CHECK_MSG(!strcmp(s.render.options_json, "{\"lights\":64,\"mode\":\"fast\",\"nested\":{\"deep\":1}}"), "%s",
              s.render.options_json);

    const char *typo[] = {"render.sampels=1"};
    EXPECT_OV_ERR("{" MIN "}", typo, VSD_ERR_INVALID, "render.sampels: unknown key (known: method, device, samples");
    const char *noeq[] = {"render.samples"};
    EXPECT_OV_ERR("{" MIN "}", noeq, VSD_ERR_INVALID, "override \"render.samples\": expected key.path=value");
    const char *empty1[] = {"=5"};
    EXPECT_OV_ERR("{" MIN "}", empty1, VSD_ERR_INVALID, "override \"=5\": empty key name");
    const char *empty2[] = {"render..samples=5"};
    EXPECT_OV_ERR("{" MIN "}", empty2, VSD_ERR_INVALID, "override \"render..samples=5\": empty key name");
    const char *notobj[] = {"camera.fov.x=1"};
    EXPECT_OV_ERR("{" MIN ", \"camera\": {\"fov\": 0.5}}", notobj, VSD_ERR_INVALID,
                  "override \"camera.fov.x=1\": camera.fov is not an object");
    const char *range[] = {"film.width=100000"};
    EXPECT_OV_ERR("{" MIN "}", range, VSD_ERR_INVALID, "film.width: 100000 is out of range 1..16384");
    const char *type[] = {"render.samples=many"};
    EXPECT_OV_ERR("{" MIN "}", type, VSD_ERR_TYPE, "render.samples: expected integer");
    const char *ver[] = {"version=2"};
    EXPECT_OV_ERR("{" MIN "}", ver, VSD_ERR_UNSUPPORTED, "version: expected 1, got 2");
    const char *opts[] = {"render.options=5"};
    EXPECT_OV_ERR("{" MIN "}", opts, VSD_ERR_TYPE, "render.options: expected object");
}

/* The shared example scenes load, and their files exist once the frame is put in. */
static void test_shared_scenes(void)
{
    static const char *names[] = {"cloud128_interior.json", "cloud256_sunset.json", "fire96_studio.json",
                                  "smoke128_forest.json", "smoke64_sunset.json"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char rel[128], path[2048], file[VSD_PATH_LEN + 32];
        snprintf(rel, sizeof rel, "scenes/%s", names[i]);
        snprintf(path, sizeof path, "%s", test_data(rel));
        vsd_scene s;
        vsd_status st = vsd_scene_load(path, NULL, 0, &s, err, sizeof err);
        CHECK_MSG(st == VSD_OK, "%s: %s", names[i], err);
        if (st)
            continue;
        CHECK(!strncmp(path, s.base_dir, strlen(s.base_dir)) && strstr(s.base_dir, "scenes"));
        CHECK(vsd_frame_path(s.volumes[0].file, s.frames.start, file, sizeof file, err, sizeof err) == VSD_OK);
        CHECK_MSG(access(file, R_OK) == 0, "%s: volume %s", names[i], file);
        CHECK_MSG(access(s.environment.file, R_OK) == 0, "%s: environment %s", names[i], s.environment.file);
        CHECK(!strncmp(s.output.exr, s.base_dir, strlen(s.base_dir)));
        CHECK(s.frames.end >= s.frames.start);
    }

    /* --frames 3-5 on a loaded scene, the way the CLI passes it */
    const char *frames[] = {"frames.start=3", "frames.end=5"};
    vsd_scene s;
    CHECK_MSG(vsd_scene_load(test_data("scenes/smoke64_sunset.json"), frames, 2, &s, err, sizeof err) == VSD_OK,
              "%s", err);
    CHECK(s.frames.start == 3 && s.frames.end == 5);
    const char *late[] = {"frames.start=40"};
    CHECK(vsd_scene_load(test_data("scenes/smoke64_sunset.json"), late, 1, &s, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "smoke64_sunset.json: frames.end: 30 is before frames.start (40)");
}

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    CHECK_MSG(f != NULL, "cannot write %s", path);
    if (!f)
        return;
    fputs(text, f);
    fclose(f);
}

/* Messages from a file start with its path. */
static void test_file_errors(void)
{
    vsd_scene s;
    char path[2048], want[2300];
    snprintf(path, sizeof path, "%s", test_tmp("scene_badfov.json"));
    write_file(path, "{\"version\": 1, \"volume\": {\"file\": \"v.vdb\"}, \"camera\": {\"fov\": \"wide\"}}");
    CHECK(vsd_scene_load(path, NULL, 0, &s, err, sizeof err) == VSD_ERR_TYPE);
    snprintf(want, sizeof want, "%s: camera.fov: expected number", path);
    CHECK(!strcmp(err, want));

    snprintf(path, sizeof path, "%s/tests/data/scenes/malformed.json", VSD_SOURCE_DIR);
    CHECK(vsd_scene_load(path, NULL, 0, &s, err, sizeof err) == VSD_ERR_FORMAT);
    snprintf(want, sizeof want, "%s: line 3, column 30: invalid JSON near 'e\": \"a.vdb\",}'", path);
    CHECK_MSG(!strcmp(err, want), "%s", err);

    snprintf(path, sizeof path, "%s", test_tmp("no_such_scene.json"));
    CHECK(vsd_scene_load(path, NULL, 0, &s, err, sizeof err) == VSD_ERR_IO);
    snprintf(want, sizeof want, "%s: cannot open: No such file or directory", path);
    CHECK_MSG(!strcmp(err, want), "%s", err);

    CHECK(vsd_scene_load(test_tmp(""), NULL, 0, &s, err, sizeof err) == VSD_ERR_IO); /* a folder */
    CHECK_CONTAINS(err, "cannot read");

    /* A relative scene path: base_dir is its folder, also relative. */
    CHECK(chdir(VSD_SOURCE_DIR) == 0);
    CHECK_MSG(vsd_scene_load("tests/data/scenes/full.json", NULL, 0, &s, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(!strcmp(s.base_dir, "tests/data/scenes"));
    CHECK(!strcmp(s.volumes[0].file, "tests/data/scenes/vdb/smoke_####.vdb"));

    /* Overrides apply to loaded files too, and a bad one is named without the file prefix. */
    const char *bad[] = {"nonsense"};
    CHECK(vsd_scene_load("tests/data/scenes/full.json", bad, 1, &s, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "override \"nonsense\"");
}

static void test_frame_path(void)
{
    char out[64], e[256];
    CHECK(vsd_frame_path("smoke_####.vdb", 1, out, sizeof out, e, sizeof e) == VSD_OK && !strcmp(out, "smoke_0001.vdb"));
    CHECK(vsd_frame_path("smoke_####.vdb", 12345, out, sizeof out, e, sizeof e) == VSD_OK && !strcmp(out, "smoke_12345.vdb"));
    CHECK(vsd_frame_path("smoke_####.vdb", -3, out, sizeof out, e, sizeof e) == VSD_OK && !strcmp(out, "smoke_-003.vdb"));
    CHECK(vsd_frame_path("f#.exr", 7, out, sizeof out, e, sizeof e) == VSD_OK && !strcmp(out, "f7.exr"));
    CHECK(vsd_frame_path("######", 42, out, sizeof out, e, sizeof e) == VSD_OK && !strcmp(out, "000042"));
    CHECK(vsd_frame_path("plain.vdb", 5, out, sizeof out, e, sizeof e) == VSD_OK && !strcmp(out, "plain.vdb"));
    /* '#' in a folder name is part of the name (as in Blender) */
    CHECK(vsd_frame_path("take#2/f_###.exr", 4, out, sizeof out, e, sizeof e) == VSD_OK &&
          !strcmp(out, "take#2/f_004.exr"));
    CHECK(vsd_frame_path("a_##_##.exr", 1, out, sizeof out, e, sizeof e) == VSD_ERR_INVALID);
    CHECK_CONTAINS(e, "\"a_##_##.exr\": more than one run of '#'");
    /* exact fit, then one byte short */
    CHECK(vsd_frame_path("ab_##", 5, out, 6, e, sizeof e) == VSD_OK && !strcmp(out, "ab_05"));
    CHECK(vsd_frame_path("ab_##", 5, out, 5, e, sizeof e) == VSD_ERR_INVALID);
    CHECK_CONTAINS(e, "path too long (6 bytes needed, buffer holds 5)");
    CHECK(vsd_frame_path("ab_##", 123, out, 6, e, sizeof e) == VSD_ERR_INVALID);
    CHECK(vsd_frame_path(NULL, 1, out, sizeof out, e, sizeof e) == VSD_ERR_INVALID);
}

/* volumes[]: several volumes, each with its own fields and `medium` (docs/scene-file.md
 * "volumes"). The single `volume` + `medium` of the other tests reads as a list of one. */
#define VOLS2 "\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"file\": \"b.vdb\"}]"

static void test_volumes_list(void)
{
    vsd_scene s;
    const char *three =
        "{\"version\": 1, \"volumes\": ["
        " {\"file\": \"fire_####.vdb\", \"grid\": \"density\", \"emission_grid\": \"flame\", \"frame_offset\": -2,"
        "  \"medium\": {\"density\": 5, \"albedo\": [0.5, 0.4, 0.3], \"emission_color\": [1, 0.5, 0.1],"
        "              \"emission_strength\": 10}},"
        " {\"file\": \"/abs/smoke_####.vdb\", \"grid\": 3, \"matrix\": [1,0,0,0.5, 0,1,0,0, 0,0,1,0, 0,0,0,1],"
        "  \"warn_above\": 100, \"medium\": {\"density\": 2, \"anisotropy\": 0.5}},"
        " {\"file\": \"cloud.vdb\", \"grid\": \"\", \"ior_grid\": \"n\", \"frame_offset\": 7,"
        "  \"medium\": {\"density\": 0.25, \"albedo\": [1, 1, 1], \"anisotropy\": -0.2, \"ior_from\": \"temperature\"}}]}";
    CHECK_MSG(parse(three, &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 3);
    /* the fire */
    CHECK(!strcmp(s.volumes[0].file, BASE "/fire_####.vdb"));
    CHECK(!strcmp(s.volumes[0].grid, "density") && s.volumes[0].grid_index == -1);
    CHECK(!strcmp(s.volumes[0].emission_grid, "flame"));
    CHECK(s.volumes[0].frame_offset == -2);
    CHECK_NEAR(s.volumes[0].medium.density, 5, 0);
    CHECK_NEAR(s.volumes[0].medium.albedo[1], 0.4, 1e-7);
    CHECK_NEAR(s.volumes[0].medium.emission_color[2], 0.1, 1e-7);
    CHECK_NEAR(s.volumes[0].medium.emission_strength, 10, 0);
    CHECK_NEAR(s.volumes[0].medium.anisotropy, 0, 0);
    /* the smoke: an absolute path, a grid by index, its own matrix and warn_above */
    CHECK(!strcmp(s.volumes[1].file, "/abs/smoke_####.vdb"));
    CHECK(!strcmp(s.volumes[1].grid, "") && s.volumes[1].grid_index == 3);
    CHECK(!strcmp(s.volumes[1].emission_grid, ""));
    CHECK(s.volumes[1].matrix[3] == 0.5 && s.volumes[1].matrix[0] == 1 && s.volumes[1].matrix[15] == 1);
    CHECK_NEAR(s.volumes[1].warn_above, 100, 0);
    CHECK(s.volumes[1].frame_offset == 0);
    CHECK_NEAR(s.volumes[1].medium.density, 2, 0);
    CHECK_NEAR(s.volumes[1].medium.anisotropy, 0.5, 0);
    CHECK_NEAR(s.volumes[1].medium.albedo[0], 0.8, 1e-7); /* the defaults of its own medium */
    CHECK_NEAR(s.volumes[1].medium.emission_strength, 0, 0);
    CHECK(!strcmp(vsd_scene_ior_grid(&s.volumes[1]), ""));
    /* the cloud */
    CHECK(!strcmp(s.volumes[2].file, BASE "/cloud.vdb"));
    CHECK(!strcmp(s.volumes[2].grid, "") && s.volumes[2].grid_index == -1);
    CHECK(!strcmp(s.volumes[2].ior_grid, "n") && !strcmp(s.volumes[2].medium.ior_from, "temperature"));
    CHECK(!strcmp(vsd_scene_ior_grid(&s.volumes[2]), "n"));
    CHECK_NEAR(s.volumes[2].medium.density, 0.25, 0);
    CHECK_NEAR(s.volumes[2].medium.albedo[2], 1, 0);
    CHECK_NEAR(s.volumes[2].medium.anisotropy, -0.2, 1e-7);
    CHECK(s.volumes[2].frame_offset == 7);

    /* frame_offset: volume v reads #### = frame + frame_offset (Blender's Offset) */
    CHECK(vsd_scene_volume_frame(&s.volumes[0], 10) == 8);
    CHECK(vsd_scene_volume_frame(&s.volumes[1], 10) == 10);
    CHECK(vsd_scene_volume_frame(&s.volumes[2], -3) == 4);
    char file[VSD_PATH_LEN + 32];
    CHECK(vsd_frame_path(s.volumes[0].file, vsd_scene_volume_frame(&s.volumes[0], 1), file, sizeof file, err,
                         sizeof err) == VSD_OK);
    CHECK_MSG(!strcmp(file, BASE "/fire_-001.vdb"), "%s", file);
    /* ... clamped to Blender's frame range */
    CHECK_MSG(parse("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"frame_offset\": -1048574},"
                    " {\"file\": \"b.vdb\", \"frame_offset\": 1048574}]}", &s) == VSD_OK, "%s", err);
    CHECK(vsd_scene_volume_frame(&s.volumes[0], -5) == -1048574);
    CHECK(vsd_scene_volume_frame(&s.volumes[0], 5) == -1048569);
    CHECK(vsd_scene_volume_frame(&s.volumes[1], 1) == 1048574);
    CHECK(vsd_scene_volume_frame(&s.volumes[1], -1048574) == 0);

    /* Defaults per entry: a second volume with only a file has every default, whatever the
     * first one sets. */
    CHECK_MSG(parse("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"grid\": \"heat\", \"emission_grid\": \"flame\","
                    " \"matrix\": [2,0,0,0, 0,2,0,0, 0,0,2,0, 0,0,0,1], \"warn_above\": 5, \"ior_grid\": \"t\","
                    " \"frame_offset\": 3, \"medium\": {\"density\": 9, \"albedo\": [0.1, 0.1, 0.1], \"anisotropy\": 0.9,"
                    " \"emission_color\": [2, 2, 2], \"emission_strength\": 4, \"ior\": 1.2, \"ior_from\": \"temperature\"}},"
                    " {\"file\": \"b.vdb\"}]}", &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 2);
    CHECK_NEAR(s.volumes[0].medium.ior, 1.2, 1e-7);
    {
        vsd_scene d;
        vsd_scene_defaults(&d);
        CHECK(d.volume_count == 1);
        const vsd_scene_volume *b = &s.volumes[1], *w = &d.volumes[0];
        CHECK(!strcmp(b->file, BASE "/b.vdb"));
        CHECK(!strcmp(b->grid, w->grid) && b->grid_index == w->grid_index);
        CHECK(!strcmp(b->emission_grid, "") && !strcmp(b->ior_grid, ""));
        CHECK(!memcmp(b->matrix, w->matrix, sizeof b->matrix));
        CHECK(b->warn_above == w->warn_above && b->frame_offset == 0);
        CHECK(!memcmp(&b->medium.density, &w->medium.density,
                      offsetof(vsd_scene_medium, ior_from) - offsetof(vsd_scene_medium, density)));
        CHECK(!strcmp(b->medium.ior_from, "none"));
    }
    /* A medium that is absent or {} is the default medium. */
    CHECK_MSG(parse("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"medium\": {}}]}", &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 1 && s.volumes[0].medium.density == 1.0f && !strcmp(s.volumes[0].medium.ior_from, "none"));

    /* The single form is a list of one: the same scene either way. */
    {
        vsd_scene a, b;
        CHECK_MSG(parse("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"grid\": \"heat\", \"frame_offset\": 2},"
                        " \"medium\": {\"density\": 3, \"albedo\": [0.5, 0.5, 0.5]}}", &a) == VSD_OK, "%s", err);
        CHECK_MSG(parse("{\"version\": 1, \"volumes\": [{\"file\": \"v.vdb\", \"grid\": \"heat\", \"frame_offset\": 2,"
                        " \"medium\": {\"density\": 3, \"albedo\": [0.5, 0.5, 0.5]}}]}", &b) == VSD_OK, "%s", err);
        CHECK(a.volume_count == 1 && !memcmp(&a, &b, sizeof a));
        /* a top-level medium without a volume is still a volume without its file */
        EXPECT_ERR("{\"version\": 1, \"medium\": {\"density\": 3}}", VSD_ERR_INVALID, "volume.file: required");
    }

    /* The limit: 16 volumes read, 17 are refused. */
    {
        static char many[4096];
        int n = snprintf(many, sizeof many, "{\"version\": 1, \"volumes\": [");
        for (int i = 0; i < VSD_MAX_VOLUMES; i++)
            n += snprintf(many + n, sizeof many - (size_t)n, "%s{\"file\": \"v%d.vdb\", \"medium\": {\"density\": %d}}",
                          i ? ", " : "", i, i);
        snprintf(many + n, sizeof many - (size_t)n, "]}");
        CHECK_MSG(parse(many, &s) == VSD_OK, "%s", err);
        CHECK(s.volume_count == VSD_MAX_VOLUMES);
        CHECK(!strcmp(s.volumes[15].file, BASE "/v15.vdb") && s.volumes[15].medium.density == 15.0f);
        snprintf(many + n, sizeof many - (size_t)n, ", {\"file\": \"v16.vdb\"}]}");
        EXPECT_ERR(many, VSD_ERR_UNSUPPORTED, "volumes: 17 volumes; at most 16 are supported");
        /* an override that appends a 17th is refused the same way */
        const char *ov17[] = {"volumes.16.file=v16.vdb"};
        snprintf(many + n, sizeof many - (size_t)n, "]}");
        EXPECT_OV_ERR(many, ov17, VSD_ERR_UNSUPPORTED, "volumes: 17 volumes; at most 16 are supported");
    }
}

static void test_volumes_errors(void)
{
    /* both forms */
    EXPECT_ERR("{" VOLS2 ", \"volume\": {\"file\": \"v.vdb\"}}", VSD_ERR_INVALID,
               "volumes: the scene also has `volume`: write either the list `volumes` (each entry with its own "
               "`medium`) or one `volume` with `medium`, not both");
    EXPECT_ERR("{" VOLS2 ", \"medium\": {\"density\": 2}}", VSD_ERR_INVALID,
               "volumes: the scene also has `medium`: write either the list `volumes` (each entry with its own "
               "`medium`) or one `volume` with `medium`, not both");
    {
        vsd_scene s;
        CHECK(parse("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}], \"volume\": {\"file\": \"v.vdb\"}}", &s) ==
              VSD_ERR_INVALID);
        CHECK_MSG(!strcmp(err, "volumes: the scene also has `volume`: write either the list `volumes` (each entry "
                               "with its own `medium`) or one `volume` with `medium`, not both"), "%s", err);
    }
    /* the list's shape */
    EXPECT_ERR("{\"version\": 1, \"volumes\": []}", VSD_ERR_INVALID, "volumes: empty; a scene holds at least one volume");
    EXPECT_ERR("{\"version\": 1, \"volumes\": {\"file\": \"a.vdb\"}}", VSD_ERR_TYPE,
               "volumes: expected array (of volume objects)");
    EXPECT_ERR("{\"version\": 1, \"volumes\": null}", VSD_ERR_TYPE, "volumes: expected array (of volume objects)");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, \"b.vdb\"]}", VSD_ERR_TYPE,
               "volumes[1]: expected object");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [[]]}", VSD_ERR_TYPE, "volumes[0]: expected object");
    EXPECT_ERR("{\"version\": 1, \"volume\": [{\"file\": \"a.vdb\"}]}", VSD_ERR_TYPE, "volume: expected object");
    /* errors name the entry */
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"file\": \"b.vdb\", \"medium\": {\"density\": -1}}]}",
               VSD_ERR_INVALID, "volumes[1].medium.density: -1 is out of range (must be >= 0)");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"file\": \"b.vdb\", \"medium\": {\"density\": \"x\"}}]}",
               VSD_ERR_TYPE, "volumes[1].medium.density: expected number");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"file\": \"b.vdb\"},"
               " {\"file\": \"c.vdb\", \"medium\": {\"albedo\": [0.5, 2, 0.5]}}]}",
               VSD_ERR_INVALID, "volumes[2].medium.albedo[1]: 2 is out of range 0..1");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"medium\": {\"dens\": 1}}]}", VSD_ERR_INVALID,
               "volumes[0].medium.dens: unknown key (known: density, albedo, anisotropy, emission_color, "
               "emission_strength, ior, ior_from)");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"medium\": [1]}]}", VSD_ERR_TYPE,
               "volumes[0].medium: expected object");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"grid\": \"density\"}]}", VSD_ERR_INVALID,
               "volumes[1].file: required");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"file\": \"b.vdb\", \"fiel\": 1}]}", VSD_ERR_INVALID,
               "volumes[1].fiel: unknown key (known: file, grid, emission_grid, matrix, warn_above, ior_grid, "
               "frame_offset, medium)");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"file\": \"b.vdb\", \"frame_offset\": 0.5}]}",
               VSD_ERR_TYPE, "volumes[1].frame_offset: expected integer");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"frame_offset\": 2000000}]}", VSD_ERR_INVALID,
               "volumes[0].frame_offset: 2000000 is out of range -1048574..1048574");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"file\": \"b_##_##.vdb\"}]}", VSD_ERR_INVALID,
               "volumes[1].file: \"/base/b_##_##.vdb\": more than one run of '#'");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 1,0,0,1]}]}",
               VSD_ERR_INVALID, "volumes[0].matrix: last row must be 0, 0, 0, 1");
    /* the single form keeps its own names; a `medium` inside `volume` is not its place */
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"medium\": {}}}", VSD_ERR_INVALID,
               "volume.medium: unknown key (a single volume's material is the top-level `medium`)");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"v.vdb\", \"frame_offset\": \"2\"}}", VSD_ERR_TYPE,
               "volume.frame_offset: expected integer");
    /* repeated keys */
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"a.vdb\"}, \"volume\": {\"file\": \"b.vdb\"}}", VSD_ERR_INVALID,
               "volume: duplicate key");
    EXPECT_ERR("{\"version\": 1, \"volume\": {\"file\": \"a.vdb\"}, \"medium\": {}, \"medium\": {}}", VSD_ERR_INVALID,
               "medium: duplicate key");
    EXPECT_ERR("{" VOLS2 ", \"volumes\": [{\"file\": \"c.vdb\"}]}", VSD_ERR_INVALID, "volumes: duplicate key");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"file\": \"b.vdb\"}]}", VSD_ERR_INVALID,
               "volumes[0].file: duplicate key");
    EXPECT_ERR("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"medium\": {\"ior\": 1.1, \"ior\": 1.2}}]}",
               VSD_ERR_INVALID, "volumes[0].medium.ior: duplicate key");

    /* From a file, the message starts with its path. */
    {
        vsd_scene s;
        char path[2048], want[2400];
        snprintf(path, sizeof path, "%s", test_tmp("scene_volumes_bad.json"));
        FILE *f = fopen(path, "wb");
        CHECK_MSG(f != NULL, "cannot write %s", path);
        if (f) {
            fputs("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\"}, {\"file\": \"b.vdb\", \"medium\": {\"density\": -2}}]}",
                  f);
            fclose(f);
        }
        CHECK(vsd_scene_load(path, NULL, 0, &s, err, sizeof err) == VSD_ERR_INVALID);
        snprintf(want, sizeof want, "%s: volumes[1].medium.density: -2 is out of range (must be >= 0)", path);
        CHECK_MSG(!strcmp(err, want), "%s", err);
    }
}

static void test_volumes_overrides(void)
{
    vsd_scene s;
    /* volumes.N.... indexes the list (0-based) */
    const char *ov1[] = {"volumes.1.medium.density=3", "volumes.0.grid=heat", "volumes.1.frame_offset=-4",
                         "volumes.0.medium.albedo=[0.1, 0.2, 0.3]"};
    CHECK_MSG(parse_ov("{" VOLS2 "}", ov1, 4, &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 2);
    CHECK_NEAR(s.volumes[1].medium.density, 3, 0);
    CHECK_NEAR(s.volumes[0].medium.density, 1, 0);
    CHECK(!strcmp(s.volumes[0].grid, "heat") && !strcmp(s.volumes[1].grid, "density"));
    CHECK(s.volumes[1].frame_offset == -4 && s.volumes[0].frame_offset == 0);
    CHECK_NEAR(s.volumes[0].medium.albedo[1], 0.2, 1e-7);
    /* index == length appends an entry; its path resolves like the file's own */
    const char *ov2[] = {"volumes.2.file=c_####.vdb", "volumes.2.medium.emission_strength=5"};
    CHECK_MSG(parse_ov("{" VOLS2 "}", ov2, 2, &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 3);
    CHECK(!strcmp(s.volumes[2].file, BASE "/c_####.vdb"));
    CHECK_NEAR(s.volumes[2].medium.emission_strength, 5, 0);
    CHECK_NEAR(s.volumes[2].medium.density, 1, 0);
    /* a whole entry as JSON, appended */
    const char *ov3[] = {"volumes.2={\"file\": \"d.vdb\", \"medium\": {\"density\": 7}}"};
    CHECK_MSG(parse_ov("{" VOLS2 "}", ov3, 1, &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 3 && !strcmp(s.volumes[2].file, BASE "/d.vdb") && s.volumes[2].medium.density == 7.0f);
    /* ... or replaced */
    const char *ov4[] = {"volumes.0={\"file\": \"e.vdb\"}"};
    CHECK_MSG(parse_ov("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"medium\": {\"density\": 9}}]}", ov4, 1, &s) ==
                  VSD_OK, "%s", err);
    CHECK(s.volume_count == 1 && !strcmp(s.volumes[0].file, BASE "/e.vdb") && s.volumes[0].medium.density == 1.0f);
    /* ... or the whole list */
    const char *ov5[] = {"volumes=[{\"file\": \"x.vdb\"}, {\"file\": \"y.vdb\"}, {\"file\": \"z.vdb\"}]"};
    CHECK_MSG(parse_ov("{" MIN "}", ov5, 1, &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 3 && !strcmp(s.volumes[2].file, BASE "/z.vdb"));
    /* an appended entry without a file is named */
    const char *ov6[] = {"volumes.2.medium.density=3"};
    EXPECT_OV_ERR("{" VOLS2 "}", ov6, VSD_ERR_INVALID, "volumes[2].file: required");
    /* what an override writes is validated and named like the file's own */
    const char *ov7[] = {"volumes.1.medium.density=-3"};
    EXPECT_OV_ERR("{" VOLS2 "}", ov7, VSD_ERR_INVALID, "volumes[1].medium.density: -3 is out of range (must be >= 0)");
    const char *ov8[] = {"volumes.1.medium.densty=3"};
    EXPECT_OV_ERR("{" VOLS2 "}", ov8, VSD_ERR_INVALID, "volumes[1].medium.densty: unknown key (known: density,");

    /* a bad index */
    const char *bad1[] = {"volumes.7.file=x.vdb"};
    EXPECT_OV_ERR("{" VOLS2 "}", bad1, VSD_ERR_INVALID,
                  "override \"volumes.7.file=x.vdb\": volumes.7: an index 0..2 of the list expected");
    {
        CHECK(parse_ov("{" VOLS2 "}", bad1, 1, &s) == VSD_ERR_INVALID);
        CHECK_MSG(!strcmp(err, "override \"volumes.7.file=x.vdb\": volumes.7: an index 0..2 of the list expected"), "%s",
                  err);
    }
    const char *bad2[] = {"volumes.-1.file=x.vdb"};
    EXPECT_OV_ERR("{" VOLS2 "}", bad2, VSD_ERR_INVALID,
                  "override \"volumes.-1.file=x.vdb\": volumes.-1: an index 0..2 of the list expected");
    const char *bad3[] = {"volumes.one.file=x.vdb"};
    EXPECT_OV_ERR("{" VOLS2 "}", bad3, VSD_ERR_INVALID,
                  "override \"volumes.one.file=x.vdb\": volumes.one: an index 0..2 of the list expected");
    const char *bad4[] = {"volumes.5={\"file\": \"x.vdb\"}"};
    EXPECT_OV_ERR("{" VOLS2 "}", bad4, VSD_ERR_INVALID,
                  "override \"volumes.5={\"file\": \"x.vdb\"}\": volumes.5: an index 0..2 of the list expected");
    const char *bad5[] = {"volumes.0.file.x=1"};
    EXPECT_OV_ERR("{" VOLS2 "}", bad5, VSD_ERR_INVALID,
                  "override \"volumes.0.file.x=1\": volumes.0.file is not an object");

    /* medium.K / volume.K name the only volume of a one-volume scene, in either form ... */
    const char *one[] = {"medium.density=3", "volume.grid=heat", "volume.frame_offset=5"};
    CHECK_MSG(parse_ov("{\"version\": 1, \"volumes\": [{\"file\": \"a.vdb\", \"medium\": {\"albedo\": [0.5, 0.5, 0.5]}}]}",
                       one, 3, &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 1);
    CHECK_NEAR(s.volumes[0].medium.density, 3, 0);
    CHECK_NEAR(s.volumes[0].medium.albedo[0], 0.5, 0);
    CHECK(!strcmp(s.volumes[0].grid, "heat") && s.volumes[0].frame_offset == 5);
    CHECK_MSG(parse_ov("{" MIN "}", one, 3, &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 1 && s.volumes[0].medium.density == 3.0f && !strcmp(s.volumes[0].grid, "heat"));
    const char *whole[] = {"medium={\"density\": 4}", "volume={\"file\": \"w.vdb\"}"};
    CHECK_MSG(parse_ov("{" MIN ", \"medium\": {\"albedo\": [0.5, 0.5, 0.5]}}", whole, 2, &s) == VSD_OK, "%s", err);
    CHECK(!strcmp(s.volumes[0].file, BASE "/w.vdb"));
    /* `volume={...}` replaces the entry, and with it the medium the entry held */
    CHECK_NEAR(s.volumes[0].medium.density, 1, 0);
    /* ... and are refused on a scene of several, saying which form to use */
    const char *two_m[] = {"medium.density=3"};
    EXPECT_OV_ERR("{" VOLS2 "}", two_m, VSD_ERR_INVALID,
                  "override \"medium.density=3\": the scene has 2 volumes; say which, e.g. volumes.0.medium.density=3");
    CHECK(parse_ov("{" VOLS2 "}", two_m, 1, &s) == VSD_ERR_INVALID);
    CHECK_MSG(!strcmp(err, "override \"medium.density=3\": the scene has 2 volumes; say which, e.g. "
                           "volumes.0.medium.density=3"), "%s", err);
    const char *two_v[] = {"volume.file=x.vdb"};
    EXPECT_OV_ERR("{" VOLS2 "}", two_v, VSD_ERR_INVALID,
                  "override \"volume.file=x.vdb\": the scene has 2 volumes; say which, e.g. volumes.0.file=x.vdb");
    const char *two_w[] = {"medium={\"density\": 3}"};
    EXPECT_OV_ERR("{" VOLS2 "}", two_w, VSD_ERR_INVALID,
                  "override \"medium={\"density\": 3}\": the scene has 2 volumes; say which, e.g. "
                  "volumes.0.medium={\"density\": 3}");
    /* counted when the override is applied: after an append, the scene has two */
    const char *grow[] = {"volumes.1.file=b.vdb", "medium.density=3"};
    EXPECT_OV_ERR("{" MIN "}", grow, VSD_ERR_INVALID,
                  "override \"medium.density=3\": the scene has 2 volumes; say which, e.g. volumes.0.medium.density=3");
    /* an entry appended to a single-form scene is named by its index */
    const char *grow2[] = {"volumes.1.file=b.vdb", "volumes.1.medium.density=-1"};
    EXPECT_OV_ERR("{" MIN "}", grow2, VSD_ERR_INVALID, "volumes[1].medium.density: -1 is out of range (must be >= 0)");
    const char *grow3[] = {"volumes.1.medium.density=2"};
    EXPECT_OV_ERR("{" MIN "}", grow3, VSD_ERR_INVALID, "volumes[1].file: required");
    const char *grow4[] = {"volumes.1.file=b.vdb", "volumes.1.medium.density=2"};
    CHECK_MSG(parse_ov("{" MIN ", \"medium\": {\"density\": 6}}", grow4, 2, &s) == VSD_OK, "%s", err);
    CHECK(s.volume_count == 2 && s.volumes[0].medium.density == 6.0f && s.volumes[1].medium.density == 2.0f);
}

int main(void)
{
    test_defaults();
    test_full_fixture();
    test_camera_look_at();
    test_camera_matrix();
    test_camera_errors();
    test_errors();
    test_values();
    test_paths();
    test_pass_names();
    test_overrides();
    test_shared_scenes();
    test_file_errors();
    test_frame_path();
    test_volumes_list();
    test_volumes_errors();
    test_volumes_overrides();
    return test_finish("test_scene");
}
