/* The accept loop: one poll over the stop pipe and the listening sockets; a TCP peer is
 * named "tcp HOST:PORT" in the log. */
#define _GNU_SOURCE
#include "accept.h"
#include "conn.h"
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

static void peer_name(const struct sockaddr_storage *ss, char *peer, size_t len)
{
    char h[64] = "?";
    int port = 0;
    if (ss->ss_family == AF_INET) {
        const struct sockaddr_in *a = (const struct sockaddr_in *)ss;
        inet_ntop(AF_INET, &a->sin_addr, h, sizeof h);
        port = ntohs(a->sin_port);
    } else if (ss->ss_family == AF_INET6) {
        const struct sockaddr_in6 *a = (const struct sockaddr_in6 *)ss;
        inet_ntop(AF_INET6, &a->sin6_addr, h, sizeof h);
        port = ntohs(a->sin6_port);
    }
    snprintf(peer, len, "tcp %s:%d", h, port);
}

int vsdd_accept_loop(vsdd_daemon *d, int stop_fd, int ufd, int tfd)
{
    for (;;) {
        struct pollfd p[3];
        int n = 0, i;
        p[n].fd = stop_fd, p[n].events = POLLIN, p[n++].revents = 0;
        p[n].fd = ufd, p[n].events = POLLIN, p[n++].revents = 0;
        if (tfd >= 0) p[n].fd = tfd, p[n].events = POLLIN, p[n++].revents = 0;
        if (poll(p, (nfds_t)n, -1) < 0) {
            if (errno == EINTR) continue;
            vsdd_log(VSDD_LOG_ERROR, "poll: %s", strerror(errno));
            return -1;
        }
        if (p[0].revents) {
            unsigned char b = 0;
            if (read(stop_fd, &b, 1) < 0) {}
            return b;
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
            if (is_tcp) peer_name(&ss, peer, sizeof peer);
            vsdd_conn_start(d, fd, is_tcp, peer);
        }
    }
}
