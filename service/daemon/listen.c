/* Listening sockets and the lock file: the Unix socket (mode 0600) guarded by an flock'ed
 * pid file so two daemons never share it, and the optional TCP socket. */
#define _GNU_SOURCE
#include "daemon_state.h"
#include "listen.h"
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

int vsdd_lock_acquire(const char *lock_path, char *err, size_t errlen)
{
    char pid[32];
    int fd = open(lock_path, O_RDWR | O_CREAT | O_CLOEXEC, 0600);
    if (fd < 0) {
        snprintf(err, errlen, "%s: cannot open the lock file: %s", lock_path, strerror(errno));
        return -1;
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        char other[32] = "";
        ssize_t n = read(fd, other, sizeof other - 1);
        other[n > 0 ? n : 0] = '\0';
        other[strcspn(other, "\n")] = '\0';
        snprintf(err, errlen, "another vsd serve (pid %s) already holds %s", other[0] ? other : "?", lock_path);
        close(fd);
        return -1;
    }
    if (ftruncate(fd, 0) == 0) {
        snprintf(pid, sizeof pid, "%ld\n", (long)getpid());
        if (pwrite(fd, pid, strlen(pid), 0) < 0) {}
    }
    return fd;
}

int vsdd_listen_unix(const char *path, char *err, size_t errlen)
{
    struct sockaddr_un a;
    mode_t old;
    int fd;
    if (strlen(path) >= sizeof a.sun_path) {
        snprintf(err, errlen, "%s: socket path too long (max %zu)", path, sizeof a.sun_path - 1);
        return -1;
    }
    fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        snprintf(err, errlen, "socket: %s", strerror(errno));
        return -1;
    }
    memset(&a, 0, sizeof a);
    a.sun_family = AF_UNIX;
    memcpy(a.sun_path, path, strlen(path));
    unlink(path); /* a stale socket of a dead daemon: we hold the lock, so nobody serves it */
    old = umask(0177);
    if (bind(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        umask(old);
        snprintf(err, errlen, "%s: bind: %s", path, strerror(errno));
        close(fd);
        return -1;
    }
    umask(old);
    chmod(path, 0600);
    if (listen(fd, 64) != 0) {
        snprintf(err, errlen, "%s: listen: %s", path, strerror(errno));
        close(fd);
        unlink(path);
        return -1;
    }
    return fd;
}

int vsdd_listen_tcp(const char *hostport, int any, char *bound, size_t boundlen, char *err, size_t errlen)
{
    char host[256], port[32];
    const char *colon = strrchr(hostport, ':');
    struct addrinfo hints, *res = NULL, *ai;
    int fd = -1, one = 1, rc;
    if (!colon || colon == hostport || !colon[1] || (size_t)(colon - hostport) >= sizeof host) {
        snprintf(err, errlen, "--tcp %s: expected HOST:PORT", hostport);
        return -1;
    }
    snprintf(host, sizeof host, "%.*s", (int)(colon - hostport), hostport);
    snprintf(port, sizeof port, "%s", colon + 1);
    if (!any && strcmp(host, "127.0.0.1") != 0 && strcmp(host, "localhost") != 0 && strcmp(host, "::1") != 0) {
        snprintf(err, errlen, "--tcp %s: binding a non-loopback address needs --listen-any", hostport);
        return -1;
    }
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_PASSIVE;
    if ((rc = getaddrinfo(host, port, &hints, &res)) != 0) {
        snprintf(err, errlen, "--tcp %s: %s", hostport, gai_strerror(rc));
        return -1;
    }
    for (ai = res; ai; ai = ai->ai_next) {
        fd = socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
        if (fd < 0) continue;
        setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        if (bind(fd, ai->ai_addr, ai->ai_addrlen) == 0 && listen(fd, 64) == 0) break;
        close(fd);
        fd = -1;
    }
    freeaddrinfo(res);
    if (fd < 0) {
        snprintf(err, errlen, "--tcp %s: cannot bind: %s", hostport, strerror(errno));
        return -1;
    }
    {
        struct sockaddr_storage ss;
        socklen_t sl = sizeof ss;
        char h[128], p[32];
        if (getsockname(fd, (struct sockaddr *)&ss, &sl) == 0 &&
            getnameinfo((struct sockaddr *)&ss, sl, h, sizeof h, p, sizeof p, NI_NUMERICHOST | NI_NUMERICSERV) == 0)
            snprintf(bound, boundlen, "%s:%s", h, p);
        else
            snprintf(bound, boundlen, "%s", hostport);
    }
    return fd;
}
