/* bench_device — the GPU measurements of issue 7, per scene and method:
 *   prepare   the first render's per-frame and per-lighting preparation on the GPU (record
 *             grid, distance map, light tables, uploads), from vsd_render_stats
 *   view      the first view pass, then `--orbit N` views of a camera orbit about the world
 *             Z axis from the cached preparation: mean time per view and frames per second,
 *             split into the device passes (kernels, launch to the last band's end), the
 *             download of the per-pixel sums, and the host's rest (sums resolved into
 *             passes, the method's own host work, allocation)
 *   CPU       the same scene on the CPU backend (all cores, or --cpu-threads) on a film of
 *             1/k^2 of the pixels (--cpu-scale k, default 4; the full film takes minutes
 *             for the brute-force methods): its preparation as measured plus its view's
 *             time per pixel scaled to the full film (before 2026-12-04 the preparation was
 *             scaled too, which overstated the speed-up of the methods that prepare), and
 *             the GPU's speed-up against it in the same run
 *   rel RMSE  of the GPU image against the CPU image on that smaller film (Combined, 4x4
 *             blocks; a float-rounding level for the deterministic methods, noise for
 *             `reference`)
 * Usage: bench_device [--scenes a,b] [--methods m,n] [--width W --height H] [--orbit N]
 *                     [--samples N] [--cpu-scale k] [--cpu-threads N] [--no-cpu]
 *                     [--data DIR] [--max-seconds S]
 *   --data         the shared data folder (default $VSD_SHARED_DATA, else the build's
 *                  ../shared/data); scene files are read from DIR/scenes
 *   --max-seconds  a time budget: no new scene/method case starts once S seconds have
 *                  passed, and the cases left are listed as not run (the GPU machine gives
 *                  one command 10 minutes)
 * Prints a markdown table on stdout (the header first, also without a GPU); exits 77 when
 * no CUDA device answers. */
#include "vsd/clock.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "vsd/compare.h"
#include "bench_camera.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct bench_opts {
    const char *scenes, *methods, *data;
    int width, height, orbit, samples, cpu_scale, cpu_threads, no_cpu;
    double max_seconds;
} bench_opts;

static const char *data_dir;

static vsd_status load_scene(const char *name, const char *method, const char *device, int w, int h, int samples,
                             vsd_scene *sc, char *err, size_t errlen)
{
    char path[1024], ov[5][64];
    const char *ovp[5];
    int i;
    snprintf(path, sizeof path, "%s/scenes/%s.json", data_dir, name);
    snprintf(ov[0], 64, "render.method=%s", method);
    snprintf(ov[1], 64, "render.device=%s", device);
    snprintf(ov[2], 64, "film.width=%d", w);
    snprintf(ov[3], 64, "film.height=%d", h);
    snprintf(ov[4], 64, "render.samples=%d", samples);
    for (i = 0; i < 5; i++) ovp[i] = ov[i];
    return vsd_scene_load(path, ovp, 5, sc, err, errlen);
}

typedef struct device_result {
    double prepare_s, first_view_s, orbit_view_s, cpu_s_scaled, rel_rmse;
    double orbit_pass_s, orbit_download_s;   /* of orbit_view_s: in device passes, in downloads */
    int samples;
    char device_name[128];
} device_result;

static vsd_status bench_one(const bench_opts *o, const char *scene, const char *method, device_result *res,
                            char *err, size_t errlen)
{
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL, *small_gpu = NULL, *small_cpu = NULL;
    vsd_render_stats st;
    vsd_render_options ro;
    double base[16], t;
    int frame, i, sw = o->width / o->cpu_scale, sh = o->height / o->cpu_scale;
    vsd_status s = load_scene(scene, method, "cuda", o->width, o->height, o->samples, &sc, err, errlen);
    memset(res, 0, sizeof *res);
    if (s) return s;
    frame = sc.frames.start;
    memcpy(base, sc.camera.matrix, sizeof base);
    if ((s = vsd_renderer_create(&sc, NULL, &r, err, errlen))) return s;
    s = vsd_renderer_render(r, frame, &fb, &st, err, errlen);
    res->prepare_s = st.prepare_seconds;
    res->first_view_s = st.render_seconds;
    res->samples = st.samples;
    snprintf(res->device_name, sizeof res->device_name, "%s", st.device_name);
    t = vsd_clock_seconds();
    for (i = 1; !s && i <= o->orbit; i++) {
        bench_orbit_camera(&sc, base, 2.0 * 3.14159265358979 * i / (o->orbit + 1));
        if (!(s = vsd_renderer_set_scene(r, &sc, err, errlen))) s = vsd_renderer_render(r, frame, &fb, &st, err, errlen);
        res->orbit_pass_s += st.device_pass_seconds / o->orbit;
        res->orbit_download_s += st.device_download_seconds / o->orbit;
    }
    res->orbit_view_s = o->orbit > 0 ? (vsd_clock_seconds() - t) / o->orbit : res->first_view_s;
    vsd_renderer_destroy(r);
    vsd_framebuffer_destroy(fb);
    r = NULL;
    if (s || o->no_cpu) return s;

    /* the CPU on a smaller film, and the GPU on the same film for the image comparison */
    if (!(s = load_scene(scene, method, "cuda", sw, sh, o->samples, &sc, err, errlen)) &&
        !(s = vsd_renderer_create(&sc, NULL, &r, err, errlen)))
        s = vsd_renderer_render(r, frame, &small_gpu, &st, err, errlen);
    vsd_renderer_destroy(r);
    r = NULL;
    memset(&ro, 0, sizeof ro);
    ro.threads = o->cpu_threads;
    if (!s && !(s = load_scene(scene, method, "cpu", sw, sh, o->samples, &sc, err, errlen)) &&
        !(s = vsd_renderer_create(&sc, &ro, &r, err, errlen)))
        s = vsd_renderer_render(r, frame, &small_cpu, &st, err, errlen);
    if (!s) {
        /* the view scales with the pixels, the preparation (lighting grids, lattices) does not */
        res->cpu_s_scaled = st.prepare_seconds + st.render_seconds * ((double)o->width * o->height / ((double)sw * sh));
        res->rel_rmse = -1;
        vsd_block_rel_rmse(small_gpu->pass[VSD_PASS_COMBINED], small_cpu->pass[VSD_PASS_COMBINED], sw, sh, 4, 4, 4,
                           &res->rel_rmse, NULL, 0);
    }
    vsd_renderer_destroy(r);
    vsd_framebuffer_destroy(small_gpu);
    vsd_framebuffer_destroy(small_cpu);
    return s;
}

static int parse(int argc, char **argv, bench_opts *o)
{
    int i;
    o->scenes = "smoke64_sunset,smoke128_forest,fire96_studio,cloud128_interior";
    o->methods = "reference,raymarch,constellation,shgrid";
    o->width = 1280;
    o->height = 720;
    o->orbit = 60;
    o->samples = 16;
    o->cpu_scale = 4;
    o->data = getenv("VSD_SHARED_DATA") && *getenv("VSD_SHARED_DATA") ? getenv("VSD_SHARED_DATA") : VSD_BENCH_DATA;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--no-cpu")) { o->no_cpu = 1; continue; }
        if (!v) return fprintf(stderr, "bench_device: %s needs a value\n", a), 0;
        if (!strcmp(a, "--scenes")) o->scenes = v;
        else if (!strcmp(a, "--methods")) o->methods = v;
        else if (!strcmp(a, "--width")) o->width = atoi(v);
        else if (!strcmp(a, "--height")) o->height = atoi(v);
        else if (!strcmp(a, "--orbit")) o->orbit = atoi(v);
        else if (!strcmp(a, "--samples")) o->samples = atoi(v);
        else if (!strcmp(a, "--cpu-scale")) o->cpu_scale = atoi(v);
        else if (!strcmp(a, "--cpu-threads")) o->cpu_threads = atoi(v);
        else if (!strcmp(a, "--data")) o->data = v;
        else if (!strcmp(a, "--max-seconds")) o->max_seconds = atof(v);
        else return fprintf(stderr, "bench_device: unknown option %s\n", a), 0;
        i++;
    }
    if (o->width < 16 || o->height < 16 || o->orbit < 0 || o->samples < 1 || o->cpu_scale < 1 ||
        o->width / o->cpu_scale < 4 || o->height / o->cpu_scale < 4 || o->max_seconds < 0)
        return fprintf(stderr, "bench_device: bad sizes\n"), 0;
    return 1;
}

static void print_header(void)
{
    printf("| scene | method | spp | GPU prepare ms | GPU first view ms | GPU orbit view ms | orbit fps | "
           "of a view: kernels ms | download ms | host ms | CPU s (scaled to film) | GPU speed-up | "
           "rel. RMSE GPU vs CPU |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    fflush(stdout);
}

int main(int argc, char **argv)
{
    bench_opts o;
    char name[256], err[1024], scenes[1024], methods[256], *sp, *mp, *sv, *mv;
    double start;
    memset(&o, 0, sizeof o);
    if (!parse(argc, argv, &o)) return 2;
    data_dir = o.data;
    start = vsd_clock_seconds();
    if (vsd_render_cuda_probe(name, sizeof name, err, sizeof err)) {
        print_header();
        fprintf(stderr, "bench_device: no CUDA device: %s\n", err);
        printf("\nno CUDA device: %s\n", err);
        return 77;
    }
    printf("GPU: %s; film %dx%d, %d orbit views, reference %d spp; CPU on a %dx%d film, %d threads (0 = all)\n\n",
           name, o.width, o.height, o.orbit, o.samples, o.width / o.cpu_scale, o.height / o.cpu_scale, o.cpu_threads);
    print_header();
    snprintf(scenes, sizeof scenes, "%s", o.scenes);
    for (sv = strtok_r(scenes, ",", &sp); sv; sv = strtok_r(NULL, ",", &sp)) {
        snprintf(methods, sizeof methods, "%s", o.methods);
        for (mv = strtok_r(methods, ",", &mp); mv; mv = strtok_r(NULL, ",", &mp)) {
            device_result r;
            vsd_status s;
            if (o.max_seconds > 0 && vsd_clock_seconds() - start > o.max_seconds) {
                printf("| %s | %s | not run: the %.0f s budget (--max-seconds) was spent |\n", sv, mv, o.max_seconds);
                fflush(stdout);
                continue;
            }
            s = bench_one(&o, sv, mv, &r, err, sizeof err);
            if (s) {
                printf("| %s | %s | failed: %s |\n", sv, mv, err);
                fflush(stdout);
                continue;
            }
            double gpu_total = r.prepare_s + r.first_view_s;
            char cpu[96] = "- | - | -";
            if (!o.no_cpu)
                snprintf(cpu, sizeof cpu, "%.2f | %.0fx | %.2g", r.cpu_s_scaled,
                         gpu_total > 0 ? r.cpu_s_scaled / gpu_total : 0.0, r.rel_rmse);
            printf("| %s | %s | %d | %.2f | %.2f | %.2f | %.1f | %.2f | %.2f | %.2f | %s |\n", sv, mv, r.samples,
                   1e3 * r.prepare_s, 1e3 * r.first_view_s, 1e3 * r.orbit_view_s,
                   r.orbit_view_s > 0 ? 1.0 / r.orbit_view_s : 0.0, 1e3 * r.orbit_pass_s, 1e3 * r.orbit_download_s,
                   1e3 * (r.orbit_view_s - r.orbit_pass_s - r.orbit_download_s), cpu);
            fflush(stdout);
        }
    }
    return 0;
}
