/* The per-user folder where methods keep work that outlives a run (crm's RBF fits): one
 * rule for the CLI and the daemon. Files there are keyed by content, so any number of
 * processes may share it. */
#include "vsd/render.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *vsd_default_cache_dir(char *buf, size_t len)
{
    const char *env;
    if ((env = getenv("VSD_CACHE_DIR")) && env[0]) {
        if (strcmp(env, "none") == 0) return NULL;
        snprintf(buf, len, "%s", env);
    } else if ((env = getenv("XDG_CACHE_HOME")) && env[0]) {
        snprintf(buf, len, "%s/vsd", env);
    } else if ((env = getenv("HOME")) && env[0]) {
        snprintf(buf, len, "%s/.cache/vsd", env);
    } else {
        return NULL;
    }
    return buf;
}
