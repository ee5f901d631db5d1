/* `vsd serve` end to end: real daemon processes on Unix sockets (and loopback TCP), driven
 * by the C client library and by raw frames. Usage: test_daemon VSD_EXECUTABLE
 *
 * Proves: streaming a sequence twice sends no VDB bytes the second time; a camera change
 * reuses the prepared renderer; remote == in-process bit for bit (raymarch), through the
 * client library and through `vsd render --remote`; hostile input costs only an ERROR;
 * CANCEL and disconnects stop jobs; BUSY when the queue is full; 8 concurrent clients;
 * the cache stays under budget; TCP needs the token; one daemon per socket; SIGTERM in
 * mid-render exits cleanly and removes the socket. */
#define _GNU_SOURCE
#include "test_common.h"
#include "test_render_util.h"
#include "test_daemon_proc.h"
#include "vsd_client.h"
#include "vsd_proto.h"
#include "vsd/render.h"
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static const char *g_vsd;
static char g_dir[1024];
static char g_vol[3][1024], g_env[1024];
static char g_vhash[3][80], g_ehash[80];

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* ---- daemons -------------------------------------------------------------------------- */




/* ---- scenes --------------------------------------------------------------------------- */
static void scene_json(char *out, size_t len, const char *vol, const char *env, double cam_x, int w, int h,
                       const char *method_opts)
{
    snprintf(out, len,
             "{\"version\":1,\"volume\":{\"file\":\"%s\",\"grid\":\"density\"},\"medium\":{\"density\":8},"
             "\"environment\":{\"file\":\"%s\"},"
             "\"camera\":{\"position\":[%g,-3.9745,1.8771],\"look_at\":[1,1,1],\"up\":[0,0,1],\"fov\":0.7},"
             "\"film\":{\"width\":%d,\"height\":%d},\"render\":{%s}}",
             vol, env, cam_x, w, h, method_opts);
}
#define RAYMARCH "\"method\":\"raymarch\",\"options\":{\"lights\":8}"
#define SLOW "\"method\":\"reference\",\"samples\":1000000"

static int render_remote(vsdc *c, const char *scene, int frame, vsdc_result *res, char *err, size_t errlen)
{
    vsdc_render_request rq;
    memset(&rq, 0, sizeof rq);
    rq.scene_json = scene;
    rq.frame = frame;
    rq.has_frame = 1;
    return vsdc_render(c, &rq, res, err, errlen);
}

static cJSON *result_info(const vsdc_result *r) { return cJSON_Parse(r->json ? r->json : "{}"); }

static int cache_flag(const cJSON *info, const char *name)
{
    return cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(info, "cache"), name));
}

/* In-process render of the same scene with the files themselves, by a new renderer into a
 * new film. */
static vsd_framebuffer *render_local_with(const char *vol, const char *env, double cam_x, int w, int h,
                                          const char *method_opts)
{
    char json[4096], err[1024];
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    scene_json(json, sizeof json, vol, env, cam_x, w, h, method_opts);
    if (vsd_scene_parse(json, "", NULL, 0, &sc, err, sizeof err) ||
        vsd_renderer_create(&sc, NULL, &r, err, sizeof err) || vsd_renderer_render(r, 1, &fb, NULL, err, sizeof err)) {
        fprintf(stderr, "local render: %s\n", err);
        vsd_framebuffer_destroy(fb);
        fb = NULL;
    }
    vsd_renderer_destroy(r);
    return fb;
}

static vsd_framebuffer *render_local(const char *vol, const char *env, double cam_x, int w, int h)
{
    return render_local_with(vol, env, cam_x, w, h, RAYMARCH);
}


/* ---- raw frames ----------------------------------------------------------------------- */
static int raw_connect(const char *sock)
{
    struct sockaddr_un a;
    int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    memset(&a, 0, sizeof a);
    a.sun_family = AF_UNIX;
    snprintf(a.sun_path, sizeof a.sun_path, "%s", sock);
    if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

static void raw_send(int fd, unsigned version, unsigned type, const char *json, uint64_t bin_len_claimed,
                     const void *bin, size_t bin_len)
{
    vsd_frame_header h;
    unsigned char hdr[VSD_PROTO_HEADER_SIZE];
    h.version = (uint16_t)version;
    h.type = (uint16_t)type;
    h.json_len = (uint32_t)strlen(json);
    h.bin_len = bin_len_claimed;
    vsd_proto_pack_header(&h, hdr);
    vsd_proto_write_full(fd, hdr, sizeof hdr);
    vsd_proto_write_full(fd, json, strlen(json));
    if (bin_len) vsd_proto_write_full(fd, bin, bin_len);
}

/* Read frames until one of `type` (any when 0) arrives; returns its JSON (or NULL on EOF). */
static cJSON *raw_recv(int fd, unsigned want, unsigned *type_out, int timeout_ms)
{
    for (;;) {
        unsigned char hdr[VSD_PROTO_HEADER_SIZE];
        vsd_frame_header h;
        char *text;
        cJSON *m;
        if (vsd_proto_read_full(fd, hdr, sizeof hdr, timeout_ms)) return NULL;
        if (vsd_proto_unpack_header(hdr, &h) || h.json_len > (1u << 24)) return NULL;
        text = calloc(1, h.json_len + 1);
        if (vsd_proto_read_full(fd, text, h.json_len, timeout_ms) || vsd_proto_skip(fd, h.bin_len, timeout_ms)) {
            free(text);
            return NULL;
        }
        m = cJSON_Parse(text);
        free(text);
        if (!want || h.type == want) {
            if (type_out) *type_out = h.type;
            return m;
        }
        cJSON_Delete(m);
    }
}

static const char *jstr(const cJSON *m, const char *k)
{
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(m, k);
    return cJSON_IsString(x) ? x->valuestring : "";
}

static double jnum(const cJSON *m, const char *a, const char *b)
{
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(m, a);
    if (b) x = cJSON_GetObjectItemCaseSensitive(x, b);
    return cJSON_IsNumber(x) ? x->valuedouble : -1;
}

/* Send raw bytes on a fresh connection (HELLO first when `hello`), expect an ERROR with `code`. */
static void expect_error(const char *sock, int hello, const void *bytes, size_t n, const char *code, const char *what)
{
    int fd = raw_connect(sock);
    unsigned type = 0;
    cJSON *m;
    CHECK_MSG(fd >= 0, "%s: connect", what);
    if (fd < 0) return;
    if (hello) {
        raw_send(fd, 1, VSD_MSG_HELLO, "{\"id\":1}", 0, NULL, 0);
        cJSON_Delete(raw_recv(fd, VSD_MSG_HELLO, NULL, 5000));
    }
    vsd_proto_write_full(fd, bytes, n);
    m = raw_recv(fd, VSD_MSG_ERROR, &type, 10000);
    CHECK_MSG(m != NULL, "%s: no ERROR came back", what);
    if (m) CHECK_MSG(strcmp(jstr(m, "code"), code) == 0, "%s: code '%s', expected '%s' (%s)", what, jstr(m, "code"),
                     code, jstr(m, "message"));
    cJSON_Delete(m);
    close(fd);
}

static void frame_bytes(unsigned char *buf, size_t *n, unsigned version, unsigned type, const char *json,
                        uint64_t bin_len)
{
    vsd_frame_header h = {(uint16_t)version, (uint16_t)type, (uint32_t)strlen(json), bin_len};
    vsd_proto_pack_header(&h, buf);
    memcpy(buf + VSD_PROTO_HEADER_SIZE, json, strlen(json));
    *n = VSD_PROTO_HEADER_SIZE + strlen(json);
}

/* A good client after the abuse: HELLO and a correct render. */
static void check_still_serves(const char *sock, const vsd_framebuffer *expect, const char *after)
{
    vsdc *c = NULL;
    vsdc_result res;
    char err[1024], scene[4096], vb[128], eb[128];
    if (vsdc_connect(sock, NULL, &c, err, sizeof err)) {
        CHECK_MSG(0, "after %s: HELLO failed: %s", after, err);
        return;
    }
    vsdc_upload_file(c, g_vol[0], vb, sizeof vb, NULL, err, sizeof err);
    vsdc_upload_file(c, g_env, eb, sizeof eb, NULL, err, sizeof err);
    scene_json(scene, sizeof scene, vb, eb, 1.0, 32, 18, RAYMARCH);
    if (render_remote(c, scene, 1, &res, err, sizeof err)) CHECK_MSG(0, "after %s: render failed: %s", after, err);
    else CHECK_MSG(test_exr_bytes_diff(res.exr, res.exr_len, expect, g_dir, "still") == 0, "after %s: wrong image", after);
    vsdc_result_free(&res);
    vsdc_close(c);
}

/* ---- concurrent clients --------------------------------------------------------------- */
typedef struct worker_arg {
    const char *sock;
    int index, ok, rendered;
    vsd_framebuffer *const *expect; /* [3] per camera */
    double longest_wait;
} worker_arg;

static void *client_thread(void *p)
{
    worker_arg *a = p;
    vsdc *c = NULL;
    char err[1024], scene[4096], vb[128], eb[128], tag[32];
    int k;
    a->ok = 1;
    if (vsdc_connect(a->sock, NULL, &c, err, sizeof err)) {
        fprintf(stderr, "client %d: %s\n", a->index, err);
        a->ok = 0;
        return NULL;
    }
    if (vsdc_upload_file(c, g_vol[0], vb, sizeof vb, NULL, err, sizeof err) ||
        vsdc_upload_file(c, g_env, eb, sizeof eb, NULL, err, sizeof err)) {
        a->ok = 0;
        vsdc_close(c);
        return NULL;
    }
    for (k = 0; k < 3; k++) {
        int cam = (a->index + k) % 3;
        vsdc_result res;
        scene_json(scene, sizeof scene, vb, eb, 0.5 + 0.5 * cam, 24, 16, RAYMARCH);
        if (render_remote(c, scene, 1, &res, err, sizeof err)) {
            fprintf(stderr, "client %d: %s\n", a->index, err);
            a->ok = 0;
            break;
        }
        snprintf(tag, sizeof tag, "c%d_%d", a->index, k);
        if (test_exr_bytes_diff(res.exr, res.exr_len, a->expect[cam], g_dir, tag) != 0) {
            fprintf(stderr, "client %d: render %d differs\n", a->index, k);
            a->ok = 0;
        } else {
            cJSON *info = result_info(&res);
            double w = jnum(info, "timings", "queue");
            if (w > a->longest_wait) a->longest_wait = w;
            cJSON_Delete(info);
            a->rendered++;
        }
        vsdc_result_free(&res);
    }
    vsdc_close(c);
    return NULL;
}

typedef struct cancel_arg {
    volatile int *flag;
    double delay;
} cancel_arg;

static void *cancel_later(void *p)
{
    cancel_arg *a = p;
    usleep((useconds_t)(a->delay * 1e6));
    *a->flag = 1;
    return NULL;
}

static cJSON *stats_of(const char *sock)
{
    vsdc *c = NULL;
    char err[512], *json = NULL;
    cJSON *o = NULL;
    if (vsdc_connect(sock, NULL, &c, err, sizeof err)) return NULL;
    if (!vsdc_stats(c, &json, err, sizeof err)) o = cJSON_Parse(json);
    free(json);
    vsdc_close(c);
    return o;
}

/* A daemon with --cache-mb `mb` renders lbl at 400x400 three times (the camera moved): each
 * result's cache.renderer and cache.film into flags[3][2]; *used: STATS used_bytes after the
 * first (the map, the volume, the renderer and any film it keeps). 0, or -1 when it failed. */
static int film_budget_run(const char *name, long mb, int flags[3][2], double *used)
{
    static const char lbl[] = "\"method\":\"lbl\",\"options\":{\"cells\":16}";
    test_daemon d = {0};
    char mbs[32], err[1024], scene[4096], vb[128], eb[128];
    const char *extra[] = {"--cache-mb", mbs, "--max-size", "512", NULL};
    vsdc *c = NULL;
    int k, rc = -1;
    snprintf(mbs, sizeof mbs, "%ld", mb);
    if (test_daemon_start(&d, g_vsd, g_dir, name, NULL, NULL, extra)) return -1;
    if (vsdc_connect(d.sock, NULL, &c, err, sizeof err) == 0 &&
        vsdc_upload_file(c, g_vol[0], vb, sizeof vb, NULL, err, sizeof err) == 0 &&
        vsdc_upload_file(c, g_env, eb, sizeof eb, NULL, err, sizeof err) == 0) {
        for (k = 0; k < 3; k++) {
            vsdc_result res;
            cJSON *info;
            scene_json(scene, sizeof scene, vb, eb, 0.5 + 0.5 * k, 400, 400, lbl);
            if (render_remote(c, scene, 1, &res, err, sizeof err)) break;
            info = result_info(&res);
            flags[k][0] = cache_flag(info, "renderer");
            flags[k][1] = cache_flag(info, "film");
            cJSON_Delete(info);
            vsdc_result_free(&res);
            if (k == 0) {
                cJSON *st = stats_of(d.sock);
                *used = jnum(st, "cache", "used_bytes");
                cJSON_Delete(st);
            }
        }
        rc = k == 3 ? 0 : -1;
    }
    if (rc) fprintf(stderr, "film budget run %s: %s\n", name, err);
    vsdc_close(c);
    test_daemon_stop(&d);
    return rc;
}

int main(int argc, char **argv)
{
    test_daemon d1 = {0}, d2 = {0}, d3 = {0}, d4 = {0};
    char err[2048], scene[4096], vb[3][128], eb[128], allow[1100];
    vsd_framebuffer *ref = NULL, *cams[3] = {NULL, NULL, NULL};
    vsdc *c = NULL;
    vsdc_result res;
    int i;
    if (argc < 2) {
        fprintf(stderr, "usage: test_daemon VSD\n");
        return 2;
    }
    g_vsd = argv[1];
    snprintf(g_dir, sizeof g_dir, "%s", test_tmp("daemon"));
    if (system("true") != 0) {}
    {
        char cmd[1200];
        snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", g_dir, g_dir);
        if (system(cmd) != 0) return 1;
    }
    for (i = 0; i < 3; i++) snprintf(g_vol[i], sizeof g_vol[i], "%s", test_data(i == 0 ? "smoke64/fluid_data_0001.vdb"
                                                                         : i == 1 ? "smoke64/fluid_data_0002.vdb"
                                                                                  : "smoke64/fluid_data_0003.vdb"));
    snprintf(g_env, sizeof g_env, "%s", test_data("env/sunset.exr"));
    if (access(g_vol[0], R_OK) != 0) {
        fprintf(stderr, "no shared data (%s): skipped\n", g_vol[0]);
        return 77;
    }
    for (i = 0; i < 3; i++) vsd_hash_file(VSD_HASH_XXH3_128, g_vol[i], g_vhash[i], NULL, err, sizeof err);
    vsd_hash_file(VSD_HASH_XXH3_128, g_env, g_ehash, NULL, err, sizeof err);
    snprintf(allow, sizeof allow, "%s", test_data("smoke64"));
    ref = render_local(g_vol[0], g_env, 1.0, 32, 18);
    for (i = 0; i < 3; i++) cams[i] = render_local(g_vol[0], g_env, 0.5 + 0.5 * i, 24, 16);
    CHECK(ref && cams[0] && cams[1] && cams[2]);
    if (!ref) return test_finish("test_daemon");

    {
        const char *extra[] = {"--allow-path", allow, "--max-size", "512", "--queue", "32", NULL};
        if (test_daemon_start(&d1, g_vsd, g_dir, "d1", NULL, NULL, extra)) return 1;
    }
    /* the socket is private */
    {
        struct stat st;
        CHECK(stat(d1.sock, &st) == 0 && (st.st_mode & 0777) == 0600);
    }
    /* one daemon per socket */
    {
        test_daemon dup = {0};
        const char *extra[] = {NULL};
        char log[2048] = "";
        FILE *f;
        int status = 0;
        snprintf(dup.sock, sizeof dup.sock, "%s", d1.sock);
        dup.pid = fork();
        if (dup.pid == 0) {
            FILE *e = freopen("/dev/null", "w", stdout);
            (void)e;
            e = freopen(d1.log, "a", stderr);
            execl(g_vsd, g_vsd, "serve", "--socket", d1.sock, (char *)NULL);
            _exit(127);
        }
        (void)extra;
        waitpid(dup.pid, &status, 0);
        CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) != 0, "a second daemon on the same socket must fail");
        f = fopen(d1.log, "r");
        if (f) {
            size_t n = fread(log, 1, sizeof log - 1, f);
            log[n] = '\0';
            fclose(f);
        }
        CHECK(access(d1.sock, F_OK) == 0); /* the first daemon's socket is still there */
    }

    /* 1. HELLO */
    if (vsdc_connect(d1.sock, NULL, &c, err, sizeof err)) {
        CHECK_MSG(0, "connect: %s", err);
        test_daemon_stop(&d1);
        return test_finish("test_daemon");
    }
    {
        cJSON *h = cJSON_Parse(vsdc_server_info(c));
        CHECK(jnum(h, "version", NULL) == 1);
        CHECK(strstr(vsdc_server_info(c), "\"raymarch\"") != NULL);
        CHECK(jnum(h, "limits", "max_width") == 512);
        CHECK(jnum(h, "limits", "max_voxels") > 0 && jnum(h, "limits", "max_job_seconds") > 0 &&
              jnum(h, "limits", "max_message_bytes") > 0 && jnum(h, "limits", "queue_length") == 32);
        cJSON_Delete(h);
    }

    /* 2. streaming a 3-frame sequence twice: the second pass sends no VDB bytes; a camera
     *    change re-renders from the prepared renderer */
    {
        int pass;
        uint64_t sent[2] = {0, 0};
        int prep_hits[2] = {0, 0};
        for (pass = 0; pass < 2; pass++) {
            vsdc *s = NULL;
            if (vsdc_connect(d1.sock, NULL, &s, err, sizeof err)) break;
            for (i = 0; i < 3; i++) {
                uint64_t up = 0;
                CHECK(vsdc_upload_file(s, g_vol[i], vb[i], sizeof vb[i], &up, err, sizeof err) == 0);
                CHECK(vsdc_upload_file(s, g_env, eb, sizeof eb, NULL, err, sizeof err) == 0);
                scene_json(scene, sizeof scene, vb[i], eb, 1.0, 32, 18, RAYMARCH);
                if (render_remote(s, scene, i + 1, &res, err, sizeof err) == 0) {
                    cJSON *info = result_info(&res);
                    prep_hits[pass] += cache_flag(info, "preparation");
                    cJSON_Delete(info);
                } else CHECK_MSG(0, "stream pass %d frame %d: %s", pass, i + 1, err);
                vsdc_result_free(&res);
            }
            sent[pass] = vsdc_bytes_uploaded(s);
            vsdc_close(s);
        }
        CHECK_MSG(sent[0] > 0, "first pass uploaded %llu bytes", (unsigned long long)sent[0]);
        CHECK_MSG(sent[1] == 0, "second pass uploaded %llu bytes (expected none)", (unsigned long long)sent[1]);
        CHECK_MSG(prep_hits[1] == 3, "second pass: %d of 3 renders reused the preparation", prep_hits[1]);
    }
    /* camera change: same inputs, new camera, the preparation is reused and is cheap */
    {
        double prep_first = -1, prep_cam = -1;
        /* a new renderer (different options) to time a full preparation */
        scene_json(scene, sizeof scene, vb[0], eb, 1.0, 32, 18, "\"method\":\"raymarch\",\"options\":{\"lights\":64}");
        if (render_remote(c, scene, 1, &res, err, sizeof err) == 0) {
            cJSON *info = result_info(&res);
            CHECK(!cache_flag(info, "renderer") && !cache_flag(info, "preparation"));
            CHECK(cache_flag(info, "volume") && cache_flag(info, "environment"));
            prep_first = jnum(info, "timings", "prepare");
            cJSON_Delete(info);
        } else CHECK_MSG(0, "render: %s", err);
        vsdc_result_free(&res);
        scene_json(scene, sizeof scene, vb[0], eb, 1.7, 32, 18, "\"method\":\"raymarch\",\"options\":{\"lights\":64}");
        if (render_remote(c, scene, 1, &res, err, sizeof err) == 0) {
            cJSON *info = result_info(&res);
            CHECK_MSG(cache_flag(info, "renderer") && cache_flag(info, "preparation"),
                      "a camera change must reuse the preparation: %s", res.json);
            prep_cam = jnum(info, "timings", "prepare");
            cJSON_Delete(info);
        } else CHECK_MSG(0, "render: %s", err);
        vsdc_result_free(&res);
        printf("preparation: first %.6fs, after a camera change %.6fs\n", prep_first, prep_cam);
        CHECK(prep_cam <= prep_first);
        /* a medium change is not a preparation hit */
        scene_json(scene, sizeof scene, vb[0], eb, 1.7, 32, 18, "\"method\":\"raymarch\",\"options\":{\"lights\":64}");
        {
            const char *ov[] = {"medium.density=4"};
            vsdc_render_request rq;
            memset(&rq, 0, sizeof rq);
            rq.scene_json = scene;
            rq.overrides = ov;
            rq.override_count = 1;
            if (vsdc_render(c, &rq, &res, err, sizeof err) == 0) {
                cJSON *info = result_info(&res);
                CHECK(cache_flag(info, "renderer") && !cache_flag(info, "preparation"));
                cJSON_Delete(info);
            } else CHECK_MSG(0, "render: %s", err);
            vsdc_result_free(&res);
        }
    }
    /* a film kept with its renderer (cache.h, vsdd_cache_keep_film): a renderer's next
     * render goes into its last one's film ("cache": {"film": true}) when the size is the
     * same, and its image is a new renderer's in a new film bit for bit, lbl's adaptive view
     * (every 4th pixel traced, the blocks between interpolated) included: nothing of the last
     * camera's picture is left in it. A film of another size is made anew. */
    {
        static const char lbl[] = "\"method\":\"lbl\",\"options\":{\"cells\":16,\"view_spacing\":4}";
        static const struct {
            double cam_x;
            int w, h, film;
        } steps[] = {{0.5, 96, 54, 0}, {1.5, 96, 54, 1}, {1.0, 64, 36, 0}, {1.5, 64, 36, 1}};
        int s;
        for (s = 0; s < 4; s++) {
            vsd_framebuffer *want = render_local_with(g_vol[0], g_env, steps[s].cam_x, steps[s].w, steps[s].h, lbl);
            char tag[32];
            scene_json(scene, sizeof scene, vb[0], eb, steps[s].cam_x, steps[s].w, steps[s].h, lbl);
            snprintf(tag, sizeof tag, "film%d", s);
            if (want && render_remote(c, scene, 1, &res, err, sizeof err) == 0) {
                cJSON *info = result_info(&res);
                long diff = test_exr_bytes_diff(res.exr, res.exr_len, want, g_dir, tag);
                CHECK_MSG(diff == 0, "film step %d (%dx%d): %ld values differ from a new renderer's", s, steps[s].w,
                          steps[s].h, diff);
                CHECK_MSG(cache_flag(info, "film") == steps[s].film, "film step %d: cache.film %d, expected %d (%s)", s,
                          cache_flag(info, "film"), steps[s].film, res.json);
                cJSON_Delete(info);
                vsdc_result_free(&res);
            } else CHECK_MSG(0, "film step %d: %s", s, want ? err : "the local render failed");
            vsd_framebuffer_destroy(want);
        }
    }

    /* 3. remote == in-process, bit for bit (raymarch is deterministic) */
    scene_json(scene, sizeof scene, vb[0], eb, 1.0, 32, 18, RAYMARCH);
    if (render_remote(c, scene, 1, &res, err, sizeof err) == 0) {
        long d = test_exr_bytes_diff(res.exr, res.exr_len, ref, g_dir, "remote");
        CHECK_MSG(d == 0, "remote and in-process renders differ in %ld values", d);
    } else CHECK_MSG(0, "render: %s", err);
    {
        /* output.compression "none" (the add-on's requests): the same values, every float
         * stored as is, so the bytes are more than the ZIP result's */
        size_t zip_len = res.exr_len;
        const char *ov[] = {"output.compression=none"};
        vsdc_render_request rq;
        vsdc_result_free(&res);
        memset(&rq, 0, sizeof rq);
        rq.scene_json = scene;
        rq.overrides = ov;
        rq.override_count = 1;
        rq.frame = 1;
        rq.has_frame = 1;
        if (vsdc_render(c, &rq, &res, err, sizeof err) == 0) {
            long d = test_exr_bytes_diff(res.exr, res.exr_len, ref, g_dir, "uncompressed");
            CHECK_MSG(d == 0, "an uncompressed result differs from the in-process render in %ld values", d);
            CHECK_MSG(res.exr_len > zip_len && res.exr_len >= (size_t)32 * 18 * 17 * sizeof(float),
                      "uncompressed result of %zu bytes (ZIP %zu)", res.exr_len, zip_len);
        } else CHECK_MSG(0, "render: %s", err);
    }
    vsdc_result_free(&res);
    /* ... and through the CLI: `vsd render --remote` writes what `vsd render` writes */
    {
        char cmd[4096], scene_path[1200], a[1200], b[1200], pa[1200], pb[1200];
        FILE *f;
        vsd_exr_image *ia = NULL, *ib = NULL;
        snprintf(scene_path, sizeof scene_path, "%s/cli.json", g_dir);
        f = fopen(scene_path, "w");
        scene_json(scene, sizeof scene, g_vol[0], g_env, 1.0, 32, 18, RAYMARCH);
        fputs(scene, f);
        fclose(f);
        snprintf(a, sizeof a, "%s/cli_local_####.exr", g_dir);
        snprintf(b, sizeof b, "%s/cli_remote/r_####.exr", g_dir);
        snprintf(pb, sizeof pb, "%s/cli_remote/r_####.png", g_dir);
        snprintf(cmd, sizeof cmd, "'%s' render '%s' --frames 1-2 --set 'volume.file=\"%s\"' --output '%s' --quiet && "
                                  "'%s' render '%s' --frames 1-2 --set 'volume.file=\"%s\"' --output '%s' --preview '%s' --quiet --remote='%s'",
                 g_vsd, scene_path, test_data("smoke64/fluid_data_####.vdb"), a, g_vsd, scene_path,
                 test_data("smoke64/fluid_data_####.vdb"), b, pb, d1.sock);
        CHECK_MSG(system(cmd) == 0, "%s", cmd);
        for (i = 1; i <= 2; i++) {
            snprintf(a, sizeof a, "%s/cli_local_%04d.exr", g_dir, i);
            snprintf(b, sizeof b, "%s/cli_remote/r_%04d.exr", g_dir, i);
            snprintf(pa, sizeof pa, "%s/cli_remote/r_%04d.png", g_dir, i);
            CHECK(access(pa, F_OK) == 0);
            if (vsd_exr_read(a, &ia, err, sizeof err) == 0 && vsd_exr_read(b, &ib, err, sizeof err) == 0) {
                int k, same = ia->channel_count == ib->channel_count && ia->width == ib->width;
                for (k = 0; same && k < ia->channel_count; k++) {
                    const float *pb2 = vsd_exr_channel(ib, ia->channel_names[k]);
                    same = pb2 && memcmp(pb2, ia->channels[k], sizeof(float) * ia->width * ia->height) == 0;
                }
                CHECK_MSG(same, "frame %d: vsd render --remote differs from vsd render", i);
            } else CHECK_MSG(0, "reading the CLI outputs: %s", err);
            vsd_exr_image_destroy(ia);
            vsd_exr_image_destroy(ib);
            ia = ib = NULL;
        }
        {
            char m[1200];
            snprintf(m, sizeof m, "%s/cli_remote/r_0001.exr", g_dir);
            CHECK(vsd_exr_read_attr(m, "vsd/method", err, sizeof err, NULL, 0) == 0 && strcmp(err, "raymarch") == 0);
        }
    }

    /* 4. hostile input: each costs an ERROR (and maybe the connection), never the daemon */
    {
        unsigned char buf[8192];
        size_t n;
        char big[600];
        for (i = 0; i < 64; i++) buf[i] = (unsigned char)(rand() & 255);
        buf[0] = 'X';
        expect_error(d1.sock, 0, buf, 64, "bad_frame", "random bytes");
        frame_bytes(buf, &n, 1, VSD_MSG_HELLO, "{\"id\":1}", 1ull << 63);
        expect_error(d1.sock, 0, buf, n, "too_large", "binary length 2^63");
        {
            vsd_frame_header h = {1, VSD_MSG_HELLO, 0xffffffffu, 0};
            vsd_proto_pack_header(&h, buf);
            expect_error(d1.sock, 0, buf, VSD_PROTO_HEADER_SIZE, "too_large", "JSON length 2^32-1");
        }
        frame_bytes(buf, &n, 1, VSD_MSG_HELLO, "{\"id\":1, \"versions\": [1,", 0);
        expect_error(d1.sock, 0, buf, n, "bad_json", "malformed JSON");
        frame_bytes(buf, &n, 1, VSD_MSG_HELLO, "[1,2,3]", 0);
        expect_error(d1.sock, 0, buf, n, "bad_json", "JSON that is not an object");
        frame_bytes(buf, &n, 1, 99, "{\"id\":1}", 0);
        expect_error(d1.sock, 1, buf, n, "unknown_type", "unknown message type");
        frame_bytes(buf, &n, 1, VSD_MSG_RESULT, "{\"id\":1}", 0);
        expect_error(d1.sock, 1, buf, n, "unknown_type", "a reply type sent as a request");
        frame_bytes(buf, &n, 7, VSD_MSG_HELLO, "{\"id\":1}", 0);
        expect_error(d1.sock, 0, buf, n, "unsupported_version", "frame version 7");
        frame_bytes(buf, &n, 1, VSD_MSG_HELLO, "{\"id\":1,\"versions\":[2,3]}", 0);
        expect_error(d1.sock, 0, buf, n, "unsupported_version", "HELLO without version 1");
        frame_bytes(buf, &n, 1, VSD_MSG_STATS, "{\"id\":1}", 0);
        expect_error(d1.sock, 0, buf, n, "hello_required", "STATS before HELLO");
        frame_bytes(buf, &n, 1, VSD_MSG_HAS, "{\"id\":1,\"hashes\":\"abc\"}", 0);
        expect_error(d1.sock, 1, buf, n, "bad_request", "HAS.hashes not an array");
        frame_bytes(buf, &n, 1, VSD_MSG_HAS, "{\"id\":1,\"hashes\":[\"../../etc/passwd\"]}", 0);
        expect_error(d1.sock, 1, buf, n, "bad_hash", "HAS with a path for a hash");
        frame_bytes(buf, &n, 1, VSD_MSG_HAS, "{\"id\":\"one\",\"hashes\":[]}", 0);
        expect_error(d1.sock, 1, buf, n, "bad_request", "id of the wrong type");
        frame_bytes(buf, &n, 1, VSD_MSG_RENDER, "{\"id\":5,\"scene\":42}", 0);
        expect_error(d1.sock, 1, buf, n, "bad_request", "RENDER.scene a number");
        scene_json(scene, sizeof scene, vb[0], eb, 1.0, 32, 18, RAYMARCH);
        snprintf((char *)buf + 4000, 4000, "{\"id\":5,\"frame\":\"x\",\"scene\":%s}", scene);
        frame_bytes(buf, &n, 1, VSD_MSG_RENDER, (char *)buf + 4000, 0);
        expect_error(d1.sock, 1, buf, n, "bad_request", "RENDER.frame a string");
        /* a RENDER naming a missing blob: the ERROR lists it */
        scene_json(scene, sizeof scene, "blob:0123456789abcdef0123456789abcdef", eb, 1.0, 32, 18, RAYMARCH);
        snprintf(big, sizeof big, "%s", "");
        snprintf((char *)buf + 4000, 4000, "{\"id\":5,\"scene\":%s}", scene);
        frame_bytes(buf, &n, 1, VSD_MSG_RENDER, (char *)buf + 4000, 0);
        expect_error(d1.sock, 1, buf, n, "missing_blob", "RENDER naming a missing blob");
        scene_json(scene, sizeof scene, "blob:zz", eb, 1.0, 32, 18, RAYMARCH);
        snprintf((char *)buf + 4000, 4000, "{\"id\":5,\"scene\":%s}", scene);
        frame_bytes(buf, &n, 1, VSD_MSG_RENDER, (char *)buf + 4000, 0);
        expect_error(d1.sock, 1, buf, n, "bad_hash", "RENDER with a malformed blob name");
        /* paths outside --allow-path */
        scene_json(scene, sizeof scene, "/etc/passwd", eb, 1.0, 32, 18, RAYMARCH);
        snprintf((char *)buf + 4000, 4000, "{\"id\":5,\"scene\":%s}", scene);
        frame_bytes(buf, &n, 1, VSD_MSG_RENDER, (char *)buf + 4000, 0);
        expect_error(d1.sock, 1, buf, n, "path_denied", "an absolute path outside --allow-path");
        scene_json(scene, sizeof scene, "../env/sunset.exr", eb, 1.0, 32, 18, RAYMARCH);
        snprintf((char *)buf + 4000, 4000, "{\"id\":5,\"scene\":%s}", scene);
        frame_bytes(buf, &n, 1, VSD_MSG_RENDER, (char *)buf + 4000, 0);
        expect_error(d1.sock, 1, buf, n, "path_denied", "a ../ escape from --allow-path");
        /* a film above the limit, an invalid scene */
        scene_json(scene, sizeof scene, vb[0], eb, 1.0, 1024, 18, RAYMARCH);
        snprintf((char *)buf + 4000, 4000, "{\"id\":5,\"scene\":%s}", scene);
        frame_bytes(buf, &n, 1, VSD_MSG_RENDER, (char *)buf + 4000, 0);
        expect_error(d1.sock, 1, buf, n, "limit", "film above --max-size");
        frame_bytes(buf, &n, 1, VSD_MSG_RENDER, "{\"id\":5,\"scene\":{\"version\":1,\"volume\":{\"file\":\"blob:0123456789abcdef0123456789abcdef\"},\"camera\":{\"fov\":\"wide\"}}}", 0);
        expect_error(d1.sock, 1, buf, n, "invalid_scene", "a scene with a wrong type");
        /* a blob whose hash does not match its bytes */
        frame_bytes(buf, &n, 1, VSD_MSG_PUT, "{\"id\":2,\"hash\":\"00000000000000000000000000000000\"}", 100);
        memset(buf + n, 7, 100);
        expect_error(d1.sock, 1, buf, n + 100, "hash_mismatch", "PUT with a wrong hash");
        /* truncated frames: the header, then part of the JSON, then the peer goes away */
        {
            int fd = raw_connect(d1.sock);
            frame_bytes(buf, &n, 1, VSD_MSG_HELLO, "{\"id\":1,\"versions\":[1]}", 0);
            vsd_proto_write_full(fd, buf, n - 5);
            close(fd);
            fd = raw_connect(d1.sock);
            vsd_proto_write_full(fd, buf, 7);
            close(fd);
            fd = raw_connect(d1.sock);
            raw_send(fd, 1, VSD_MSG_HELLO, "{\"id\":1}", 0, NULL, 0);
            frame_bytes(buf, &n, 1, VSD_MSG_PUT, "{\"id\":2,\"hash\":\"00000000000000000000000000000000\"}", 1 << 20);
            vsd_proto_write_full(fd, buf, n + 1000);
            close(fd);
        }
        /* after bad JSON the connection still works */
        {
            int fd = raw_connect(d1.sock);
            cJSON *m;
            frame_bytes(buf, &n, 1, VSD_MSG_HELLO, "{nope", 0);
            vsd_proto_write_full(fd, buf, n);
            cJSON_Delete(raw_recv(fd, VSD_MSG_ERROR, NULL, 5000));
            raw_send(fd, 1, VSD_MSG_HELLO, "{\"id\":3}", 0, NULL, 0);
            m = raw_recv(fd, VSD_MSG_HELLO, NULL, 5000);
            CHECK_MSG(m && jnum(m, "id", NULL) == 3, "HELLO after bad JSON on the same connection");
            cJSON_Delete(m);
            close(fd);
        }
        CHECK(test_daemon_alive(&d1));
        check_still_serves(d1.sock, ref, "hostile input");
    }
    /* server-side paths inside --allow-path work */
    {
        char path_scene[4096];
        scene_json(path_scene, sizeof path_scene, "fluid_data_0001.vdb", eb, 1.0, 32, 18, RAYMARCH);
        if (render_remote(c, path_scene, 1, &res, err, sizeof err) == 0)
            CHECK_MSG(test_exr_bytes_diff(res.exr, res.exr_len, ref, g_dir, "path") == 0, "server-path render differs");
        else CHECK_MSG(0, "render with an allowed server path: %s", err);
        vsdc_result_free(&res);
    }
    /* the refractive index's grid (medium.ior_from = temperature: the file's "temperature"
     * grid) is a fourth cached input: fetched, reported in RESULT.cache.ior, reused, and it
     * changes lbl's image; a missing one is an error naming it */
    {
        static const char *const variants[3] = {"\"density\":8}", "\"density\":8,\"ior_from\":\"temperature\"}",
                                                "\"density\":8},\"volume\":{\"file\":\"fluid_data_0001.vdb\",\"ior_grid\":\"nope\"}"};
        unsigned char *plain = NULL;
        size_t plain_len = 0;
        int v;
        for (v = 0; v < 3; v++) {
            char base[4096], scn[4200], *at;
            scene_json(base, sizeof base, "fluid_data_0001.vdb", eb, 1.0, 32, 18, "\"method\":\"lbl\"");
            at = strstr(base, "\"density\":8}");
            if (!at) {
                CHECK(0);
                break;
            }
            if (v == 2) {
                /* the volume section again, with the grid: replace the first one instead */
                char *vol = strstr(base, "\"volume\":{");
                char *end = vol ? strchr(vol, '}') : NULL;
                if (!vol || !end) break;
                snprintf(scn, sizeof scn, "%.*s\"volume\":{\"file\":\"fluid_data_0001.vdb\",\"grid\":\"density\","
                         "\"ior_grid\":\"nope\"}%s", (int)(vol - base), base, end + 1);
            } else {
                snprintf(scn, sizeof scn, "%.*s%s%s", (int)(at - base), base, variants[v], at + strlen("\"density\":8}"));
            }
            if (render_remote(c, scn, 1, &res, err, sizeof err) == 0) {
                cJSON *info = result_info(&res);
                CHECK_MSG(v != 2, "a missing ior grid rendered");
                if (v == 0) {
                    plain = malloc(res.exr_len);
                    if (plain) memcpy(plain, res.exr, res.exr_len);
                    plain_len = res.exr_len;
                } else {
                    CHECK_MSG(!cache_flag(info, "ior"), "the first temperature render found its grid cached");
                    CHECK_MSG(plain && (plain_len != res.exr_len || memcmp(plain, res.exr, res.exr_len) != 0),
                              "heat haze left lbl's image unchanged");
                }
                cJSON_Delete(info);
            } else {
                CHECK_MSG(v == 2, "render variant %d: %s", v, err);
                if (v == 2) {
                    printf("missing ior grid: %s: %s\n", vsdc_error_code(c), err);
                    CHECK_CONTAINS(err, "'nope'");
                }
            }
            vsdc_result_free(&res);
        }
        /* the same temperature scene again: every input from the cache */
        {
            char base[4096], scn[4200], *at;
            scene_json(base, sizeof base, "fluid_data_0001.vdb", eb, 1.0, 32, 18, "\"method\":\"lbl\"");
            at = strstr(base, "\"density\":8}");
            if (at) {
                snprintf(scn, sizeof scn, "%.*s%s%s", (int)(at - base), base, variants[1], at + strlen("\"density\":8}"));
                if (render_remote(c, scn, 1, &res, err, sizeof err) == 0) {
                    cJSON *info = result_info(&res);
                    CHECK_MSG(cache_flag(info, "ior"), "the temperature grid was not reused: %s", res.json);
                    cJSON_Delete(info);
                } else CHECK_MSG(0, "temperature render again: %s", err);
                vsdc_result_free(&res);
            }
        }
        free(plain);
    }

    /* 5. CANCEL stops a running job */
    {
        volatile int flag = 0;
        cancel_arg ca = {&flag, 0.5};
        pthread_t t;
        vsdc_render_request rq;
        double t0, dt;
        int rc;
        scene_json(scene, sizeof scene, vb[0], eb, 1.0, 64, 64, SLOW);
        memset(&rq, 0, sizeof rq);
        rq.scene_json = scene;
        rq.cancel = &flag;
        pthread_create(&t, NULL, cancel_later, &ca);
        t0 = now();
        rc = vsdc_render(c, &rq, &res, err, sizeof err);
        dt = now() - t0;
        pthread_join(t, NULL);
        CHECK_MSG(rc == VSDC_ERR_SERVER && strcmp(vsdc_error_code(c), "cancelled") == 0, "cancel: rc %d code %s (%s)",
                  rc, vsdc_error_code(c), err);
        CHECK_MSG(dt < 5.0, "cancel took %.2fs", dt);
        printf("cancel: answered %.3fs after the request (cancel sent at 0.5s)\n", dt);
        vsdc_result_free(&res);
    }
    /* a client that disconnects in mid-render has its job cancelled */
    {
        int fd = raw_connect(d1.sock), k, stopped = 0;
        char msg[5000];
        double t0;
        raw_send(fd, 1, VSD_MSG_HELLO, "{\"id\":1}", 0, NULL, 0);
        cJSON_Delete(raw_recv(fd, VSD_MSG_HELLO, NULL, 5000));
        snprintf(msg, sizeof msg, "{\"id\":2,\"scene\":%s}", scene);
        raw_send(fd, 1, VSD_MSG_RENDER, msg, 0, NULL, 0);
        cJSON_Delete(raw_recv(fd, VSD_MSG_PROGRESS, NULL, 5000));
        usleep(300000);
        close(fd);
        t0 = now();
        for (k = 0; k < 100 && !stopped; k++) {
            cJSON *s = stats_of(d1.sock);
            stopped = s && jnum(s, "queue", "running") == 0;
            cJSON_Delete(s);
            if (!stopped) usleep(50000);
        }
        CHECK_MSG(stopped, "the job of a disconnected client kept running");
        printf("disconnect: job stopped %.3fs after the client left\n", now() - t0);
    }

    /* 6. 8 concurrent clients, 3 renders each: all correct, none starves */
    {
        pthread_t t[8];
        worker_arg wa[8];
        double t0 = now(), longest = 0;
        int ok = 1, total = 0;
        for (i = 0; i < 8; i++) {
            memset(&wa[i], 0, sizeof wa[i]);
            wa[i].sock = d1.sock;
            wa[i].index = i;
            wa[i].expect = cams;
            pthread_create(&t[i], NULL, client_thread, &wa[i]);
        }
        for (i = 0; i < 8; i++) {
            pthread_join(t[i], NULL);
            ok &= wa[i].ok;
            total += wa[i].rendered;
            if (wa[i].longest_wait > longest) longest = wa[i].longest_wait;
        }
        CHECK_MSG(ok && total == 24, "concurrent clients: %d of 24 renders correct", total);
        printf("8 clients x 3 renders: %.2fs, longest queue wait %.2fs\n", now() - t0, longest);
    }
    vsdc_close(c);
    c = NULL;
    CHECK(test_daemon_stop(&d1) == 0);
    CHECK(access(d1.sock, F_OK) != 0);

    /* 7. BUSY when the queue is full; SIGTERM in mid-render exits cleanly */
    {
        const char *extra[] = {"--queue", "1", "--workers", "1", NULL};
        int fd, got_busy = 0, got_shutdown = 0, k, rc;
        char msg[5000];
        if (test_daemon_start(&d2, g_vsd, g_dir, "d2", NULL, NULL, extra) == 0) {
            vsdc *s = NULL;
            if (vsdc_connect(d2.sock, NULL, &s, err, sizeof err) == 0) {
                vsdc_upload_file(s, g_vol[0], vb[0], sizeof vb[0], NULL, err, sizeof err);
                vsdc_upload_file(s, g_env, eb, sizeof eb, NULL, err, sizeof err);
                vsdc_close(s);
            }
            scene_json(scene, sizeof scene, vb[0], eb, 1.0, 64, 64, SLOW);
            fd = raw_connect(d2.sock);
            raw_send(fd, 1, VSD_MSG_HELLO, "{\"id\":1}", 0, NULL, 0);
            cJSON_Delete(raw_recv(fd, VSD_MSG_HELLO, NULL, 5000));
            for (k = 2; k <= 4; k++) {
                snprintf(msg, sizeof msg, "{\"id\":%d,\"scene\":%s}", k, scene);
                raw_send(fd, 1, VSD_MSG_RENDER, msg, 0, NULL, 0);
                if (k == 2) cJSON_Delete(raw_recv(fd, VSD_MSG_PROGRESS, NULL, 5000)); /* job 2 running */
            }
            for (k = 0; k < 50 && !got_busy; k++) {
                unsigned type;
                cJSON *m = raw_recv(fd, 0, &type, 5000);
                if (!m) break;
                if (type == VSD_MSG_ERROR && strcmp(jstr(m, "code"), "busy") == 0 && jnum(m, "id", NULL) == 4)
                    got_busy = 1;
                cJSON_Delete(m);
            }
            CHECK_MSG(got_busy, "a full queue must answer BUSY");
            rc = test_daemon_stop(&d2);
            for (k = 0; k < 100; k++) {
                unsigned type;
                cJSON *m = raw_recv(fd, 0, &type, 2000);
                if (!m) break;
                if (type == VSD_MSG_ERROR && strcmp(jstr(m, "code"), "shutdown") == 0) got_shutdown = 1;
                cJSON_Delete(m);
            }
            close(fd);
            CHECK_MSG(rc == 0, "SIGTERM in mid-render: exit status %d", rc);
            CHECK_MSG(got_shutdown, "clients are told about the shutdown");
            CHECK_MSG(access(d2.sock, F_OK) != 0, "SIGTERM must remove the socket");
            {
                char lock[400];
                snprintf(lock, sizeof lock, "%s.lock", d2.sock);
                CHECK(access(lock, F_OK) != 0);
            }
        } else CHECK(0);
    }

    /* 8. the cache stays under its budget while a longer sequence streams through */
    {
        const char *extra[] = {"--cache-mb", "16", NULL};
        if (test_daemon_start(&d3, g_vsd, g_dir, "d3", NULL, NULL, extra) == 0) {
            vsdc *s = NULL;
            double peak = 0, budget = 16 << 20, evictions = 0;
            int frames_ok = 0;
            if (vsdc_connect(d3.sock, NULL, &s, err, sizeof err) == 0) {
                for (i = 1; i <= 12; i++) {
                    char vpath[1200], vblob[128];
                    snprintf(vpath, sizeof vpath, "%s/fluid_data_%04d.vdb", test_data("smoke64"), i);
                    if (vsdc_upload_file(s, vpath, vblob, sizeof vblob, NULL, err, sizeof err) ||
                        vsdc_upload_file(s, g_env, eb, sizeof eb, NULL, err, sizeof err)) {
                        CHECK_MSG(0, "upload frame %d: %s", i, err);
                        break;
                    }
                    scene_json(scene, sizeof scene, vblob, eb, 1.0, 16, 9, RAYMARCH);
                    if (render_remote(s, scene, i, &res, err, sizeof err) == 0) frames_ok++;
                    else CHECK_MSG(0, "frame %d: %s", i, err);
                    vsdc_result_free(&res);
                    {
                        char *json = NULL;
                        cJSON *st;
                        vsdc_stats(s, &json, err, sizeof err);
                        st = cJSON_Parse(json ? json : "{}");
                        if (jnum(st, "cache", "peak_bytes") > peak) peak = jnum(st, "cache", "peak_bytes");
                        evictions = jnum(st, "cache", "evictions");
                        cJSON_Delete(st);
                        free(json);
                    }
                }
                vsdc_close(s);
            }
            CHECK(frames_ok == 12);
            CHECK_MSG(peak <= budget, "cache peak %.0f bytes above the budget %.0f", peak, budget);
            CHECK_MSG(evictions > 0, "a sequence larger than the budget must evict");
            printf("cache: 12 frames through a 16 MiB budget, peak %.1f MiB, %g evictions\n", peak / 1048576, evictions);
            CHECK(test_daemon_stop(&d3) == 0);
        } else CHECK(0);
    }

    /* 9. TCP: without the token, or with a wrong one, refused */
    {
        char tokfile[1200];
        FILE *f;
        snprintf(tokfile, sizeof tokfile, "%s/token", g_dir);
        f = fopen(tokfile, "w");
        fputs("s3cret-token-123\n", f);
        fclose(f);
        chmod(tokfile, 0600);
        {
            const char *extra[] = {"--tcp", "127.0.0.1:0", "--token-file", tokfile, NULL};
            if (test_daemon_start(&d4, g_vsd, g_dir, "d4", NULL, NULL, extra) == 0) {
                char ready[512] = "", addr[128] = "";
                cJSON *r;
                vsdc *s = NULL;
                size_t n;
                f = fopen(d4.ready, "r");
                n = fread(ready, 1, sizeof ready - 1, f);
                ready[n] = '\0';
                fclose(f);
                r = cJSON_Parse(ready);
                snprintf(addr, sizeof addr, "%s", jstr(r, "tcp"));
                cJSON_Delete(r);
                CHECK(strncmp(addr, "127.0.0.1:", 10) == 0);
                CHECK(vsdc_connect(addr, NULL, &s, err, sizeof err) == VSDC_ERR_SERVER && strstr(err, "auth"));
                CHECK(vsdc_connect(addr, "wrong-token-000", &s, err, sizeof err) == VSDC_ERR_SERVER && strstr(err, "auth"));
                if (vsdc_connect(addr, "s3cret-token-123", &s, err, sizeof err) == 0) {
                    char *json = NULL;
                    CHECK(vsdc_stats(s, &json, err, sizeof err) == 0);
                    free(json);
                    vsdc_close(s);
                } else CHECK_MSG(0, "TCP with the right token: %s", err);
                /* the Unix socket needs no token */
                if (vsdc_connect(d4.sock, NULL, &s, err, sizeof err) == 0) vsdc_close(s);
                else CHECK_MSG(0, "unix: %s", err);
                CHECK(test_daemon_stop(&d4) == 0);
            } else CHECK(0);
        }
        {
            /* TCP without a token file is refused at start-up */
            int status;
            pid_t p = fork();
            if (p == 0) {
                FILE *e = freopen("/dev/null", "w", stderr);
                (void)e;
                execl(g_vsd, g_vsd, "serve", "--socket", "/tmp/vsd-test-notoken.sock", "--tcp", "127.0.0.1:0",
                      (char *)NULL);
                _exit(127);
            }
            waitpid(p, &status, 0);
            CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 2);
        }
    }

    /* a kept film never costs a renderer its place: it is kept only into room the memory
     * budget has free. A first daemon measures what the map, the volume and the renderer
     * hold (STATS used_bytes less the film it keeps); with a budget of that plus half a
     * film the renderer stays cached and its film is not kept, with that plus two films it
     * is. (Counting the film by making room for it, as a renderer's growth is, evicted the
     * renderer at the first budget.) */
    {
        int flags[3][2], p, k;
        double used = 0, film = 0, base;
        for (p = 0; p < VSD_PASS_COUNT; p++) film += 400.0 * 400.0 * vsd_pass_channels((vsd_pass)p) * sizeof(float);
        if (film_budget_run("fb_probe", 2048, flags, &used) == 0) {
            CHECK_MSG(flags[1][0] && flags[1][1], "a roomy budget keeps the renderer and its film (%d %d)", flags[1][0],
                      flags[1][1]);
            base = used - film;
            printf("film budget: %.1f MB held besides a %.1f MB film\n", base / 1048576.0, film / 1048576.0);
            if (film_budget_run("fb_tight", (long)ceil((base + 0.5 * film) / 1048576.0), flags, &used) == 0)
                for (k = 1; k < 3; k++)
                    CHECK_MSG(flags[k][0] && !flags[k][1],
                              "budget for the renderer and half a film, render %d: renderer %d film %d (expected 1 0)", k,
                              flags[k][0], flags[k][1]);
            else CHECK_MSG(0, "the tight budget's daemon failed");
            if (film_budget_run("fb_room", (long)ceil((base + 2.0 * film) / 1048576.0), flags, &used) == 0)
                for (k = 1; k < 3; k++)
                    CHECK_MSG(flags[k][0] && flags[k][1],
                              "budget for the renderer and two films, render %d: renderer %d film %d (expected 1 1)", k,
                              flags[k][0], flags[k][1]);
            else CHECK_MSG(0, "the roomy budget's daemon failed");
        } else CHECK_MSG(0, "the probe daemon failed");
    }

    vsd_framebuffer_destroy(ref);
    for (i = 0; i < 3; i++) vsd_framebuffer_destroy(cams[i]);
    if (d1.pid) test_daemon_stop(&d1);
    if (d2.pid) test_daemon_stop(&d2);
    if (d3.pid) test_daemon_stop(&d3);
    if (d4.pid) test_daemon_stop(&d4);
    return test_finish("test_daemon");
}
