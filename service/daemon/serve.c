/* `vsd serve`: start-up (lock, sockets, cache, workers), the accept loop and a clean
 * shutdown on SIGTERM/SIGINT (jobs cancelled, clients told, socket removed). The options
 * are parsed in serve_options.c; `serve --loader-zygote` is the isolated loader's zygote. */
#define _GNU_SOURCE
#include "cache.h"
#include "conn.h"
#include "jobs.h"
#include "listen.h"
#include "loader.h"
#include "reply.h"
#include "serve.h"
#include "serve_options.h"
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <malloc.h>
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

static int signal_pipe[2] = {-1, -1};

static void on_signal(int sig)
{
    unsigned char b = (unsigned char)sig;
    int saved = errno;
    if (write(signal_pipe[1], &b, 1) < 0) {}
    errno = saved;
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
    int rc, lock_fd, ufd, tfd = -1;
    sigset_t block, old;
    struct sigaction sa;
    /* the isolated loader's zygote (loader_isolated.c spawns this executable) */
    if (argc == 2 && strcmp(argv[1], "--loader-zygote") == 0) return vsdd_loader_zygote_main();
    rc = vsdd_serve_options(argc, argv, ready, sizeof ready);
    if (rc >= 0) return rc;
    g_daemon.start_time = vsd_clock_seconds();
    signal(SIGPIPE, SIG_IGN);
    /* Large blocks (renderers' grids, lattices, RBF fits, decoded volumes) always get their
     * own mappings, returned to the system when freed. glibc otherwise raises its mmap
     * threshold to the size of each large block freed (up to 32 MiB), after which such
     * blocks come from the arenas and stay resident after the cache evicts them: the soak
     * (8 clients x 40 jobs, --cache-mb 64) peaked at 145-173 MiB RSS with 76 MiB of heap in
     * use, and at 114-116 MiB with this set (docs/soak.md). */
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
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
    if (g_daemon.cfg.loader == VSDD_LOADER_ISOLATED)
        vsdd_log(VSDD_LOG_INFO, "decoding VDBs and maps in child processes (%llu MiB, %g s each)",
                 (unsigned long long)(g_daemon.cfg.loader_bytes >> 20), g_daemon.cfg.loader_seconds);
    else
        vsdd_log(VSDD_LOG_WARN, "--loader inprocess: a decoder crash on a hostile file stops the daemon");
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
    vsdd_loader_shutdown();
    vsdd_cache_shutdown();
    if (ready[0]) unlink(ready);
    unlink(g_daemon.cfg.lock_path);
    close(lock_fd);
    vsdd_log(VSDD_LOG_INFO, "stopped");
    return 0;
}
