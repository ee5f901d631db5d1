/* The daemon's one shared state and the lifetime of the connections in it (see
 * daemon_state.h). Connections are freed here, not in conn.c, because jobs (a layer below
 * the connection readers) hold references too. */
#define _GNU_SOURCE
#include "daemon_state.h"
#include <stdlib.h>
#include <unistd.h>

vsdd_daemon g_daemon = {.lock = PTHREAD_MUTEX_INITIALIZER,
                        .queue_cond = PTHREAD_COND_INITIALIZER,
                        .idle_cond = PTHREAD_COND_INITIALIZER};

void vsdd_conn_release_locked(vsdd_conn *c)
{
    vsdd_conn **p;
    if (--c->refs > 0) return;
    for (p = &g_daemon.conns; *p; p = &(*p)->next)
        if (*p == c) {
            *p = c->next;
            break;
        }
    g_daemon.conn_count--;
    close(c->fd);
    pthread_mutex_destroy(&c->wlock);
    free(c);
    pthread_cond_broadcast(&g_daemon.idle_cond);
}

void vsdd_conn_release(vsdd_conn *c)
{
    pthread_mutex_lock(&g_daemon.lock);
    vsdd_conn_release_locked(c);
    pthread_mutex_unlock(&g_daemon.lock);
}

void vsdd_count(uint64_t *counter, uint64_t n)
{
    pthread_mutex_lock(&g_daemon.lock);
    *counter += n;
    pthread_mutex_unlock(&g_daemon.lock);
}
