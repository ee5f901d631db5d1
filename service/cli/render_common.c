/* What in-process and remote `vsd render` share (render_common.h). */
#define _POSIX_C_SOURCE 200809L
#include "render_common.h"
#include "commands.h"
#include <signal.h>
#include <stdio.h>

static volatile int g_cancel = 0;

static void on_sigint(int sig)
{
    (void)sig;
    g_cancel = 1;
}

volatile int *vsd_cli_cancel_on_sigint(void)
{
    signal(SIGINT, on_sigint);
    return &g_cancel;
}

int vsd_exit_code_for(vsd_status st, int writing)
{
    if (st == VSD_ERR_IO && !writing) return VSD_EXIT_INPUT;
    switch (st) {
    case VSD_OK: return VSD_EXIT_OK;
    case VSD_ERR_CANCELLED: return VSD_EXIT_CANCELLED;
    case VSD_ERR_FORMAT: case VSD_ERR_NOT_FOUND: case VSD_ERR_TYPE: case VSD_ERR_INVALID:
    case VSD_ERR_UNSUPPORTED: return VSD_EXIT_INPUT;
    default: return VSD_EXIT_RENDER_FAILED;
    }
}

int vsd_cli_job_scene(const vsd_render_job *job, vsd_scene *scene)
{
    char err[2048];
    vsd_status st = vsd_render_job_scene(job, scene, err, sizeof err);
    if (st) fprintf(stderr, "vsd render: %s\n", err);
    return vsd_exit_code_for(st, 0);
}
