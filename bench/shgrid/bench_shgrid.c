/* bench_shgrid — the measurements of issue 4 (results in docs/methods/shgrid.md):
 *   table     Delalandre et al.'s Table 1 axes: grid {10,32,50,100}^3 x SH order {2,3,4}:
 *             record-grid time, per-view render time (cached grid, second view), and
 *             VolumeDir relative RMSE (4x4 blocks) against `reference` single scattering
 *   speed     per-view render from a cached grid at WxH against `raymarch` with as many
 *             lights as shgrid marches directions per record (192 HEALPix directions + the
 *             32 extracted lights of the defaults = 224), in the same run; raymarch is timed on a
 *             film of 1/256 of the pixels with the same framing, one ray per pixel, and
 *             scaled per ray, because a full 1280x720 frame at 192 lights takes hours
 *             on 2 cores
 *   sequence  every frame of smoke64 with default settings: time per frame including the
 *             record grid
 * Usage: bench_shgrid [table|speed|sequence|all] [--width W --height H] [--ref-samples N]
 *                     [--scene FILE] [--frame N] [--threads N] */
#include "vsd/render.h"
#include "vsd/scene.h"
#include "vsd/compare.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *scene_path = VSD_SHARED_DATA "/scenes/smoke64_sunset.json";
static int frame = 24, width = 320, height = 180, ref_samples = 1024, threads = 0;

static vsd_status render(const char *const *ov, int nov, int fr, vsd_framebuffer **fb, vsd_render_stats *st,
                         vsd_renderer **keep)
{
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_render_options ro;
    char err[1024];
    vsd_status s = vsd_scene_load(scene_path, ov, nov, &sc, err, sizeof err);
    memset(&ro, 0, sizeof ro);
    ro.threads = threads;
    if (!s) s = vsd_renderer_create(&sc, &ro, &r, err, sizeof err);
    if (!s) s = vsd_renderer_render(r, fr, fb, st, err, sizeof err);
    if (s) fprintf(stderr, "bench_shgrid: %s\n", err);
    if (keep && !s) *keep = r;
    else vsd_renderer_destroy(r);
    return s;
}

static void size_ov(char buf[4][48], int w, int h, int fr)
{
    snprintf(buf[0], 48, "film.width=%d", w);
    snprintf(buf[1], 48, "film.height=%d", h);
    snprintf(buf[2], 48, "frames.start=%d", fr);
    snprintf(buf[3], 48, "frames.end=%d", fr);
}

static double dir_err(const vsd_framebuffer *a, const vsd_framebuffer *b)
{
    double e = -1;
    vsd_block_rel_rmse(a->pass[VSD_PASS_VOLUME_DIR], b->pass[VSD_PASS_VOLUME_DIR], a->width, a->height, 3, 3, 4, &e, NULL, 0);
    return e;
}

/* A second view: the renderer keeps the record grid; only the camera moves. */
static double second_view(vsd_renderer *r, int w, int h, vsd_framebuffer **fb)
{
    vsd_render_stats st;
    char err[1024];
    vsd_scene sc;
    char sz[4][48];
    const char *ov[6];
    int i;
    size_ov(sz, w, h, frame);
    for (i = 0; i < 4; i++) ov[i] = sz[i];
    ov[4] = "render.method=shgrid";
    if (vsd_scene_load(scene_path, ov, 5, &sc, err, sizeof err)) return -1;
    sc.camera.matrix[3] += 0.05;   /* nudge the camera along its right axis's x */
    if (vsd_renderer_set_scene(r, &sc, err, sizeof err)) return -1;
    if (vsd_renderer_render(r, frame, fb, &st, err, sizeof err)) return -1;
    return st.render_seconds;
}

static void bench_table(void)
{
    const int grids[] = {10, 32, 50, 100}, orders[] = {2, 3, 4};
    char sz[4][48], rs[48], gb[48], ob[48];
    const char *ov[8];
    vsd_framebuffer *ref = NULL;
    vsd_render_stats st;
    int gi, oi, i;
    size_ov(sz, width, height, frame);
    for (i = 0; i < 4; i++) ov[i] = sz[i];
    ov[4] = "render.method=reference";
    snprintf(rs, sizeof rs, "render.samples=%d", ref_samples);
    ov[5] = rs;
    if (render(ov, 6, frame, &ref, &st, NULL)) return;
    printf("reference: %d spp, %.1fs\n", ref_samples, st.render_seconds);
    printf("%-6s %-5s %10s %12s %12s %10s\n", "grid", "order", "records_s", "view_s", "view_s_2nd", "dir_rmse");
    for (gi = 0; gi < 4; gi++)
        for (oi = 0; oi < 3; oi++) {
            vsd_framebuffer *fb = NULL, *fb2 = NULL;
            vsd_renderer *r = NULL;
            double v2;
            snprintf(gb, sizeof gb, "render.options.grid=%d", grids[gi]);
            snprintf(ob, sizeof ob, "render.options.order=%d", orders[oi]);
            ov[4] = "render.method=shgrid";
            ov[5] = gb;
            ov[6] = ob;
            if (render(ov, 7, frame, &fb, &st, &r)) continue;
            v2 = second_view(r, width, height, &fb2);
            printf("%-6d %-5d %10.2f %12.3f %12.3f %10.4f\n", grids[gi], orders[oi], st.prepare_seconds,
                   st.render_seconds, v2, dir_err(fb, ref));
            fflush(stdout);
            vsd_framebuffer_destroy(fb);
            vsd_framebuffer_destroy(fb2);
            vsd_renderer_destroy(r);
        }
    vsd_framebuffer_destroy(ref);
}

static void bench_speed(void)
{
    char sz[4][48];
    const char *ov[8];
    vsd_framebuffer *fb = NULL, *fb2 = NULL, *rm = NULL;
    vsd_render_stats st;
    vsd_renderer *r = NULL;
    double view, rm_s, scale;
    int i, cw = width / 16, ch = height / 16;   /* 1/256 of the pixels */
    size_ov(sz, width, height, frame);
    for (i = 0; i < 4; i++) ov[i] = sz[i];
    ov[4] = "render.method=shgrid";
    if (render(ov, 5, frame, &fb, &st, &r)) return;
    view = second_view(r, width, height, &fb2);
    printf("shgrid %dx%d: record grid %.2fs, first view %.2fs, cached view %.2fs\n", width, height,
           st.prepare_seconds, st.render_seconds, view);
    /* raymarch on a film of 1/256 of the pixels with the same camera and framing (the same
     * rays, subsampled) and one ray per pixel: the per-ray cost is what is compared, scaled
     * to shgrid's width x height x pixel_samples^2 rays */
    snprintf(sz[0], 48, "film.width=%d", cw);
    snprintf(sz[1], 48, "film.height=%d", ch);
    ov[4] = "render.method=raymarch";
    ov[5] = "render.options.lights=224";
    ov[6] = "render.options.pixel_samples=1";
    if (render(ov, 7, frame, &rm, &st, NULL)) return;
    rm_s = st.render_seconds + st.prepare_seconds;
    scale = (double)width * height * 4 / ((double)cw * ch);   /* shgrid: 2x2 rays per pixel */
    printf("raymarch 224 lights %dx%d (1 ray/pixel): %.2fs -> %.1fs scaled to %dx%d x 4 rays; cached shgrid view is %.1fx faster\n", cw, ch,
           rm_s, rm_s * scale, width, height, rm_s * scale / view);
    vsd_framebuffer_destroy(fb);
    vsd_framebuffer_destroy(fb2);
    vsd_framebuffer_destroy(rm);
    vsd_renderer_destroy(r);
}

static void bench_sequence(void)
{
    char sz[4][48], fs[48];
    const char *ov[6];
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_render_options ro;
    vsd_framebuffer *fb = NULL;
    char err[1024];
    double total = 0, rec = 0;
    int f, i;
    size_ov(sz, width, height, 1);
    for (i = 0; i < 2; i++) ov[i] = sz[i];
    ov[2] = "frames.start=1";
    snprintf(fs, sizeof fs, "frames.end=30");
    ov[3] = fs;
    ov[4] = "render.method=shgrid";
    if (vsd_scene_load(scene_path, ov, 5, &sc, err, sizeof err)) { fprintf(stderr, "%s\n", err); return; }
    memset(&ro, 0, sizeof ro);
    ro.threads = threads;
    if (vsd_renderer_create(&sc, &ro, &r, err, sizeof err)) { fprintf(stderr, "%s\n", err); return; }
    for (f = sc.frames.start; f <= sc.frames.end; f++) {
        vsd_render_stats st;
        if (vsd_renderer_render(r, f, &fb, &st, err, sizeof err)) { fprintf(stderr, "%s\n", err); break; }
        total += st.load_seconds + st.prepare_seconds + st.render_seconds;
        rec += st.prepare_seconds;
        printf("frame %2d: load %.2fs record grid %.2fs render %.2fs\n", f, st.load_seconds, st.prepare_seconds,
               st.render_seconds);
        fflush(stdout);
    }
    printf("sequence %dx%d, %d frames: %.2fs per frame (record grid %.2fs per frame)\n", width, height,
           sc.frames.end - sc.frames.start + 1, total / (sc.frames.end - sc.frames.start + 1),
           rec / (sc.frames.end - sc.frames.start + 1));
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
}

int main(int argc, char **argv)
{
    const char *what = "all";
    int i;
    for (i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--width") && i + 1 < argc) width = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--height") && i + 1 < argc) height = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--ref-samples") && i + 1 < argc) ref_samples = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--scene") && i + 1 < argc) scene_path = argv[++i];
        else if (!strcmp(argv[i], "--frame") && i + 1 < argc) frame = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (argv[i][0] != '-') what = argv[i];
        else { fprintf(stderr, "usage: bench_shgrid [table|speed|sequence|all] [--width W --height H] "
                               "[--ref-samples N] [--scene FILE] [--frame N] [--threads N]\n"); return 2; }
    }
    if (!strcmp(what, "table") || !strcmp(what, "all")) bench_table();
    if (!strcmp(what, "speed") || !strcmp(what, "all")) bench_speed();
    if (!strcmp(what, "sequence") || !strcmp(what, "all")) bench_sequence();
    return 0;
}
