/* daemon.h — internals of `vsd serve` (docs/protocol.md describes what clients see).
 *
 * Threads: the main thread accepts connections and waits for SIGTERM/SIGINT; each
 * connection has a reader thread (conn.c) that parses frames and answers everything but
 * RENDER itself; RENDER becomes a job in a bounded FIFO queue (jobs.c) run by --workers
 * worker threads (render_job.c); a watchdog cancels jobs past max_job_seconds.
 * Locks: g_daemon.lock guards connections, the queue and running jobs; the cache has its
 * own lock (cache.c); a connection's wlock serialises frames written to it. Never take
 * g_daemon.lock while holding the cache lock. */
#ifndef VSD_DAEMON_H
#define VSD_DAEMON_H
#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <cjson/cJSON.h>
#include "vsd/render.h"
#include "../protocol/vsd_proto.h"

#define VSDD_MAX_ALLOW 8

/* A renderer slot's inputs: density, emission, environment, the refractive index's grid */
#define VSDD_SLOT_PINS 4

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
    uint64_t cache_bytes;
    int workers, threads, queue_max, max_connections;
    uint64_t max_message;          /* binary part of one frame (a PUT blob) */
    uint32_t max_json;             /* JSON part of one frame */
    int max_dim;                   /* film width/height */
    uint64_t max_pixels;
    uint64_t max_voxels;           /* active voxels of one grid */
    double max_job_seconds;
    int log_level;                 /* 0 error, 1 warn, 2 info, 3 debug */
} vsdd_config;

enum { VSDD_LOG_ERROR = 0, VSDD_LOG_WARN, VSDD_LOG_INFO, VSDD_LOG_DEBUG };
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

double vsdd_now(void);

/* conn.c */
void vsdd_conn_start(int fd, int is_tcp, const char *peer);
void vsdd_conn_release(vsdd_conn *c);            /* takes g_daemon.lock */
void vsdd_conn_release_locked(vsdd_conn *c);
/* Send one frame (JSON object consumed: deleted here). 0 ok, -1 connection gone. */
int vsdd_send(vsdd_conn *c, unsigned type, cJSON *json, const void *bin, size_t bin_len);
int vsdd_send2(vsdd_conn *c, unsigned type, cJSON *json, const void *a, size_t alen, const void *b, size_t blen);
/* ERROR {id, code, message} (+ extra fields from `extra`, consumed, may be NULL). */
int vsdd_send_error(vsdd_conn *c, const cJSON *id, const char *code, const char *message, cJSON *extra);
int vsdd_send_error_id(vsdd_conn *c, double id, int has_id, const char *code, const char *message, cJSON *extra);

/* jobs.c */
int vsdd_jobs_start(void);
/* Queue a RENDER (takes ownership of req). Returns 0 queued, -1 busy, -2 stopping. */
int vsdd_job_submit(vsdd_conn *c, double id, cJSON *req, int *position);
/* Cancel by (conn, id); returns 1 when found. */
int vsdd_job_cancel(vsdd_conn *c, double id);
void vsdd_jobs_cancel_conn(vsdd_conn *c);        /* on disconnect */
void vsdd_jobs_stop(void);                       /* cancel everything, join workers */
void vsdd_jobs_counts(int *queued, int *running);

/* render_job.c: run one job on the calling worker thread; sends PROGRESS/RESULT/ERROR. */
void vsdd_run_job(vsdd_job *job, int worker);

/* cache.c */
int vsdd_cache_init(char *err, size_t errlen);
void vsdd_cache_shutdown(void);
int vsdd_cache_has_blob(const char *hash);
/* Receive `len` bytes from fd into the blob store, verifying `hash`. Returns 0 ok (or
 * already stored), else fills code/message (and the stream may be unusable: *fatal). */
int vsdd_cache_put_blob(int fd, const char *hash, uint64_t len, const char **code, char *msg, size_t msglen,
                        int *fatal);
cJSON *vsdd_cache_stats(void);

typedef struct vsdd_entry vsdd_entry;
/* Pinned volume / env entries (loaded on a miss). src is "blob:<hash>" or a confined path. */
int vsdd_cache_get_volume(const char *src, const char *grid, int grid_index, vsdd_entry **out, int *hit,
                          const char **code, char *msg, size_t msglen);
int vsdd_cache_get_env(const char *src, const char *colorspace, vsdd_entry **out, int *hit,
                       const char **code, char *msg, size_t msglen);
const vsd_volume *vsdd_entry_volume(const vsdd_entry *e);
const vsd_env *vsdd_entry_env(const vsdd_entry *e);
void vsdd_cache_unpin(vsdd_entry *e);
/* The file behind src ("blob:<hash>", pinned into *blob until vsdd_cache_unpin, or a
 * confined path, *blob = NULL): what the EXR's vsd/scene_hash reads (the file's bytes). */
int vsdd_cache_pin_file(const char *src, char *path, size_t len, vsdd_entry **blob, const char **code, char *msg,
                        size_t msglen);

/* A renderer kept per (method, options, volume, emission, environment): a camera change
 * re-renders from its prepared state. */
typedef struct vsdd_slot {
    vsd_renderer *r;
    volatile int cancel;
    vsdd_job *job;                 /* the job rendering now (progress goes to it) */
    double last_progress_time;
    float last_fraction;
    char last_stage[32];
    char prep_key[2048];           /* scene fields preparation depends on, last render */
    vsdd_entry *pins[VSDD_SLOT_PINS]; /* density, emission, env, ior grid entries (may be NULL) */
    vsdd_entry *self;
} vsdd_slot;
/* Find an idle renderer for key or create one. Takes over the caller's pins in every case
 * (kept by a new slot, released on a hit or a failure); returns 0 or -vsd_status.
 * The slot is in use until vsdd_cache_release_slot. */
int vsdd_cache_get_slot(const char *key, const vsd_scene *scene, vsdd_entry *pins[VSDD_SLOT_PINS], vsdd_slot **out, int *hit,
                        char *msg, size_t msglen);
void vsdd_cache_release_slot(vsdd_slot *s, int keep);

/* serve.c */
int vsdd_path_allowed(const char *path, char *resolved, size_t len);

#endif
