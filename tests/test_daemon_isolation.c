/* The daemon's isolated loader (issue 16 item 3). Usage: test_daemon_isolation VSD
 *
 * Proves, through the loader API (linked in, its child being the real `vsd`):
 *   - an isolated load gives the same volume / map, byte for byte, as an in-process one;
 *   - every error keeps its code and message: a missing grid, files of the wrong kind and
 *     40 byte-mutated copies of a smoke64 frame give identical results both ways;
 *   - the cost: median load time of smoke64 and smoke128 frames, isolated vs in-process.
 * and through real `vsd serve` processes, with the child's test hook
 * (VSD_TEST_LOADER_CRASH) aimed at three uploaded frames:
 *   - a decoder that crashes, hangs or allocates without bound costs that client an ERROR
 *     naming the blob and what happened (signal, the --loader-seconds deadline, the
 *     --loader-mb limit holding), and the daemon renders the next frame correctly;
 *   - isolated and --loader inprocess daemons render the same pixels as an in-process
 *     render; the in-process daemon ignores the hook (only the child reads it). */
#define _GNU_SOURCE
#include "test_common.h"
#include "test_daemon_proc.h"
#include "daemon.h"
#include "vsd_client.h"
#include "vsd/render.h"
#include <cjson/cJSON.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static const char *g_vsd;
static char g_dir[1024];
/* the loader API's configuration, as `vsd serve` would set it, and the loader made from it */
static vsdd_config g_cfg;
static vsdd_loader *g_loader;

/* ---- the loader API, both modes ------------------------------------------------------------ */

static void set_mode(int mode) { g_cfg.loader = mode; } /* the loader reads it on every decode */

static int load_volume(int mode, const char *src, const char *path, const char *grid, vsd_volume **v, vsdd_err *e)
{
    set_mode(mode);
    memset(e, 0, sizeof *e);
    return vsdd_load_volume(g_loader, src, path, grid, -1, v, e);
}

static int same_volume(const vsd_volume *a, const vsd_volume *b)
{
    size_t cells = (size_t)a->brick_dims[0] * a->brick_dims[1] * a->brick_dims[2];
    vsd_volume ha = *a, hb = *b;
    ha.brick_slots = hb.brick_slots = NULL;
    ha.voxels = hb.voxels = NULL;
    ha.brick_min = hb.brick_min = ha.brick_max = hb.brick_max = NULL;
    return memcmp(&ha, &hb, sizeof ha) == 0 &&
           (!cells || (memcmp(a->brick_slots, b->brick_slots, cells * 4) == 0 &&
                       memcmp(a->brick_min, b->brick_min, cells * 4) == 0 &&
                       memcmp(a->brick_max, b->brick_max, cells * 4) == 0)) &&
           (!a->brick_count || memcmp(a->voxels, b->voxels, (size_t)a->brick_count * VSD_BRICK_VOXELS * 4) == 0);
}

/* Both modes on one input: the same volume, or the same error. Returns 1 when they agree. */
static int agree_volume(const char *src, const char *path, const char *grid, vsdd_err *iso_err)
{
    vsd_volume *a = NULL, *b = NULL;
    vsdd_err ea, eb;
    int ra = load_volume(VSDD_LOADER_ISOLATED, src, path, grid, &a, &ea);
    int rb = load_volume(VSDD_LOADER_INPROCESS, src, path, grid, &b, &eb);
    int ok = ra == rb && (ra ? strcmp(ea.code, eb.code) == 0 && strcmp(ea.msg, eb.msg) == 0 : same_volume(a, b));
    if (!ok)
        fprintf(stderr, "%s: isolated rc %d %s '%s' / in-process rc %d %s '%s'\n", path, ra, ra ? ea.code : "",
                ra ? ea.msg : "", rb, rb ? eb.code : "", rb ? eb.msg : "");
    if (iso_err) *iso_err = ea;
    vsd_volume_destroy(a);
    vsd_volume_destroy(b);
    return ok;
}

static int agree_env(const char *src, const char *path)
{
    vsd_env *a = NULL, *b = NULL;
    vsdd_err ea = {0}, eb = {0};
    int ra, rb, ok;
    set_mode(VSDD_LOADER_ISOLATED);
    ra = vsdd_load_env(g_loader, src, path, "", &a, &ea);
    set_mode(VSDD_LOADER_INPROCESS);
    rb = vsdd_load_env(g_loader, src, path, "", &b, &eb);
    ok = ra == rb && (ra ? strcmp(ea.code, eb.code) == 0 && strcmp(ea.msg, eb.msg) == 0
                         : a->width == b->width && a->height == b->height && strcmp(a->file, b->file) == 0 &&
                               memcmp(a->rgb, b->rgb, (size_t)a->width * a->height * 12) == 0);
    if (!ok) fprintf(stderr, "%s: isolated rc %d '%s' / in-process rc %d '%s'\n", path, ra, ea.msg, rb, eb.msg);
    vsd_env_destroy(a);
    vsd_env_destroy(b);
    return ok;
}

static void test_same_results(void)
{
    static const char *const frames[] = {"smoke64/fluid_data_0001.vdb", "smoke128/fluid_data_0030.vdb"};
    char path[1200], mpath[1200];
    vsdd_err e;
    unsigned long long rng = 16031ull;
    unsigned char *orig;
    long size = 0;
    int i, agreed = 0, errors = 0;
    for (i = 0; i < 2; i++) {
        snprintf(path, sizeof path, "%s", test_data(frames[i]));
        CHECK_MSG(agree_volume(path, path, "density", NULL), "%s density", frames[i]);
        CHECK_MSG(agree_volume(path, path, "", NULL), "%s first float grid", frames[i]);
    }
    snprintf(path, sizeof path, "%s", test_data("env/sunset.exr"));
    CHECK_MSG(agree_env(path, path), "sunset.exr");
    snprintf(path, sizeof path, "%s", test_data("env/interior.hdr"));
    CHECK_MSG(agree_env(path, path), "interior.hdr");
    /* errors: a missing grid names the grid; wrong kinds of file; a blob name in messages */
    snprintf(path, sizeof path, "%s", test_data(frames[0]));
    CHECK(agree_volume("blob:0123456789abcdef0123456789abcdef", path, "nope", &e));
    CHECK_CONTAINS(e.msg, "'nope'");
    CHECK_CONTAINS(e.msg, "blob:0123456789abcdef0123456789abcdef: ");
    CHECK(e.msg[0] && !strstr(e.msg, path)); /* the daemon's private file stays private */
    CHECK(agree_volume(path, test_data("env/sunset.exr"), "density", NULL));
    CHECK(agree_env(path, path));
    /* byte-mutated copies (the mutation experiment of test_hostile_vdb, smaller) */
    orig = test_read_file(path, &size);
    CHECK(orig != NULL);
    for (i = 0; orig && i < 40; i++) {
        unsigned char *m = malloc((size_t)size);
        int k, n = 1 + (int)(test_urand(&rng) * 8);
        FILE *f;
        memcpy(m, orig, (size_t)size);
        for (k = 0; k < n; k++) m[8 + (long)(test_urand(&rng) * (double)(size - 8))] = (unsigned char)(test_urand(&rng) * 256);
        snprintf(mpath, sizeof mpath, "%s/mutant%02d.vdb", g_dir, i);
        f = fopen(mpath, "wb");
        if (f) {
            fwrite(m, 1, (size_t)size, f);
            fclose(f);
        }
        free(m);
        if (agree_volume(mpath, mpath, "density", &e)) agreed++;
        if (e.code) errors++;
        unlink(mpath);
    }
    free(orig);
    printf("mutated copies: %d of 40 agree (%d load errors)\n", agreed, errors);
    CHECK(agreed == 40);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median load time of `frames` (each loaded `rounds` times, modes interleaved). */
static void measure(const char *label, const char *const *frames, int nframes, int rounds)
{
    double t[2][256];
    int n = 0, r, f, mode;
    for (r = 0; r < rounds; r++)
        for (f = 0; f < nframes && n < 256; f++, n++)
            for (mode = 0; mode < 2; mode++) {
                vsd_volume *v = NULL;
                vsdd_err e;
                double t0 = vsd_clock_seconds();
                int rc = load_volume(mode, frames[f], frames[f], "density", &v, &e);
                t[mode][n] = vsd_clock_seconds() - t0;
                CHECK_MSG(rc == 0, "%s: %s", frames[f], e.msg);
                vsd_volume_destroy(v);
            }
    qsort(t[0], (size_t)n, sizeof(double), cmp_double);
    qsort(t[1], (size_t)n, sizeof(double), cmp_double);
    printf("| %s | %d | %.1f ms | %.1f ms | %+.1f ms |\n", label, n, 1e3 * t[1][n / 2], 1e3 * t[0][n / 2],
           1e3 * (t[0][n / 2] - t[1][n / 2]));
}

static void test_cost(void)
{
    char p64[6][1100], p128[3][1100];
    const char *f64[6], *f128[3];
    int i;
    for (i = 0; i < 6; i++) {
        snprintf(p64[i], sizeof p64[i], "%s/fluid_data_%04d.vdb", test_data("smoke64"), i + 1);
        f64[i] = p64[i];
    }
    for (i = 0; i < 3; i++) {
        snprintf(p128[i], sizeof p128[i], "%s/fluid_data_%04d.vdb", test_data("smoke128"), 30 + 15 * i);
        f128[i] = p128[i];
    }
    printf("| frames (density grid) | loads | in-process (median) | isolated (median) | extra per frame |\n"
           "|---|---|---|---|---|\n");
    measure("smoke64 0001-0006", f64, 6, 3);
    measure("smoke128 0030/0045/0060", f128, 3, 4);
}

/* ---- real daemons ---------------------------------------------------------------------- */





/* Upload frame's VDB and sunset.exr, render 32x18 raymarch; the EXR's pixels are compared
 * with `expect` when given. Returns 0 rendered (and equal), else -1 with the error. */
static int render_frame(const char *sock, const char *vdb, const vsd_framebuffer *expect, char *code, char *err,
                        size_t errlen)
{
    vsdc *c = NULL;
    vsdc_result res;
    vsdc_render_request rq;
    char vb[128], eb[128], scene[2048];
    int rc = -1;
    code[0] = '\0';
    if (vsdc_connect(sock, NULL, &c, err, errlen)) return -1;
    if (vsdc_upload_file(c, vdb, vb, sizeof vb, NULL, err, errlen) ||
        vsdc_upload_file(c, test_data("env/sunset.exr"), eb, sizeof eb, NULL, err, errlen)) {
        vsdc_close(c);
        return -1;
    }
    snprintf(scene, sizeof scene,
             "{\"version\":1,\"volume\":{\"file\":\"%s\",\"grid\":\"density\"},\"medium\":{\"density\":8},"
             "\"environment\":{\"file\":\"%s\"},"
             "\"camera\":{\"position\":[1,-3.9745,1.8771],\"look_at\":[1,1,1],\"up\":[0,0,1],\"fov\":0.7},"
             "\"film\":{\"width\":32,\"height\":18},\"render\":{\"method\":\"raymarch\",\"options\":{\"lights\":8}}}",
             vb, eb);
    memset(&rq, 0, sizeof rq);
    rq.scene_json = scene;
    if (vsdc_render(c, &rq, &res, err, errlen) == 0) {
        rc = 0;
        if (expect) {
            char path[1200];
            FILE *f;
            vsd_exr_image *img = NULL;
            snprintf(path, sizeof path, "%s/result.exr", g_dir);
            f = fopen(path, "wb");
            if (f) {
                fwrite(res.exr, 1, res.exr_len, f);
                fclose(f);
            }
            if (vsd_exr_read(path, &img, err, errlen) || img->width != expect->width) rc = -1;
            else {
                const float *r = vsd_exr_channel(img, "ViewLayer.Combined.R");
                long i, n = (long)expect->width * expect->height;
                for (i = 0; r && i < n; i++)
                    if (memcmp(&r[i], &expect->pass[VSD_PASS_COMBINED][i * 4], 4) != 0) break;
                if (!r || i < n) {
                    snprintf(err, errlen, "the image differs from the in-process render at pixel %ld", i);
                    rc = -1;
                }
            }
            vsd_exr_image_destroy(img);
        }
        vsdc_result_free(&res);
    } else {
        snprintf(code, 64, "%s", vsdc_error_code(c));
    }
    vsdc_close(c);
    return rc;
}

static vsd_framebuffer *render_local(const char *vdb)
{
    char json[2048], err[1024];
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    snprintf(json, sizeof json,
             "{\"version\":1,\"volume\":{\"file\":\"%s\",\"grid\":\"density\"},\"medium\":{\"density\":8},"
             "\"environment\":{\"file\":\"%s\"},"
             "\"camera\":{\"position\":[1,-3.9745,1.8771],\"look_at\":[1,1,1],\"up\":[0,0,1],\"fov\":0.7},"
             "\"film\":{\"width\":32,\"height\":18},\"render\":{\"method\":\"raymarch\",\"options\":{\"lights\":8}}}",
             vdb, test_data("env/sunset.exr"));
    if (vsd_scene_parse(json, "", NULL, 0, &sc, err, sizeof err) ||
        vsd_renderer_create(&sc, NULL, &r, err, sizeof err) || vsd_renderer_render(r, 1, &fb, NULL, err, sizeof err)) {
        fprintf(stderr, "local render: %s\n", err);
        vsd_framebuffer_destroy(fb);
        fb = NULL;
    }
    vsd_renderer_destroy(r);
    return fb;
}

static void test_daemons(void)
{
    char vdb[5][1100], hash[5][80], hook[512], err[2048], code[64];
    const char *iso_args[] = {"--loader-seconds", "2", "--loader-mb", "512", NULL};
    const char *inp_args[] = {"--loader", "inprocess", NULL};
    test_daemon iso = {0}, inp = {0};
    vsd_framebuffer *expect;
    double t0;
    int i;
    for (i = 1; i <= 4; i++) {
        snprintf(vdb[i], sizeof vdb[i], "%s/fluid_data_%04d.vdb", test_data("smoke64"), i);
        vsd_hash_file(VSD_HASH_XXH3_128, vdb[i], hash[i], NULL, err, sizeof err);
    }
    /* frames 2, 3 and 4 make the child crash, hang and allocate without bound */
    snprintf(hook, sizeof hook, "segv:%s,hang:%s,oom:%s", hash[2], hash[3], hash[4]);
    expect = render_local(vdb[1]);
    CHECK(expect != NULL);
    if (!expect || test_daemon_start(&iso, g_vsd, g_dir, "iso", "VSD_TEST_LOADER_CRASH", hook, iso_args) ||
        test_daemon_start(&inp, g_vsd, g_dir, "inp", "VSD_TEST_LOADER_CRASH", hook, inp_args)) {
        CHECK(0);
        return;
    }
    CHECK_MSG(render_frame(iso.sock, vdb[1], expect, code, err, sizeof err) == 0, "isolated: %s", err);
    CHECK_MSG(render_frame(inp.sock, vdb[1], expect, code, err, sizeof err) == 0, "in-process: %s", err);

    CHECK(render_frame(iso.sock, vdb[2], NULL, code, err, sizeof err) != 0);
    printf("crash: %s: %s\n", code, err);
    CHECK(strcmp(code, "bad_input") == 0);
    CHECK_CONTAINS(err, "the decoder crashed (signal 11");
    CHECK_CONTAINS(err, hash[2]);
    CHECK(test_daemon_alive(&iso));
    CHECK_MSG(render_frame(iso.sock, vdb[1], expect, code, err, sizeof err) == 0, "after the crash: %s", err);

    t0 = vsd_clock_seconds();
    CHECK(render_frame(iso.sock, vdb[3], NULL, code, err, sizeof err) != 0);
    t0 = vsd_clock_seconds() - t0;
    printf("hang (%.2fs): %s: %s\n", t0, code, err);
    CHECK(strcmp(code, "limit") == 0);
    CHECK_CONTAINS(err, "the decoder ran past 2 s");
    CHECK_MSG(t0 < 10, "the hang took %.1fs to report", t0);

    CHECK(render_frame(iso.sock, vdb[4], NULL, code, err, sizeof err) != 0);
    printf("oom: %s: %s\n", code, err);
    CHECK(strcmp(code, "bad_input") == 0);
    CHECK_CONTAINS(err, "out of memory");
    {
        const char *p = strstr(err, "test hook: ");
        long mib = p ? strtol(p + 11, NULL, 10) : -1;
        CHECK_MSG(mib >= 0 && mib < 512, "the child allocated %ld MiB under --loader-mb 512", mib);
    }
    CHECK(test_daemon_alive(&iso));
    CHECK_MSG(render_frame(iso.sock, vdb[1], expect, code, err, sizeof err) == 0, "after all three: %s", err);

    /* in-process: the hook is the child's only, so frame 2 renders */
    CHECK_MSG(render_frame(inp.sock, vdb[2], NULL, code, err, sizeof err) == 0, "in-process frame 2: %s", err);
    CHECK(test_daemon_stop(&iso) == 0);
    CHECK(test_daemon_stop(&inp) == 0);
    vsd_framebuffer_destroy(expect);
}

int main(int argc, char **argv)
{
    char cmd[1200];
    if (argc < 2) {
        fprintf(stderr, "usage: test_daemon_isolation VSD\n");
        return 2;
    }
    g_vsd = argv[1];
    snprintf(g_dir, sizeof g_dir, "%s", test_tmp("daemon_isolation"));
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", g_dir, g_dir);
    if (system(cmd) != 0) return 1;
    if (access(test_data("smoke128/fluid_data_0030.vdb"), R_OK) != 0) {
        fprintf(stderr, "no shared data: skipped\n");
        return 77;
    }
    vsdd_log_set_level(VSDD_LOG_ERROR);
    g_cfg.max_voxels = 1000000000ull;
    g_cfg.max_pixels = 67108864ull;
    g_cfg.loader_bytes = 4096ull << 20;
    g_cfg.loader_seconds = 60;
    snprintf(g_cfg.loader_exe, sizeof g_cfg.loader_exe, "%s", g_vsd);
    g_loader = vsdd_loader_new(&g_cfg);
    if (!g_loader) return 1;
    test_same_results();
    test_cost();
    test_daemons();
    vsdd_loader_free(g_loader);
    return test_finish("test_daemon_isolation");
}
