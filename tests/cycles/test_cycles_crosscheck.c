/* `reference` against Blender Cycles on the same scene (docs/architecture.md §10; method, numbers and
 * findings in docs/cycles-crosscheck.md).
 *
 * A small scene -- smoke64 frame 24, dense enough (density 30, albedo 0.9, HG g = 0.4)
 * that ~70% of the light reaching the camera has scattered more than once, lit by the soft
 * studio.exr rotated by 1.2 rad, 96x54 -- is rendered twice by vsd's `reference` (seeds 1
 * and 2, 2048 spp) and twice by Cycles through tests/cycles/cycles_scene.py (seeds 1 and 2,
 * 512 spp). All four images are compared after a 4x4 block average:
 *
 *   rel(X, Y) = sqrt(mean over blocks and channels of (X - Y)^2) / mean |Y|
 *   e         = rel(mean of the vsd pair, mean of the Cycles pair)       (what is tested)
 *   floor     = sqrt(rel(vsd1, vsd2)^2 + rel(cyc1, cyc2)^2) / 2          (e's size from
 *               noise alone: a difference of two renders has the sum of their variances,
 *               and the mean of a pair half the variance of one render)
 *
 * for Combined RGB, Combined alpha, VolumeDir, VolumeInd (and Emit when the scene emits).
 * Asserted: e <= K floor, and |mean(vsd) - mean(Cycles)| / mean(Cycles) <= 4 se + 0.5%
 * (se from the seed pairs: blocks are independent, every pixel has its own random stream;
 * 0.5% covers the bias of Cycles' ray marching at a quarter-voxel step, and with the 4 se
 * the +0.5-1% excess of Cycles 5.0's default null scattering on the dense smoke).
 *
 * K comes from a null study (docs/cycles-crosscheck.md): e / floor of two unbiased
 * renderers, measured on 40 disjoint quadruples of vsd-only renders of this scene (seeds
 * 1..160, 512 spp): Combined RGB mean 0.96 sd 0.115 max 1.32; alpha 1.05 / 0.19 / 1.57;
 * VolumeDir 0.95 / 0.15 / 1.32; VolumeInd 0.95 / 0.125 / 1.29. K = mean + 5 sd, rounded
 * up: 1.55, 2.0, 1.75, 1.6. A bias b adds in quadrature (e^2 = floor^2 + b^2), so the RMSE
 * check fails once b > sqrt(K^2 - 1) floor (Combined RGB: ~3%); the mean check catches a
 * global bias of ~1% (Combined RGB) and ~0.6% (alpha).
 *
 * Measured on the 2-core development machine (Blender 3.4.1, both renderers on 2 threads):
 *   Combined RGB  e 0.0290  floor 0.0265  (1.10)  mean -0.00% (se 0.15%)
 *   alpha         e 0.0033  floor 0.0038  (0.87)  mean -0.02% (se 0.02%)
 *   VolumeDir     e 0.0468  floor 0.0515  (0.91)  mean -0.47% (se 0.29%)
 *   VolumeInd     e 0.0369  floor 0.0311  (1.18)  mean +0.19% (se 0.18%)
 *   without the half-voxel correction below: Combined RGB e 0.151 (5.7 floor), alpha 0.164
 *   (41 floor).
 *   Time: about 60 s on an idle machine (vsd 2 x 5.5 s, Cycles 2 x 15-30 s), 142 s with the
 *   machine shared (load average 8).
 * Both renderers are deterministic for a fixed seed, so on one build the test gives the same
 * numbers every run; the bounds matter when code changes reshuffle the noise.
 *
 * Cycles 3.4-4.5 place voxel i's centre at index i + 0.5, vsd (like OpenVDB) and Cycles 5.0
 * at i: for 3.4-4.5 the script moves the Blender object by half a voxel (its default
 * --voxel-centres openvdb) so both render the same field.
 *
 *   test_cycles_crosscheck [--blender 'CMD [ARG...]'] [--script PATH] [--vsd-spp N]
 *                          [--cycles-spp N] [--scene smoke|fire|lights|volumes] [--dir DIR]
 *                          [--cycles-arg ARG]...
 *   test_cycles_crosscheck --compare V1.exr V2.exr C1.exr C2.exr   (the metrics of 4 files)
 *
 * --blender is the command that stands in for `blender`: a path, a name on $PATH, or several
 * words separated by spaces (no quoting), e.g. a bpy wheel's python followed by
 * tests/blender_addon/blender_wheel.py (ctest test_cycles_crosscheck_blender42/45/50 and
 * _fire_blender42/45/50; measured against each version in docs/cycles-crosscheck.md, "Newer
 * Cycles"). --cycles-arg passes one more argument to cycles_scene.py (repeatable), e.g.
 * --cycles-arg --volume-biased. The Blender 5.0 pass names (Volume Direct, Volume Indirect,
 * Emission) are read as VolumeDir, VolumeInd and Emit.
 *
 * --scene fire (ctest test_cycles_crosscheck_fire, with --vsd-spp 1024 --cycles-spp 256) checks
 * emission and its passes on fire96 frame 48. --scene lights (ctest
 * test_cycles_crosscheck_lights, the same spp) checks the scene's lights[] in Cycles' units: the
 * smoke scene under a map dimmed to 0.15, lit by a point light (radius 0.1), a spot with a
 * soft edge and a sun with a 2-degree disc; measured: Combined RGB e/floor 0.97, mean
 * +0.07% (se 0.26%), VolumeDir 1.12 / -0.34%, VolumeInd 0.99 / +0.19%. Exit 77 (ctest SKIP)
 * when no Blender is found. Nothing is cached between runs: the working folder's files are
 * deleted first. */
#define _POSIX_C_SOURCE 200809L
#include "test_common.h"
#include "vsd/clock.h"
#include "vsd/compare.h"
#include "vsd/image.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "run_logged.h"
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#ifndef VSD_BLENDER_EXE
#define VSD_BLENDER_EXE "blender"
#endif
#ifndef VSD_CYCLES_SCRIPT
#define VSD_CYCLES_SCRIPT VSD_SOURCE_DIR "/tests/cycles/cycles_scene.py"
#endif

#define WIDTH 96
#define HEIGHT 54
#define BLOCK 4
#define MEAN_SIGMAS 4.0    /* |mean difference| <= MEAN_SIGMAS se + MEAN_BIAS */
#define MEAN_BIAS 0.005

/* ---- images ---------------------------------------------------------------------------- */

/* The four compared quantities, each an interleaved buffer of `ch` channels. */
enum { Q_RGB, Q_ALPHA, Q_DIR, Q_IND, Q_EMIT, Q_COUNT };
static const char *const q_name[Q_COUNT] = {"Combined RGB", "Combined alpha", "VolumeDir", "VolumeInd", "Emit"};
static const int q_channels[Q_COUNT] = {3, 1, 3, 3, 3};
/* e <= ratio_bound * floor: the null study's mean + 5 sd of e / floor, rounded up (top
 * comment). Emit is only checked when the scene emits (--scene fire); its bound has had no
 * null study and takes the widest of the others. */
static const double ratio_bound[Q_COUNT] = {1.55, 2.0, 1.75, 1.6, 2.0};

typedef struct planes {
    int width, height;
    float *q[Q_COUNT];
} planes;

static void planes_free(planes *p)
{
    int i;
    for (i = 0; i < Q_COUNT; i++) free(p->q[i]);
    memset(p, 0, sizeof *p);
}

/* Channel `names[c]` ("ViewLayer.<pass>.<channel>"), or the same channel of the pass's
 * Blender 5.0 name `alt` ("Volume Direct", "Volume Indirect", "Emission": 5.0 names its
 * passes as its UI does; vsd and Blender 3.4-4.5 write VolumeDir, VolumeInd, Emit). */
static const float *find_channel(const vsd_exr_image *img, const char *name, const char *alt)
{
    const float *src = vsd_exr_channel(img, name);
    const char *chan = strrchr(name, '.');
    char other[128];
    if (src || !alt || !chan) return src;
    snprintf(other, sizeof other, "ViewLayer.%s%s", alt, chan);
    return vsd_exr_channel(img, other);
}

static int gather(const vsd_exr_image *img, const char *const *names, const char *alt, int ch, float **out)
{
    int n = img->width * img->height, c, i;
    *out = malloc(sizeof(float) * (size_t)n * ch);
    if (!*out) return 0;
    for (c = 0; c < ch; c++) {
        const float *src = find_channel(img, names[c], alt);
        if (!src) {
            fprintf(stderr, "missing channel %s\n", names[c]);
            return 0;
        }
        for (i = 0; i < n; i++) (*out)[(size_t)i * ch + c] = src[i];
    }
    return 1;
}

static int load_planes(const char *path, planes *p)
{
    static const char *const rgb[] = {"ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B"};
    static const char *const alpha[] = {"ViewLayer.Combined.A"};
    static const char *const dir[] = {"ViewLayer.VolumeDir.R", "ViewLayer.VolumeDir.G", "ViewLayer.VolumeDir.B"};
    static const char *const ind[] = {"ViewLayer.VolumeInd.R", "ViewLayer.VolumeInd.G", "ViewLayer.VolumeInd.B"};
    static const char *const emit[] = {"ViewLayer.Emit.R", "ViewLayer.Emit.G", "ViewLayer.Emit.B"};
    const char *const *names[Q_COUNT] = {rgb, alpha, dir, ind, emit};
    static const char *const alt[Q_COUNT] = {NULL, NULL, "Volume Direct", "Volume Indirect", "Emission"};
    vsd_exr_image *img = NULL;
    char err[1024];
    int i, ok = 1;
    memset(p, 0, sizeof *p);
    if (vsd_exr_read(path, &img, err, sizeof err) != VSD_OK) {
        fprintf(stderr, "%s\n", err);
        return 0;
    }
    p->width = img->width;
    p->height = img->height;
    for (i = 0; i < Q_COUNT && ok; i++) ok = gather(img, names[i], alt[i], q_channels[i], &p->q[i]);
    vsd_exr_image_destroy(img);
    if (!ok) fprintf(stderr, "%s: not a vsd/Blender multilayer EXR with Combined, VolumeDir, VolumeInd, Emit\n", path);
    return ok;
}

/* (a + b) / 2 */
static float *average(const float *a, const float *b, size_t n)
{
    float *o = malloc(sizeof(float) * n);
    size_t i;
    if (!o) return NULL;
    for (i = 0; i < n; i++) o[i] = 0.5f * (a[i] + b[i]);
    return o;
}

/* NAN when the reference is black (no emission) */
static double rel(const float *a, const float *b, int w, int h, int ch)
{
    double r = NAN;
    char err[256];
    if (vsd_block_rel_rmse(a, b, w, h, ch, ch, BLOCK, &r, err, sizeof err) != VSD_OK) return NAN;
    return r;
}

/* Mean over whole blocks (as the RMSE sees them) of the channel-summed image. */
static double block_mean(const float *a, int w, int h, int ch)
{
    int bw = w / BLOCK, bh = h / BLOCK, x, y, c;
    double s = 0;
    for (y = 0; y < bh * BLOCK; y++)
        for (x = 0; x < bw * BLOCK; x++)
            for (c = 0; c < ch; c++) s += a[((size_t)y * w + x) * ch + c];
    return s / ((double)bw * bh * BLOCK * BLOCK);
}

/* Squared standard error of the mean of (x1 + x2)/2 over whole blocks, from the pair
 * difference: per block, var((x1+x2)/2) = E[(x1-x2)^2]/4; blocks are independent (every
 * pixel has its own random stream), so the variances of the block means add. */
static double mean_se2(const float *x1, const float *x2, int w, int h, int ch)
{
    int bw = w / BLOCK, bh = h / BLOCK, bx, by, x, y, c;
    double s = 0, n = (double)bw * bh;
    for (by = 0; by < bh; by++)
        for (bx = 0; bx < bw; bx++) {
            double d = 0;
            for (y = by * BLOCK; y < (by + 1) * BLOCK; y++)
                for (x = bx * BLOCK; x < (bx + 1) * BLOCK; x++)
                    for (c = 0; c < ch; c++) {
                        size_t i = ((size_t)y * w + x) * ch + c;
                        d += x1[i] - x2[i];
                    }
            d /= BLOCK * BLOCK;
            s += d * d / 4.0;
        }
    return s / (n * n);
}

typedef struct metrics {
    double e, rv, rc, floor, ratio;     /* relative RMSEs and e / floor */
    double mean_v, mean_c, mean_diff, mean_se;  /* relative mean difference and its se */
} metrics;

static int measure(const planes *v1, const planes *v2, const planes *c1, const planes *c2, metrics m[Q_COUNT])
{
    int w = v1->width, h = v1->height, q;
    const planes *all[4] = {v1, v2, c1, c2};
    for (q = 0; q < 4; q++)
        if (all[q]->width != w || all[q]->height != h) {
            fprintf(stderr, "image sizes differ (%dx%d vs %dx%d)\n", all[q]->width, all[q]->height, w, h);
            return 0;
        }
    for (q = 0; q < Q_COUNT; q++) {
        int ch = q_channels[q];
        size_t n = (size_t)w * h * ch;
        float *va = average(v1->q[q], v2->q[q], n), *ca = average(c1->q[q], c2->q[q], n);
        metrics *r = &m[q];
        if (!va || !ca) {
            free(va);
            free(ca);
            return 0;
        }
        r->e = rel(va, ca, w, h, ch);
        r->rv = rel(v1->q[q], v2->q[q], w, h, ch);
        r->rc = rel(c1->q[q], c2->q[q], w, h, ch);
        r->floor = 0.5 * sqrt(r->rv * r->rv + r->rc * r->rc);
        r->ratio = r->e / r->floor;
        r->mean_v = block_mean(va, w, h, ch);
        r->mean_c = block_mean(ca, w, h, ch);
        r->mean_diff = (r->mean_v - r->mean_c) / r->mean_c;
        r->mean_se = sqrt(mean_se2(v1->q[q], v2->q[q], w, h, ch) + mean_se2(c1->q[q], c2->q[q], w, h, ch)) /
                     r->mean_c;
        free(va);
        free(ca);
    }
    return 1;
}

static void print_metrics(const metrics m[Q_COUNT])
{
    int q;
    printf("| quantity | e = rel. RMSE vsd vs Cycles | vsd seed-to-seed | Cycles seed-to-seed | noise floor "
           "| e / floor | bound | mean vsd | mean Cycles | mean diff | se |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (q = 0; q < Q_COUNT; q++) {
        if (!(m[q].mean_c > 0)) {
            printf("| %s | - | - | - | - | - | - | %.5f | %.5f | - | - |\n", q_name[q], m[q].mean_v, m[q].mean_c);
            continue;
        }
        printf("| %s | %.4f | %.4f | %.4f | %.4f | %.2f | %.2f | %.5f | %.5f | %+.2f%% | %.2f%% |\n", q_name[q],
               m[q].e, m[q].rv, m[q].rc, m[q].floor, m[q].ratio, ratio_bound[q], m[q].mean_v, m[q].mean_c,
               100 * m[q].mean_diff, 100 * m[q].mean_se);
    }
    fflush(stdout);
}

static void check_metrics(const metrics m[Q_COUNT])
{
    int q;
    for (q = 0; q < Q_COUNT; q++) {
        if (q == Q_EMIT && !(m[q].mean_c > 0)) { /* no emission: both must be black */
            CHECK_MSG(m[q].mean_v == 0, "Emit: vsd has emission (%g) where Cycles has none", m[q].mean_v);
            continue;
        }
        CHECK_MSG(m[q].e <= ratio_bound[q] * m[q].floor,
                  "%s: vsd vs Cycles rel. RMSE %.4f exceeds %.2f x the noise floor %.4f (= %.4f)", q_name[q],
                  m[q].e, ratio_bound[q], m[q].floor, ratio_bound[q] * m[q].floor);
        CHECK_MSG(fabs(m[q].mean_diff) <= MEAN_SIGMAS * m[q].mean_se + MEAN_BIAS,
                  "%s: mean differs by %+.3f%% (vsd %.5f, Cycles %.5f); allowed %.0f se (se %.3f%%) + %.1f%%",
                  q_name[q], 100 * m[q].mean_diff, m[q].mean_v, m[q].mean_c, MEAN_SIGMAS, 100 * m[q].mean_se,
                  100 * MEAN_BIAS);
    }
}

static int compare_files(char **paths)
{
    planes p[4];
    metrics m[Q_COUNT];
    int i, ok = 1;
    memset(p, 0, sizeof p);
    for (i = 0; i < 4 && ok; i++) ok = load_planes(paths[i], &p[i]);
    if (ok) ok = measure(&p[0], &p[1], &p[2], &p[3], m);
    if (ok) {
        print_metrics(m);
        check_metrics(m);
    }
    for (i = 0; i < 4; i++) planes_free(&p[i]);
    if (!ok) return 2;
    return test_finish("test_cycles_crosscheck --compare");
}

/* ---- renders --------------------------------------------------------------------------- */

/* The frame every render uses (the scene's frames.start). */
static int g_frame = 24;
/* The spot's mask has the cosine to its axis (Cycles 3.x) or not (4.2, 4.5, 5.0:
 * --spot-no-cosine writes "spot_cosine": false, as the add-on sends from those versions). */
static int g_spot_cosine = 1;

/* "smoke": smoke64 frame 24, no emission. "fire" (the emission conventions and their passes,
 * about 4x slower in Cycles): fire96 frame 48 with its flame grid, as
 * ../shared/data/scenes/fire96_studio.json. "volumes" (issue 30): three volumes, each with
 * its own material and frame: the fire, a smoke overlapping its upper side (smoke64 frame
 * 24 = scene frame 48 with frame_offset -24, moved 0.7 m along x and 0.5 m up; g 0.3), and
 * a cloud above both (cloud128 moved up 3.4 m; albedo 0.97, g 0.6). The cloud is not scaled:
 * Cycles 3.4 renders a volume object scaled by 0.5 about 6 % more opaque than the same view
 * of the unscaled object twice as far away, where vsd gives the same image for both
 * (docs/cycles-crosscheck.md, "Scaled volume objects"). */
static int write_scene(const char *path, const char *which)
{
    FILE *f;
    char vdb[2048], env[2048];
    int fire = strcmp(which, "fire") == 0, lights = strcmp(which, "lights") == 0;
    int volumes = strcmp(which, "volumes") == 0;
    if (!fire && !lights && !volumes && strcmp(which, "smoke") != 0) {
        fprintf(stderr, "--scene: expected smoke, fire, lights or volumes, got %s\n", which);
        return 0;
    }
    f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "%s: %s\n", path, strerror(errno));
        return 0;
    }
    g_frame = fire || volumes ? 48 : 24;
    snprintf(vdb, sizeof vdb, "%s", test_data(fire ? "fire96/fluid_data_####.vdb" : "smoke64/fluid_data_####.vdb"));
    snprintf(env, sizeof env, "%s", test_data("env/studio.exr"));
    if (volumes) {
        char smoke[2048], cloud[2048];
        snprintf(vdb, sizeof vdb, "%s", test_data("fire96/fluid_data_####.vdb"));
        snprintf(smoke, sizeof smoke, "%s", test_data("smoke64/fluid_data_####.vdb"));
        snprintf(cloud, sizeof cloud, "%s", test_data("cloud/cloud128.vdb"));
        fprintf(f,
                "{\"version\": 1,\n"
                " \"volumes\": [\n"
                "  {\"file\": \"%s\", \"grid\": \"density\", \"emission_grid\": \"flame\",\n"
                "   \"medium\": {\"density\": 6.0, \"albedo\": [0.6, 0.6, 0.6], \"anisotropy\": 0.0,"
                " \"emission_color\": [1.0, 0.4, 0.08], \"emission_strength\": 8.0}},\n"
                "  {\"file\": \"%s\", \"grid\": \"density\", \"frame_offset\": -24,\n"
                "   \"matrix\": [1,0,0,0.7, 0,1,0,0, 0,0,1,0.5, 0,0,0,1],\n"
                "   \"medium\": {\"density\": 12.0, \"albedo\": [0.9, 0.85, 0.8], \"anisotropy\": 0.3}},\n"
                "  {\"file\": \"%s\", \"grid\": \"density\",\n"
                "   \"matrix\": [1,0,0,1.2, 0,1,0,1.0, 0,0,1,3.4, 0,0,0,1],\n"
                "   \"medium\": {\"density\": 3.0, \"albedo\": [0.97, 0.97, 0.97], \"anisotropy\": 0.6}}],\n"
                " \"environment\": {\"file\": \"%s\", \"strength\": 1.0, \"rotation_z\": 0.0},\n"
                " \"camera\": {\"position\": [-2.9, -10.2, 2.3], \"look_at\": [1.2, 1.0, 1.9],"
                " \"up\": [0, 0, 1], \"fov\": 0.7},\n",
                vdb, smoke, cloud, env);
    } else if (fire)
        fprintf(f,
                "{\"version\": 1,\n"
                " \"volume\": {\"file\": \"%s\", \"grid\": \"density\", \"emission_grid\": \"flame\"},\n"
                " \"medium\": {\"density\": 6.0, \"albedo\": [0.6, 0.6, 0.6], \"anisotropy\": 0.0,"
                " \"emission_color\": [1.0, 0.4, 0.08], \"emission_strength\": 8.0},\n"
                " \"environment\": {\"file\": \"%s\", \"strength\": 1.0, \"rotation_z\": 0.0},\n"
                " \"camera\": {\"position\": [1.8738, -3.9555, 1.4402], \"look_at\": [1.0, 1.0, 1.0],"
                " \"up\": [0, 0, 1], \"fov\": 0.7},\n",
                vdb, env);
    else
        /* Camera 6 m from the plume's middle, 25 degrees round from -Y, 8 degrees up: the
         * 1.9 m plume fills most of the frame's height. */
        fprintf(f,
                "{\"version\": 1,\n"
                " \"volume\": {\"file\": \"%s\", \"grid\": \"density\"},\n"
                " \"medium\": {\"density\": 30.0, \"albedo\": [0.9, 0.9, 0.9], \"anisotropy\": 0.4},\n"
                " \"environment\": {\"file\": \"%s\", \"strength\": %g, \"rotation_z\": 1.2},\n"
                " \"camera\": {\"position\": [-1.521, -4.3949, 1.835], \"look_at\": [0.99, 0.99, 1.0],"
                " \"up\": [0, 0, 1], \"fov\": 0.7},\n",
                vdb, env, lights ? 0.15 : 1.0);
    if (lights)
        /* The scene's lights in Cycles' units, against a dimmed map: a warm point light of
         * radius 0.1 up to the right, a cool spot from the left whose soft edge crosses the
         * plume, and a low sun with a 2-degree disc. */
        fprintf(f, " \"lights\": [{\"type\": \"point\", \"power\": 400, \"position\": [2.6, -1.2, 2.4], \"radius\": 0.1,"
                   " \"color\": [1.0, 0.75, 0.5]},\n"
                   "  {\"type\": \"spot\", \"power\": 1500, \"position\": [-2.2, 0.2, 1.2], \"direction\": [1, 0.3, -0.05],"
                   " \"spot_size\": 0.7, \"spot_blend\": 0.4, \"spot_cosine\": %s, \"color\": [0.5, 0.7, 1.0]},\n"
                   "  {\"type\": \"sun\", \"strength\": 2.0, \"direction\": [0.2, 0.9, -0.3], \"angle\": 0.035}],\n",
                g_spot_cosine ? "true" : "false");
    fprintf(f,
            " \"film\": {\"width\": %d, \"height\": %d, \"transparent\": true},\n"
            " \"render\": {\"method\": \"reference\", \"samples\": 1024, \"seed\": 1},\n"
            " \"frames\": {\"start\": %d, \"end\": %d},\n"
            " \"output\": {\"passes\": [\"Combined\", \"VolumeDir\", \"VolumeInd\", \"Emit\", \"Transmittance\"]}}\n",
            WIDTH, HEIGHT, g_frame, g_frame);
    return fclose(f) == 0;
}

/* Render with the library exactly as `vsd render` does, and write the EXR. */
static int render_vsd(const char *scene_path, int seed, int spp, const char *exr, double *seconds)
{
    char ov_seed[64], ov_spp[64], ov_out[VSD_PATH_LEN + 32], err[1024], written[VSD_PATH_LEN];
    const char *ov[3] = {ov_seed, ov_spp, ov_out};
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    vsd_render_stats stats;
    vsd_render_options ro = {0};
    double t0 = vsd_clock_seconds();
    int ok = 0;
    snprintf(ov_seed, sizeof ov_seed, "render.seed=%d", seed);
    snprintf(ov_spp, sizeof ov_spp, "render.samples=%d", spp);
    snprintf(ov_out, sizeof ov_out, "output.exr=\"%s\"", exr);
    memset(&stats, 0, sizeof stats);
    if (vsd_scene_load(scene_path, ov, 3, &sc, err, sizeof err) != VSD_OK ||
        vsd_renderer_create(&sc, &ro, &r, err, sizeof err) != VSD_OK ||
        vsd_renderer_render(r, g_frame, &fb, &stats, err, sizeof err) != VSD_OK ||
        vsd_write_frame_outputs(&sc, g_frame, fb, &stats, written, sizeof written, NULL, 0, err, sizeof err) != VSD_OK)
        fprintf(stderr, "vsd render (seed %d): %s\n", seed, err);
    else
        ok = 1;
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
    *seconds = vsd_clock_seconds() - t0;
    if (ok)
        printf("vsd reference seed %d: %d spp, %d threads, render %.2f s\n", seed, stats.samples, stats.threads,
               stats.render_seconds);
    return ok;
}

static void print_tail(const char *log)
{
    FILE *f = fopen(log, "r");
    char buf[4096];
    long size;
    size_t n;
    if (!f) return;
    fseek(f, 0, SEEK_END);
    size = ftell(f);
    fseek(f, size > (long)sizeof buf - 1 ? size - (long)sizeof buf + 1 : 0, SEEK_SET);
    n = fread(buf, 1, sizeof buf - 1, f);
    buf[n] = '\0';
    fclose(f);
    fprintf(stderr, "---- %s (tail) ----\n%s\n----\n", log, buf);
}

static double json_number(const char *path, const char *key)
{
    FILE *f = fopen(path, "r");
    char buf[4096], pat[128];
    const char *p;
    size_t n;
    if (!f) return NAN;
    n = fread(buf, 1, sizeof buf - 1, f);
    buf[n] = '\0';
    fclose(f);
    snprintf(pat, sizeof pat, "\"%s\":", key);
    p = strstr(buf, pat);
    return p ? strtod(p + strlen(pat), NULL) : NAN;
}

/* The value of a string "key" in a small JSON file, or "?" */
static void json_string(const char *path, const char *key, char *out, size_t len)
{
    FILE *f = fopen(path, "r");
    char buf[4096], pat[128];
    const char *p, *q;
    size_t n;
    snprintf(out, len, "?");
    if (!f) return;
    n = fread(buf, 1, sizeof buf - 1, f);
    buf[n] = '\0';
    fclose(f);
    snprintf(pat, sizeof pat, "\"%s\": \"", key);
    p = strstr(buf, pat);
    if (!p) return;
    p += strlen(pat);
    q = strchr(p, '"');
    if (q) snprintf(out, len, "%.*s", (int)(q - p), p);
}

/* The command standing in for `blender`: its words (blender[0] resolved to a path, e.g.
 * a bpy wheel's python followed by tests/blender_addon/blender_wheel.py), and extra
 * arguments for cycles_scene.py (--cycles-arg). */
#define MAX_WORDS 16
typedef struct command {
    char *word[MAX_WORDS + 1];
    int n;
} command;

static int render_cycles(const command *blender, const command *extra, const char *script, const char *scene_path,
                         int seed, int spp, const char *exr, const char *dir, double *seconds)
{
    char s_spp[32], s_seed[32], s_w[32], s_h[32], s_frame[32], tjson[1200], log[1200], version[64];
    char *argv[32 + 2 * MAX_WORDS];
    int n = 0, rc, k;
    double t0 = vsd_clock_seconds();
    snprintf(s_spp, sizeof s_spp, "%d", spp);
    snprintf(s_seed, sizeof s_seed, "%d", seed);
    snprintf(s_w, sizeof s_w, "%d", WIDTH);
    snprintf(s_h, sizeof s_h, "%d", HEIGHT);
    snprintf(s_frame, sizeof s_frame, "%d", g_frame);
    snprintf(tjson, sizeof tjson, "%s/cycles_seed%d.json", dir, seed);
    snprintf(log, sizeof log, "%s/cycles_seed%d.log", dir, seed);
    for (k = 0; k < blender->n; k++) argv[n++] = blender->word[k];
    n = cycles_scene_args(argv, n, script, scene_path, exr, s_w, s_h, s_spp, s_seed, tjson);
    argv[n++] = "--frame";
    argv[n++] = s_frame;
    for (k = 0; k < extra->n; k++) argv[n++] = extra->word[k];
    argv[n] = NULL;
    rc = run_logged(argv, log);
    *seconds = vsd_clock_seconds() - t0;
    if (rc != 0 || access(exr, R_OK) != 0) {
        fprintf(stderr, "Cycles render (seed %d) failed with status %d\n", seed, rc);
        print_tail(log);
        return 0;
    }
    json_string(tjson, "blender", version, sizeof version);
    printf("Cycles seed %d: Blender %s, %d spp, render %.2f s (Blender run %.2f s)\n", seed, version, spp,
           json_number(tjson, "render_seconds"), *seconds);
    return 1;
}

/* Split `s` (modified in place) at spaces and tabs into cmd; 0 when empty or too many. */
static int split_words(char *s, command *cmd)
{
    char *save = NULL, *w;
    cmd->n = 0;
    for (w = strtok_r(s, " \t", &save); w; w = strtok_r(NULL, " \t", &save)) {
        if (cmd->n == MAX_WORDS) return 0;
        cmd->word[cmd->n++] = w;
    }
    cmd->word[cmd->n] = NULL;
    return cmd->n > 0;
}

/* Find blender: an absolute path as given, else search $PATH. */
static int find_exe(const char *name, char *out, size_t len)
{
    const char *path = getenv("PATH");
    if (strchr(name, '/')) {
        if (strlen(name) >= len) return 0;
        memcpy(out, name, strlen(name) + 1);
        return access(out, X_OK) == 0;
    }
    while (path && *path) {
        const char *end = strchr(path, ':');
        size_t l = end ? (size_t)(end - path) : strlen(path);
        if (l + strlen(name) + 2 <= len) {
            memcpy(out, path, l);
            out[l] = '/';
            memcpy(out + l + 1, name, strlen(name) + 1);
            if (access(out, X_OK) == 0) return 1;
        }
        path = end ? end + 1 : NULL;
    }
    return 0;
}

static void empty_dir(const char *dir)
{
    static const char *const names[] = {"scene.json", "vsd_seed1.exr", "vsd_seed2.exr", "cycles_seed1.exr",
                                        "cycles_seed2.exr", "cycles_seed1.json", "cycles_seed2.json",
                                        "cycles_seed1.log", "cycles_seed2.log"};
    size_t i;
    char p[1200];
    mkdir(dir, 0755);
    for (i = 0; i < sizeof names / sizeof names[0]; i++) {
        snprintf(p, sizeof p, "%s/%s", dir, names[i]);
        unlink(p);
    }
}

int main(int argc, char **argv)
{
    const char *blender_arg = VSD_BLENDER_EXE, *script = VSD_CYCLES_SCRIPT, *which = "smoke";
    char blender[1024], blender_words[2048], dir[900], scene_path[1024], vexr[2][1024], cexr[2][1024];
    command cmd, extra;
    int vsd_spp = 2048, cycles_spp = 512, i, ok = 1;
    double t_start = vsd_clock_seconds(), tv[2] = {0, 0}, tc[2] = {0, 0};
    planes p[4];
    metrics m[Q_COUNT];

    snprintf(dir, sizeof dir, "%s", test_tmp("cycles_crosscheck"));
    extra.n = 0;
    extra.word[0] = NULL;
    for (i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--compare") == 0 && i + 4 < argc) return compare_files(argv + i + 1);
        else if (strcmp(argv[i], "--blender") == 0 && i + 1 < argc) blender_arg = argv[++i];
        else if (strcmp(argv[i], "--script") == 0 && i + 1 < argc) script = argv[++i];
        else if (strcmp(argv[i], "--vsd-spp") == 0 && i + 1 < argc) vsd_spp = atoi(argv[++i]);
        else if (strcmp(argv[i], "--cycles-spp") == 0 && i + 1 < argc) cycles_spp = atoi(argv[++i]);
        else if (strcmp(argv[i], "--scene") == 0 && i + 1 < argc) which = argv[++i];
        else if (strcmp(argv[i], "--spot-no-cosine") == 0) g_spot_cosine = 0;
        else if (strcmp(argv[i], "--dir") == 0 && i + 1 < argc) snprintf(dir, sizeof dir, "%s", argv[++i]);
        else if (strcmp(argv[i], "--cycles-arg") == 0 && i + 1 < argc && extra.n < MAX_WORDS) {
            extra.word[extra.n++] = argv[++i];
            extra.word[extra.n] = NULL;
        } else {
            fprintf(stderr,
                    "usage: %s [--blender 'CMD [ARG...]'] [--script PATH] [--vsd-spp N] [--cycles-spp N]\n"
                    "          [--dir DIR] [--scene smoke|fire|lights|volumes] [--spot-no-cosine] [--cycles-arg ARG]...\n"
                    "       %s --compare VSD1.exr VSD2.exr CYCLES1.exr CYCLES2.exr\n",
                    argv[0], argv[0]);
            return 2;
        }
    }
    /* --blender: a path, a name on $PATH, or a command of several words separated by
     * spaces (no quoting): e.g. "<venv>/bin/python tests/blender_addon/blender_wheel.py" */
    snprintf(blender_words, sizeof blender_words, "%s", blender_arg);
    if (!split_words(blender_words, &cmd)) {
        fprintf(stderr, "--blender: expected a command of 1 to %d words, got '%s'\n", MAX_WORDS, blender_arg);
        return 2;
    }
    if (!find_exe(cmd.word[0], blender, sizeof blender)) {
        printf("SKIP: no Blender executable (%s)\n", cmd.word[0]);
        return 77;
    }
    cmd.word[0] = blender;
    for (i = 1; i < cmd.n; i++)
        if (access(cmd.word[i], F_OK) != 0 && cmd.word[i][0] == '/') {
            printf("SKIP: %s: %s (the Blender command's file is gone)\n", cmd.word[i], strerror(errno));
            return 77;
        }
    if (access(script, R_OK) != 0) {
        fprintf(stderr, "%s: %s\n", script, strerror(errno));
        return 1;
    }
    empty_dir(dir);
    snprintf(scene_path, sizeof scene_path, "%s/scene.json", dir);
    if (!write_scene(scene_path, which)) return 1;
    for (i = 0; i < 2; i++) {
        snprintf(vexr[i], sizeof vexr[i], "%s/vsd_seed%d.exr", dir, i + 1);
        snprintf(cexr[i], sizeof cexr[i], "%s/cycles_seed%d.exr", dir, i + 1);
    }
    printf("scene %s: %dx%d, vsd reference %d spp, Cycles %d spp, seeds 1 and 2\n", scene_path, WIDTH, HEIGHT,
           vsd_spp, cycles_spp);
    fflush(stdout);
    for (i = 0; i < 2 && ok; i++) {
        ok = render_vsd(scene_path, i + 1, vsd_spp, vexr[i], &tv[i]);
        CHECK(ok);
    }
    for (i = 0; i < 2 && ok; i++) {
        ok = render_cycles(&cmd, &extra, script, scene_path, i + 1, cycles_spp, cexr[i], dir, &tc[i]);
        CHECK(ok);
    }
    fflush(stdout);
    if (!ok) return test_finish("test_cycles_crosscheck");

    memset(p, 0, sizeof p);
    ok = load_planes(vexr[0], &p[0]) && load_planes(vexr[1], &p[1]) && load_planes(cexr[0], &p[2]) &&
         load_planes(cexr[1], &p[3]) && measure(&p[0], &p[1], &p[2], &p[3], m);
    CHECK(ok);
    if (ok) {
        print_metrics(m);
        check_metrics(m);
    }
    for (i = 0; i < 4; i++) planes_free(&p[i]);
    printf("time: vsd %.1f + %.1f s, Cycles (Blender runs) %.1f + %.1f s, total %.1f s\n", tv[0], tv[1], tc[0],
           tc[1], vsd_clock_seconds() - t_start);
    return test_finish("test_cycles_crosscheck");
}
