/* libFuzzer target for the daemon's message handlers: the real connection handler of
 * service/daemon/conn.c (its reader thread, HELLO/HAS/PUT/RENDER/CANCEL/STATS/BYE, the blob
 * cache, the job queue and render_job.c's RENDER parsing and checks) runs in this process,
 * and the input is what a client sends on one connection.
 *
 * Input: byte 0 bit 0 says whether the connection counts as TCP (token required); the rest
 * is the client's byte stream. The harness cuts the stream into frames by their headers'
 * own lengths (as the daemon reads them; a frame that runs past the end is sent truncated,
 * last) and after each complete frame sends a sentinel frame of an unknown type, whose
 * ERROR reply proves that every earlier frame has been handled; RENDER jobs are then
 * waited for. That keeps each input deterministic: the jobs run rather than racing the
 * disconnect. At the end the client half-closes and reads until the daemon closes; the
 * blob cache is emptied between inputs so no input depends on an earlier one.
 *
 * Limits are small (64 KiB JSON, 1 MiB blobs, 32x32 films, 2 s jobs) so a render that a
 * mutated scene asks for stays cheap; a job that ignores its limit shows up as a timeout. */
#define _GNU_SOURCE
#include "daemon.h"
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#define SENTINEL_TYPE 0x7ff0
#define SENTINEL_ID "-424242"
#define SENTINEL_KEY "\"id\":" SENTINEL_ID ","
#define IO_TIMEOUT_MS 20000 /* nothing from the daemon for this long: a hang, abort */

static char g_root[256];
static vsdd_daemon g_d; /* the daemon this harness runs in its own process */

static void write_file(const char *dir, const char *name, const void *data, size_t len)
{
    char p[512];
    FILE *f;
    snprintf(p, sizeof p, "%s/%s", dir, name);
    f = fopen(p, "wb");
    if (f) {
        if (len) fwrite(data, 1, len, f);
        fclose(f);
    }
}

static void remove_tree(const char *dir)
{
    char cmd[600];
    /* only our own mkdtemp folder; nothing else can match the template */
    if (strncmp(dir, "/tmp/vsd-fuzz-daemon-", 21) == 0) {
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
        if (system(cmd) != 0) {}
    }
}

static void daemon_stop(void)
{
    vsdd_daemon_stop(&g_d);
    remove_tree(g_root);
}

static void daemon_start(void)
{
    vsdd_config *c = &g_d.cfg;
    char allow[300], err[512];
    const char *log = getenv("VSD_FUZZ_LOG");
    snprintf(g_root, sizeof g_root, "/tmp/vsd-fuzz-daemon-XXXXXX");
    if (!mkdtemp(g_root)) {
        perror("fuzz_daemon: mkdtemp");
        abort();
    }
    /* --allow-path: server-side paths resolve here; a non-VDB and an empty file give errors */
    snprintf(allow, sizeof allow, "%s/allow", g_root);
    mkdir(allow, 0700);
    write_file(allow, "not_a.vdb", "not a vdb\n", 10);
    write_file(allow, "empty.hdr", "", 0);
    write_file(allow, "map.hdr", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n\x80\x80\x80\x81", 47);
    memset(c, 0, sizeof *c);
    if (!realpath(allow, c->allow[0])) abort();
    c->allow_count = 1;
    snprintf(c->cache_parent, sizeof c->cache_parent, "%s", g_root);
    snprintf(c->token, sizeof c->token, "fuzz-token-0123");
    c->cache_bytes = 8u << 20;
    c->blob_bytes = 32u << 20;
    c->workers = 1;
    c->threads = 1;
    c->queue_max = 4;
    c->max_connections = 4;
    c->max_message = 1u << 20;
    c->max_json = 64u << 10;
    c->max_dim = 32;
    c->max_pixels = 1024;
    c->max_voxels = 1u << 20;
    c->max_job_seconds = 2;
    c->log_level = log && *log ? atoi(log) : -1; /* -1: silent; VSD_FUZZ_LOG=3 shows everything */
    c->loader = VSDD_LOADER_INPROCESS; /* decode here, where the sanitizers and coverage see it */
    vsdd_log_set_level(c->log_level);
    g_d.start_time = vsd_clock_seconds();
    signal(SIGPIPE, SIG_IGN);
    if (vsdd_daemon_start(&g_d, err, sizeof err)) {
        fprintf(stderr, "fuzz_daemon: cannot start the daemon: %s\n", err);
        abort();
    }
    atexit(daemon_stop);
}

/* The replies, parsed as they arrive: only whether the sentinel's ERROR came back matters. */
typedef struct replies {
    unsigned char *buf;
    size_t len, cap;
    int eof, sentinels;
} replies;

static void scan_replies(replies *r)
{
    size_t at = 0;
    while (r->len - at >= VSD_PROTO_HEADER_SIZE) {
        vsd_frame_header h;
        size_t total;
        if (vsd_proto_unpack_header(r->buf + at, &h)) abort(); /* the daemon sent garbage */
        total = VSD_PROTO_HEADER_SIZE + (size_t)h.json_len + (size_t)h.bin_len;
        if (r->len - at < total) break;
        if (h.type == VSD_MSG_ERROR &&
            memmem(r->buf + at + VSD_PROTO_HEADER_SIZE, h.json_len, SENTINEL_KEY, sizeof SENTINEL_KEY - 1))
            r->sentinels++;
        at += total;
    }
    memmove(r->buf, r->buf + at, r->len - at);
    r->len -= at;
}

/* Read what is there (wait up to timeout_ms for the first byte). */
static void pump(int fd, replies *r, int timeout_ms)
{
    struct pollfd p = {fd, POLLIN, 0};
    if (r->eof) return;
    if (poll(&p, 1, timeout_ms) <= 0) return;
    for (;;) {
        ssize_t n;
        if (r->cap - r->len < 65536) {
            size_t cap = r->cap ? r->cap * 2 : 131072;
            unsigned char *b = realloc(r->buf, cap);
            if (!b) abort();
            r->buf = b;
            r->cap = cap;
        }
        n = recv(fd, r->buf + r->len, r->cap - r->len, MSG_DONTWAIT);
        if (n > 0) {
            r->len += (size_t)n;
            continue;
        }
        if (n == 0 || (errno != EAGAIN && errno != EINTR)) r->eof = 1;
        break;
    }
    scan_replies(r);
}

/* Send everything, reading replies meanwhile (a daemon blocked writing to us cannot read).
 * Returns -1 when the daemon has closed. */
static int send_all(int fd, replies *r, const uint8_t *data, size_t len)
{
    size_t done = 0;
    while (done < len) {
        struct pollfd p = {fd, POLLIN | POLLOUT, 0};
        if (r->eof || poll(&p, 1, IO_TIMEOUT_MS) <= 0) return -1;
        if (p.revents & POLLIN) pump(fd, r, 0);
        if (p.revents & POLLOUT) {
            ssize_t n = send(fd, data + done, len - done, MSG_DONTWAIT | MSG_NOSIGNAL);
            if (n < 0 && errno != EAGAIN && errno != EINTR) return -1;
            if (n > 0) done += (size_t)n;
        }
        if ((p.revents & (POLLERR | POLLHUP)) && !(p.revents & POLLOUT)) return -1;
    }
    return 0;
}

static int daemon_busy(int *conns)
{
    int queued, running, listed, readers;
    vsdd_jobs_counts(g_d.jobs, &queued, &running);
    vsdd_conns_counts(g_d.conns, &listed, &readers);
    *conns = listed + readers;
    return queued > 0 || running > 0;
}

/* The daemon is idle between inputs: stopped and started again, with an empty cache. */
static void reset_cache(void)
{
    char err[512];
    vsdd_daemon_stop(&g_d);
    if (vsdd_daemon_start(&g_d, err, sizeof err)) {
        fprintf(stderr, "fuzz_daemon: %s\n", err);
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int started;
    static const char sentinel_json[] = "{\"id\":" SENTINEL_ID ",\"x\":0}";
    unsigned char sentinel[VSD_PROTO_HEADER_SIZE + sizeof sentinel_json - 1];
    vsd_frame_header sh = {VSD_PROTO_VERSION, SENTINEL_TYPE, sizeof sentinel_json - 1, 0};
    replies r = {NULL, 0, 0, 0, 0};
    size_t at = 1;
    int sv[2], conns = 0, waited;
    if (!started) {
        daemon_start();
        started = 1;
    }
    if (size < 1) return 0;
    vsd_proto_pack_header(&sh, sentinel);
    memcpy(sentinel + VSD_PROTO_HEADER_SIZE, sentinel_json, sizeof sentinel_json - 1);
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) return 0;
    vsdd_conn_start(&g_d, sv[1], data[0] & 1, "fuzz"); /* the daemon owns sv[1] from here */

    while (at < size && !r.eof) {
        size_t left = size - at, len = left;
        int want, complete = 0;
        if (left >= VSD_PROTO_HEADER_SIZE) {
            const uint8_t *p = data + at;
            uint64_t jl = ((uint64_t)p[8] << 24) | ((uint64_t)p[9] << 16) | ((uint64_t)p[10] << 8) | p[11];
            uint64_t bl = 0;
            for (int i = 12; i < 20; i++) bl = (bl << 8) | p[i];
            if (jl <= left - VSD_PROTO_HEADER_SIZE && bl <= left - VSD_PROTO_HEADER_SIZE - jl) {
                len = VSD_PROTO_HEADER_SIZE + (size_t)jl + (size_t)bl;
                complete = 1;
            }
        }
        if (send_all(sv[0], &r, data + at, len)) break;
        at += len;
        if (!complete) break; /* a truncated last frame: the daemon waits for the rest */
        want = r.sentinels + 1;
        if (send_all(sv[0], &r, sentinel, sizeof sentinel)) break;
        for (waited = 0; r.sentinels < want && !r.eof; waited += 100) {
            if (waited > IO_TIMEOUT_MS) abort(); /* the daemon stopped answering: a hang */
            pump(sv[0], &r, 100);
        }
        /* RENDER jobs run to their end before the next frame */
        for (waited = 0; daemon_busy(&conns) && !r.eof; waited++) {
            if (waited > IO_TIMEOUT_MS) abort();
            pump(sv[0], &r, 1);
        }
    }
    /* half-close: the daemon reads EOF, cancels what is left and closes its end */
    shutdown(sv[0], SHUT_WR);
    for (waited = 0; !r.eof; waited += 100) {
        if (waited > IO_TIMEOUT_MS) abort();
        pump(sv[0], &r, 100);
    }
    close(sv[0]);
    /* the connection is freed under the lock once its last reference goes */
    for (waited = 0; daemon_busy(&conns) || conns > 0; waited++) {
        if (waited > IO_TIMEOUT_MS) abort();
        usleep(1000);
    }
    free(r.buf);
    reset_cache();
    return 0;
}
