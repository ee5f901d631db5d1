/* test_daemon_proc.h — a real `vsd serve` for the daemon tests (test_daemon,
 * test_daemon_isolation): started on a socket in a test folder, with a ready file and a
 * log, stopped with SIGTERM. */
#ifndef VSD_TEST_DAEMON_PROC_H
#define VSD_TEST_DAEMON_PROC_H
#include <sys/types.h>

typedef struct test_daemon {
    pid_t pid;
    char sock[256], ready[300], log[300];
} test_daemon;

/* `vsd serve` with DIR/NAME.sock, DIR/NAME.ready (--ready-file), its stderr in DIR/NAME.log,
 * --cache-dir DIR, --log-level debug, then `extra` (NULL-terminated, may be NULL); the
 * child gets env_name=env_value when env_name is given. Waits up to 10 s for the ready
 * file: 0, or -1 with a line naming the log. */
int test_daemon_start(test_daemon *d, const char *vsd, const char *dir, const char *name, const char *env_name,
                      const char *env_value, const char *const *extra);
/* SIGTERM and wait: its exit status, 128 + the signal that ended it, or -1 when it did not
 * exit within 10 s (it is then killed). */
int test_daemon_stop(test_daemon *d);
int test_daemon_alive(const test_daemon *d);

#endif
