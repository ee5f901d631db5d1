/* `vsd`, the command users type. `vsd render --remote` runs here: it only parses the job,
 * hashes and uploads files and writes what the daemon returns, so this executable links no
 * renderer library (OpenVDB, TBB, OpenColorIO, OpenEXR, OpenBLAS, CUDA). Loading those
 * took 60 ms of every remote render's start (79% in the dynamic loader, 62 libraries);
 * this starts in about 2 ms (docs/daemon-bench.md). Every other command, and a remote
 * render with --continue (it reads the EXR files already written) or --help, runs in
 * vsd-core, which holds all commands and which this replaces itself with (execv: the same
 * process id, arguments and environment). */
#define _GNU_SOURCE
#include <stdlib.h>
#include "commands.h"
#include "render_common.h"
#include "render_remote.h"
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#define CORE_NAME "vsd-core"

/* vsd-core beside this executable (a build folder), else in ../libexec/vsd (installed). */
static int exec_core(char **argv)
{
    static const char *const places[] = {"%s/" CORE_NAME, "%s/../libexec/vsd/" CORE_NAME};
    char self[4096], core[4096 + 64];
    char *slash;
    size_t i;
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0 || (size_t)n >= sizeof self - 1) {
        fprintf(stderr, "vsd: cannot find this executable (/proc/self/exe): %s\n",
                n <= 0 ? strerror(errno) : "path too long");
        return VSD_EXIT_RENDER_FAILED;
    }
    self[n] = '\0';
    slash = strrchr(self, '/');
    if (slash) *slash = '\0';
    for (i = 0; i < sizeof places / sizeof places[0]; i++) {
        snprintf(core, sizeof core, places[i], self);
        if (access(core, X_OK) == 0) {
            /* the command the user ran, for what names it to others (vsd farm's scripts) */
            if (slash) *slash = '/';
            setenv("VSD_FRONT", self, 1);
            execv(core, argv);
            fprintf(stderr, "vsd: cannot run %s: %s\n", core, strerror(errno));
            return VSD_EXIT_RENDER_FAILED;
        }
    }
    fprintf(stderr, "vsd: " CORE_NAME " (every command but `render --remote`) is neither in %s nor in "
                    "%s/../libexec/vsd: the installation is incomplete\n", self, self);
    return VSD_EXIT_RENDER_FAILED;
}

/* Only a command line that names --remote is parsed here (an INI file's own remote
 * setting, if it had one, would simply run in vsd-core). */
static int asks_remote(int argc, char **argv)
{
    int i;
    if (argc < 2 || strcmp(argv[1], "render") != 0) return 0;
    for (i = 2; i < argc; i++)
        if (strcmp(argv[i], "--remote") == 0 || strncmp(argv[i], "--remote=", 9) == 0) return 1;
    return 0;
}

int main(int argc, char **argv)
{
    static vsd_render_job job; /* large: its override strings */
    vsd_scene scene;
    int rc;
    if (!asks_remote(argc, argv)) return exec_core(argv);
    rc = vsd_render_job_parse(argc - 1, argv + 1, &job);
    /* The parse printed nothing for these: vsd-core parses again and does the rest. */
    if (job.help || job.usage_error || (!rc && job.resume)) return exec_core(argv);
    if (rc) return rc;
    if ((rc = vsd_cli_job_scene(&job, &scene)) != 0) return rc;
    return vsd_render_job_remote(&scene, &job, scene.frames.end - scene.frames.start + 1, NULL, NULL,
                                 vsd_cli_cancel_on_sigint());
}
