/* daemon_state.h — the bottom layer's shared state: the configuration, the connection and
 * job records, the one `g_daemon` and the reference count that keeps a connection alive
 * while a reader or a job uses it. Every other daemon file may include this; it includes
 * nothing of the daemon's. The clock is the library's vsd_clock_seconds (vsd/clock.h). */
#ifndef VSD_DAEMON_STATE_H
#define VSD_DAEMON_STATE_H
#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <cjson/cJSON.h>
#include "vsd/clock.h"
#include "vsd/render.h"
#include "../protocol/vsd_proto.h"

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
    char cache_parent[VSD_PATH_LEN];
    char cache_dir[VSD_PATH_LEN];  /* private folder made at start, removed at exit */
    char method_cache[VSD_PATH_LEN]; /* methods' work kept between runs (crm fits); "" = none */
    uint64_t cache_bytes;          /* --cache-mb: volumes, maps, renderers (memory) */
    uint64_t blob_bytes;           /* --blob-mb: blob files (disk), a budget of their own so
                                      memory pressure never evicts an upload before its RENDER */
    int workers, threads, queue_max, max_connections;
    uint64_t max_message;          /* binary part of one frame (a PUT blob) */
    uint32_t max_json;             /* JSON part of one frame */
    int max_dim;                   /* film width/height */
    uint64_t max_pixels;
    uint64_t max_voxels;           /* active voxels of one grid */
    double max_job_seconds;
    int log_level;                 /* 0 error, 1 warn, 2 info, 3 debug */
    int loader;                    /* VSDD_LOADER_*: --loader isolated|inprocess */
    uint64_t loader_bytes;         /* --loader-mb: the decoder process's address space */
    double loader_seconds;         /* --loader-seconds: wall clock of one decode */
    char loader_exe[VSD_PATH_LEN]; /* the executable that runs `serve --loader-child` */
} vsdd_config;

enum { VSDD_LOG_ERROR = 0, VSDD_LOG_WARN, VSDD_LOG_INFO, VSDD_LOG_DEBUG };
/* log.c: one line on stderr per event. */
void vsdd_log(int level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

typedef struct vsdd_conn {
    int fd;
    unsigned id;
    int is_tcp;
    int hello_done;
    int dead;                      /* write failed or reader gone: drop frames */
    int refs;                      /* reader + jobs; guarded by g_daemon.lock */
    pthread_mutex_t wlock;
    char peer[64];
    struct vsdd_conn *next;
} vsdd_conn;

enum { VSDD_JOB_QUEUED, VSDD_JOB_RUNNING };
enum { VSDD_CANCEL_NONE = 0, VSDD_CANCEL_CLIENT, VSDD_CANCEL_DISCONNECT, VSDD_CANCEL_TIMEOUT, VSDD_CANCEL_SHUTDOWN };

typedef struct vsdd_job {
    double id;                     /* the client's request id (JSON number) */
    unsigned long seq;             /* daemon-wide job number (logs, temp names) */
    vsdd_conn *conn;               /* one reference held */
    cJSON *req;                    /* the RENDER message, owned */
    int state;
    int cancel_reason;             /* VSDD_CANCEL_*; guarded by g_daemon.lock */
    volatile int *cancel_flag;     /* the renderer's cancel flag while running */
    double queued_at, started_at;
    struct vsdd_job *next;         /* queue or running list */
} vsdd_job;

typedef struct vsdd_daemon {
    vsdd_config cfg;
    pthread_mutex_t lock;
    pthread_cond_t queue_cond;     /* workers wait for jobs */
    pthread_cond_t idle_cond;      /* shutdown waits for readers */
    vsdd_conn *conns;
    int conn_count, readers;
    vsdd_job *queue_head, *queue_tail, *running;
    int queued;
    int stopping;
    unsigned long next_job_seq;
    unsigned next_conn_id;
    double start_time;
    char cuda_device[128];         /* the GPU HELLO offers, "" when none answered at start */
    /* counters for STATS */
    uint64_t jobs_done, jobs_failed, jobs_cancelled, jobs_busy, bytes_received, blobs_received;
} vsdd_daemon;

extern vsdd_daemon g_daemon;

/* Drop one reference; the last one closes the socket and frees the record. */
void vsdd_conn_release(vsdd_conn *c);            /* takes g_daemon.lock */
void vsdd_conn_release_locked(vsdd_conn *c);

/* Add one to a counter of g_daemon (jobs_done, ...) under g_daemon.lock. */
void vsdd_count(uint64_t *counter, uint64_t n);

#endif
