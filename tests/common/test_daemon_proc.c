/* A `vsd serve` process for tests (test_daemon_proc.h). */
#define _DEFAULT_SOURCE
#include "test_daemon_proc.h"
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

int test_daemon_start(test_daemon *d, const char *vsd, const char *dir, const char *name, const char *env_name,
                      const char *env_value, const char *const *extra)
{
    const char *argv[64];
    int n = 0, i;
    snprintf(d->sock, sizeof d->sock, "%s/%s.sock", dir, name);
    snprintf(d->ready, sizeof d->ready, "%s/%s.ready", dir, name);
    snprintf(d->log, sizeof d->log, "%s/%s.log", dir, name);
    unlink(d->ready);
    argv[n++] = vsd;
    argv[n++] = "serve";
    argv[n++] = "--socket";
    argv[n++] = d->sock;
    argv[n++] = "--ready-file";
    argv[n++] = d->ready;
    argv[n++] = "--cache-dir";
    argv[n++] = dir;
    argv[n++] = "--log-level";
    argv[n++] = "debug";
    for (i = 0; extra && extra[i] && n < 62; i++) argv[n++] = extra[i];
    argv[n] = NULL;
    d->pid = fork();
    if (d->pid == 0) {
        FILE *f = freopen(d->log, "w", stderr);
        (void)f;
        if (env_name) setenv(env_name, env_value ? env_value : "", 1);
        execv(vsd, (char *const *)argv);
        _exit(127);
    }
    for (i = 0; i < 200; i++) {
        if (access(d->ready, F_OK) == 0) return 0;
        usleep(50000);
    }
    fprintf(stderr, "daemon %s did not start (see %s)\n", name, d->log);
    return -1;
}

int test_daemon_stop(test_daemon *d)
{
    int i, status;
    if (d->pid <= 0) return -1;
    kill(d->pid, SIGTERM);
    for (i = 0; i < 200; i++) {
        if (waitpid(d->pid, &status, WNOHANG) == d->pid) {
            d->pid = 0;
            return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        }
        usleep(50000);
    }
    kill(d->pid, SIGKILL);
    waitpid(d->pid, &status, 0);
    d->pid = 0;
    return -1;
}

int test_daemon_alive(const test_daemon *d)
{
    int status;
    return d->pid > 0 && waitpid(d->pid, &status, WNOHANG) == 0;
}
