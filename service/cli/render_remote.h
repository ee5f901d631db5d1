/* render_remote.h — `vsd render --remote`: the same frames and files as in-process
 * rendering, rendered by a daemon (render_remote.c). */
#ifndef VSD_CLI_RENDER_REMOTE_H
#define VSD_CLI_RENDER_REMOTE_H
#include "render_args.h"
#include "vsd/render.h"

typedef struct vsd_remote_options {
    const char *address;         /* "" = default socket, a path, or HOST:PORT */
    const char *token_file;      /* for TCP; NULL = $VSD_TOKEN */
    int quiet;
    vsd_progress_fn progress;    /* the CLI's progress printer */
    void *user;
    void (*begin_frame)(void *user, int frame);
    void (*end_frame)(void *user, int ok);   /* after each rendered (ok) or failed frame */
    void (*report)(void *user);              /* after a written frame's line (run's ETA) */
    /* --continue: frames for which this answers non-zero are not rendered; NULL = none. */
    int (*skip_frame)(void *skip_user, int frame);
    void *skip_user;
    volatile int *cancel;        /* SIGINT */
} vsd_remote_options;

/* Uploads the frames' VDB files and the environment map the daemon lacks, renders every
 * frame, writes output.exr (and the preview PNG when the scene asks) via temp + rename.
 * Returns the process exit code. */
int vsd_render_remote(const char *scene_path, const vsd_scene *scene, const char *const *overrides,
                      int override_count, const vsd_remote_options *opt);

/* vsd_render_remote as `vsd render --remote` runs it: the CLI's progress lines over the
 * `to_render` frames that `skip` (NULL: none) does not skip, and `cancel` (SIGINT). */
int vsd_render_job_remote(const vsd_scene *scene, const vsd_render_job *job, int to_render,
                          int (*skip)(void *skip_user, int frame), void *skip_user, volatile int *cancel);
#endif
