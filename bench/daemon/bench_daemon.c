/* vsd_bench_daemon — the daemon measurements of issue 5 ("Measure"; results in
 * docs/daemon-bench.md). Starts its own `vsd serve` on a temporary Unix socket, then prints a
 * markdown table of:
 *
 *  1. round-trip overhead: a small raymarch render (32x18, lights=8, smoke64 frame 1 and
 *     studio.exr uploaded once as blobs) through the daemon with every input cached, against
 *     the same render in-process through the library (renderer kept across renders);
 *     the two interleaved, medians over --repeat runs (default 15). Target: overhead < 5 ms
 *     plus the EXR transfer (counted here as the daemon's EXR encode time).
 *  2. blob upload throughput: PUT of a 64 MiB and a 256 MiB random blob (first PUT: hashed,
 *     verified and stored by the daemon; second PUT of the same blob: read and dropped).
 *     Target: >= 500 MB/s.
 *  3. camera change on a cached shgrid preparation: smoke64 frame 24, shgrid, 320x180, once
 *     cold (record grid included), then from --repeat other camera positions (warm; median);
 *     the ratio and RESULT's cache flags.
 *
 * Usage: vsd_bench_daemon [--vsd PATH] [--repeat N]   (stop: SIGTERM to the daemon at the end) */
#define _GNU_SOURCE
#include "vsd_client.h"
#include "vsd_proto.h"
#include "vsd/clock.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include <cjson/cJSON.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#ifndef VSD_EXECUTABLE
#define VSD_EXECUTABLE "vsd"
#endif
#ifndef VSD_SHARED_DATA
#define VSD_SHARED_DATA "../shared/data"
#endif

static const char *g_vsd = VSD_EXECUTABLE;
static int g_repeat = 15;
static char g_dir[256], g_sock[300], g_ready[300], g_log[300];
static pid_t g_pid;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    if (n <= 0) return 0;
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* ---- the daemon ----------------------------------------------------------------------- */
static int start_daemon(void)
{
    int i;
    snprintf(g_dir, sizeof g_dir, "/tmp/vsd-dbench-XXXXXX");
    if (!mkdtemp(g_dir)) {
        perror("mkdtemp");
        return -1;
    }
    snprintf(g_sock, sizeof g_sock, "%s/vsd.sock", g_dir);
    snprintf(g_ready, sizeof g_ready, "%s/ready.json", g_dir);
    snprintf(g_log, sizeof g_log, "%s/serve.log", g_dir);
    g_pid = fork();
    if (g_pid < 0) {
        perror("fork");
        return -1;
    }
    if (g_pid == 0) {
        FILE *f = freopen(g_log, "w", stderr);
        (void)f;
        execl(g_vsd, g_vsd, "serve", "--socket", g_sock, "--ready-file", g_ready, "--cache-dir", g_dir,
              "--log-level", "warn", (char *)NULL);
        _exit(127);
    }
    for (i = 0; i < 400; i++) {
        int status;
        if (access(g_ready, F_OK) == 0) return 0;
        if (waitpid(g_pid, &status, WNOHANG) == g_pid) {
            g_pid = 0;
            break;
        }
        usleep(25000);
    }
    fprintf(stderr, "vsd_bench_daemon: `%s serve` did not start (log: %s)\n", g_vsd, g_log);
    return -1;
}

static int stop_daemon(void)
{
    int i, status;
    if (g_pid <= 0) return -1;
    kill(g_pid, SIGTERM);
    for (i = 0; i < 400; i++) {
        if (waitpid(g_pid, &status, WNOHANG) == g_pid) {
            g_pid = 0;
            return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        }
        usleep(25000);
    }
    kill(g_pid, SIGKILL);
    waitpid(g_pid, &status, 0);
    g_pid = 0;
    return -1;
}

static void cleanup_dir(void)
{
    char cmd[400];
    if (!g_dir[0] || strncmp(g_dir, "/tmp/vsd-dbench-", 16) != 0) return;
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    if (system(cmd) != 0) fprintf(stderr, "vsd_bench_daemon: could not remove %s\n", g_dir);
}

/* ---- scenes and results --------------------------------------------------------------- */
static void scene_json(char *out, size_t len, const char *vol, const char *env, double cam_x, int w, int h,
                       const char *render)
{
    snprintf(out, len,
             "{\"version\":1,\"volume\":{\"file\":\"%s\",\"grid\":\"density\"},\"medium\":{\"density\":8},"
             "\"environment\":{\"file\":\"%s\"},"
             "\"camera\":{\"position\":[%.4f,-3.9745,1.8771],\"look_at\":[1,1,1],\"up\":[0,0,1],\"fov\":0.7},"
             "\"film\":{\"width\":%d,\"height\":%d},\"render\":{%s}}",
             vol, env, cam_x, w, h, render);
}
#define RAYMARCH8 "\"method\":\"raymarch\",\"options\":{\"lights\":8}"
#define SHGRID "\"method\":\"shgrid\""

typedef struct timed_result {
    double wall;           /* client side: RENDER sent .. RESULT read */
    double t_queue, t_load, t_prepare, t_render, t_encode, t_total;   /* RESULT timings */
    size_t exr_len;
    char cache[160];       /* RESULT cache flags, e.g. "volume renderer preparation" */
} timed_result;

static double jnum(const cJSON *o, const char *k)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    return cJSON_IsNumber(v) ? v->valuedouble : -1;
}

static int render_remote(vsdc *c, const char *scene, int frame, timed_result *tr)
{
    vsdc_render_request rq;
    vsdc_result res;
    char err[1024];
    double t0;
    int s;
    cJSON *info, *tm, *ca, *it;
    memset(&rq, 0, sizeof rq);
    memset(&res, 0, sizeof res);
    memset(tr, 0, sizeof *tr);
    rq.scene_json = scene;
    rq.frame = frame;
    rq.has_frame = 1;
    t0 = vsd_clock_seconds();
    s = vsdc_render(c, &rq, &res, err, sizeof err);
    tr->wall = vsd_clock_seconds() - t0;
    if (s) {
        fprintf(stderr, "vsd_bench_daemon: render: %s (%s)\n", err, vsdc_error_code(c));
        vsdc_result_free(&res);
        return -1;
    }
    tr->exr_len = res.exr_len;
    info = cJSON_Parse(res.json ? res.json : "{}");
    tm = cJSON_GetObjectItemCaseSensitive(info, "timings");
    tr->t_queue = jnum(tm, "queue");
    tr->t_load = jnum(tm, "load");
    tr->t_prepare = jnum(tm, "prepare");
    tr->t_render = jnum(tm, "render");
    tr->t_encode = jnum(tm, "encode");
    tr->t_total = jnum(tm, "total");
    ca = cJSON_GetObjectItemCaseSensitive(info, "cache");
    cJSON_ArrayForEach(it, ca)
    {
        size_t n = strlen(tr->cache);
        snprintf(tr->cache + n, sizeof tr->cache - n, "%s%s=%s", n ? ", " : "", it->string,
                 cJSON_IsTrue(it) ? "true" : cJSON_IsNull(it) ? "null" : "false");
    }
    cJSON_Delete(info);
    vsdc_result_free(&res);
    return 0;
}

/* ---- 1. round trip against in-process ------------------------------------------------- */
static int bench_overhead(vsdc *c, const char *vol, const char *env)
{
    char vblob[80], eblob[80], scene[4096], err[1024];
    uint64_t sent = 0;
    int i, n = g_repeat;
    double *wall = calloc((size_t)n, sizeof *wall), *loc = calloc((size_t)n, sizeof *loc);
    double *srv = calloc((size_t)n, sizeof *srv), *enc = calloc((size_t)n, sizeof *enc);
    double *rnd = calloc((size_t)n, sizeof *rnd), *dif = calloc((size_t)n, sizeof *dif);
    char local_scene[4096];
    timed_result tr;
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    double m_wall, m_loc, m_srv, m_enc, m_rnd, m_dif;
    size_t exr_len = 0;
    char cache[160] = "";

    if (vsdc_upload_file(c, vol, vblob, sizeof vblob, &sent, err, sizeof err) ||
        vsdc_upload_file(c, env, eblob, sizeof eblob, &sent, err, sizeof err)) {
        fprintf(stderr, "vsd_bench_daemon: upload: %s\n", err);
        return -1;
    }
    scene_json(scene, sizeof scene, vblob, eblob, 1.0, 32, 18, RAYMARCH8);
    if (render_remote(c, scene, 1, &tr)) return -1;   /* warm-up: loads and prepares */

    scene_json(local_scene, sizeof local_scene, vol, env, 1.0, 32, 18, RAYMARCH8);
    if (vsd_scene_parse(local_scene, "", NULL, 0, &sc, err, sizeof err) ||
        vsd_renderer_create(&sc, NULL, &r, err, sizeof err) || vsd_renderer_render(r, 1, &fb, NULL, err, sizeof err)) {
        fprintf(stderr, "vsd_bench_daemon: in-process render: %s\n", err);
        return -1;
    }
    /* interleaved, so that load from other jobs on a shared machine hits both alike */
    for (i = 0; i < n; i++) {
        double t0;
        if (render_remote(c, scene, 1, &tr)) return -1;
        wall[i] = tr.wall;
        srv[i] = tr.t_total;
        enc[i] = tr.t_encode;
        rnd[i] = tr.t_render;
        exr_len = tr.exr_len;
        snprintf(cache, sizeof cache, "%s", tr.cache);
        t0 = vsd_clock_seconds();
        if (vsd_renderer_render(r, 1, &fb, NULL, err, sizeof err)) {
            fprintf(stderr, "vsd_bench_daemon: in-process render: %s\n", err);
            return -1;
        }
        loc[i] = vsd_clock_seconds() - t0;
        dif[i] = wall[i] - loc[i];
    }
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);

    m_wall = median(wall, n);
    m_loc = median(loc, n);
    m_srv = median(srv, n);
    m_enc = median(enc, n);
    m_rnd = median(rnd, n);
    m_dif = median(dif, n);
    printf("### 1. Round trip vs in-process (32x18 raymarch, lights=8, smoke64 frame 1 + studio.exr as cached "
           "blobs; median of %d)\n\n",
           n);
    printf("| measure | value |\n|---|---|\n");
    printf("| daemon round trip (client wall clock, RENDER to RESULT read) | %.2f ms |\n", 1e3 * m_wall);
    printf("| in-process `vsd_renderer_render` (renderer kept, inputs cached) | %.2f ms |\n", 1e3 * m_loc);
    printf("| **overhead** (median round trip - median in-process) | **%.2f ms** |\n", 1e3 * (m_wall - m_loc));
    printf("| overhead, median of the paired differences | %.2f ms |\n", 1e3 * m_dif);
    printf("| overhead without the EXR encode (paired median - encode median) | %.2f ms |\n", 1e3 * (m_dif - m_enc));
    printf("| EXR result size | %zu bytes (%.1f KiB) |\n", exr_len, exr_len / 1024.0);
    printf("| daemon's own timings: render / encode (EXR) / total | %.2f / %.2f / %.2f ms |\n", 1e3 * m_rnd,
           1e3 * m_enc, 1e3 * m_srv);
    printf("| overhead outside the daemon's job (round trip - daemon total) | %.2f ms |\n", 1e3 * (m_wall - m_srv));
    printf("| RESULT cache flags | %s |\n", cache);
    printf("| target: overhead < 5 ms + EXR transfer (encode) | %s |\n\n",
           m_dif < 0.005 + m_enc ? "met" : "NOT met");
    free(wall);
    free(loc);
    free(srv);
    free(enc);
    free(rnd);
    free(dif);
    return 0;
}

/* ---- 2. upload throughput ------------------------------------------------------------- */
static int bench_upload(vsdc *c)
{
    const size_t sizes[] = {(size_t)64 << 20, (size_t)256 << 20};
    int k, worst_ok = 1;
    printf("### 2. Blob upload over the Unix socket (random bytes, `vsdc_put`)\n\n");
    printf("| blob | hash (XXH3-128, client) | first PUT (verified + stored) | repeat PUT (already cached: read and "
           "dropped) |\n|---|---|---|---|\n");
    for (k = 0; k < 2; k++) {
        size_t len = sizes[k], i;
        uint64_t *buf = malloc(len), x = 0x9E3779B97F4A7C15ull ^ (uint64_t)k;
        char hash[VSD_HASH_HEX_MAX], err[1024];
        double t0, th, t1, t2;
        if (!buf) return -1;
        for (i = 0; i < len / 8; i++) {   /* xorshift64* */
            x ^= x >> 12;
            x ^= x << 25;
            x ^= x >> 27;
            buf[i] = x * 0x2545F4914F6CDD1Dull;
        }
        t0 = vsd_clock_seconds();
        vsd_hash_buffer(VSD_HASH_XXH3_128, buf, len, hash);
        th = vsd_clock_seconds() - t0;
        t0 = vsd_clock_seconds();
        if (vsdc_put(c, hash, buf, len, err, sizeof err)) {
            fprintf(stderr, "vsd_bench_daemon: PUT %zu MiB: %s (%s)\n", len >> 20, err, vsdc_error_code(c));
            free(buf);
            return -1;
        }
        t1 = vsd_clock_seconds() - t0;
        t0 = vsd_clock_seconds();
        if (vsdc_put(c, hash, buf, len, err, sizeof err)) {
            fprintf(stderr, "vsd_bench_daemon: PUT again %zu MiB: %s\n", len >> 20, err);
            free(buf);
            return -1;
        }
        t2 = vsd_clock_seconds() - t0;
        free(buf);
        printf("| %zu MiB | %.0f ms | %.3f s = **%.0f MB/s** | %.3f s = %.0f MB/s |\n", len >> 20, 1e3 * th, t1,
               len / t1 / 1e6, t2, len / t2 / 1e6);
        if (len / t1 / 1e6 < 500) worst_ok = 0;
    }
    printf("\nTarget >= 500 MB/s (first PUT): %s\n\n", worst_ok ? "met" : "NOT met");
    return 0;
}

/* ---- 3. camera change on a cached shgrid preparation ---------------------------------- */
static int bench_shgrid(vsdc *c, const char *vol, const char *env)
{
    char vblob[80], eblob[80], scene[4096], err[1024];
    uint64_t sent = 0;
    timed_result cold, warm, last;
    int i, n = g_repeat > 5 ? 5 : g_repeat;
    double w[16], wr[16], m_wall, m_render;
    if (vsdc_upload_file(c, vol, vblob, sizeof vblob, &sent, err, sizeof err) ||
        vsdc_upload_file(c, env, eblob, sizeof eblob, &sent, err, sizeof err)) {
        fprintf(stderr, "vsd_bench_daemon: upload: %s\n", err);
        return -1;
    }
    scene_json(scene, sizeof scene, vblob, eblob, 1.0, 320, 180, SHGRID);
    if (render_remote(c, scene, 24, &cold)) return -1;
    for (i = 0; i < n; i++) {
        scene_json(scene, sizeof scene, vblob, eblob, 1.3 + 0.1 * i, 320, 180, SHGRID);
        if (render_remote(c, scene, 24, &warm)) return -1;
        if (i == 0) last = warm;
        w[i] = warm.wall;
        wr[i] = warm.t_render;
    }
    m_wall = median(w, n);
    m_render = median(wr, n);
    printf("### 3. Camera change on a cached shgrid preparation (smoke64 frame 24, studio.exr, 320x180; warm = "
           "median of %d new camera positions)\n\n",
           n);
    printf("| render | round trip | daemon load / prepare / render / encode | RESULT cache |\n|---|---|---|---|\n");
    printf("| cold (full: load + record grid + view) | %.3f s | %.3f / %.3f / %.3f / %.3f s | %s |\n", cold.wall,
           cold.t_load, cold.t_prepare, cold.t_render, cold.t_encode, cold.cache);
    printf("| warm (camera moved, first) | %.3f s | %.3f / %.3f / %.3f / %.3f s | %s |\n", last.wall, last.t_load,
           last.t_prepare, last.t_render, last.t_encode, last.cache);
    printf("| warm (median of %d) | %.3f s | render %.3f s | |\n", n, m_wall, m_render);
    printf("\n**Ratio full / camera change: %.2fx** (round trip, cold / warm median)\n\n", cold.wall / m_wall);
    return 0;
}

int main(int argc, char **argv)
{
    vsdc *c = NULL;
    char err[1024];
    int i, rc = 0, st;
    const char *vol1 = VSD_SHARED_DATA "/smoke64/fluid_data_0001.vdb";
    const char *vol24 = VSD_SHARED_DATA "/smoke64/fluid_data_0024.vdb";
    const char *env = VSD_SHARED_DATA "/env/studio.exr";
    for (i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--vsd") && i + 1 < argc) g_vsd = argv[++i];
        else if (!strcmp(argv[i], "--repeat") && i + 1 < argc) g_repeat = atoi(argv[++i]);
        else {
            fprintf(stderr, "usage: vsd_bench_daemon [--vsd PATH] [--repeat N]\n");
            return 2;
        }
    }
    if (g_repeat < 1) g_repeat = 1;
    if (g_repeat > 1000) g_repeat = 1000;
    if (access(vol1, R_OK) || access(vol24, R_OK) || access(env, R_OK)) {
        fprintf(stderr, "vsd_bench_daemon: no shared data under %s\n", VSD_SHARED_DATA);
        return 77;
    }
    if (start_daemon()) {
        cleanup_dir();
        return 1;
    }
    if (vsdc_connect(g_sock, NULL, &c, err, sizeof err)) {
        fprintf(stderr, "vsd_bench_daemon: connect: %s\n", err);
        stop_daemon();
        cleanup_dir();
        return 1;
    }
    printf("## vsd daemon benchmark (vsd %s, --repeat %d)\n\n", vsd_version(), g_repeat);
    fflush(stdout);
    if (bench_overhead(c, vol1, env)) rc = 1;
    fflush(stdout);
    if (!rc && bench_upload(c)) rc = 1;
    fflush(stdout);
    if (!rc && bench_shgrid(c, vol24, env)) rc = 1;
    vsdc_close(c);
    st = stop_daemon();
    printf("Daemon stopped with SIGTERM: exit status %d\n", st);
    if (st != 0) rc = 1;
    if (rc) fprintf(stderr, "vsd_bench_daemon: daemon log: %s\n", g_log);
    else cleanup_dir();
    return rc;
}
