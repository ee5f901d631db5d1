/* bench_constellation — the measurements of issue 3 (Navarro et al. 2009, Table 1 style).
 *
 *   vsd_bench_constellation table1   [--size N] [--lights K] [--frame F] [--threshold T]
 *                                    [--scene S] [--modes 0123] [--shadow-step H]
 *       scene S (default scenes/smoke64_sunset.json) frame F (24) at NxN (default 512):
 *       0 raymarch brute force with K lights, then constellation 1 without accelerations,
 *       2 + validity mask, 3 + mask + distance map; --modes picks rows (e.g. 23 to re-run
 *       only the accelerated rows at another threshold: rows 0 and 1 do not depend on it);
 *       --shadow-step sets the constellation rows' shadow step (world units, 0 = default
 *       half a voxel, the same step as raymarch).
 *   vsd_bench_constellation rmse     [--width W --height H --samples S]
 *       VolumeDir relative RMSE (4x4 blocks) of constellation (K lights, 2x2 rays) against
 *       reference on smoke64 frame 24 and cloud128, with the reference's own noise floor
 *       (two seeds).
 *   vsd_bench_constellation sequence [--size N]
 *       all 30 frames of smoke64: distance-map and dense-grid builds (timed on their own),
 *       prepare (both, as the render builds them) and render time per frame.
 *
 * Times are wall clock and process CPU time (user + system) of the render call; on a
 * shared machine CPU time is the steadier figure. Data come from VSD_SHARED_DATA. */
#include "vsd/clock.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "vsd/vdbio.h"
#include "vsd/compare.h"
#include "src/grids/distance_map.h"
#include "methods/constellation/dense_grid.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

static double cpu(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec + (double)ru.ru_stime.tv_sec +
           1e-6 * (double)ru.ru_stime.tv_usec;
}

static const char *data(const char *rel)
{
    static char buf[2048];
    snprintf(buf, sizeof buf, "%s/%s", VSD_SHARED_DATA, rel);
    return buf;
}

typedef struct run_result {
    double wall, cpu, prepare;
    vsd_framebuffer *fb;
} run_result;

/* Render one frame of a scene file with overrides; returns 0 on failure. */
static int render_once(const char *scene, const char *const *ov, int nov, int frame, run_result *out)
{
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_render_stats stats;
    char err[1024];
    double w0, c0;
    vsd_status st = vsd_scene_load(data(scene), ov, nov, &sc, err, sizeof err);
    memset(out, 0, sizeof *out);
    if (!st) st = vsd_renderer_create(&sc, NULL, &r, err, sizeof err);
    w0 = vsd_clock_seconds();
    c0 = cpu();
    if (!st) st = vsd_renderer_render(r, frame, &out->fb, &stats, err, sizeof err);
    out->wall = vsd_clock_seconds() - w0;
    out->cpu = cpu() - c0;
    out->prepare = stats.prepare_seconds;
    vsd_renderer_destroy(r);
    if (st) {
        fprintf(stderr, "%s: %s\n", scene, err);
        return 0;
    }
    return 1;
}

static int arg_int(int argc, char **argv, const char *name, int def)
{
    int i;
    for (i = 2; i + 1 < argc; i++)
        if (strcmp(argv[i], name) == 0) return atoi(argv[i + 1]);
    return def;
}

static double arg_num(int argc, char **argv, const char *name, double def)
{
    int i;
    for (i = 2; i + 1 < argc; i++)
        if (strcmp(argv[i], name) == 0) return atof(argv[i + 1]);
    return def;
}

static const char *arg_str(int argc, char **argv, const char *name, const char *def)
{
    int i;
    for (i = 2; i + 1 < argc; i++)
        if (strcmp(argv[i], name) == 0) return argv[i + 1];
    return def;
}

static int table1(int argc, char **argv)
{
    int size = arg_int(argc, argv, "--size", 512), lights = arg_int(argc, argv, "--lights", 64);
    int frame = arg_int(argc, argv, "--frame", 24);
    double thr = arg_num(argc, argv, "--threshold", 0.0);
    const char *scene = arg_str(argc, argv, "--scene", "scenes/smoke64_sunset.json");
    const char *modes = arg_str(argc, argv, "--modes", "0123");
    double shadow_step = arg_num(argc, argv, "--shadow-step", 0.0);
    char o[9][128];
    const char *ov[9];
    const char *names[4] = {"raymarch (brute force)", "constellation, no acceleration", "+ validity mask",
                            "+ validity mask + distance map"};
    double base_w = 0, base_c = 0;
    run_result res[4];
    int k, i, on[4];
    memset(res, 0, sizeof res);
    for (k = 0; k < 4; k++) on[k] = strchr(modes, '0' + k) != NULL;
    printf("%s frame %d, %dx%d, %d lights, 1 ray per pixel, slice = half a voxel, shadow step %s, threshold %g\n",
           scene, frame, size, size, lights, shadow_step > 0 ? arg_str(argc, argv, "--shadow-step", "") : "half a voxel",
           thr);
    printf("%-34s %10s %10s %10s %9s\n", "mode", "wall s", "cpu s", "prepare s", "speed-up");
    for (k = 0; k < 4; k++) {
        int n = 0;
        if (!on[k]) continue;
        snprintf(o[n++], 128, "film.width=%d", size);
        snprintf(o[n++], 128, "film.height=%d", size);
        snprintf(o[n++], 128, "render.method=%s", k == 0 ? "raymarch" : "constellation");
        snprintf(o[n++], 128, "render.options.lights=%d", lights);
        snprintf(o[n++], 128, "render.options.pixel_samples=1");
        if (k > 0) {
            snprintf(o[n++], 128, "render.options.validity_mask=%s", k >= 2 ? "true" : "false");
            snprintf(o[n++], 128, "render.options.distance_map=%s", k >= 3 ? "true" : "false");
            snprintf(o[n++], 128, "render.options.density_threshold=%g", thr);
            snprintf(o[n++], 128, "render.options.shadow_step=%g", shadow_step);
        }
        for (i = 0; i < n; i++) ov[i] = o[i];
        if (!render_once(scene, ov, n, frame, &res[k])) return 1;
        if (k == 0) {
            base_w = res[k].wall;
            base_c = res[k].cpu;
        }
        if (on[0])
            printf("%-34s %10.2f %10.2f %10.3f %5.2f/%.2f\n", names[k], res[k].wall, res[k].cpu, res[k].prepare,
                   base_w / res[k].wall, base_c / res[k].cpu);
        else
            printf("%-34s %10.2f %10.2f %10.3f %9s\n", names[k], res[k].wall, res[k].cpu, res[k].prepare, "-");
        fflush(stdout);
    }
    for (k = 2; k < 4 && on[1]; k++) {
        double e = 0;
        if (on[k] && vsd_block_rel_rmse(res[k].fb->pass[VSD_PASS_VOLUME_DIR], res[1].fb->pass[VSD_PASS_VOLUME_DIR], size,
                               size, 3, 3, 1, &e, NULL, 0) == VSD_OK)
            printf("VolumeDir rel. RMSE of '%s' against no acceleration: %.6f\n", names[k], e);
    }
    if (on[0] && on[3]) {
        double e = 0;
        if (vsd_block_rel_rmse(res[3].fb->pass[VSD_PASS_VOLUME_DIR], res[0].fb->pass[VSD_PASS_VOLUME_DIR], size, size,
                               3, 3, 4, &e, NULL, 0) == VSD_OK)
            printf("VolumeDir rel. RMSE (4x4 blocks) constellation vs raymarch: %.4f\n", e);
    }
    for (k = 0; k < 4; k++)
        if (res[k].fb) vsd_framebuffer_destroy(res[k].fb);
    printf("speed-up = wall/cpu time of raymarch divided by the mode's\n");
    return 0;
}

static int rmse(int argc, char **argv)
{
    int w = arg_int(argc, argv, "--width", 64), h = arg_int(argc, argv, "--height", 36);
    int spp = arg_int(argc, argv, "--samples", 4096), lights = arg_int(argc, argv, "--lights", 64);
    const char *scenes[2] = {"scenes/smoke64_sunset.json", "scenes/cloud128_interior.json"};
    const int frames[2] = {24, 1};
    int s;
    printf("%dx%d, reference %d spp (seeds 1 and 2 averaged), constellation %d lights, 2x2 rays per pixel\n", w, h,
           spp, lights);
    for (s = 0; s < 2; s++) {
        char o[6][128];
        const char *ov[6];
        run_result ref[2], cst;
        double e_noise = 0, e = 0, e_t = 0;
        int k, i, n;
        for (k = 0; k < 3; k++) {
            n = 0;
            snprintf(o[n++], 128, "film.width=%d", w);
            snprintf(o[n++], 128, "film.height=%d", h);
            if (k < 2) {
                snprintf(o[n++], 128, "render.method=reference");
                snprintf(o[n++], 128, "render.samples=%d", spp);
                snprintf(o[n++], 128, "render.seed=%d", k + 1);
            } else {
                snprintf(o[n++], 128, "render.method=constellation");
                snprintf(o[n++], 128, "render.options.lights=%d", lights);
                snprintf(o[n++], 128, "render.options.pixel_samples=2");
            }
            for (i = 0; i < n; i++) ov[i] = o[i];
            if (!render_once(scenes[s], ov, n, frames[s], k < 2 ? &ref[k] : &cst)) return 1;
        }
        vsd_block_rel_rmse(ref[1].fb->pass[VSD_PASS_VOLUME_DIR], ref[0].fb->pass[VSD_PASS_VOLUME_DIR], w, h, 3, 3, 4,
                           &e_noise, NULL, 0);
        {
            size_t p, np = (size_t)w * h * 3;
            for (p = 0; p < np; p++)
                ref[0].fb->pass[VSD_PASS_VOLUME_DIR][p] =
                    0.5f * (ref[0].fb->pass[VSD_PASS_VOLUME_DIR][p] + ref[1].fb->pass[VSD_PASS_VOLUME_DIR][p]);
        }
        vsd_block_rel_rmse(cst.fb->pass[VSD_PASS_VOLUME_DIR], ref[0].fb->pass[VSD_PASS_VOLUME_DIR], w, h, 3, 3, 4, &e,
                           NULL, 0);
        vsd_block_rel_rmse(cst.fb->pass[VSD_PASS_TRANSMITTANCE], ref[0].fb->pass[VSD_PASS_TRANSMITTANCE], w, h, 3, 3,
                           4, &e_t, NULL, 0);
        /* the two seeds' difference has sqrt(2) times one reference's noise and their mean
         * 1/sqrt(2) times it: the mean's noise is e_noise / 2, and it adds in quadrature */
        printf("%s: VolumeDir rel. RMSE %.4f (reference seed-to-seed %.4f, so the averaged reference's own noise is "
               "about %.4f; bias estimate sqrt(e^2 - noise^2) = %.4f); Transmittance %.4f; constellation render %.2f s, "
               "references %.1f + %.1f s\n",
               scenes[s], e, e_noise, 0.5 * e_noise,
               e * e > 0.25 * e_noise * e_noise ? sqrt(e * e - 0.25 * e_noise * e_noise) : 0.0, e_t, cst.wall,
               ref[0].wall, ref[1].wall);
        vsd_framebuffer_destroy(ref[0].fb);
        vsd_framebuffer_destroy(ref[1].fb);
        vsd_framebuffer_destroy(cst.fb);
    }
    return 0;
}

static int sequence(int argc, char **argv)
{
    int size = arg_int(argc, argv, "--size", 256), f;
    double thr = arg_num(argc, argv, "--threshold", 0.0), tot_dm = 0, tot_dense = 0, tot_frame = 0;
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    char o[4][128], err[1024];
    const char *ov[4] = {o[0], o[1], o[2], o[3]};
    snprintf(o[0], 128, "film.width=%d", size);
    snprintf(o[1], 128, "film.height=%d", size);
    snprintf(o[2], 128, "render.method=constellation");
    snprintf(o[3], 128, "render.options.density_threshold=%g", thr);
    if (vsd_scene_load(data("scenes/smoke64_sunset.json"), ov, 4, &sc, err, sizeof err) ||
        vsd_renderer_create(&sc, NULL, &r, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    printf("smoke64 frames 1-30 at %dx%d, constellation defaults (64 lights), one renderer (as `vsd render`)\n", size,
           size);
    printf("%5s %8s %12s %10s %10s %10s %10s\n", "frame", "voxels", "dist map s", "dense s", "prepare s", "render s",
           "frame s");
    for (f = 1; f <= 30; f++) {
        vsd_render_stats st;
        vsd_volume *vol = NULL;
        vsd_distance_map dm;
        vsd_dense_grid dg;
        char path[1024];
        vsd_grid_select sel = {"density", -1};
        double w0;
        /* the distance map of this frame, timed on its own (the render builds it again in prepare) */
        snprintf(path, sizeof path, "%s/smoke64/fluid_data_%04d.vdb", VSD_SHARED_DATA, f);
        if (vsd_vdb_load(path, sel, &vol, err, sizeof err) ||
            vsd_distance_map_build(vol, (float)thr, 0, &dm, err, sizeof err) ||
            vsd_dense_grid_build(vol, &dm, (float)thr, &dg, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        w0 = vsd_clock_seconds();
        if (vsd_renderer_render(r, f, &fb, &st, err, sizeof err)) {
            fprintf(stderr, "frame %d: %s\n", f, err);
            return 1;
        }
        printf("%5d %8llu %12.4f %10.4f %10.4f %10.3f %10.3f\n", f, (unsigned long long)st.active_voxels, dm.seconds,
               dg.seconds, st.prepare_seconds, st.render_seconds, vsd_clock_seconds() - w0);
        fflush(stdout);
        tot_dm += dm.seconds;
        tot_dense += dg.seconds;
        vsd_dense_grid_free(&dg);
        tot_frame += vsd_clock_seconds() - w0;
        vsd_distance_map_free(&dm);
        vsd_volume_destroy(vol);
    }
    printf("mean: distance map %.4f s, dense grid %.4f s, frame (load + prepare + render) %.3f s\n", tot_dm / 30,
           tot_dense / 30, tot_frame / 30);
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc >= 2 && strcmp(argv[1], "table1") == 0) return table1(argc, argv);
    if (argc >= 2 && strcmp(argv[1], "rmse") == 0) return rmse(argc, argv);
    if (argc >= 2 && strcmp(argv[1], "sequence") == 0) return sequence(argc, argv);
    fprintf(stderr, "usage: vsd_bench_constellation table1|rmse|sequence [--size N] [--lights K] ...\n");
    return 2;
}
