/* Daemon logging: one line per event on stderr, "<time> vsd serve: <level>: <message>". */
#define _POSIX_C_SOURCE 200809L
#include "daemon_state.h"
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* Set once at start, before any thread; VSDD_LOG_ERROR until then (the loader's zygote and
 * children, which have no options, log only errors). */
static int log_level = VSDD_LOG_ERROR;

void vsdd_log_set_level(int level) { log_level = level; }

void vsdd_log(int level, const char *fmt, ...)
{
    static const char *const names[] = {"error", "warn", "info", "debug"};
    char line[2048], stamp[32];
    struct timespec ts;
    struct tm tm;
    va_list ap;
    int n;
    if (level > log_level) return;
    clock_gettime(CLOCK_REALTIME, &ts);
    localtime_r(&ts.tv_sec, &tm);
    strftime(stamp, sizeof stamp, "%Y-%m-%d %H:%M:%S", &tm);
    n = snprintf(line, sizeof line, "%s.%03ld vsd serve: %s: ", stamp, ts.tv_nsec / 1000000L,
                 names[level < 0 ? 0 : level > 3 ? 3 : level]);
    va_start(ap, fmt);
    vsnprintf(line + n, sizeof line - (size_t)n - 1, fmt, ap);
    va_end(ap);
    n = (int)strlen(line);
    /* one write per line, so lines from different threads never interleave */
    for (int i = 0; i < n; i++)
        if (line[i] == '\n') line[i] = ' ';
    line[n++] = '\n';
    if (write(STDERR_FILENO, line, (size_t)n) < 0) {}
}
