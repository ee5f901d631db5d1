/* The daemon's lock order (service/daemon/lock_order.h). Usage: test_daemon_locks VSD
 *
 * Proves:
 *   (a) the checker: two locks taken in the wrong order, or two of one rank, are reported
 *       (counted, and logged once per pair of ranks); the right order is not, nor locks
 *       held by different threads, nor a lock taken again after a condition wait;
 *   (b) a whole daemon, run in this process with concurrent clients on a Unix socket —
 *       uploads, HAS, STATS, renders that reuse renderers and cached volumes, a CANCEL, a
 *       disconnect in mid-render, a job past --max-job-seconds, and a shutdown with a job
 *       running — takes no lock out of order.
 *
 * The daemon runs in this process (vsdd_daemon_start, the real accept loop on a thread,
 * vsdd_daemon_stop: what `vsd serve` runs, without its signal handling) rather than as a
 * `vsd serve` child: the violation counter is then read directly, the protocol carries
 * nothing new, and a ThreadSanitizer build of this test sees every daemon thread. Decodes
 * go to the isolated loader, whose child is the real `vsd` given on the command line. */
#define _GNU_SOURCE
#include "test_common.h"
#include "daemon.h"
#include "listen.h"
#include "vsd_client.h"
#include <cjson/cJSON.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>

static char g_dir[1024], g_sock[1100];
static char g_vol[3][1024], g_env[1024];

/* ---- (a) the checker ---------------------------------------------------------------- */

typedef struct held_arg {
    vsdd_mutex *m;
    int hold, go;
} held_arg;

static void *hold_cache(void *p)
{
    held_arg *a = p;
    vsdd_lock(a->m);
    __atomic_store_n(&a->hold, 1, __ATOMIC_SEQ_CST);
    while (!__atomic_load_n(&a->go, __ATOMIC_SEQ_CST)) usleep(1000);
    vsdd_unlock(a->m);
    return NULL;
}

/* stderr into `path` while f runs; the text written goes to out. */
static void capture_stderr(const char *path, void (*f)(void *), void *arg, char *out, size_t len)
{
    int saved = dup(STDERR_FILENO), fd = open(path, O_RDWR | O_CREAT | O_TRUNC, 0600);
    ssize_t n;
    out[0] = '\0';
    if (saved < 0 || fd < 0) return;
    dup2(fd, STDERR_FILENO);
    f(arg);
    dup2(saved, STDERR_FILENO);
    close(saved);
    n = pread(fd, out, len - 1, 0);
    out[n > 0 ? n : 0] = '\0';
    close(fd);
}

static void wrong_order(void *p)
{
    vsdd_mutex *m = p; /* m[0] jobs, m[1] cache */
    vsdd_lock(&m[1]);
    vsdd_lock(&m[0]);
    vsdd_unlock(&m[0]);
    vsdd_unlock(&m[1]);
}

static void same_rank(void *p)
{
    vsdd_mutex *w = p;
    vsdd_lock(&w[0]);
    vsdd_lock(&w[1]);
    vsdd_unlock(&w[1]);
    vsdd_unlock(&w[0]);
}

static void test_checker(void)
{
    vsdd_mutex m[2], w[2], counters;
    pthread_cond_t cond = PTHREAD_COND_INITIALIZER;
    uint64_t base = vsdd_lock_violations();
    char path[1200], log[4096];
    vsdd_mutex_init(&m[0], VSDD_RANK_JOBS);
    vsdd_mutex_init(&m[1], VSDD_RANK_CACHE);
    vsdd_mutex_init(&w[0], VSDD_RANK_CONN_WRITE);
    vsdd_mutex_init(&w[1], VSDD_RANK_CONN_WRITE);
    vsdd_mutex_init(&counters, VSDD_RANK_COUNTERS);

    /* the right order, released in either order */
    vsdd_lock(&m[0]);
    vsdd_lock(&m[1]);
    vsdd_lock(&counters);
    vsdd_unlock(&counters);
    vsdd_unlock(&m[1]);
    vsdd_unlock(&m[0]);
    vsdd_lock(&m[0]);
    vsdd_lock(&m[1]);
    vsdd_unlock(&m[0]);
    vsdd_lock(&counters); /* still above the cache lock held */
    vsdd_unlock(&counters);
    vsdd_unlock(&m[1]);
    CHECK_MSG(vsdd_lock_violations() == base, "the right order was reported");

    /* the wrong order: counted once per time, logged once per pair of ranks */
    snprintf(path, sizeof path, "%s/checker.log", g_dir);
    capture_stderr(path, wrong_order, m, log, sizeof log);
    CHECK_MSG(vsdd_lock_violations() == base + 1, "cache then jobs: %llu violations, expected 1",
              (unsigned long long)(vsdd_lock_violations() - base));
    CHECK_CONTAINS(log, "lock order violated: jobs (rank 1) taken while holding cache");
    capture_stderr(path, wrong_order, m, log, sizeof log);
    CHECK(vsdd_lock_violations() == base + 2);
    CHECK_MSG(strstr(log, "lock order violated") == NULL, "the same pair was logged twice: %s", log);

    /* two locks of one rank (two connections' writers) at once */
    capture_stderr(path, same_rank, w, log, sizeof log);
    CHECK_MSG(vsdd_lock_violations() == base + 3, "two locks of one rank were not reported");
    CHECK_CONTAINS(log, "conn_write (rank 6) taken while holding conn_write");

    /* one thread's locks do not constrain another's */
    {
        held_arg a = {&m[1], 0, 0};
        pthread_t t;
        pthread_create(&t, NULL, hold_cache, &a);
        while (!__atomic_load_n(&a.hold, __ATOMIC_SEQ_CST)) usleep(1000);
        vsdd_lock(&m[0]);
        vsdd_unlock(&m[0]);
        __atomic_store_n(&a.go, 1, __ATOMIC_SEQ_CST);
        pthread_join(t, NULL);
        CHECK_MSG(vsdd_lock_violations() == base + 3, "a lock held by another thread was counted");
    }

    /* a condition wait gives the lock back and takes it again: still held after it */
    {
        struct timespec until = vsdd_deadline_ms(1);
        vsdd_lock(&m[1]);
        vsdd_cond_timedwait(&cond, &m[1], &until);
        vsdd_lock(&counters);
        vsdd_unlock(&counters);
        CHECK_MSG(vsdd_lock_violations() == base + 3, "a lock above the one waited on was reported");
        vsdd_lock(&m[0]);
        vsdd_unlock(&m[0]);
        vsdd_unlock(&m[1]);
        CHECK_MSG(vsdd_lock_violations() == base + 4, "a lock below the one waited on was not reported");
    }
    vsdd_mutex_destroy(&m[0]);
    vsdd_mutex_destroy(&m[1]);
    vsdd_mutex_destroy(&w[0]);
    vsdd_mutex_destroy(&w[1]);
    vsdd_mutex_destroy(&counters);
    printf("checker: wrong orders and same ranks reported, right orders not\n");
}

/* ---- (b) a daemon with concurrent clients --------------------------------------------- */

static void scene_json(char *out, size_t len, const char *vol, const char *env, double cam_x, const char *render)
{
    snprintf(out, len,
             "{\"version\":1,\"volume\":{\"file\":\"%s\",\"grid\":\"density\"},\"medium\":{\"density\":8},"
             "\"environment\":{\"file\":\"%s\"},"
             "\"camera\":{\"position\":[%g,-3.9745,1.8771],\"look_at\":[1,1,1],\"up\":[0,0,1],\"fov\":0.7},"
             "\"film\":{\"width\":24,\"height\":16},\"render\":{%s}}",
             vol, env, cam_x, render);
}
#define RAYMARCH "\"method\":\"raymarch\",\"options\":{\"lights\":8}"
#define SLOW "\"method\":\"reference\",\"samples\":1000000"

enum { ROLE_RENDER, ROLE_CANCEL, ROLE_DISCONNECT, ROLE_TIMEOUT, ROLE_STATS, ROLE_SHUTDOWN };

typedef struct client {
    int role, index;
    int ok;                        /* the role's outcome came */
    char detail[512];
    volatile int *renders_left;    /* ROLE_STATS polls until the renderers are done */
} client;

typedef struct later {
    volatile int *flag;
    int fd;
    double delay;
} later;

static void *act_later(void *p)
{
    later *a = p;
    usleep((useconds_t)(a->delay * 1e6));
    if (a->flag) *a->flag = 1;
    if (a->fd >= 0) shutdown(a->fd, SHUT_RDWR); /* a client that vanishes in mid-render */
    return NULL;
}

static int upload(vsdc *c, int vol, char *vb, char *eb, char *err, size_t errlen)
{
    return vsdc_upload_file(c, g_vol[vol], vb, 128, NULL, err, errlen) ||
           vsdc_upload_file(c, g_env, eb, 128, NULL, err, errlen);
}

/* One render that is meant to be stopped; the ERROR code it ended with, or "" / "(result)". */
static void stopped_render(vsdc *c, const char *scene, volatile int *cancel, later *act, char *code, size_t len)
{
    vsdc_render_request rq;
    vsdc_result res;
    char err[1024];
    pthread_t t;
    memset(&rq, 0, sizeof rq);
    rq.scene_json = scene;
    rq.cancel = cancel;
    if (act) pthread_create(&t, NULL, act_later, act);
    if (vsdc_render(c, &rq, &res, err, sizeof err) == 0) {
        snprintf(code, len, "(result)");
        vsdc_result_free(&res);
    } else {
        snprintf(code, len, "%s", vsdc_error_code(c));
    }
    if (act) pthread_join(t, NULL);
}

static void role_render(client *a, vsdc *c)
{
    char err[1024], scene[4096], vb[128], eb[128];
    int k, done = 0;
    if (upload(c, a->index % 3, vb, eb, err, sizeof err)) {
        snprintf(a->detail, sizeof a->detail, "upload: %s", err);
        return;
    }
    for (k = 0; k < 3; k++) {
        vsdc_render_request rq;
        vsdc_result res;
        memset(&rq, 0, sizeof rq);
        scene_json(scene, sizeof scene, vb, eb, 0.5 + 0.5 * ((a->index + k) % 3), RAYMARCH);
        rq.scene_json = scene;
        if (vsdc_render(c, &rq, &res, err, sizeof err)) {
            snprintf(a->detail, sizeof a->detail, "render %d: %s", k, err);
            break;
        }
        done += res.exr_len > 0;
        vsdc_result_free(&res);
    }
    a->ok = done == 3;
}

static void role_stopped(client *a, vsdc *c)
{
    static const char *const expect[] = {[ROLE_CANCEL] = "cancelled", [ROLE_TIMEOUT] = "timeout",
                                         [ROLE_SHUTDOWN] = "shutdown"};
    char err[1024], scene[4096], vb[128], eb[128], code[64];
    volatile int flag = 0;
    later act = {&flag, -1, 0.4};
    if (upload(c, 0, vb, eb, err, sizeof err)) {
        snprintf(a->detail, sizeof a->detail, "upload: %s", err);
        return;
    }
    scene_json(scene, sizeof scene, vb, eb, 1.0, SLOW);
    if (a->role == ROLE_DISCONNECT) act.fd = vsdc_fd(c), act.flag = NULL;
    stopped_render(c, scene, a->role == ROLE_CANCEL ? &flag : NULL,
                   a->role == ROLE_CANCEL || a->role == ROLE_DISCONNECT ? &act : NULL, code, sizeof code);
    /* a disconnected client only sees its connection fail */
    a->ok = a->role == ROLE_DISCONNECT ? strcmp(code, "(result)") != 0 : strcmp(code, expect[a->role]) == 0;
    snprintf(a->detail, sizeof a->detail, "ended with \"%s\"", code);
}

static void role_stats(client *a, vsdc *c)
{
    char err[1024], *json;
    const char *hashes[1] = {"00000000000000000000000000000000"};
    int missing[1], rounds = 0;
    a->ok = 1;
    while (__atomic_load_n(a->renders_left, __ATOMIC_SEQ_CST) > 0 && rounds < 2000) {
        json = NULL;
        if (vsdc_stats(c, &json, err, sizeof err) || vsdc_has(c, hashes, 1, missing, err, sizeof err)) {
            snprintf(a->detail, sizeof a->detail, "stats/has: %s", err);
            a->ok = 0;
            free(json);
            return;
        }
        free(json);
        rounds++;
        usleep(20000);
    }
}

static void *client_main(void *p)
{
    client *a = p;
    vsdc *c = NULL;
    char err[1024];
    if (vsdc_connect(g_sock, NULL, &c, err, sizeof err)) {
        snprintf(a->detail, sizeof a->detail, "connect: %s", err);
        return NULL;
    }
    if (a->role == ROLE_RENDER) role_render(a, c);
    else if (a->role == ROLE_STATS) role_stats(a, c);
    else role_stopped(a, c);
    if (a->role == ROLE_RENDER) __atomic_fetch_sub(a->renders_left, 1, __ATOMIC_SEQ_CST);
    vsdc_close(c);
    return NULL;
}

typedef struct acceptor {
    vsdd_daemon *d;
    int stop_fd, ufd;
} acceptor;

static void *accept_main(void *p)
{
    acceptor *a = p;
    vsdd_accept_loop(a->d, a->stop_fd, a->ufd, -1);
    return NULL;
}

static void config(vsdd_config *c, const char *vsd)
{
    memset(c, 0, sizeof *c);
    snprintf(c->socket_path, sizeof c->socket_path, "%s", g_sock);
    snprintf(c->cache_parent, sizeof c->cache_parent, "%s", g_dir);
    c->cache_bytes = 64ull << 20;
    c->blob_bytes = 64ull << 20;
    c->workers = 2;
    c->threads = 1;
    c->queue_max = 32;
    c->max_connections = 32;
    c->max_message = 64ull << 20;
    c->max_json = 1u << 20;
    c->max_dim = 512;
    c->max_pixels = 1u << 20;
    c->max_voxels = 1000000000ull;
    c->max_job_seconds = 3; /* the ROLE_TIMEOUT job runs past it */
    c->log_level = VSDD_LOG_ERROR;
    c->loader = VSDD_LOADER_ISOLATED;
#if defined(__SANITIZE_THREAD__)
    /* the loader's child runs under --loader-mb's address-space limit, in which
     * ThreadSanitizer's own allocator cannot start: decode in the daemon instead */
    c->loader = VSDD_LOADER_INPROCESS;
#endif
    c->loader_bytes = 2048ull << 20;
    c->loader_seconds = 60;
    snprintf(c->loader_exe, sizeof c->loader_exe, "%s", vsd);
}

static void test_daemon_run(const char *vsd)
{
    static vsdd_daemon d; /* static: a reader outliving the stop never sees it go away */
    static const int roles[] = {ROLE_RENDER, ROLE_RENDER, ROLE_RENDER, ROLE_RENDER, ROLE_CANCEL,
                                ROLE_DISCONNECT, ROLE_TIMEOUT, ROLE_STATS};
    enum { N = sizeof roles / sizeof roles[0] };
    client cl[N], last;
    pthread_t t[N], acc_t, last_t;
    acceptor acc;
    char err[1024];
    int stop[2], i, queued = 0, running = 0, waited;
    volatile int renders_left = 4;
    uint64_t base = vsdd_lock_violations(), counts[VSDD_COUNT_KINDS];
    config(&d.cfg, vsd);
    vsdd_log_set_level(d.cfg.log_level);
    d.start_time = vsd_clock_seconds();
    acc.ufd = vsdd_listen_unix(g_sock, err, sizeof err);
    if (acc.ufd < 0 || pipe(stop) != 0 || vsdd_daemon_start(&d, err, sizeof err)) {
        CHECK_MSG(0, "cannot start the daemon: %s", err);
        return;
    }
    acc.d = &d;
    acc.stop_fd = stop[0];
    pthread_create(&acc_t, NULL, accept_main, &acc);

    memset(cl, 0, sizeof cl);
    for (i = 0; i < N; i++) {
        cl[i].role = roles[i];
        cl[i].index = i;
        cl[i].renders_left = &renders_left;
        pthread_create(&t[i], NULL, client_main, &cl[i]);
    }
    for (i = 0; i < N; i++) pthread_join(t[i], NULL);
    for (i = 0; i < N; i++) CHECK_MSG(cl[i].ok, "client %d (role %d): %s", i, cl[i].role, cl[i].detail);

    /* the stopped jobs end on their workers a little after their clients return */
    for (waited = 0; waited < 1000 && (queued || running || waited == 0); waited++) {
        usleep(10000);
        vsdd_jobs_counts(d.jobs, &queued, &running);
    }
    /* shutdown with a job running: it is cancelled and its client told */
    memset(&last, 0, sizeof last);
    last.role = ROLE_SHUTDOWN;
    pthread_create(&last_t, NULL, client_main, &last);
    for (waited = 0; waited < 1000 && running == 0; waited++) {
        usleep(10000);
        vsdd_jobs_counts(d.jobs, &queued, &running);
    }
    CHECK_MSG(running == 1, "the last job did not start");
    vsdd_counters_get(d.counters, counts);
    if (write(stop[1], "\017", 1) != 1) {}
    pthread_join(acc_t, NULL);
    close(acc.ufd);
    unlink(g_sock);
    vsdd_daemon_stop(&d);
    pthread_join(last_t, NULL);
    CHECK_MSG(last.ok, "the job running at shutdown: %s", last.detail);
    close(stop[0]);
    close(stop[1]);

    CHECK_MSG(counts[VSDD_COUNT_DONE] >= 12, "%llu jobs done, expected 12",
              (unsigned long long)counts[VSDD_COUNT_DONE]);
    CHECK_MSG(counts[VSDD_COUNT_CANCELLED] >= 3, "%llu jobs cancelled, expected 3 (cancel, disconnect, timeout)",
              (unsigned long long)counts[VSDD_COUNT_CANCELLED]);
    CHECK_MSG(d.jobs == NULL && d.cache == NULL, "the daemon's modules were not freed (a reader still ran)");
    CHECK_MSG(vsdd_lock_violations() == base, "%llu lock order violation(s) in a daemon run (see the log above)",
              (unsigned long long)(vsdd_lock_violations() - base));
    printf("daemon run: %llu jobs done, %llu cancelled, %llu lock order violations\n",
           (unsigned long long)counts[VSDD_COUNT_DONE], (unsigned long long)counts[VSDD_COUNT_CANCELLED],
           (unsigned long long)(vsdd_lock_violations() - base));
}

int main(int argc, char **argv)
{
    char cmd[1200];
    int i;
    if (argc < 2) {
        fprintf(stderr, "usage: test_daemon_locks VSD\n");
        return 2;
    }
    signal(SIGPIPE, SIG_IGN);
    snprintf(g_dir, sizeof g_dir, "%s", test_tmp("daemon_locks"));
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", g_dir, g_dir);
    if (system(cmd) != 0) return 1;
    snprintf(g_sock, sizeof g_sock, "%s/d.sock", g_dir);
    test_checker();
    for (i = 0; i < 3; i++) snprintf(g_vol[i], sizeof g_vol[i], "%s", test_data(i == 0 ? "smoke64/fluid_data_0001.vdb"
                                                                         : i == 1 ? "smoke64/fluid_data_0002.vdb"
                                                                                  : "smoke64/fluid_data_0003.vdb"));
    snprintf(g_env, sizeof g_env, "%s", test_data("env/sunset.exr"));
    if (access(g_vol[0], R_OK) != 0 || access(g_env, R_OK) != 0) {
        fprintf(stderr, "no shared data (%s): the daemon run is skipped\n", g_vol[0]);
        return test_finish("test_daemon_locks");
    }
    test_daemon_run(argv[1]);
    return test_finish("test_daemon_locks");
}
