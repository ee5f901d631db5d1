/* `vsd serve`: options, start-up (lock, sockets, cache, workers), the accept loop and a
 * clean shutdown on SIGTERM/SIGINT (jobs cancelled, clients told, socket removed). */
#define _GNU_SOURCE
#include "daemon.h"
#include "listen.h"
#include "serve.h"
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <netinet/in.h>
#include <arpa/inet.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

vsdd_daemon g_daemon = {.lock = PTHREAD_MUTEX_INITIALIZER,
                        .queue_cond = PTHREAD_COND_INITIALIZER,
                        .idle_cond = PTHREAD_COND_INITIALIZER};

static int signal_pipe[2] = {-1, -1};

double vsdd_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void on_signal(int sig)
{
    unsigned char b = (unsigned char)sig;
    int saved = errno;
    if (write(signal_pipe[1], &b, 1) < 0) {}
    errno = saved;
}

int vsdd_path_allowed(const char *path, char *resolved, size_t len)
{
    char real[PATH_MAX];
    int i;
    if (!realpath(path, real)) return -1;
    for (i = 0; i < g_daemon.cfg.allow_count; i++) {
        const char *dir = g_daemon.cfg.allow[i];
        size_t n = strlen(dir);
        if (strncmp(real, dir, n) == 0 && (real[n] == '/' || (n == 1 && dir[0] == '/'))) {
            struct stat st;
            if (stat(real, &st) != 0 || !S_ISREG(st.st_mode)) return -1;
            if (strlen(real) >= len) return -1;
            snprintf(resolved, len, "%s", real);
            return 0;
        }
    }
    return -1;
}

static void serve_usage(FILE *f)
{
    fprintf(f,
            "usage: vsd serve [options]\n"
            "  --socket PATH          Unix socket (default $XDG_RUNTIME_DIR/vsd.sock, else /tmp/vsd-$UID.sock)\n"
            "  --tcp HOST:PORT        also listen on TCP (127.0.0.1 unless --listen-any; needs --token-file)\n"
            "  --listen-any           allow a non-loopback --tcp address\n"
            "  --token-file FILE      token TCP clients must send in HELLO\n"
            "  --allow-path DIR       RENDER may name files under DIR (repeatable; default: blobs only)\n"
            "  --cache-mb N           memory budget of all caches (default 2048)\n"
            "  --cache-dir DIR        where blob files live (default $TMPDIR or /tmp)\n"
            "  --method-cache DIR     where methods keep work between runs, e.g. crm's RBF fits (default\n"
            "                         $VSD_CACHE_DIR, else $XDG_CACHE_HOME/vsd or ~/.cache/vsd; 'none' = off)\n"
            "  --workers N            jobs rendered at once (default 1)\n"
            "  --threads N            CPU threads per job (default: all cores / workers)\n"
            "  --queue N              jobs that may wait; more are refused with BUSY (default 16)\n"
            "  --max-connections N    (default 64)\n"
            "  --max-message-mb N     largest binary part (a PUT blob) (default 1024)\n"
            "  --max-json-kb N        largest JSON part (default 1024)\n"
            "  --max-size N           largest film width or height (default 16384)\n"
            "  --max-pixels N         largest film width*height (default 67108864)\n"
            "  --max-voxels N         most active voxels of one grid (default 1000000000)\n"
            "  --max-job-seconds S    a job running longer is cancelled (default 3600, 0 = no limit)\n"
            "  --log-level L          error, warn, info (default) or debug\n"
            "  --lock-file PATH       pid/lock file (default SOCKET.lock)\n"
            "  --ready-file PATH      write {\"socket\",\"tcp\",\"pid\"} JSON here once listening\n");
}

static int parse_u64(const char *flag, const char *v, uint64_t lo, uint64_t hi, uint64_t *out)
{
    char *end;
    unsigned long long x;
    errno = 0;
    x = strtoull(v, &end, 10);
    if (errno || end == v || *end || v[0] == '-' || x < lo || x > hi) {
        fprintf(stderr, "vsd serve: %s: expected an integer in %llu..%llu, got '%s'\n", flag, (unsigned long long)lo,
                (unsigned long long)hi, v);
        return -1;
    }
    *out = x;
    return 0;
}

static int read_token(const char *path, char *out, size_t len)
{
    FILE *f = fopen(path, "r");
    struct stat st;
    size_t n;
    if (!f) {
        fprintf(stderr, "vsd serve: --token-file %s: %s\n", path, strerror(errno));
        return -1;
    }
    if (fstat(fileno(f), &st) == 0 && (st.st_mode & 077))
        fprintf(stderr, "vsd serve: warning: %s is readable by others (chmod 600 it)\n", path);
    n = fread(out, 1, len - 1, f);
    fclose(f);
    out[n] = '\0';
    while (n > 0 && (out[n - 1] == '\n' || out[n - 1] == '\r' || out[n - 1] == ' ' || out[n - 1] == '\t')) out[--n] = '\0';
    if (n < 8) {
        fprintf(stderr, "vsd serve: --token-file %s: the token must have at least 8 characters\n", path);
        return -1;
    }
    return 0;
}

/* Returns -1 to go on, else an exit code. */
static int parse_args(int argc, char **argv, char *ready_file, size_t ready_len)
{
    vsdd_config *c = &g_daemon.cfg;
    const char *xdg = getenv("XDG_RUNTIME_DIR"), *tmp = getenv("TMPDIR");
    const char *token_file = NULL;
    uint64_t v;
    int i;
    memset(c, 0, sizeof *c);
    if (xdg && xdg[0]) snprintf(c->socket_path, sizeof c->socket_path, "%s/vsd.sock", xdg);
    else snprintf(c->socket_path, sizeof c->socket_path, "/tmp/vsd-%ld.sock", (long)getuid());
    snprintf(c->cache_parent, sizeof c->cache_parent, "%s", tmp && tmp[0] ? tmp : "/tmp");
    c->cache_bytes = 2048ull << 20;
    if (!vsd_default_cache_dir(c->method_cache, sizeof c->method_cache)) c->method_cache[0] = '\0';
    c->workers = 1;
    c->queue_max = 16;
    c->max_connections = 64;
    c->max_message = 1024ull << 20;
    c->max_json = 1024u << 10;
    c->max_dim = 16384;
    c->max_pixels = 67108864ull;
    c->max_voxels = 1000000000ull;
    c->max_job_seconds = 3600;
    c->log_level = VSDD_LOG_INFO;
    ready_file[0] = '\0';
    for (i = 1; i < argc; i++) {
        const char *a = argv[i], *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            serve_usage(stdout);
            return 0;
        }
        if (!strcmp(a, "--listen-any")) {
            c->listen_any = 1;
            continue;
        }
        if (!val) {
            fprintf(stderr, "vsd serve: %s needs a value (see vsd serve --help)\n", a);
            return 2;
        }
        i++;
        if (!strcmp(a, "--socket")) {
            if (strlen(val) >= sizeof c->socket_path) {
                fprintf(stderr, "vsd serve: --socket: path too long\n");
                return 2;
            }
            snprintf(c->socket_path, sizeof c->socket_path, "%s", val);
        } else if (!strcmp(a, "--tcp")) snprintf(c->tcp, sizeof c->tcp, "%s", val);
        else if (!strcmp(a, "--token-file")) token_file = val;
        else if (!strcmp(a, "--allow-path")) {
            char real[PATH_MAX];
            struct stat st;
            if (c->allow_count >= VSDD_MAX_ALLOW || !realpath(val, real) || stat(real, &st) || !S_ISDIR(st.st_mode) ||
                strlen(real) >= VSD_PATH_LEN) {
                fprintf(stderr, "vsd serve: --allow-path %s: not an existing folder (or more than %d)\n", val,
                        VSDD_MAX_ALLOW);
                return 2;
            }
            memcpy(c->allow[c->allow_count++], real, strlen(real) + 1); /* length checked above */
        } else if (!strcmp(a, "--cache-mb")) {
            if (parse_u64(a, val, 1, 1ull << 24, &v)) return 2;
            c->cache_bytes = v << 20;
        } else if (!strcmp(a, "--cache-dir")) snprintf(c->cache_parent, sizeof c->cache_parent, "%s", val);
        else if (!strcmp(a, "--method-cache"))
            snprintf(c->method_cache, sizeof c->method_cache, "%s", strcmp(val, "none") ? val : "");
        else if (!strcmp(a, "--workers")) {
            if (parse_u64(a, val, 1, 256, &v)) return 2;
            c->workers = (int)v;
        } else if (!strcmp(a, "--threads")) {
            if (parse_u64(a, val, 0, 4096, &v)) return 2;
            c->threads = (int)v;
        } else if (!strcmp(a, "--queue")) {
            if (parse_u64(a, val, 0, 100000, &v)) return 2;
            c->queue_max = (int)v;
        } else if (!strcmp(a, "--max-connections")) {
            if (parse_u64(a, val, 1, 100000, &v)) return 2;
            c->max_connections = (int)v;
        } else if (!strcmp(a, "--max-message-mb")) {
            if (parse_u64(a, val, 1, 1ull << 24, &v)) return 2;
            c->max_message = v << 20;
        } else if (!strcmp(a, "--max-json-kb")) {
            if (parse_u64(a, val, 1, 1u << 20, &v)) return 2;
            c->max_json = (uint32_t)(v << 10);
        } else if (!strcmp(a, "--max-size")) {
            if (parse_u64(a, val, 1, 16384, &v)) return 2;
            c->max_dim = (int)v;
        } else if (!strcmp(a, "--max-pixels")) {
            if (parse_u64(a, val, 1, 67108864ull, &v)) return 2;
            c->max_pixels = v;
        } else if (!strcmp(a, "--max-voxels")) {
            if (parse_u64(a, val, 1, UINT64_MAX >> 1, &v)) return 2;
            c->max_voxels = v;
        } else if (!strcmp(a, "--max-job-seconds")) {
            char *end;
            double s = strtod(val, &end);
            if (end == val || *end || !(s >= 0) || s > 1e7) {
                fprintf(stderr, "vsd serve: --max-job-seconds: expected seconds >= 0, got '%s'\n", val);
                return 2;
            }
            c->max_job_seconds = s;
        } else if (!strcmp(a, "--log-level")) {
            static const char *const levels[] = {"error", "warn", "info", "debug"};
            int k;
            for (k = 0; k < 4 && strcmp(val, levels[k]); k++) {}
            if (k == 4) {
                fprintf(stderr, "vsd serve: --log-level: expected error, warn, info or debug\n");
                return 2;
            }
            c->log_level = k;
        } else if (!strcmp(a, "--lock-file")) snprintf(c->lock_path, sizeof c->lock_path, "%s", val);
        else if (!strcmp(a, "--ready-file")) snprintf(ready_file, ready_len, "%s", val);
        else {
            fprintf(stderr, "vsd serve: unknown option '%s' (see vsd serve --help)\n", a);
            return 2;
        }
    }
    if (c->tcp[0] && !token_file) {
        fprintf(stderr, "vsd serve: --tcp needs --token-file (TCP clients must authenticate)\n");
        return 2;
    }
    if (token_file && read_token(token_file, c->token, sizeof c->token)) return 2;
    if (!c->lock_path[0]) snprintf(c->lock_path, sizeof c->lock_path, "%s.lock", c->socket_path);
    if (c->threads == 0 && c->workers > 1) {
        long cores = sysconf(_SC_NPROCESSORS_ONLN);
        c->threads = cores > c->workers ? (int)(cores / c->workers) : 1;
    }
    return -1;
}

static void write_ready_file(const char *path, const char *tcp_bound)
{
    char tmp[VSD_PATH_LEN + 16];
    FILE *f;
    cJSON *o = cJSON_CreateObject();
    char *text;
    cJSON_AddStringToObject(o, "socket", g_daemon.cfg.socket_path);
    if (tcp_bound[0]) cJSON_AddStringToObject(o, "tcp", tcp_bound);
    else cJSON_AddNullToObject(o, "tcp");
    cJSON_AddNumberToObject(o, "pid", (double)getpid());
    text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    f = fopen(tmp, "w");
    if (f && text) {
        fputs(text, f);
        fputc('\n', f);
        if (fclose(f) == 0) rename(tmp, path);
    } else if (f) fclose(f);
    free(text);
}

int vsd_cmd_serve(int argc, char **argv)
{
    char err[1024], ready[VSD_PATH_LEN], tcp_bound[300] = "";
    int rc = parse_args(argc, argv, ready, sizeof ready), lock_fd, ufd, tfd = -1;
    sigset_t block, old;
    struct sigaction sa;
    if (rc >= 0) return rc;
    g_daemon.start_time = vsdd_now();
    signal(SIGPIPE, SIG_IGN);
    /* probe the GPU once, so HELLO can offer "cuda" and the log says which device */
    if (vsd_render_cuda_probe(g_daemon.cuda_device, sizeof g_daemon.cuda_device, err, sizeof err) == VSD_OK)
        vsdd_log(VSDD_LOG_INFO, "CUDA device: %s", g_daemon.cuda_device);
    else
        vsdd_log(VSDD_LOG_INFO, "no CUDA: %s; rendering on the CPU", err);
    lock_fd = vsdd_lock_acquire(g_daemon.cfg.lock_path, err, sizeof err);
    if (lock_fd < 0) {
        vsdd_log(VSDD_LOG_ERROR, "%s", err);
        return 1;
    }
    ufd = vsdd_listen_unix(g_daemon.cfg.socket_path, err, sizeof err);
    if (ufd < 0) {
        vsdd_log(VSDD_LOG_ERROR, "%s", err);
        unlink(g_daemon.cfg.lock_path);
        close(lock_fd);
        return 1;
    }
    if (g_daemon.cfg.tcp[0]) {
        tfd = vsdd_listen_tcp(g_daemon.cfg.tcp, g_daemon.cfg.listen_any, tcp_bound, sizeof tcp_bound, err, sizeof err);
        if (tfd < 0) {
            vsdd_log(VSDD_LOG_ERROR, "%s", err);
            close(ufd);
            unlink(g_daemon.cfg.socket_path);
            unlink(g_daemon.cfg.lock_path);
            close(lock_fd);
            return 2;
        }
    }
    if (vsdd_cache_init(err, sizeof err)) {
        vsdd_log(VSDD_LOG_ERROR, "%s", err);
        close(ufd);
        if (tfd >= 0) close(tfd);
        unlink(g_daemon.cfg.socket_path);
        unlink(g_daemon.cfg.lock_path);
        close(lock_fd);
        return 1;
    }
    /* signals: the handler only writes to a pipe the accept loop polls; threads block them */
    if (pipe2(signal_pipe, O_CLOEXEC | O_NONBLOCK) != 0) {
        vsdd_log(VSDD_LOG_ERROR, "pipe: %s", strerror(errno));
        return 1;
    }
    sigemptyset(&block);
    sigaddset(&block, SIGTERM);
    sigaddset(&block, SIGINT);
    pthread_sigmask(SIG_BLOCK, &block, &old);
    if (vsdd_jobs_start()) {
        vsdd_log(VSDD_LOG_ERROR, "cannot start worker threads");
        return 1;
    }
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    pthread_sigmask(SIG_UNBLOCK, &block, NULL);
    vsdd_log(VSDD_LOG_INFO, "vsd %s listening on %s%s%s (workers %d, queue %d, cache %llu MiB in %s)", vsd_version(),
             g_daemon.cfg.socket_path, tcp_bound[0] ? " and tcp " : "", tcp_bound, g_daemon.cfg.workers,
             g_daemon.cfg.queue_max, (unsigned long long)(g_daemon.cfg.cache_bytes >> 20), g_daemon.cfg.cache_dir);
    if (ready[0]) write_ready_file(ready, tcp_bound);

    for (;;) {
        struct pollfd p[3];
        int n = 0, i;
        p[n].fd = signal_pipe[0], p[n].events = POLLIN, p[n++].revents = 0;
        p[n].fd = ufd, p[n].events = POLLIN, p[n++].revents = 0;
        if (tfd >= 0) p[n].fd = tfd, p[n].events = POLLIN, p[n++].revents = 0;
        if (poll(p, (nfds_t)n, -1) < 0) {
            if (errno == EINTR) continue;
            vsdd_log(VSDD_LOG_ERROR, "poll: %s", strerror(errno));
            break;
        }
        if (p[0].revents) {
            unsigned char sig = 0;
            if (read(signal_pipe[0], &sig, 1) < 0) {}
            vsdd_log(VSDD_LOG_INFO, "%s: shutting down", sig == SIGINT ? "SIGINT" : "SIGTERM");
            break;
        }
        for (i = 1; i < n; i++) {
            struct sockaddr_storage ss;
            socklen_t sl = sizeof ss;
            int fd, is_tcp = p[i].fd == tfd;
            char peer[96] = "unix";
            if (!(p[i].revents & POLLIN)) continue;
            fd = accept4(p[i].fd, (struct sockaddr *)&ss, &sl, SOCK_CLOEXEC);
            if (fd < 0) {
                if (errno != EINTR && errno != EAGAIN && errno != ECONNABORTED)
                    vsdd_log(VSDD_LOG_WARN, "accept: %s", strerror(errno));
                if (errno == EMFILE || errno == ENFILE) usleep(100000);
                continue;
            }
            if (is_tcp) {
                char h[64] = "?";
                int port = 0;
                if (ss.ss_family == AF_INET) {
                    struct sockaddr_in *a = (struct sockaddr_in *)&ss;
                    inet_ntop(AF_INET, &a->sin_addr, h, sizeof h);
                    port = ntohs(a->sin_port);
                } else if (ss.ss_family == AF_INET6) {
                    struct sockaddr_in6 *a = (struct sockaddr_in6 *)&ss;
                    inet_ntop(AF_INET6, &a->sin6_addr, h, sizeof h);
                    port = ntohs(a->sin6_port);
                }
                snprintf(peer, sizeof peer, "tcp %s:%d", h, port);
            }
            vsdd_conn_start(fd, is_tcp, peer);
        }
    }

    /* shutdown: no new connections, jobs cancelled (their clients get ERROR shutdown), every
     * client told, sockets and files removed */
    close(ufd);
    unlink(g_daemon.cfg.socket_path);
    if (tfd >= 0) close(tfd);
    vsdd_jobs_stop();
    {
        vsdd_conn *c, **list;
        struct timespec ts;
        int k = 0, m;
        pthread_mutex_lock(&g_daemon.lock);
        list = malloc(sizeof *list * (size_t)(g_daemon.conn_count + 1));
        for (c = g_daemon.conns; c && list; c = c->next) {
            c->refs++; /* keep it alive while we talk to it */
            list[k++] = c;
        }
        pthread_mutex_unlock(&g_daemon.lock);
        for (m = 0; m < k; m++) {
            vsdd_send_error_id(list[m], 0, 0, VSD_E_SHUTDOWN, "the daemon is shutting down", NULL);
            pthread_mutex_lock(&list[m]->wlock);
            list[m]->dead = 1;
            shutdown(list[m]->fd, SHUT_RDWR); /* wakes its reader */
            pthread_mutex_unlock(&list[m]->wlock);
        }
        pthread_mutex_lock(&g_daemon.lock);
        for (m = 0; m < k; m++) vsdd_conn_release_locked(list[m]);
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_sec += 5;
        while (g_daemon.readers > 0)
            if (pthread_cond_timedwait(&g_daemon.idle_cond, &g_daemon.lock, &ts) != 0) break;
        pthread_mutex_unlock(&g_daemon.lock);
        free(list);
    }
    vsdd_cache_shutdown();
    if (ready[0]) unlink(ready);
    unlink(g_daemon.cfg.lock_path);
    close(lock_fd);
    vsdd_log(VSDD_LOG_INFO, "stopped");
    return 0;
}
