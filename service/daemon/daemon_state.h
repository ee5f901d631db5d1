/* daemon_state.h — the bottom layer's shared definitions: the configuration, the
 * connection record, and the daemon record that every thread is handed (serve.c makes one
 * and passes it down; there is no global). The record holds the configuration, read-only
 * once the daemon runs, and one pointer per module whose state is private to that module's
 * files (each struct is defined in its .c or internal header, so no other file can touch
 * its fields; docs/daemon-internals.md lists who owns what). Every other daemon file may
 * include this; it includes nothing of the daemon's but lock_order.h. The clock is the
 * library's vsd_clock_seconds (vsd/clock.h). */
#ifndef VSD_DAEMON_STATE_H
#define VSD_DAEMON_STATE_H
#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <cjson/cJSON.h>
#include "vsd/clock.h"
#include "vsd/render.h"
#include "../protocol/vsd_proto.h"
#include "lock_order.h"

#define VSDD_MAX_ALLOW 8

/* How uploaded VDBs and maps are decoded (loader.h). */
enum { VSDD_LOADER_ISOLATED = 0, VSDD_LOADER_INPROCESS };

typedef struct vsdd_config {
    char socket_path[108];
    char lock_path[VSD_PATH_LEN];
    char tcp[256];                 /* "" = no TCP */
    int listen_any;
    char token[512];               /* from --token-file; required for TCP */
    char allow[VSDD_MAX_ALLOW][VSD_PATH_LEN]; /* realpath'd --allow-path folders */
    int allow_count;
    char cache_parent[VSD_PATH_LEN]; /* the cache makes its private folder in it (cache.c) */
    char method_cache[VSD_PATH_LEN]; /* methods' work kept between runs (crm fits); "" = none */
    uint64_t cache_bytes;          /* --cache-mb: volumes, maps, renderers (memory) */
    uint64_t blob_bytes;           /* --blob-mb: blob files (disk), a budget of their own so
                                      memory pressure never evicts an upload before its RENDER */
    int workers, threads, queue_max, max_connections;
    uint64_t max_message;          /* binary part of one frame (a PUT blob) */
    uint32_t max_json;             /* JSON part of one frame */
    int max_dim;                   /* film width/height */
    uint64_t max_pixels;
    uint64_t max_voxels;           /* active voxels of one grid, and of the density grids of
                                      a scene's volumes together (render_job_inputs.c) */
    double max_job_seconds;
    int log_level;                 /* 0 error, 1 warn, 2 info, 3 debug */
    int loader;                    /* VSDD_LOADER_*: --loader isolated|inprocess */
    uint64_t loader_bytes;         /* --loader-mb: the decoder process's address space */
    double loader_seconds;         /* --loader-seconds: wall clock of one decode */
    char loader_exe[VSD_PATH_LEN]; /* the executable that runs `serve --loader-child` */
} vsdd_config;

enum { VSDD_LOG_ERROR = 0, VSDD_LOG_WARN, VSDD_LOG_INFO, VSDD_LOG_DEBUG };
/* log.c: one line on stderr per event. The level is log.c's own (set once at start, before
 * any thread): logging is the process's, like its stderr, so no record is passed for it. */
void vsdd_log(int level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
void vsdd_log_set_level(int level);

/* One client connection. Its fields are grouped by owner: the first group is set before the
 * reader thread starts and only read after; each other group is touched by its file only. */
typedef struct vsdd_conn {
    int fd;
    unsigned id;                   /* set by conns.c when the connection is registered */
    int is_tcp;
    char peer[64];
    int hello_done;                /* conn.c's reader thread only */
    struct {                       /* reply.c's: frames out, one writer at a time */
        vsdd_mutex lock;           /* VSDD_RANK_CONN_WRITE */
        int dead;                  /* a write failed or the reader is gone: drop frames */
    } out;
    struct {                       /* conns.c's, under its lock */
        int refs;                  /* the reader + each job of the connection */
        struct vsdd_conn *next;
    } link;
} vsdd_conn;

/* Why a job stopped early (cancel.c keeps the first one raised). */
enum { VSDD_CANCEL_NONE = 0, VSDD_CANCEL_CLIENT, VSDD_CANCEL_DISCONNECT, VSDD_CANCEL_TIMEOUT, VSDD_CANCEL_SHUTDOWN };

/* The modules' own state, defined where said. */
typedef struct vsdd_conns vsdd_conns;        /* conns.c: the connection list and references */
typedef struct vsdd_jobs vsdd_jobs;          /* jobs.c: queue, running jobs, workers, watchdog */
typedef struct vsdd_cache vsdd_cache;        /* cache_internal.h: blobs, volumes, maps, renderers */
typedef struct vsdd_loader vsdd_loader;      /* loader.c / loader_isolated.c: the decoder zygote */
typedef struct vsdd_counters vsdd_counters;  /* counters.c: what STATS counts */

typedef struct vsdd_daemon {
    /* filled before the daemon starts (serve_options.c, serve.c), read-only after */
    vsdd_config cfg;
    double start_time;
    char cuda_device[128];         /* the GPU HELLO offers, "" when none answered at start */
    /* made by vsdd_daemon_start (daemon.c), freed by vsdd_daemon_stop */
    vsdd_counters *counters;
    vsdd_conns *conns;
    vsdd_loader *loader;
    vsdd_cache *cache;
    vsdd_jobs *jobs;
} vsdd_daemon;

#endif
