/* The daemon's side of an isolated decode: hand the request to the zygote
 * (loader_zygote.c) with a result pipe and a status socket, read the child's reply before
 * the --loader-seconds deadline (loader_wire.c), then its exit status from the zygote,
 * and turn whatever happened into a volume or map or an error that names the source.
 * When the deadline passes, closing the status socket makes the zygote kill the child.
 *
 * The zygote is started (fork + exec of this executable, so it begins single-threaded and
 * clean) on the first decode, and again if it ever dies. */
#define _GNU_SOURCE
#include "loader.h"
#include "loader_wire.h"
#include "loader_zygote.h"
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

struct vsdd_zygote {
    const vsdd_config *cfg;        /* the daemon's, read-only: executable, limits */
    vsdd_mutex lock;
    int fd;                        /* the zygote's request socket, -1 when none runs */
    pid_t pid;
};

vsdd_zygote *vsdd_zygote_new(const vsdd_config *cfg)
{
    vsdd_zygote *z = calloc(1, sizeof *z);
    if (!z) return NULL;
    z->cfg = cfg;
    vsdd_mutex_init(&z->lock, VSDD_RANK_LOADER);
    z->fd = -1;
    z->pid = -1;
    return z;
}

/* Lock held. Stop the zygote: EOF on its socket ends it; reap it. */
static void zygote_stop_locked(vsdd_zygote *z)
{
    int i, status;
    if (z->fd < 0) return;
    close(z->fd);
    z->fd = -1;
    for (i = 0; i < 200 && waitpid(z->pid, &status, WNOHANG) == 0; i++) usleep(5000);
    if (i == 200) {
        kill(z->pid, SIGKILL);
        waitpid(z->pid, &status, 0);
    }
    z->pid = -1;
}

/* Lock held. Spawn `serve --loader-zygote` with its end of a SEQPACKET pair on fd 3. */
static int zygote_start_locked(vsdd_zygote *z, vsdd_err *e)
{
    char *argv[] = {"vsd", "serve", "--loader-zygote", NULL};
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t attr;
    sigset_t none, dflt;
    int sv[2], rc;
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0)
        return vsdd_fail(e, VSD_E_INTERNAL, "cannot start the loader: socketpair: %s", strerror(errno));
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, sv[1], 3);
    posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addclosefrom_np(&fa, 4);
    posix_spawnattr_init(&attr);
    sigemptyset(&none);
    sigemptyset(&dflt);
    sigaddset(&dflt, SIGPIPE); /* the daemon ignores it; a child whose reader is gone should die */
    sigaddset(&dflt, SIGTERM);
    sigaddset(&dflt, SIGINT);
    posix_spawnattr_setsigmask(&attr, &none); /* worker threads block SIGTERM/SIGINT */
    posix_spawnattr_setsigdefault(&attr, &dflt);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    rc = posix_spawn(&z->pid, z->cfg->loader_exe, &fa, &attr, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&attr);
    close(sv[1]);
    if (rc != 0) {
        close(sv[0]);
        z->pid = -1;
        return vsdd_fail(e, VSD_E_INTERNAL, "cannot start the loader %s: %s", z->cfg->loader_exe, strerror(rc));
    }
    z->fd = sv[0];
    vsdd_log(VSDD_LOG_DEBUG, "loader zygote started (pid %d)", (int)z->pid);
    return 0;
}

void vsdd_zygote_stop(vsdd_zygote *z)
{
    vsdd_lock(&z->lock);
    zygote_stop_locked(z);
    vsdd_unlock(&z->lock);
}

void vsdd_zygote_free(vsdd_zygote *z)
{
    if (!z) return;
    vsdd_zygote_stop(z);
    vsdd_mutex_destroy(&z->lock);
    free(z);
}

/* Hand req with its two descriptors to the zygote, starting (or restarting) it. */
static int submit(vsdd_zygote *z, const vsdd_load_req *req, int pipe_w, int status_w, vsdd_err *e)
{
    char cbuf[CMSG_SPACE(2 * sizeof(int))];
    struct iovec iov = {(void *)req, sizeof *req};
    struct msghdr mh;
    struct cmsghdr *cm;
    int fds[2] = {pipe_w, status_w}, attempt, rc = -1;
    memset(cbuf, 0, sizeof cbuf);
    memset(&mh, 0, sizeof mh);
    mh.msg_iov = &iov;
    mh.msg_iovlen = 1;
    mh.msg_control = cbuf;
    mh.msg_controllen = sizeof cbuf;
    cm = CMSG_FIRSTHDR(&mh);
    cm->cmsg_level = SOL_SOCKET;
    cm->cmsg_type = SCM_RIGHTS;
    cm->cmsg_len = CMSG_LEN(sizeof fds);
    memcpy(CMSG_DATA(cm), fds, sizeof fds);
    vsdd_lock(&z->lock);
    for (attempt = 0; attempt < 2 && rc; attempt++) {
        if (z->fd < 0 && zygote_start_locked(z, e)) break;
        if (sendmsg(z->fd, &mh, MSG_NOSIGNAL) == (ssize_t)sizeof *req) rc = 0;
        else {
            vsdd_log(VSDD_LOG_WARN, "loader zygote (pid %d) gone (%s): starting another", (int)z->pid, strerror(errno));
            zygote_stop_locked(z);
        }
    }
    vsdd_unlock(&z->lock);
    if (rc && !e->code) vsdd_fail(e, VSD_E_INTERNAL, "cannot reach the loader: %s", strerror(errno));
    return rc;
}

/* The zygote's word on the child, before the deadline. 0, or -1 (in->timed_out says why). */
static int get_status(vsdd_wire_in *in, int fd, vsdd_zygote_status *st)
{
    for (;;) {
        struct pollfd p = {fd, POLLIN, 0};
        double left = in->deadline - vsd_clock_seconds();
        ssize_t n;
        if (left <= 0) {
            in->timed_out = 1;
            return -1;
        }
        if (poll(&p, 1, (int)(left * 1000) + 1) <= 0) continue;
        n = recv(fd, st, sizeof *st, 0);
        if (n == (ssize_t)sizeof *st) return 0;
        if (n < 0 && errno == EINTR) continue;
        return -1;
    }
}

static int run_child(vsdd_zygote *z, vsdd_load_req *req, vsd_volume **vol, vsd_env **env, vsdd_err *e)
{
    const vsdd_config *cfg = z->cfg;
    const char *src = req->src;
    vsdd_wire_in in;
    vsdd_err child_err = {NULL, ""};
    vsdd_zygote_status st = {-1, 0};
    double t0 = vsd_clock_seconds();
    int pp[2], ss[2], got, have_status, status;
    req->mb = cfg->loader_bytes >> 20;
    if (pipe2(pp, O_CLOEXEC) != 0) return vsdd_fail(e, VSD_E_INTERNAL, "loading %s: pipe: %s", src, strerror(errno));
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, ss) != 0) {
        close(pp[0]);
        close(pp[1]);
        return vsdd_fail(e, VSD_E_INTERNAL, "loading %s: socketpair: %s", src, strerror(errno));
    }
    fcntl(pp[0], F_SETPIPE_SZ, 1 << 20); /* fewer round trips for big grids; best effort */
    got = submit(z, req, pp[1], ss[1], e);
    close(pp[1]);
    close(ss[1]);
    if (got) {
        close(pp[0]);
        close(ss[0]);
        return -1;
    }
    memset(&in, 0, sizeof in);
    in.fd = pp[0];
    in.deadline = t0 + cfg->loader_seconds;
    in.max_bytes = cfg->loader_bytes;
    got = vsdd_wire_get(&in, &child_err, vol, env);
    close(pp[0]);
    have_status = !in.timed_out && get_status(&in, ss[0], &st) == 0;
    close(ss[0]); /* before the zygote reaped the child: it kills it */
    status = st.wait_status;
    vsdd_log(VSDD_LOG_DEBUG, "loader: %s: %.3fs, peak %lld KiB, status 0x%x", src, vsd_clock_seconds() - t0,
             (long long)st.maxrss_kib, status);
    if (got >= 0 && have_status && status >= 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0) {
        if (got != VSDD_WIRE_ERROR) return 0;
        *e = child_err;
        return -1;
    }
    vsd_volume_destroy(*vol);
    vsd_env_destroy(*env);
    *vol = NULL;
    *env = NULL;
    if (in.timed_out)
        return vsdd_fail(e, VSD_E_LIMIT, "loading %s: the decoder ran past %g s (--loader-seconds)", src,
                         cfg->loader_seconds);
    if (!have_status || status < 0)
        return vsdd_fail(e, VSD_E_INTERNAL, "loading %s: the loader failed to run the decoder", src);
    if (WIFSIGNALED(status))
        return vsdd_fail(e, VSD_E_INPUT,
                         "loading %s: the decoder crashed (signal %d, %s; it had used %lld of its %llu MiB, --loader-mb)",
                         src, WTERMSIG(status), strsignal(WTERMSIG(status)), (long long)(st.maxrss_kib >> 10),
                         (unsigned long long)(cfg->loader_bytes >> 20));
    if (WIFEXITED(status) && WEXITSTATUS(status) != 0)
        return vsdd_fail(e, VSD_E_INTERNAL, "loading %s: the decoder exited with status %d", src, WEXITSTATUS(status));
    return vsdd_fail(e, VSD_E_INTERNAL, "loading %s: the decoder's reply is %s", src, in.why[0] ? in.why : "truncated");
}

static vsdd_load_req *make_req(int kind, const char *src, const char *path, const char *name, int index,
                               uint64_t limit, vsdd_err *e)
{
    vsdd_load_req *req = calloc(1, sizeof *req);
    if (!req) {
        vsdd_fail(e, VSD_E_INTERNAL, "out of memory");
        return NULL;
    }
    req->kind = kind;
    req->index = index;
    req->limit = limit;
    snprintf(req->path, sizeof req->path, "%s", path);
    snprintf(req->src, sizeof req->src, "%s", src);
    snprintf(req->name, sizeof req->name, "%s", name);
    return req;
}

int vsdd_isolated_volume(vsdd_zygote *z, const char *src, const char *path, const char *grid, int grid_index,
                         vsd_volume **out, vsdd_err *e)
{
    vsd_env *unused = NULL;
    vsdd_load_req *req = make_req(VSDD_WIRE_VOLUME, src, path, grid, grid_index, z->cfg->max_voxels, e);
    int rc = req ? run_child(z, req, out, &unused, e) : -1;
    free(req);
    return rc;
}

int vsdd_isolated_env(vsdd_zygote *z, const char *src, const char *path, const char *conversion, vsd_env **out,
                      vsdd_err *e)
{
    vsd_volume *unused = NULL;
    vsdd_load_req *req = make_req(VSDD_WIRE_ENV, src, path, conversion, -1, z->cfg->max_pixels, e);
    int rc = req ? run_child(z, req, &unused, out, e) : -1;
    free(req);
    return rc;
}
