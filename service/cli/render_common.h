/* render_common.h — what `vsd render` does the same way in-process (vsd-core) and through
 * a daemon from the light `vsd` front: exit codes for library errors, loading the job's
 * scene with its message, and Ctrl-C as a cancel flag. */
#ifndef VSD_CLI_RENDER_COMMON_H
#define VSD_CLI_RENDER_COMMON_H
#include "render_args.h"
#include "vsd/status.h"

/* A library error's exit code: reading failures (a missing VDB or map) are bad input,
 * writing failures (`writing` set) failed renders. */
int vsd_exit_code_for(vsd_status st, int writing);

/* vsd_render_job_scene with the CLI's message ("vsd render: ..."): 0 or the exit code. */
int vsd_cli_job_scene(const vsd_render_job *job, vsd_scene *scene);

/* SIGINT sets the flag returned (the renderer's and the client's cancel) from now on. */
volatile int *vsd_cli_cancel_on_sigint(void);
#endif
