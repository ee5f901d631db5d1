/* daemon.h — internals of `vsd serve` (docs/protocol.md describes what clients see).
 *
 * Layers: each file calls only the layers below it (never up, never around in a loop).
 *
 *     serve.c, serve_options.c     start-up, options, accept loop, shutdown
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
 *        |- loader_isolated.c      daemon side: request to the zygote, deadline, status
 *        |- loader_zygote.c        `serve --loader-zygote`: forks one child per decode
 *        |- loader_child.c         child: rlimits, seccomp (loader_sandbox.c), test hook
 *        |- loader_wire.c          the child's reply on a pipe, checked by the parent
 *        '- loader_decode.c        the one decoding path both modes run
 *     ------------------------------------------------------------------------------
 *     bottom: daemon_state.c (config, g_daemon, connection lifetime), log.c,
 *             reply.c (frames out, vsdd_err), policy.c (blob names, --allow-path),
 *             listen.c (sockets, lock file); the clock is vsd_clock_seconds (vsd/clock.h)
 *
 * (conn.c also reads the cache for HAS/PUT/STATS: still downward.) The cache receives
 * the renderer's progress callback from render_job_render.c rather than calling it.
 *
 * Threads: the main thread accepts connections and waits for SIGTERM/SIGINT; each
 * connection has a reader thread (conn.c) that parses frames and answers everything but
 * RENDER itself; RENDER becomes a job in a bounded FIFO queue (jobs.c) run by --workers
 * worker threads (render_job.c); a watchdog cancels jobs past max_job_seconds. A cache
 * miss on a volume or map decodes it in a child process forked by the loader zygote, a
 * separate single-threaded process (loader_zygote.c); the worker waits for it at most
 * --loader-seconds.
 * Locks: g_daemon.lock guards connections, the queue and running jobs; the cache has its
 * own lock (cache.c); a connection's wlock serialises frames written to it. Never take
 * g_daemon.lock while holding the cache lock.
 *
 * This header includes every layer's header, for code outside the daemon that wants the
 * whole of it (tests, fuzz harnesses); the daemon's own files include what they use. */
#ifndef VSD_DAEMON_H
#define VSD_DAEMON_H
#include "daemon_state.h"
#include "reply.h"
#include "policy.h"
#include "loader.h"
#include "cache.h"
#include "render_job.h"
#include "jobs.h"
#include "conn.h"
#endif
