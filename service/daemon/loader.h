/* loader.h — turning a VDB or map file into a vsd_volume / vsd_env for the cache.
 *
 * By default (--loader isolated) the decoders (OpenVDB, Blosc, OpenEXR, OCIO) run in a
 * short-lived child process (loader_child.c), limited in address space (--loader-mb) and
 * wall-clock time (--loader-seconds): a crash, hang or runaway allocation on hostile
 * input then costs the client an ERROR, not the daemon. The children are forked by a
 * zygote (loader_zygote.c), a single-threaded `vsd serve --loader-zygote` started once.
 * The child streams the decoded arrays back through a pipe (loader_wire.c) and the parent
 * rebuilds the same structs, bit for bit. --loader inprocess decodes on the worker thread
 * (for debugging). Both run vsdd_decode_* below, so limits and messages are the same. */
#ifndef VSD_DAEMON_LOADER_H
#define VSD_DAEMON_LOADER_H
#include "reply.h"

/* The daemon's loader (loader.c): decodes as cfg->loader says (read on every decode), within
 * cfg's limits. cfg must outlive it. NULL when out of memory. */
vsdd_loader *vsdd_loader_new(const vsdd_config *cfg);
/* Stop the zygote (at shutdown); a later isolated decode would start it again. */
void vsdd_loader_shutdown(vsdd_loader *l);
void vsdd_loader_free(vsdd_loader *l);
/* src is what the client named ("blob:<hash>" or a confined path; messages use it), path
 * the file to read. 0, or -1 with e filled. */
int vsdd_load_volume(vsdd_loader *l, const char *src, const char *path, const char *grid, int grid_index,
                     vsd_volume **out, vsdd_err *e);
int vsdd_load_env(vsdd_loader *l, const char *src, const char *path, const char *conversion, vsd_env **out,
                  vsdd_err *e);

/* loader_decode.c: the decoding itself, with the daemon's limits passed in (the child has
 * no daemon configuration). */
int vsdd_decode_volume(const char *src, const char *path, const char *grid, int grid_index, uint64_t max_voxels,
                       vsd_volume **out, vsdd_err *e);
int vsdd_decode_env(const char *src, const char *path, const char *conversion, uint64_t max_pixels, vsd_env **out,
                    vsdd_err *e);

/* loader_isolated.c: the daemon's side of one isolated decode, and the zygote it talks to
 * (started on the first decode, its socket and pid under its own lock, VSDD_RANK_LOADER). */
typedef struct vsdd_zygote vsdd_zygote;
vsdd_zygote *vsdd_zygote_new(const vsdd_config *cfg);
void vsdd_zygote_stop(vsdd_zygote *z);
void vsdd_zygote_free(vsdd_zygote *z);            /* stops it first */
int vsdd_isolated_volume(vsdd_zygote *z, const char *src, const char *path, const char *grid, int grid_index,
                         vsd_volume **out, vsdd_err *e);
int vsdd_isolated_env(vsdd_zygote *z, const char *src, const char *path, const char *conversion, vsd_env **out,
                      vsdd_err *e);

/* One decode request, as the daemon sends it to the zygote (one SOCK_SEQPACKET message). */
typedef struct vsdd_load_req {
    int32_t kind;                  /* VSDD_WIRE_VOLUME or VSDD_WIRE_ENV (loader_wire.h) */
    int32_t index;                 /* grid index, -1 = by name */
    uint64_t limit;                /* max voxels of the grid / max pixels (x4) of the map */
    uint64_t mb;                   /* the child's address space, MiB */
    char path[VSD_PATH_LEN];       /* the file */
    char src[VSD_PATH_LEN + 8];    /* the client's name for it (messages) */
    char name[1024];               /* grid name or colour conversion (vsd_env_conversion) */
} vsdd_load_req;

/* loader_zygote.c: main of `vsd serve --loader-zygote` (spawned by loader_isolated.c with
 * its request socket on fd 3). Forks one child per request. Returns the exit status. */
int vsdd_loader_zygote_main(void);
/* loader_child.c: the forked child's whole life (result on fd 3); does not return. */
void vsdd_loader_child_run(const vsdd_load_req *req)
#if defined(__GNUC__)
    __attribute__((noreturn))
#endif
    ;

#endif
