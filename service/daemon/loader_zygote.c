/* The loader zygote: `vsd serve --loader-zygote`, one per daemon, spawned (fork + exec,
 * so it starts clean) by loader_isolated.c with its request socket on fd 3. It stays
 * single-threaded and never decodes anything itself, so forking it is safe and cheap —
 * unlike forking the multi-threaded daemon (locks held by other threads) or exec'ing the
 * executable per decode (~60 shared libraries to relocate each time).
 *
 * Each request (one SOCK_SEQPACKET message, vsdd_load_req) brings two descriptors: the
 * pipe the child writes its result to, and a status socket. The zygote forks the child,
 * and when it has reaped it, sends its wait status and peak memory on the status socket.
 * When the daemon closes the status socket first (its deadline passed), the zygote kills
 * the child. The zygote exits when the daemon closes fd 3, or dies (PR_SET_PDEATHSIG). */
#define _GNU_SOURCE
#include "loader.h"
#include "loader_zygote.h"
#include "vsd/vdbio.h"
#include <dirent.h>
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#define REQUEST_FD 3
#define MAX_CHILDREN 512

typedef struct child_rec {
    pid_t pid;
    int status_fd; /* -1 once the daemon gave up on it */
} child_rec;

static child_rec kids[MAX_CHILDREN];
static int nkids;

/* One request: 0 handled (or refused), -1 the daemon is gone. */
static int take_request(void)
{
    vsdd_load_req req;
    char cbuf[CMSG_SPACE(2 * sizeof(int))];
    struct iovec iov = {&req, sizeof req};
    struct msghdr mh;
    struct cmsghdr *cm;
    int fds[2] = {-1, -1};
    ssize_t n;
    pid_t pid;
    memset(&mh, 0, sizeof mh);
    mh.msg_iov = &iov;
    mh.msg_iovlen = 1;
    mh.msg_control = cbuf;
    mh.msg_controllen = sizeof cbuf;
    n = recvmsg(REQUEST_FD, &mh, MSG_CMSG_CLOEXEC);
    if (n == 0 || (n < 0 && errno != EINTR && errno != EAGAIN)) return -1;
    if (n < 0) return 0;
    cm = CMSG_FIRSTHDR(&mh);
    if (cm && cm->cmsg_type == SCM_RIGHTS && cm->cmsg_len == CMSG_LEN(2 * sizeof(int))) memcpy(fds, CMSG_DATA(cm), sizeof fds);
    if (n != (ssize_t)sizeof req || fds[0] < 0 || nkids >= MAX_CHILDREN) {
        vsdd_zygote_status st = {-1, 0};
        if (fds[1] >= 0) send(fds[1], &st, sizeof st, MSG_NOSIGNAL);
        if (fds[0] >= 0) close(fds[0]);
        if (fds[1] >= 0) close(fds[1]);
        return 0;
    }
    req.path[sizeof req.path - 1] = req.src[sizeof req.src - 1] = req.name[sizeof req.name - 1] = '\0';
    pid = fork();
    if (pid == 0) {
        sigset_t none;
        sigemptyset(&none);
        sigprocmask(SIG_SETMASK, &none, NULL);
        prctl(PR_SET_PDEATHSIG, SIGKILL); /* a hung decoder dies with the zygote */
        /* the result pipe becomes fd 3 (replacing the request socket); nothing else stays */
        if (dup2(fds[0], 3) != 3) _exit(5);
        closefrom(4);
        vsdd_loader_child_run(&req);
    }
    close(fds[0]);
    if (pid < 0) {
        vsdd_zygote_status st = {-1, 0};
        send(fds[1], &st, sizeof st, MSG_NOSIGNAL);
        close(fds[1]);
        return 0;
    }
    kids[nkids].pid = pid;
    kids[nkids++].status_fd = fds[1];
    return 0;
}

static void reap_children(void)
{
    for (;;) {
        struct rusage ru;
        int status, i;
        pid_t pid = wait4(-1, &status, WNOHANG, &ru);
        if (pid <= 0) return;
        for (i = 0; i < nkids && kids[i].pid != pid; i++) {}
        if (i == nkids) continue;
        if (kids[i].status_fd >= 0) {
            vsdd_zygote_status st = {status, (int64_t)ru.ru_maxrss};
            send(kids[i].status_fd, &st, sizeof st, MSG_NOSIGNAL);
            close(kids[i].status_fd);
        }
        kids[i] = kids[--nkids];
    }
}

/* OpenVDB registers its grid, map and metadata types once per process (about 10 ms):
 * do it here, once, instead of in every child. It starts no thread (checked: a zygote
 * with threads could not fork safely, so it then says so and the children pay instead). */
static void warm_up(void)
{
    char err[256];
    vsd_grid_info *grids = NULL;
    int n = 0;
    DIR *d;
    struct dirent *de;
    vsd_vdb_list("/dev/null", &grids, &n, err, sizeof err); /* not a VDB: initialises, reads nothing */
    vsd_vdb_list_free(grids);
    n = 0;
    d = opendir("/proc/self/task");
    while (d && (de = readdir(d)))
        if (de->d_name[0] != '.') n++;
    if (d) closedir(d);
    if (n > 1) fprintf(stderr, "vsd serve: loader zygote: %d threads after initialising OpenVDB\n", n);
}

int vsdd_loader_zygote_main(void)
{
    struct pollfd p[2 + MAX_CHILDREN];
    sigset_t chld;
    int sfd, i;
    prctl(PR_SET_PDEATHSIG, SIGKILL); /* never outlive the daemon */
    if (getppid() == 1) return 3;
    sigemptyset(&chld);
    sigaddset(&chld, SIGCHLD);
    sigprocmask(SIG_BLOCK, &chld, NULL);
    sfd = signalfd(-1, &chld, SFD_CLOEXEC | SFD_NONBLOCK);
    if (sfd < 0) return 4;
    warm_up();
    for (;;) {
        int n = 0;
        p[n].fd = REQUEST_FD, p[n].events = POLLIN, p[n++].revents = 0;
        p[n].fd = sfd, p[n].events = POLLIN, p[n++].revents = 0;
        for (i = 0; i < nkids; i++) p[n].fd = kids[i].status_fd, p[n].events = POLLIN, p[n++].revents = 0;
        if (poll(p, (nfds_t)n, -1) < 0) {
            if (errno == EINTR) continue;
            break;
        }
        if (p[1].revents) {
            struct signalfd_siginfo si;
            while (read(sfd, &si, sizeof si) > 0) {}
            reap_children();
        }
        /* a closed status socket: the daemon's deadline passed; the child dies now and is
         * reaped with the others */
        for (i = 2; i < n; i++)
            if (p[i].revents && p[i].fd >= 0) {
                int k;
                for (k = 0; k < nkids && kids[k].status_fd != p[i].fd; k++) {}
                if (k == nkids) continue;
                kill(kids[k].pid, SIGKILL);
                close(kids[k].status_fd);
                kids[k].status_fd = -1;
            }
        if (p[0].revents && take_request() < 0) break;
    }
    for (i = 0; i < nkids; i++) kill(kids[i].pid, SIGKILL);
    return 0;
}
