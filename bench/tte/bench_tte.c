/* bench_tte — time to error, the yardstick of every method (issue 12).
 *
 * Per scene and deterministic method, at the timing film (--width x --height, default
 * 1280x720), one renderer going through the edits a user makes, each timed on the wall:
 *   cold      a fresh renderer: load + prepare + view
 *   camera    the camera turned 10 degrees about world Z: cached preparation, view only
 *   lighting  the environment rotated by 0.5 rad: the lighting stage and a view
 *   frame     the next VDB frame of the sequence (n/a for single-file scenes)
 * and the error of a render at the evaluation film (--eval-width x --eval-height, default
 * 320x180) against the scene's converged reference at that film: relative RMSE over 4x4
 * blocks (vsd_block_rel_rmse) of Combined RGB, VolumeDir and VolumeInd; a method's
 * method_info (crm: RBFs, fit, hash, stage times) goes to stderr.
 *
 * For `reference`, one row per sample count of --spp-list (default 16,64,256,1024): the
 * error at the evaluation film, and the time of the view pass there scaled to the timing
 * film by the pixel ratio (path tracing time is linear in pixels; rendering 1024 spp at
 * 1280x720 on 2 cores would take most of an hour per scene). Its camera-change time is
 * that whole render: a path tracer caches nothing.
 *
 * The converged reference: two renders of --ref-spp/2 samples (seeds 1001, 1002)
 * averaged, cached in --cache (default <build>/bench-cache) as an EXR keyed by the scene
 * file's hash, the film and the sample count; its noise, rel(half1, half2)/2, is printed
 * beside it: errors below about twice that are not resolved.
 *
 * Output: a markdown table on stdout, and with --csv FILE one line per point
 * (scene,method,spp,cold,camera,lighting,frame,err_combined,err_voldir,err_volind) for
 * bench/tte/plot_tte.py, which draws the log-log plot of error against camera-change time.
 * A render past --time-limit seconds (default 600) is cancelled and shown as "> limit".
 * --set key=value (up to 8) overrides a scene field for the methods' renders, not for the
 * reference (e.g. --set render.options.step=0.0156).
 * --reference-caches none,lbl (default none): the `reference` rows once per value of its
 * render.options.cache (issue 33), shown as "reference+lbl"; the cache's lighting is in the
 * cold time and not scaled (it does not grow with the film), the paths are.
 * --cycles-spp 16,32,64 (default none): Blender Cycles (--blender, default the one CMake
 * found; tests/cycles/cycles_scene.py with the cross-check's settings) renders the scene at
 * the evaluation film with each sample count, one row "cycles" each, its error against the
 * same converged reference and its own path-tracing time (the EXR header's render_time)
 * scaled to the timing film as the reference's is; its cold time adds Cycles' scene sync.
 * Issue 33's equal-error speed-up over Cycles is read off these rows and the reference's
 * (bench/tte/plot_tte.py prints it). */
#define _POSIX_C_SOURCE 200809L
#include "bench_cycles.h"
#include "vsd/clock.h"
#include "vsd/compare.h"
#include "vsd/image.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "bench_camera.h"
#include "bench_frames.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#define BLOCK 4

#define MAX_SETS 8

typedef struct tte_opts {
    const char *data, *scenes, *methods, *cache, *csv, *spp_list, *ref_caches, *cycles_spp, *blender, *cycles_script;
    const char *sets[MAX_SETS];   /* --set key=value overrides for the methods (not the reference) */
    int set_count;
    int width, height, eval_w, eval_h, ref_spp, threads;
    double time_limit;
} tte_opts;

typedef struct timed {
    double start, limit, fraction;
    volatile int cancel;
} timed;

/* the progress callback doubles as the watchdog: past the limit it asks the render to stop */
static void on_progress(void *user, const char *stage, float fraction)
{
    timed *t = user;
    (void)stage;
    t->fraction = fraction;
    if (vsd_clock_seconds() - t->start > t->limit) t->cancel = 1;
}

/* extra: one more override (reference's cache), or NULL */
static int load(const tte_opts *o, const char *scene, const char *method, int w, int h, int spp, int seed,
                const char *extra, vsd_scene *sc)
{
    char path[1024], ov[5][96], err[1024];
    const char *ovp[6 + MAX_SETS];
    int i, n = 5;
    snprintf(path, sizeof path, "%s/scenes/%s.json", o->data, scene);
    snprintf(ov[0], sizeof ov[0], "render.method=%s", method);
    snprintf(ov[1], sizeof ov[1], "film.width=%d", w);
    snprintf(ov[2], sizeof ov[2], "film.height=%d", h);
    snprintf(ov[3], sizeof ov[3], "render.samples=%d", spp);
    snprintf(ov[4], sizeof ov[4], "render.seed=%d", seed);
    for (i = 0; i < 5; i++) ovp[i] = ov[i];
    if (strcmp(method, "reference") != 0)
        for (i = 0; i < o->set_count; i++) ovp[n++] = o->sets[i];
    if (extra) ovp[n++] = extra;
    if (vsd_scene_load(path, ovp, n, sc, err, sizeof err) != VSD_OK) {
        fprintf(stderr, "bench_tte: %s\n", err);
        return 0;
    }
    return 1;
}

/* One render on r (made from sc when *r is NULL); wall seconds, or -1 when it failed or
 * ran past the limit (*fb then holds nothing new). */
static double render_timed(const tte_opts *o, const vsd_scene *sc, vsd_renderer **r, int frame,
                           vsd_framebuffer **fb, vsd_render_stats *st)
{
    vsd_render_options ro;
    timed t;
    char err[1024];
    vsd_status s;
    memset(&t, 0, sizeof t);
    t.limit = o->time_limit;
    t.start = vsd_clock_seconds();
    memset(&ro, 0, sizeof ro);
    ro.threads = o->threads;
    ro.progress = on_progress;
    ro.user = &t;
    ro.cancel = &t.cancel;
    s = *r ? vsd_renderer_set_scene(*r, sc, err, sizeof err) : vsd_renderer_create(sc, &ro, r, err, sizeof err);
    if (!s) s = vsd_renderer_render(*r, frame, fb, st, err, sizeof err);
    if (s) {
        if (s != VSD_ERR_CANCELLED) fprintf(stderr, "bench_tte: %s\n", err);
        return -1.0;
    }
    return vsd_clock_seconds() - t.start;
}

/* rel. RMSE over 4x4 blocks of one pass's RGB (img and ref in the pass's channel layout) */
static double pass_error(const float *img, const float *ref, int pass, int w, int h)
{
    double e = NAN;
    int ch = vsd_pass_channels((vsd_pass)pass);
    if (!img || !ref || vsd_block_rel_rmse(img, ref, w, h, 3, ch, BLOCK, &e, NULL, 0)) return NAN;
    return e;
}

static double block_error(const vsd_framebuffer *a, const float *ref, int pass, int w, int h)
{
    return pass_error(a->pass[pass], ref, pass, w, h);
}

/* ---- the converged reference ----------------------------------------------------------- */

typedef struct reference {
    float *pass[VSD_PASS_COUNT];   /* Combined RGBA and VolumeDir RGB are read */
    double noise;                  /* expected rel. RMSE of the reference's Combined */
} reference;

static unsigned long long file_fnv(const char *path)
{
    FILE *f = fopen(path, "rb");
    unsigned long long h = 1469598103934665603ULL;
    int c;
    if (!f) return 0;
    while ((c = fgetc(f)) != EOF) h = (h ^ (unsigned char)c) * 1099511628211ULL;
    fclose(f);
    return h;
}

/* Combined, VolumeDir and VolumeInd of a multilayer EXR (vsd's or Blender's names) at w x h;
 * want_noise: a cached reference, which carries its noise in the header. */
static int read_reference(const char *exr, int w, int h, int want_noise, reference *ref)
{
    static const struct { int pass, channels; const char *name; } passes[] = {
        {VSD_PASS_COMBINED, 4, "Combined"}, {VSD_PASS_VOLUME_DIR, 3, "VolumeDir"}, {VSD_PASS_VOLUME_IND, 3, "VolumeInd"}};
    static const char rgba[] = "RGBA";
    vsd_exr_image *img = NULL;
    char err[512], noise[64], name[64];
    int c, i, k, ok;
    if (vsd_exr_read(exr, &img, err, sizeof err) != VSD_OK) return 0;
    ok = img->width == w && img->height == h &&
         (!want_noise || vsd_exr_read_attr(exr, "vsd/bench_ref_noise", noise, sizeof noise, err, sizeof err) == VSD_OK);
    for (k = 0; k < 3 && ok; k++) {
        float *dst = ref->pass[passes[k].pass] = malloc(sizeof(float) * passes[k].channels * (size_t)w * h);
        ok = dst != NULL;
        for (c = 0; c < passes[k].channels && ok; c++) {
            const float *p;
            snprintf(name, sizeof name, "ViewLayer.%s.%c", passes[k].name, rgba[c]);
            if (!(p = vsd_exr_channel(img, name))) ok = 0;
            for (i = 0; ok && i < w * h; i++) dst[passes[k].channels * i + c] = p[i];
        }
    }
    if (ok && want_noise) ref->noise = atof(noise);
    vsd_exr_image_destroy(img);
    return ok;
}

static int get_reference(const tte_opts *o, const char *scene, reference *ref)
{
    char path[1024], exr[1200], noise[64], err[1024];
    vsd_framebuffer *half[2] = {NULL, NULL};
    vsd_render_stats st;
    vsd_scene sc;
    int i, p, ok = 1, w = o->eval_w, h = o->eval_h, n = (o->ref_spp + 1) / 2;
    memset(ref, 0, sizeof *ref);
    snprintf(path, sizeof path, "%s/scenes/%s.json", o->data, scene);
    mkdir(o->cache, 0755);
    snprintf(exr, sizeof exr, "%s/tte_%s_%dx%d_%dspp_%016llx.exr", o->cache, scene, w, h, 2 * n, file_fnv(path));
    if (read_reference(exr, w, h, 1, ref)) return 1;
    fprintf(stderr, "[%s] converged reference: 2 x %d spp at %dx%d -> %s\n", scene, n, w, h, exr);
    for (i = 0; i < 2 && ok; i++) {
        vsd_renderer *r = NULL;
        tte_opts unlimited = *o;
        unlimited.time_limit = 1e30;
        ok = load(o, scene, "reference", w, h, n, 1001 + i, NULL, &sc) &&
             render_timed(&unlimited, &sc, &r, sc.frames.start, &half[i], &st) >= 0;
        vsd_renderer_destroy(r);
    }
    if (ok) {
        vsd_exr_attr attr;
        vsd_exr_write_options wo;
        ref->noise = 0.5 * block_error(half[0], half[1]->pass[VSD_PASS_COMBINED], VSD_PASS_COMBINED, w, h);
        for (p = 0; p < VSD_PASS_COUNT; p++) {
            size_t k, cnt = (size_t)w * h * vsd_pass_channels((vsd_pass)p);
            for (k = 0; k < cnt; k++) {
                float a = half[0]->pass[p][k], b = half[1]->pass[p][k];
                half[0]->pass[p][k] = p == VSD_PASS_DEPTH ? (a >= VSD_DEPTH_EMPTY ? b : b >= VSD_DEPTH_EMPTY ? a : 0.5f * (a + b))
                                                          : 0.5f * (a + b);
            }
        }
        snprintf(noise, sizeof noise, "%.6g", ref->noise);
        attr.name = "vsd/bench_ref_noise";
        attr.value = noise;
        memset(&wo, 0, sizeof wo);
        wo.attrs = &attr;
        wo.attr_count = 1;
        if (vsd_exr_write(exr, half[0], &wo, err, sizeof err) != VSD_OK) fprintf(stderr, "bench_tte: %s\n", err);
        ok = read_reference(exr, w, h, 1, ref);
    }
    vsd_framebuffer_destroy(half[0]);
    vsd_framebuffer_destroy(half[1]);
    return ok;
}

static void free_reference(reference *ref)
{
    int p;
    for (p = 0; p < VSD_PASS_COUNT; p++) free(ref->pass[p]);
}

/* ---- one method on one scene ----------------------------------------------------------- */

typedef struct row {
    int spp;
    double cold, camera, lighting, frame, err_comb, err_vdir, err_vind;
} row;


static void measure_method(const tte_opts *o, const char *scene, const char *method, const reference *ref, row *out)
{
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    vsd_render_stats st;
    double base[16];
    int f2;
    memset(out, 0, sizeof *out);
    out->frame = out->err_comb = out->err_vdir = NAN;
    if (!load(o, scene, method, o->width, o->height, 1, 1, NULL, &sc)) return;
    memcpy(base, sc.camera.matrix, sizeof base);
    out->cold = render_timed(o, &sc, &r, sc.frames.start, &fb, &st);
    out->spp = st.samples;
    if (out->cold >= 0) {
        bench_orbit_camera(&sc, base, 10.0 * 3.14159265358979 / 180.0);
        out->camera = render_timed(o, &sc, &r, sc.frames.start, &fb, &st);
        sc.environment.rotation_z += 0.5f;
        out->lighting = render_timed(o, &sc, &r, sc.frames.start, &fb, &st);
        f2 = bench_next_frame(&sc, sc.frames.start);
        out->frame = f2 ? render_timed(o, &sc, &r, f2, &fb, &st) : NAN;
    } else {
        out->camera = out->lighting = -1;
    }
    vsd_renderer_destroy(r);
    r = NULL;
    /* the error at the evaluation film, the scene as it is */
    if (load(o, scene, method, o->eval_w, o->eval_h, 1, 1, NULL, &sc) &&
        render_timed(o, &sc, &r, sc.frames.start, &fb, &st) >= 0) {
        out->err_comb = block_error(fb, ref->pass[VSD_PASS_COMBINED], VSD_PASS_COMBINED, o->eval_w, o->eval_h);
        out->err_vdir = block_error(fb, ref->pass[VSD_PASS_VOLUME_DIR], VSD_PASS_VOLUME_DIR, o->eval_w, o->eval_h);
        out->err_vind = block_error(fb, ref->pass[VSD_PASS_VOLUME_IND], VSD_PASS_VOLUME_IND, o->eval_w, o->eval_h);
        if (st.method_info[0]) fprintf(stderr, "[%s] %s: %s\n", scene, method, st.method_info);
    }
    vsd_renderer_destroy(r);
    vsd_framebuffer_destroy(fb);
}

static void measure_reference(const tte_opts *o, const char *scene, int spp, const char *cache, const reference *ref,
                              row *out)
{
    char set[96];
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    vsd_render_stats st;
    double scale = ((double)o->width * o->height) / ((double)o->eval_w * o->eval_h);
    memset(out, 0, sizeof *out);
    out->spp = spp;
    out->cold = out->camera = out->lighting = out->frame = out->err_comb = out->err_vdir = out->err_vind = NAN;
    snprintf(set, sizeof set, "render.options.cache=%s", cache);
    if (load(o, scene, "reference", o->eval_w, o->eval_h, spp, 7, set, &sc) &&
        render_timed(o, &sc, &r, sc.frames.start, &fb, &st) >= 0) {
        /* a path tracer redoes everything for every edit: each is one full render */
        out->camera = out->lighting = out->frame = st.render_seconds * scale;
        out->cold = (st.load_seconds + st.prepare_seconds) + out->camera;
        out->err_comb = block_error(fb, ref->pass[VSD_PASS_COMBINED], VSD_PASS_COMBINED, o->eval_w, o->eval_h);
        out->err_vdir = block_error(fb, ref->pass[VSD_PASS_VOLUME_DIR], VSD_PASS_VOLUME_DIR, o->eval_w, o->eval_h);
        out->err_vind = block_error(fb, ref->pass[VSD_PASS_VOLUME_IND], VSD_PASS_VOLUME_IND, o->eval_w, o->eval_h);
    } else {
        out->camera = out->lighting = out->frame = out->cold = -1.0;   /* past the limit: "> limit" */
    }
    vsd_renderer_destroy(r);
    vsd_framebuffer_destroy(fb);
}

/* Cycles at the evaluation film with spp samples: errors against the converged reference,
 * its path-tracing time scaled to the timing film (as the reference's), cold = sync + that. */
static void measure_cycles(const tte_opts *o, const char *scene, int spp, const reference *ref, row *out)
{
    char path[1024], exr[1200], log[1200], tjson[1200];
    bench_cycles_result cr;
    reference img;
    double scale = ((double)o->width * o->height) / ((double)o->eval_w * o->eval_h);
    memset(out, 0, sizeof *out);
    memset(&img, 0, sizeof img);
    out->spp = spp;
    out->cold = out->camera = out->lighting = out->frame = out->err_comb = out->err_vdir = out->err_vind = NAN;
    snprintf(path, sizeof path, "%s/scenes/%s.json", o->data, scene);
    snprintf(exr, sizeof exr, "%s/tte_%s_cycles_%dspp.exr", o->cache, scene, spp);
    snprintf(log, sizeof log, "%s/tte_%s_cycles_%dspp.log", o->cache, scene, spp);
    snprintf(tjson, sizeof tjson, "%s/tte_%s_cycles_%dspp.json", o->cache, scene, spp);
    fprintf(stderr, "[%s] Cycles: %dx%d, %d spp (log %s)\n", scene, o->eval_w, o->eval_h, spp, log);
    bench_run_cycles(o->blender, o->cycles_script, path, exr, log, tjson, o->eval_w, o->eval_h, spp, 7, &cr);
    if (!cr.ok || cr.samples != spp || !read_reference(exr, o->eval_w, o->eval_h, 0, &img)) {
        fprintf(stderr, "[%s] Cycles: no usable image (samples %d), see %s\n", scene, cr.samples, log);
        free_reference(&img);
        return;
    }
    out->camera = out->lighting = out->frame = cr.render * scale;
    out->cold = cr.sync + out->camera;
    out->err_comb = pass_error(img.pass[VSD_PASS_COMBINED], ref->pass[VSD_PASS_COMBINED], VSD_PASS_COMBINED, o->eval_w, o->eval_h);
    out->err_vdir = pass_error(img.pass[VSD_PASS_VOLUME_DIR], ref->pass[VSD_PASS_VOLUME_DIR], VSD_PASS_VOLUME_DIR, o->eval_w, o->eval_h);
    out->err_vind = pass_error(img.pass[VSD_PASS_VOLUME_IND], ref->pass[VSD_PASS_VOLUME_IND], VSD_PASS_VOLUME_IND, o->eval_w, o->eval_h);
    free_reference(&img);
}

static void cell(char *buf, size_t len, double s, double limit)
{
    if (isnan(s)) snprintf(buf, len, "n/a");
    else if (s < 0) snprintf(buf, len, "> %.0f", limit);
    else if (s < 10) snprintf(buf, len, "%.3f", s);
    else snprintf(buf, len, "%.1f", s);
}

static void print_row(const tte_opts *o, FILE *csv, const char *scene, const char *method, const row *rw, int scaled)
{
    char c[4][32];
    cell(c[0], 32, rw->cold, o->time_limit);
    cell(c[1], 32, rw->camera, o->time_limit);
    cell(c[2], 32, rw->lighting, o->time_limit);
    cell(c[3], 32, rw->frame, o->time_limit);
    printf("| %s | %s | %d | %s | %s%s | %s | %s | %.2f%% | %.2f%% | %.2f%% |\n", scene, method, rw->spp, c[0], c[1],
           scaled ? " (scaled)" : "", c[2], c[3], 100.0 * rw->err_comb, 100.0 * rw->err_vdir, 100.0 * rw->err_vind);
    fflush(stdout);
    if (csv) {
        fprintf(csv, "%s,%s,%d,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n", scene, method, rw->spp, rw->cold, rw->camera,
                rw->lighting, rw->frame, rw->err_comb, rw->err_vdir, rw->err_vind);
        fflush(csv);
    }
}

static int parse(int argc, char **argv, tte_opts *o)
{
    int i;
    const char *env = getenv("VSD_SHARED_DATA");
    o->data = env && *env ? env : VSD_BENCH_DATA;
    o->scenes = "smoke128_forest,cloud256_sunset";
    o->methods = "raymarch,shgrid,constellation";
    o->cache = VSD_BENCH_CACHE;
    o->spp_list = "16,64,256,1024";
    o->ref_caches = "none";
    o->cycles_spp = "";
    o->blender = VSD_BENCH_BLENDER;
    o->cycles_script = VSD_BENCH_CYCLES_SCRIPT;
    o->width = 1280;
    o->height = 720;
    o->eval_w = 320;
    o->eval_h = 180;
    o->ref_spp = 4096;
    o->time_limit = 600;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) return fprintf(stderr, "bench_tte: %s needs a value\n", a), 0;
        if (!strcmp(a, "--data")) o->data = v;
        else if (!strcmp(a, "--scenes")) o->scenes = v;
        else if (!strcmp(a, "--methods")) o->methods = v;
        else if (!strcmp(a, "--cache")) o->cache = v;
        else if (!strcmp(a, "--csv")) o->csv = v;
        else if (!strcmp(a, "--spp-list")) o->spp_list = v;
        else if (!strcmp(a, "--reference-caches")) o->ref_caches = v;
        else if (!strcmp(a, "--cycles-spp")) o->cycles_spp = v;
        else if (!strcmp(a, "--blender")) o->blender = v;
        else if (!strcmp(a, "--width")) o->width = atoi(v);
        else if (!strcmp(a, "--height")) o->height = atoi(v);
        else if (!strcmp(a, "--eval-width")) o->eval_w = atoi(v);
        else if (!strcmp(a, "--eval-height")) o->eval_h = atoi(v);
        else if (!strcmp(a, "--ref-spp")) o->ref_spp = atoi(v);
        else if (!strcmp(a, "--threads")) o->threads = atoi(v);
        else if (!strcmp(a, "--time-limit")) o->time_limit = atof(v);
        else if (!strcmp(a, "--set") && o->set_count < MAX_SETS) o->sets[o->set_count++] = v;
        else return fprintf(stderr, "bench_tte: unknown option %s\n", a), 0;
        i++;
    }
    if (o->width < 16 || o->height < 16 || o->eval_w < 16 || o->eval_h < 16 || o->ref_spp < 2 || !(o->time_limit > 0))
        return fprintf(stderr, "bench_tte: bad sizes\n"), 0;
    return 1;
}

int main(int argc, char **argv)
{
    tte_opts o;
    char scenes[1024], methods[512], spps[256], caches[256], *sp, *mp, *pp, *cp, *sv, *mv, *pv, *cv;
    char cycles[256];
    FILE *csv = NULL;
    memset(&o, 0, sizeof o);
    if (!parse(argc, argv, &o)) return 2;
    if (o.csv && !(csv = fopen(o.csv, "w"))) return fprintf(stderr, "bench_tte: cannot write %s\n", o.csv), 1;
    if (csv) fprintf(csv, "scene,method,spp,cold,camera,lighting,frame,err_combined,err_voldir,err_volind\n");
    printf("timing film %dx%d, error at %dx%d against a %d-spp reference (4x4 blocks), %d threads (0 = all), "
           "vsd %s\n\n",
           o.width, o.height, o.eval_w, o.eval_h, o.ref_spp, o.threads, vsd_version());
    printf("| scene | method | spp | cold s | camera change s | lighting change s | new frame s | Combined err | "
           "VolumeDir err | VolumeInd err |\n|---|---|---|---|---|---|---|---|---|---|\n");
    snprintf(scenes, sizeof scenes, "%s", o.scenes);
    for (sv = strtok_r(scenes, ",", &sp); sv; sv = strtok_r(NULL, ",", &sp)) {
        reference ref;
        row rw;
        if (!get_reference(&o, sv, &ref)) {
            printf("| %s | - | - | no reference |\n", sv);
            continue;
        }
        fprintf(stderr, "[%s] reference noise %.3f%%\n", sv, 100.0 * ref.noise);
        snprintf(caches, sizeof caches, "%s", o.ref_caches);
        for (cv = strtok_r(caches, ",", &cp); cv; cv = strtok_r(NULL, ",", &cp)) {
            char label[64];
            snprintf(label, sizeof label, strcmp(cv, "none") ? "reference+%s" : "reference", cv);
            snprintf(spps, sizeof spps, "%s", o.spp_list);
            for (pv = strtok_r(spps, ",", &pp); pv; pv = strtok_r(NULL, ",", &pp)) {
                measure_reference(&o, sv, atoi(pv), cv, &ref, &rw);
                print_row(&o, csv, sv, label, &rw, 1);
            }
        }
        snprintf(cycles, sizeof cycles, "%s", o.cycles_spp);
        for (pv = strtok_r(cycles, ",", &pp); pv; pv = strtok_r(NULL, ",", &pp)) {
            measure_cycles(&o, sv, atoi(pv), &ref, &rw);
            print_row(&o, csv, sv, "cycles", &rw, 1);
        }
        snprintf(methods, sizeof methods, "%s", o.methods);
        for (mv = strtok_r(methods, ",", &mp); mv; mv = strtok_r(NULL, ",", &mp)) {
            measure_method(&o, sv, mv, &ref, &rw);
            print_row(&o, csv, sv, mv, &rw, 0);
        }
        printf("| %s | (reference noise) | %d | | | | | %.2f%% | |\n", sv, o.ref_spp, 100.0 * ref.noise);
        free_reference(&ref);
    }
    if (csv) fclose(csv);
    return 0;
}
