/* The connection list and the lifetime of connection records (conns.h). Records are freed
 * here, not in conn.c, because jobs (a layer below the connection readers) hold references
 * too: the last reference closes the socket. Everything here is under cs->lock
 * (VSDD_RANK_CONNS); jobs.c takes a reference while it holds the jobs lock (a lower rank). */
#define _GNU_SOURCE
#include "conns.h"
#include "reply.h"
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

struct vsdd_conns {
    vsdd_mutex lock;
    pthread_cond_t idle;           /* broadcast when a reader ends or a record is freed */
    vsdd_conn *list;
    int count, readers;
    unsigned next_id;
};

vsdd_conns *vsdd_conns_new(void)
{
    vsdd_conns *cs = calloc(1, sizeof *cs);
    if (!cs) return NULL;
    vsdd_mutex_init(&cs->lock, VSDD_RANK_CONNS);
    pthread_cond_init(&cs->idle, NULL);
    return cs;
}

void vsdd_conns_free(vsdd_conns *cs)
{
    if (!cs) return;
    pthread_cond_destroy(&cs->idle);
    vsdd_mutex_destroy(&cs->lock);
    free(cs);
}

vsdd_conn *vsdd_conn_new(int fd, int is_tcp, const char *peer)
{
    vsdd_conn *c = calloc(1, sizeof *c);
    if (!c) {
        close(fd);
        return NULL;
    }
    c->fd = fd;
    c->is_tcp = is_tcp;
    c->link.refs = 1;
    snprintf(c->peer, sizeof c->peer, "%s", peer);
    vsdd_out_init(c);
    return c;
}

void vsdd_conn_discard(vsdd_conn *c)
{
    close(c->fd);
    vsdd_out_destroy(c);
    free(c);
}

int vsdd_conns_add(vsdd_conns *cs, vsdd_conn *c, int max)
{
    int rc = 0;
    vsdd_lock(&cs->lock);
    c->id = ++cs->next_id;
    if (cs->count >= max) rc = -1;
    else {
        c->link.next = cs->list;
        cs->list = c;
        cs->count++;
        cs->readers++;
    }
    vsdd_unlock(&cs->lock);
    return rc;
}

void vsdd_conn_hold(vsdd_conns *cs, vsdd_conn *c)
{
    vsdd_lock(&cs->lock);
    c->link.refs++;
    vsdd_unlock(&cs->lock);
}

/* Lock held. */
static void release_locked(vsdd_conns *cs, vsdd_conn *c)
{
    vsdd_conn **p;
    if (--c->link.refs > 0) return;
    for (p = &cs->list; *p; p = &(*p)->link.next)
        if (*p == c) {
            *p = c->link.next;
            break;
        }
    cs->count--;
    vsdd_conn_discard(c);
    pthread_cond_broadcast(&cs->idle);
}

void vsdd_conn_release(vsdd_conns *cs, vsdd_conn *c)
{
    vsdd_lock(&cs->lock);
    release_locked(cs, c);
    vsdd_unlock(&cs->lock);
}

void vsdd_conns_reader_done(vsdd_conns *cs, vsdd_conn *c)
{
    vsdd_lock(&cs->lock);
    cs->readers--;
    release_locked(cs, c);
    pthread_cond_broadcast(&cs->idle);
    vsdd_unlock(&cs->lock);
}

int vsdd_conns_count(vsdd_conns *cs)
{
    int n;
    vsdd_lock(&cs->lock);
    n = cs->count;
    vsdd_unlock(&cs->lock);
    return n;
}

void vsdd_conns_counts(vsdd_conns *cs, int *listed, int *readers)
{
    vsdd_lock(&cs->lock);
    *listed = cs->count;
    *readers = cs->readers;
    vsdd_unlock(&cs->lock);
}

vsdd_conn **vsdd_conns_hold_all(vsdd_conns *cs, int *n)
{
    vsdd_conn **list, *c;
    int k = 0;
    vsdd_lock(&cs->lock);
    list = malloc(sizeof *list * (size_t)(cs->count + 1));
    for (c = cs->list; c && list; c = c->link.next) {
        c->link.refs++; /* kept alive while the caller talks to it */
        list[k++] = c;
    }
    vsdd_unlock(&cs->lock);
    *n = k;
    return list;
}

int vsdd_conns_wait_readers(vsdd_conns *cs, double seconds)
{
    struct timespec until = vsdd_deadline_ms((long)(seconds * 1000));
    int left;
    vsdd_lock(&cs->lock);
    while (cs->readers > 0)
        if (vsdd_cond_timedwait(&cs->idle, &cs->lock, &until) != 0) break;
    left = cs->readers;
    vsdd_unlock(&cs->lock);
    return left > 0 ? -1 : 0;
}
