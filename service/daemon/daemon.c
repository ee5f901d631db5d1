/* The daemon record's life (daemon.h): its modules made in dependency order from its
 * configuration, and stopped and freed in the reverse order at shutdown. */
#define _GNU_SOURCE
#include "daemon.h"
#include "counters.h"
#include "conns.h"
#include <stdio.h>

int vsdd_daemon_start(vsdd_daemon *d, char *err, size_t errlen)
{
    d->counters = vsdd_counters_new();
    d->conns = vsdd_conns_new();
    d->loader = vsdd_loader_new(&d->cfg);
    if (!d->counters || !d->conns || !d->loader) {
        snprintf(err, errlen, "out of memory");
        vsdd_daemon_stop(d);
        return -1;
    }
    d->cache = vsdd_cache_new(&d->cfg, d->loader, err, errlen);
    if (!d->cache) {
        vsdd_daemon_stop(d);
        return -1;
    }
    d->jobs = vsdd_jobs_start(d);
    if (!d->jobs) {
        snprintf(err, errlen, "cannot start worker threads");
        vsdd_daemon_stop(d);
        return -1;
    }
    return 0;
}

void vsdd_daemon_stop(vsdd_daemon *d)
{
    int readers = 0, listed = 0;
    if (d->jobs) vsdd_jobs_stop(d->jobs);
    if (d->conns) {
        vsdd_conn_stop_all(d);
        vsdd_conns_counts(d->conns, &listed, &readers);
    }
    if (d->loader) vsdd_loader_shutdown(d->loader);
    if (d->cache) vsdd_cache_shutdown(d->cache);
    if (readers > 0) {
        /* a reader that outlived the wait may still touch its connection, the jobs or the
         * cache: leave them to the process's exit rather than free them under it */
        vsdd_log(VSDD_LOG_WARN, "%d connection reader(s) still running at exit", readers);
        return;
    }
    vsdd_jobs_free(d->jobs);
    vsdd_cache_free(d->cache);
    vsdd_loader_free(d->loader);
    vsdd_conns_free(d->conns);
    vsdd_counters_free(d->counters);
    d->jobs = NULL;
    d->cache = NULL;
    d->loader = NULL;
    d->conns = NULL;
    d->counters = NULL;
}
