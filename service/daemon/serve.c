/* `vsd serve`: start-up (lock, sockets, the daemon record's modules), the accept loop
 * (accept.c) and a clean shutdown on SIGTERM/SIGINT (jobs cancelled, clients told, socket
 * removed). The options are parsed in serve_options.c; `serve --loader-zygote` is the
 * isolated loader's zygote. The daemon record is made here and handed to every thread; no
 * other file names it. */
#define _GNU_SOURCE
#include "daemon.h"
#include "listen.h"
#include "serve.h"
#include "serve_options.h"
#include <errno.h>
#include <fcntl.h>
#include <malloc.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The one process-wide thing: a signal handler can only reach a static. */
static int signal_pipe[2] = {-1, -1};

static void on_signal(int sig)
{
    unsigned char b = (unsigned char)sig;
    int saved = errno;
    if (write(signal_pipe[1], &b, 1) < 0) {}
    errno = saved;
}

static void write_ready_file(const vsdd_daemon *d, const char *path, const char *tcp_bound)
{
    char tmp[VSD_PATH_LEN + 16];
    FILE *f;
    cJSON *o = cJSON_CreateObject();
    char *text;
    cJSON_AddStringToObject(o, "socket", d->cfg.socket_path);
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

/* Undo the listening part of start-up. */
static void unlisten(const vsdd_config *cfg, int lock_fd, int ufd, int tfd)
{
    if (ufd >= 0) close(ufd);
    if (tfd >= 0) close(tfd);
    if (ufd >= 0) unlink(cfg->socket_path);
    unlink(cfg->lock_path);
    close(lock_fd);
}

static void log_start(const vsdd_daemon *d, const char *tcp_bound)
{
    const vsdd_config *cfg = &d->cfg;
    vsdd_log(VSDD_LOG_INFO, "vsd %s listening on %s%s%s (workers %d, queue %d, cache %llu MiB in %s)", vsd_version(),
             cfg->socket_path, tcp_bound[0] ? " and tcp " : "", tcp_bound, cfg->workers, cfg->queue_max,
             (unsigned long long)(cfg->cache_bytes >> 20), vsdd_cache_dir(d->cache));
    if (cfg->loader == VSDD_LOADER_ISOLATED)
        vsdd_log(VSDD_LOG_INFO, "decoding VDBs and maps in child processes (%llu MiB, %g s each)",
                 (unsigned long long)(cfg->loader_bytes >> 20), cfg->loader_seconds);
    else
        vsdd_log(VSDD_LOG_WARN, "--loader inprocess: a decoder crash on a hostile file stops the daemon");
}

int vsd_cmd_serve(int argc, char **argv)
{
    /* static, not on this stack, only so that a reader thread that outlives the shutdown
     * wait never sees it go away before the process exits; only this function names it */
    static vsdd_daemon daemon_record;
    vsdd_daemon *d = &daemon_record;
    const vsdd_config *cfg = &d->cfg;
    char err[1024], ready[VSD_PATH_LEN], tcp_bound[300] = "";
    int rc, lock_fd, ufd, tfd = -1, sig;
    sigset_t block, old;
    struct sigaction sa;
    /* the isolated loader's zygote (loader_isolated.c spawns this executable) */
    if (argc == 2 && strcmp(argv[1], "--loader-zygote") == 0) return vsdd_loader_zygote_main();
    rc = vsdd_serve_options(argc, argv, &d->cfg, ready, sizeof ready);
    if (rc >= 0) return rc;
    vsdd_log_set_level(cfg->log_level);
    d->start_time = vsd_clock_seconds();
    signal(SIGPIPE, SIG_IGN);
    /* Large blocks (renderers' grids, lattices, RBF fits, decoded volumes) always get their
     * own mappings, returned to the system when freed. glibc otherwise raises its mmap
     * threshold to the size of each large block freed (up to 32 MiB), after which such
     * blocks come from the arenas and stay resident after the cache evicts them: the soak
     * (8 clients x 40 jobs, --cache-mb 64) peaked at 145-173 MiB RSS with 76 MiB of heap in
     * use, and at 114-116 MiB with this set (docs/soak.md). */
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
    /* probe the GPU once, so HELLO can offer "cuda" and the log says which device */
    if (vsd_render_cuda_probe(d->cuda_device, sizeof d->cuda_device, err, sizeof err) == VSD_OK)
        vsdd_log(VSDD_LOG_INFO, "CUDA device: %s", d->cuda_device);
    else
        vsdd_log(VSDD_LOG_INFO, "no CUDA: %s; rendering on the CPU", err);
    lock_fd = vsdd_lock_acquire(cfg->lock_path, err, sizeof err);
    if (lock_fd < 0) {
        vsdd_log(VSDD_LOG_ERROR, "%s", err);
        return 1;
    }
    ufd = vsdd_listen_unix(cfg->socket_path, err, sizeof err);
    if (ufd < 0) {
        vsdd_log(VSDD_LOG_ERROR, "%s", err);
        unlisten(cfg, lock_fd, -1, -1);
        return 1;
    }
    if (cfg->tcp[0]) {
        tfd = vsdd_listen_tcp(cfg->tcp, cfg->listen_any, tcp_bound, sizeof tcp_bound, err, sizeof err);
        if (tfd < 0) {
            vsdd_log(VSDD_LOG_ERROR, "%s", err);
            unlisten(cfg, lock_fd, ufd, -1);
            return 2;
        }
    }
    /* signals: the handler only writes to a pipe the accept loop polls; threads block them */
    if (pipe2(signal_pipe, O_CLOEXEC | O_NONBLOCK) != 0) {
        vsdd_log(VSDD_LOG_ERROR, "pipe: %s", strerror(errno));
        unlisten(cfg, lock_fd, ufd, tfd);
        return 1;
    }
    sigemptyset(&block);
    sigaddset(&block, SIGTERM);
    sigaddset(&block, SIGINT);
    pthread_sigmask(SIG_BLOCK, &block, &old);
    if (vsdd_daemon_start(d, err, sizeof err)) {
        vsdd_log(VSDD_LOG_ERROR, "%s", err);
        unlisten(cfg, lock_fd, ufd, tfd);
        return 1;
    }
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    pthread_sigmask(SIG_UNBLOCK, &block, NULL);
    log_start(d, tcp_bound);
    if (ready[0]) write_ready_file(d, ready, tcp_bound);

    sig = vsdd_accept_loop(d, signal_pipe[0], ufd, tfd);
    if (sig >= 0) vsdd_log(VSDD_LOG_INFO, "%s: shutting down", sig == SIGINT ? "SIGINT" : "SIGTERM");

    /* shutdown: no new connections, jobs cancelled (their clients get ERROR shutdown), every
     * client told, sockets and files removed */
    close(ufd);
    unlink(cfg->socket_path);
    if (tfd >= 0) close(tfd);
    vsdd_daemon_stop(d);
    if (ready[0]) unlink(ready);
    unlink(cfg->lock_path);
    close(lock_fd);
    if (vsdd_lock_violations())
        vsdd_log(VSDD_LOG_ERROR, "%llu lock order violation(s) (service/daemon/lock_order.h)",
                 (unsigned long long)vsdd_lock_violations());
    vsdd_log(VSDD_LOG_INFO, "stopped");
    return 0;
}
