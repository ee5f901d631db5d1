/* loader_sandbox.h — the loader child's seccomp filter (Linux x86-64 and arm64). */
#ifndef VSD_DAEMON_LOADER_SANDBOX_H
#define VSD_DAEMON_LOADER_SANDBOX_H
#include <stddef.h>
/* Install it for the rest of the process's life: 0, or -1 with err filled (an
 * architecture or kernel without it: the child goes on without). */
int vsdd_sandbox_enter(char *err, size_t errlen);
#endif
