/* loader_zygote.h — what the zygote sends back on a request's status socket once it has
 * reaped the child (loader_zygote.c, read by loader_isolated.c). */
#ifndef VSD_DAEMON_LOADER_ZYGOTE_H
#define VSD_DAEMON_LOADER_ZYGOTE_H
#include <stdint.h>
typedef struct vsdd_zygote_status {
    int32_t wait_status;    /* as from waitpid; -1 = the zygote could not fork */
    int64_t maxrss_kib;     /* the child's peak resident memory */
} vsdd_zygote_status;
#endif
