/* vsd_bench — per rendering method and scene: load / prepare / render times, accuracy
 * against a converged `reference`, and (with Blender installed) Cycles' time for the same
 * render. Prints a markdown table (bench/README.md has the command and results).
 *
 * For each scene of the scenes folder (default ../shared/data/scenes) and each method of
 * vsd_method_names():
 *   time      one render at --width x --height (default 640x360) with --spp samples for
 *             progressive methods (default 16); load, prepare and render seconds are the
 *             renderer's own stats (a fresh renderer per method, so load is a cold load).
 *   accuracy  one render at 160x90 with the same settings, compared with the scene's
 *             converged reference after 4x4 block averaging: relative RMSE
 *             sqrt(mean (a-b)^2) / mean |b| over blocks and channels, for Combined RGB and
 *             alpha separately (docs/cycles-crosscheck.md defines it).
 *   reference computed once per scene at 160x90 with --ref-spp samples as two half-sample
 *             renders (seeds 1001, 1002) averaged, and cached in the cache folder
 *             (default <build>/bench-cache/<scene>_ref.exr + <scene>_ref.json). The JSON and
 *             the EXR's header record the sample count, a hash of the scene file, and the
 *             noise estimate: rel(half1, half2) / 2, the expected rel. RMSE of the
 *             reference itself (the average of two halves has half the variance of one).
 *             A cache entry is reused when the scene file is unchanged and it has at least
 *             the samples asked for; --refresh recomputes it.
 *   Cycles    when Blender is found (and not --no-cycles): tests/cycles/cycles_scene.py
 *             renders the scene at the timing resolution and spp; the table gives Cycles'
 *             own path-tracing time (the EXR's cycles.ViewLayer.render_time) and
 *             synchronisation time, and for the reference row the ratio of time per sample
 *             per pixel, vsd reference / Cycles (< 1: vsd is faster).
 * A render that exceeds --time-limit is cancelled; its time is then extrapolated from the
 * progress it reported and shown as "~N" (and its accuracy as "-").
 *
 * Defaults: 640x360, 16 spp, reference 2048 spp, 300 s limit per render.
 * --quick: 320x180, 4 spp, reference 256 spp, 20 s limit -- a few minutes in all once the
 * references are cached. */
#define _POSIX_C_SOURCE 200809L
#include "vsd/clock.h"
#include "vsd/compare.h"
#include "vsd/image.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "bench_cycles.h"
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#ifndef VSD_BENCH_SCENES
#define VSD_BENCH_SCENES "../shared/data/scenes"
#endif
#ifndef VSD_BENCH_CACHE
#define VSD_BENCH_CACHE "bench-cache"
#endif
#ifndef VSD_BENCH_BLENDER
#define VSD_BENCH_BLENDER "blender"
#endif
#ifndef VSD_BENCH_CYCLES_SCRIPT
#define VSD_BENCH_CYCLES_SCRIPT "tests/cycles/cycles_scene.py"
#endif

#define ACC_W 160
#define ACC_H 90
#define BLOCK 4
#define MAX_SCENES 64
#define PATHLEN 1024

typedef struct options {
    const char *scene_dir, *cache_dir, *blender, *script, *device, *out;
    const char *scenes, *methods;  /* comma lists, NULL = all */
    int width, height, spp, ref_spp, threads, cycles, refresh;
    double time_limit;
} options;

static int in_list(const char *list, const char *name)
{
    size_t n = strlen(name);
    const char *p = list;
    if (!list) return 1;
    while (*p) {
        const char *e = strchr(p, ',');
        size_t l = e ? (size_t)(e - p) : strlen(p);
        if (l == n && strncmp(p, name, n) == 0) return 1;
        if (!e) break;
        p = e + 1;
    }
    return 0;
}

/* FNV-1a of the scene file: the cache key that notices edits. */
static int file_hash(const char *path, char *out, size_t len)
{
    FILE *f = fopen(path, "rb");
    unsigned long long h = 1469598103934665603ULL;
    int c;
    if (!f) return 0;
    while ((c = fgetc(f)) != EOF) {
        h ^= (unsigned char)c;
        h *= 1099511628211ULL;
    }
    fclose(f);
    snprintf(out, len, "%016llx", h);
    return 1;
}

/* ---- rendering with a time limit ------------------------------------------------------- */

typedef struct watch {
    volatile int cancel;
    double start, deadline, stage_start, last_time;
    float last_fraction;
    char stage[64];
    pthread_mutex_t lock;
    int done;
} watch;

static void on_progress(void *user, const char *stage, float fraction)
{
    watch *w = user;
    double t = vsd_clock_seconds();
    pthread_mutex_lock(&w->lock);
    if (strncmp(w->stage, stage, sizeof w->stage - 1) != 0) {
        snprintf(w->stage, sizeof w->stage, "%s", stage);
        w->stage_start = t;
    }
    w->last_fraction = fraction;
    w->last_time = t;
    pthread_mutex_unlock(&w->lock);
}

static void *watchdog(void *arg)
{
    watch *w = arg;
    for (;;) {
        struct timespec ts = {0, 50 * 1000 * 1000};
        int done;
        pthread_mutex_lock(&w->lock);
        done = w->done;
        pthread_mutex_unlock(&w->lock);
        if (done) return NULL;
        if (vsd_clock_seconds() > w->deadline) w->cancel = 1;
        nanosleep(&ts, NULL);
    }
}

typedef struct run_result {
    vsd_status status;
    vsd_render_stats stats;
    int cancelled;
    double estimate;   /* extrapolated render seconds when cancelled (0 = unknown) */
    char err[1024];
} run_result;

/* Load the scene with the bench's overrides; method NULL keeps the scene's. */
static int load_scene(const char *path, const char *method, const options *o, int w, int h, int spp, int seed,
                      vsd_scene *sc, char *err, size_t errlen)
{
    char ov[8][160];
    const char *ovp[8];
    int n = 0, i;
    snprintf(ov[n++], sizeof ov[0], "film.width=%d", w);
    snprintf(ov[n++], sizeof ov[0], "film.height=%d", h);
    snprintf(ov[n++], sizeof ov[0], "render.samples=%d", spp);
    snprintf(ov[n++], sizeof ov[0], "render.seed=%d", seed);
    if (method) snprintf(ov[n++], sizeof ov[0], "render.method=%s", method);
    if (o->device) snprintf(ov[n++], sizeof ov[0], "render.device=%s", o->device);
    for (i = 0; i < n; i++) ovp[i] = ov[i];
    return vsd_scene_load(path, ovp, n, sc, err, errlen) == VSD_OK;
}

/* One render of `sc` (frame = frames.start) into *fb, cancelled after the time limit. */
static void render_once(const vsd_scene *sc, const options *o, vsd_framebuffer **fb, run_result *r)
{
    vsd_render_options ro;
    vsd_renderer *rd = NULL;
    watch w;
    pthread_t th;
    int have_thread;
    memset(r, 0, sizeof *r);
    memset(&w, 0, sizeof w);
    pthread_mutex_init(&w.lock, NULL);
    w.start = w.stage_start = vsd_clock_seconds();
    w.deadline = w.start + o->time_limit;
    memset(&ro, 0, sizeof ro);
    ro.threads = o->threads;
    ro.progress = on_progress;
    ro.user = &w;
    ro.cancel = &w.cancel;
    have_thread = pthread_create(&th, NULL, watchdog, &w) == 0;
    r->status = vsd_renderer_create(sc, &ro, &rd, r->err, sizeof r->err);
    if (r->status == VSD_OK)
        r->status = vsd_renderer_render(rd, sc->frames.start, fb, &r->stats, r->err, sizeof r->err);
    pthread_mutex_lock(&w.lock);
    w.done = 1;
    pthread_mutex_unlock(&w.lock);
    if (have_thread) pthread_join(th, NULL);
    if (r->status == VSD_ERR_CANCELLED) {
        r->cancelled = 1;
        /* the stage that was running when time ran out, extrapolated to its end */
        if (w.last_fraction > 0.01f) {
            double before = w.stage_start - w.start - r->stats.load_seconds - r->stats.prepare_seconds;
            r->estimate = (before > 0 ? before : 0) + (w.last_time - w.stage_start) / w.last_fraction;
        }
    }
    vsd_renderer_destroy(rd);
    pthread_mutex_destroy(&w.lock);
}

/* ---- reference cache ------------------------------------------------------------------- */

typedef struct reference {
    int samples;
    double noise_rgb, noise_alpha, seconds;
    float *rgba;   /* ACC_W x ACC_H x 4, Combined */
} reference;

static double rel_rmse(const float *a, const float *b, int ch, int stride)
{
    double r = NAN;
    char err[256];
    if (vsd_block_rel_rmse(a, b, ACC_W, ACC_H, ch, stride, BLOCK, &r, err, sizeof err) != VSD_OK) return NAN;
    return r;
}

static double json_number(const char *text, const char *key)
{
    char pat[128];
    const char *p;
    snprintf(pat, sizeof pat, "\"%s\":", key);
    p = strstr(text, pat);
    return p ? strtod(p + strlen(pat), NULL) : NAN;
}

static char *read_text(const char *path)
{
    FILE *f = fopen(path, "rb");
    char *buf;
    long n;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    buf = malloc((size_t)n + 1);
    if (buf) {
        n = (long)fread(buf, 1, (size_t)n, f);
        buf[n] = '\0';
    }
    fclose(f);
    return buf;
}

static int load_cached_reference(const char *exr, const char *js, const char *hash, int want_spp, reference *ref)
{
    char *text = read_text(js), tag[64];
    vsd_exr_image *img = NULL;
    char err[512];
    static const char *const ch[4] = {"ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B",
                                      "ViewLayer.Combined.A"};
    int ok = 0, c, i;
    if (!text) return 0;
    snprintf(tag, sizeof tag, "\"scene_hash\": \"%s\"", hash);
    if (strstr(text, tag) && json_number(text, "samples") >= want_spp && json_number(text, "width") == ACC_W &&
        json_number(text, "height") == ACC_H && vsd_exr_read(exr, &img, err, sizeof err) == VSD_OK &&
        img->width == ACC_W && img->height == ACC_H) {
        ref->rgba = malloc(sizeof(float) * ACC_W * ACC_H * 4);
        ok = ref->rgba != NULL;
        for (c = 0; c < 4 && ok; c++) {
            const float *p = vsd_exr_channel(img, ch[c]);
            if (!p) ok = 0;
            else
                for (i = 0; i < ACC_W * ACC_H; i++) ref->rgba[i * 4 + c] = p[i];
        }
        ref->samples = (int)json_number(text, "samples");
        ref->noise_rgb = json_number(text, "noise_rel_rmse_rgb");
        ref->noise_alpha = json_number(text, "noise_rel_rmse_alpha");
        ref->seconds = json_number(text, "seconds");
    }
    vsd_exr_image_destroy(img);
    free(text);
    if (!ok) {
        free(ref->rgba);
        ref->rgba = NULL;
    }
    return ok;
}

static int compute_reference(const char *scene_path, const char *name, const char *hash, const options *o,
                             const char *exr, const char *js, reference *ref)
{
    vsd_framebuffer *h[2] = {NULL, NULL}, *avg = NULL;
    vsd_scene sc;
    run_result r;
    options lim = *o;
    char err[1024], s_spp[32], s_rgb[32], s_a[32];
    double t0 = vsd_clock_seconds();
    int i, p, ok = 1, half = (o->ref_spp + 1) / 2;
    lim.time_limit = 1e9; /* the reference always completes */
    fprintf(stderr, "[%s] reference: 2 x %d spp at %dx%d (cached in %s)\n", name, half, ACC_W, ACC_H, exr);
    for (i = 0; i < 2 && ok; i++) {
        if (!load_scene(scene_path, "reference", o, ACC_W, ACC_H, half, 1001 + i, &sc, err, sizeof err)) {
            fprintf(stderr, "[%s] %s\n", name, err);
            ok = 0;
            break;
        }
        render_once(&sc, &lim, &h[i], &r);
        if (r.status != VSD_OK) {
            fprintf(stderr, "[%s] reference: %s\n", name, r.err);
            ok = 0;
        }
    }
    if (ok && vsd_framebuffer_create(ACC_W, ACC_H, &avg, err, sizeof err) != VSD_OK) ok = 0;
    if (ok) {
        vsd_exr_attr attrs[5];
        vsd_exr_write_options wo;
        for (p = 0; p < VSD_PASS_COUNT; p++) {
            size_t n = (size_t)ACC_W * ACC_H * vsd_pass_channels((vsd_pass)p), k;
            for (k = 0; k < n; k++) {
                float a = h[0]->pass[p][k], b = h[1]->pass[p][k];
                if (p == VSD_PASS_DEPTH) /* mean of the valid estimates */
                    avg->pass[p][k] = a >= VSD_DEPTH_EMPTY ? b : b >= VSD_DEPTH_EMPTY ? a : 0.5f * (a + b);
                else
                    avg->pass[p][k] = 0.5f * (a + b);
            }
        }
        ref->samples = 2 * half;
        ref->noise_rgb = 0.5 * rel_rmse(h[0]->pass[VSD_PASS_COMBINED], h[1]->pass[VSD_PASS_COMBINED], 3, 4);
        ref->noise_alpha = 0.5 * rel_rmse(h[0]->pass[VSD_PASS_COMBINED] + 3, h[1]->pass[VSD_PASS_COMBINED] + 3, 1, 4);
        ref->seconds = vsd_clock_seconds() - t0;
        ref->rgba = malloc(sizeof(float) * ACC_W * ACC_H * 4);
        if (!ref->rgba) ok = 0;
        else memcpy(ref->rgba, avg->pass[VSD_PASS_COMBINED], sizeof(float) * ACC_W * ACC_H * 4);
        snprintf(s_spp, sizeof s_spp, "%d", ref->samples);
        snprintf(s_rgb, sizeof s_rgb, "%.6g", ref->noise_rgb);
        snprintf(s_a, sizeof s_a, "%.6g", ref->noise_alpha);
        attrs[0].name = "vsd/bench_ref_samples";
        attrs[0].value = s_spp;
        attrs[1].name = "vsd/bench_ref_noise_rel_rmse_rgb";
        attrs[1].value = s_rgb;
        attrs[2].name = "vsd/bench_ref_noise_rel_rmse_alpha";
        attrs[2].value = s_a;
        attrs[3].name = "vsd/bench_scene_hash";
        attrs[3].value = hash;
        attrs[4].name = "vsd/bench_scene";
        attrs[4].value = scene_path;
        memset(&wo, 0, sizeof wo);
        wo.attrs = attrs;
        wo.attr_count = 5;
        if (ok && vsd_exr_write(exr, avg, &wo, err, sizeof err) != VSD_OK) {
            fprintf(stderr, "[%s] %s (reference not cached)\n", name, err);
        } else if (ok) {
            FILE *f = fopen(js, "w");
            if (f) {
                fprintf(f,
                        "{\n \"scene\": \"%s\",\n \"scene_hash\": \"%s\",\n \"frame\": %d,\n \"width\": %d,\n"
                        " \"height\": %d,\n \"samples\": %d,\n \"seeds\": [1001, 1002],\n"
                        " \"noise_rel_rmse_rgb\": %.6g,\n \"noise_rel_rmse_alpha\": %.6g,\n"
                        " \"seconds\": %.2f,\n \"threads\": %d,\n \"vsd_version\": \"%s\"\n}\n",
                        scene_path, hash, sc.frames.start, ACC_W, ACC_H, ref->samples, ref->noise_rgb,
                        ref->noise_alpha, ref->seconds, r.stats.threads, vsd_version());
                fclose(f);
            }
        }
    }
    vsd_framebuffer_destroy(h[0]);
    vsd_framebuffer_destroy(h[1]);
    vsd_framebuffer_destroy(avg);
    return ok;
}

/* ---- Cycles ---------------------------------------------------------------------------- */

static void run_cycles(const char *scene_path, const char *name, const options *o, bench_cycles_result *cr)
{
    char out[PATHLEN + 64], log[PATHLEN + 64], tjson[PATHLEN + 64];
    snprintf(out, sizeof out, "%s/%s_cycles.exr", o->cache_dir, name);
    snprintf(log, sizeof log, "%s/%s_cycles.log", o->cache_dir, name);
    snprintf(tjson, sizeof tjson, "%s/%s_cycles.json", o->cache_dir, name);
    fprintf(stderr, "[%s] Cycles: %dx%d, %d spp (log %s)\n", name, o->width, o->height, o->spp, log);
    bench_run_cycles(o->blender, o->script, scene_path, out, log, tjson, o->width, o->height, o->spp, 0, cr);
}

/* ---- the table ------------------------------------------------------------------------- */

static void fmt_time(char *buf, size_t len, const run_result *r, double seconds)
{
    if (r->status != VSD_OK) snprintf(buf, len, "-");
    else snprintf(buf, len, seconds < 10 ? "%.2f" : "%.1f", seconds);
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: vsd_bench [--scenes a,b] [--methods m,n] [--device auto|cpu|cuda] [--quick]\n"
            "                 [--width W --height H] [--spp N] [--ref-spp N] [--time-limit S]\n"
            "                 [--threads N] [--no-cycles] [--blender PATH] [--script PATH]\n"
            "                 [--scene-dir DIR] [--cache DIR] [--refresh] [--out TABLE.md]\n"
            "scenes are file names without .json; defaults: %s, %s\n",
            VSD_BENCH_SCENES, VSD_BENCH_CACHE);
}

int main(int argc, char **argv)
{
    options o;
    char *names[MAX_SCENES];
    int nscenes = 0, i, quick = 0, spp_set = 0, ref_set = 0, size_set = 0, limit_set = 0;
    DIR *d;
    struct dirent *de;
    FILE *table;
    char table_buf[65536];
    size_t tl = 0;
    const char *const *methods = vsd_method_names();
    double t_start = vsd_clock_seconds();

    memset(&o, 0, sizeof o);
    o.scene_dir = VSD_BENCH_SCENES;
    o.cache_dir = VSD_BENCH_CACHE;
    o.blender = VSD_BENCH_BLENDER;
    o.script = VSD_BENCH_CYCLES_SCRIPT;
    o.cycles = 1;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--quick")) quick = 1;
        else if (!strcmp(a, "--no-cycles")) o.cycles = 0;
        else if (!strcmp(a, "--refresh")) o.refresh = 1;
        else if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        } else if (!v) {
            usage(stderr);
            return 2;
        } else if (!strcmp(a, "--scenes")) o.scenes = v, i++;
        else if (!strcmp(a, "--methods")) o.methods = v, i++;
        else if (!strcmp(a, "--device")) o.device = v, i++;
        else if (!strcmp(a, "--width")) o.width = atoi(v), size_set = 1, i++;
        else if (!strcmp(a, "--height")) o.height = atoi(v), size_set = 1, i++;
        else if (!strcmp(a, "--spp")) o.spp = atoi(v), spp_set = 1, i++;
        else if (!strcmp(a, "--ref-spp")) o.ref_spp = atoi(v), ref_set = 1, i++;
        else if (!strcmp(a, "--time-limit")) o.time_limit = atof(v), limit_set = 1, i++;
        else if (!strcmp(a, "--threads")) o.threads = atoi(v), i++;
        else if (!strcmp(a, "--blender")) o.blender = v, i++;
        else if (!strcmp(a, "--script")) o.script = v, i++;
        else if (!strcmp(a, "--scene-dir")) o.scene_dir = v, i++;
        else if (!strcmp(a, "--cache")) o.cache_dir = v, i++;
        else if (!strcmp(a, "--out")) o.out = v, i++;
        else {
            fprintf(stderr, "vsd_bench: unknown option %s\n", a);
            usage(stderr);
            return 2;
        }
    }
    if (!size_set) o.width = quick ? 320 : 640, o.height = quick ? 180 : 360;
    if (!spp_set) o.spp = quick ? 4 : 16;
    if (!ref_set) o.ref_spp = quick ? 256 : 2048;
    if (!limit_set) o.time_limit = quick ? 20 : 300;
    if (o.width < 1 || o.height < 1 || o.spp < 1 || o.ref_spp < 2 || o.time_limit <= 0) {
        usage(stderr);
        return 2;
    }
    if (o.cycles && (access(o.script, R_OK) != 0 || run_logged((char *[]){(char *)o.blender, "--version", NULL},
                                                               "/dev/null") != 0)) {
        fprintf(stderr, "vsd_bench: no Blender (%s) or no %s: Cycles columns left empty\n", o.blender, o.script);
        o.cycles = 0;
    }
    mkdir(o.cache_dir, 0755);

    d = opendir(o.scene_dir);
    if (!d) {
        fprintf(stderr, "vsd_bench: %s: %s\n", o.scene_dir, strerror(errno));
        return 1;
    }
    while ((de = readdir(d)) && nscenes < MAX_SCENES) {
        size_t l = strlen(de->d_name);
        char base[256];
        if (l < 6 || strcmp(de->d_name + l - 5, ".json") != 0 || l - 5 >= sizeof base) continue;
        memcpy(base, de->d_name, l - 5);
        base[l - 5] = '\0';
        if (in_list(o.scenes, base)) names[nscenes++] = strdup(base);
    }
    closedir(d);
    qsort(names, (size_t)nscenes, sizeof names[0], cmp_str);
    if (nscenes == 0) {
        fprintf(stderr, "vsd_bench: no scene matches in %s\n", o.scene_dir);
        return 1;
    }

    tl += (size_t)snprintf(table_buf + tl, sizeof table_buf - tl,
                           "| scene | method | device | spp | load s | prepare s | render s (%dx%d) "
                           "| rel. RMSE RGB (%dx%d) | rel. RMSE alpha | reference noise RGB / alpha "
                           "| time/spp/px vs Cycles |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
                           o.width, o.height, ACC_W, ACC_H);
    for (i = 0; i < nscenes; i++) {
        char scene_path[PATHLEN], hash[32], exr[PATHLEN + 64], js[PATHLEN + 64], err[1024];
        reference ref;
        bench_cycles_result cyc;
        const char *const *m;
        memset(&ref, 0, sizeof ref);
        memset(&cyc, 0, sizeof cyc);
        snprintf(scene_path, sizeof scene_path, "%s/%s.json", o.scene_dir, names[i]);
        if (!file_hash(scene_path, hash, sizeof hash)) {
            fprintf(stderr, "vsd_bench: %s: cannot read\n", scene_path);
            continue;
        }
        snprintf(exr, sizeof exr, "%s/%s_ref.exr", o.cache_dir, names[i]);
        snprintf(js, sizeof js, "%s/%s_ref.json", o.cache_dir, names[i]);
        if (o.refresh || !load_cached_reference(exr, js, hash, o.ref_spp, &ref)) {
            if (!compute_reference(scene_path, names[i], hash, &o, exr, js, &ref)) ref.rgba = NULL;
        } else
            fprintf(stderr, "[%s] reference: cached, %d spp (%s)\n", names[i], ref.samples, exr);
        if (o.cycles) run_cycles(scene_path, names[i], &o, &cyc);

        for (m = methods; *m; m++) {
            vsd_scene sc;
            vsd_framebuffer *fb = NULL;
            run_result rt, ra;
            char t_load[32], t_prep[32], t_rend[32], e_rgb[32] = "-", e_a[32] = "-", ratio[48] = "", noise[48] = "-";
            if (!in_list(o.methods, *m)) continue;
            /* accuracy first: at 160x90 it is the cheaper render, so a method too slow for
             * the timing resolution still gets its error measured */
            if (ref.rgba) {
                fprintf(stderr, "[%s] %s: %dx%d accuracy\n", names[i], *m, ACC_W, ACC_H);
                if (load_scene(scene_path, *m, &o, ACC_W, ACC_H, o.spp, 1, &sc, err, sizeof err)) {
                    render_once(&sc, &o, &fb, &ra);
                    if (ra.status == VSD_OK) {
                        snprintf(e_rgb, sizeof e_rgb, "%.4f", rel_rmse(fb->pass[VSD_PASS_COMBINED], ref.rgba, 3, 4));
                        snprintf(e_a, sizeof e_a, "%.4f",
                                 rel_rmse(fb->pass[VSD_PASS_COMBINED] + 3, ref.rgba + 3, 1, 4));
                    } else if (ra.cancelled)
                        snprintf(e_rgb, sizeof e_rgb, "> %.0f s", o.time_limit);
                    else
                        fprintf(stderr, "[%s] %s: %s\n", names[i], *m, ra.err);
                    vsd_framebuffer_destroy(fb);
                    fb = NULL;
                } else
                    fprintf(stderr, "[%s] %s\n", names[i], err);
            }
            fprintf(stderr, "[%s] %s: %dx%d timing\n", names[i], *m, o.width, o.height);
            if (!load_scene(scene_path, *m, &o, o.width, o.height, o.spp, 1, &sc, err, sizeof err)) {
                fprintf(stderr, "[%s] %s\n", names[i], err);
                continue;
            }
            render_once(&sc, &o, &fb, &rt);
            if (rt.status != VSD_OK && !rt.cancelled) fprintf(stderr, "[%s] %s: %s\n", names[i], *m, rt.err);
            fmt_time(t_load, sizeof t_load, &rt, rt.stats.load_seconds);
            fmt_time(t_prep, sizeof t_prep, &rt, rt.stats.prepare_seconds);
            fmt_time(t_rend, sizeof t_rend, &rt, rt.stats.render_seconds);
            if (rt.cancelled) {
                /* the renderer sets each stage's time when the stage ends: a stage with no
                 * time yet is the one that was cut short */
                char est[32];
                if (rt.estimate > 0) snprintf(est, sizeof est, "~%.0f", rt.estimate);
                else snprintf(est, sizeof est, "> %.0f", o.time_limit);
                snprintf(t_load, sizeof t_load, "%.2f", rt.stats.load_seconds);
                if (rt.stats.render_seconds > 0) {
                    snprintf(t_prep, sizeof t_prep, "%.2f", rt.stats.prepare_seconds);
                    snprintf(t_rend, sizeof t_rend, "%s", est);
                } else {
                    snprintf(t_prep, sizeof t_prep, "%s", est);
                    snprintf(t_rend, sizeof t_rend, "-");
                }
            }
            if (o.cycles && cyc.ok && strcmp(*m, "reference") == 0 && rt.status == VSD_OK) {
                double px = (double)o.width * o.height;
                double tv = rt.stats.render_seconds / (px * rt.stats.samples), tc = cyc.render / (px * cyc.samples);
                snprintf(ratio, sizeof ratio, "%.3f", tv / tc);
            }
            vsd_framebuffer_destroy(fb);
            fb = NULL;

            if (ref.rgba) snprintf(noise, sizeof noise, "%.4f / %.4f (%d spp)", ref.noise_rgb, ref.noise_alpha, ref.samples);
            tl += (size_t)snprintf(table_buf + tl, sizeof table_buf - tl,
                                   "| %s | %s | %s | %d | %s | %s | %s | %s | %s | %s | %s |\n", names[i], *m,
                                   rt.stats.device[0] ? rt.stats.device : (o.device ? o.device : "auto"),
                                   rt.stats.samples ? rt.stats.samples : o.spp, t_load, t_prep, t_rend, e_rgb, e_a,
                                   noise, ratio[0] ? ratio : "");
            if (tl >= sizeof table_buf) tl = sizeof table_buf - 1;
        }
        if (o.cycles) {
            char rend[32] = "-", sync[32] = "-";
            if (cyc.ok) {
                snprintf(rend, sizeof rend, "%.1f", cyc.render);
                snprintf(sync, sizeof sync, "%.2f", cyc.sync);
            }
            tl += (size_t)snprintf(table_buf + tl, sizeof table_buf - tl,
                                   "| %s | Cycles (Blender) | cpu | %d | %s (sync) | - | %s | - | - | - | 1 |\n",
                                   names[i], o.spp, sync, rend);
            if (tl >= sizeof table_buf) tl = sizeof table_buf - 1;
        }
        free(ref.rgba);
        fprintf(stderr, "%s", table_buf); /* running table, so a long run shows its progress */
    }

    table = stdout;
    printf("\nvsd_bench: %s, %dx%d timing renders, %d spp for progressive methods; accuracy at %dx%d vs a "
           "%d+ spp reference, 4x4 blocks; time limit %.0f s per render; total %.0f s\n\n",
           vsd_version(), o.width, o.height, o.spp, ACC_W, ACC_H, o.ref_spp, o.time_limit, vsd_clock_seconds() - t_start);
    fputs(table_buf, table);
    if (o.out) {
        FILE *f = fopen(o.out, "w");
        if (f) {
            fputs(table_buf, f);
            fclose(f);
        }
    }
    for (i = 0; i < nscenes; i++) free(names[i]);
    return 0;
}
