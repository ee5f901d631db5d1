/* daemon.h — internals of `vsd serve` (docs/protocol.md describes what clients see).
 *
 * Layers: each file calls only the layers below it (never up, never around in a loop).
 *
 *     serve.c, serve_options.c     start-up, options, shutdown
 *     daemon.c, accept.c           the daemon record's modules made and freed; the accept loop
 *        |
 *     conn.c                       one reader thread per connection: frames, HELLO, HAS,
 *        |                         PUT, CANCEL, STATS, BYE; RENDER becomes a job
 *     jobs.c                       bounded FIFO, --workers threads, watchdog, cancel
 *        |
 *     render_job.c                 one RENDER in four steps (render_job_steps.h):
 *        |                         _parse -> _inputs -> _render -> _reply, one vsdd_err
 *     cache.c                      blobs (--blob-mb), volumes, maps (--cache-mb)
 *        '- cache_slots.c          renderers: admission by memory, sizes learned per method
 *        |
 *     loader.c                     decode a VDB / map: isolated (default) or in-process
 *        |- loader_isolated.c      daemon side: the zygote, request, deadline, status
 *        |- loader_zygote.c        `serve --loader-zygote`: forks one child per decode
 *        |- loader_child.c         child: rlimits, seccomp (loader_sandbox.c), test hook
 *        |- loader_wire.c          the child's reply on a pipe, checked by the parent
 *        '- loader_decode.c        the one decoding path both modes run
 *     ------------------------------------------------------------------------------
 *     bottom: daemon_state.h (config, connection record, the daemon record), conns.c
 *             (connection list and lifetime), cancel.c (one job's cancellation),
 *             counters.c (STATS counters), lock_order.c (ranked mutexes), log.c,
 *             reply.c (frames out, vsdd_err), policy.c (blob names, --allow-path),
 *             listen.c (sockets, lock file); the clock is vsd_clock_seconds (vsd/clock.h)
 *
 * (conn.c also reads the cache for HAS/PUT/STATS: still downward.) The cache receives
 * the renderer's progress callback from render_job_render.c rather than calling it.
 *
 * State: no globals. serve.c makes one vsdd_daemon (daemon_state.h) and hands it down:
 * the reader threads, the workers and the watchdog get it when they start; each module
 * keeps its state in its own struct, defined in its own file, and the others call its
 * functions (docs/daemon-internals.md: who owns what).
 *
 * Threads: the main thread accepts connections and waits for SIGTERM/SIGINT; each
 * connection has a reader thread (conn.c) that parses frames and answers everything but
 * RENDER itself; RENDER becomes a job in a bounded FIFO queue (jobs.c) run by --workers
 * worker threads (render_job.c); a watchdog cancels jobs past max_job_seconds. A cache
 * miss on a volume or map decodes it in a child process forked by the loader zygote, a
 * separate single-threaded process (loader_zygote.c); the worker waits for it at most
 * --loader-seconds.
 * Locks: every mutex is a vsdd_mutex with a rank; lock_order.h lists them and why the
 * order is what it is, and checks it on every lock.
 *
 * This header includes every layer's header, for code outside the daemon that wants the
 * whole of it (tests, fuzz harnesses); the daemon's own files include what they use. */
#ifndef VSD_DAEMON_H
#define VSD_DAEMON_H
#include "daemon_state.h"
#include "lock_order.h"
#include "conns.h"
#include "cancel.h"
#include "counters.h"
#include "reply.h"
#include "policy.h"
#include "loader.h"
#include "cache.h"
#include "render_job.h"
#include "jobs.h"
#include "conn.h"
#include "accept.h"

/* daemon.c: make d's modules from d->cfg (counters, connections, loader, cache, then the
 * jobs with their worker threads): 0, or -1 with err and nothing left made. */
int vsdd_daemon_start(vsdd_daemon *d, char *err, size_t errlen);
/* Stop what vsdd_daemon_start made: jobs cancelled (their clients told), every client told
 * `shutdown` and its reader waited for (5 s at most), the loader's zygote stopped, the cache
 * emptied and its folder removed; then the modules freed (unless a reader outlived the wait). */
void vsdd_daemon_stop(vsdd_daemon *d);
#endif
