/* run_logged.h — run a program with its output into a log file (header-only), shared by the
 * Cycles cross-check (tests/cycles/test_cycles_crosscheck.c) and vsd_bench, which both run
 * Blender with cycles_scene.py and keep its output for when it fails. Needs
 * _POSIX_C_SOURCE 200809L. */
#ifndef VSD_RUN_LOGGED_H
#define VSD_RUN_LOGGED_H
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

/* Run argv (argv[0] a path, or a name looked up in $PATH) with stdout and stderr into `log`;
 * returns its exit status, 128 + the signal when one killed it, -1 when it was not run. */
static inline int run_logged(char *const argv[], const char *log)
{
    pid_t pid = fork();
    int status;
    if (pid < 0) return -1;
    if (pid == 0) {
        int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
            close(fd);
        }
        execvp(argv[0], argv);
        fprintf(stderr, "exec %s: %s\n", argv[0], strerror(errno));
        _exit(127);
    }
    if (waitpid(pid, &status, 0) < 0) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

/* Appends to argv[n..] Blender's headless arguments and cycles_scene.py's common ones (the
 * script, the scene, the EXR out, the film, the samples, the seed when not NULL, the timings'
 * JSON); returns the new n. The caller puts the Blender command first and may add more of
 * the script's options after (--frame, --step-rate ...), then argv[n] = NULL. */
static inline int cycles_scene_args(char **argv, int n, const char *script, const char *scene, const char *out,
                                    const char *width, const char *height, const char *samples, const char *seed,
                                    const char *time_json)
{
    argv[n++] = "--background";
    argv[n++] = "--factory-startup";
    argv[n++] = "--python-exit-code";
    argv[n++] = "1";
    argv[n++] = "--python";
    argv[n++] = (char *)script;
    argv[n++] = "--";
    argv[n++] = "--scene";
    argv[n++] = (char *)scene;
    argv[n++] = "--out";
    argv[n++] = (char *)out;
    argv[n++] = "--width";
    argv[n++] = (char *)width;
    argv[n++] = "--height";
    argv[n++] = (char *)height;
    argv[n++] = "--samples";
    argv[n++] = (char *)samples;
    if (seed) {
        argv[n++] = "--seed";
        argv[n++] = (char *)seed;
    }
    argv[n++] = "--time-json";
    argv[n++] = (char *)time_json;
    return n;
}

#endif
