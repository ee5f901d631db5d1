/* policy.h — bottom layer: which files a RENDER may name (blob:<hash> names, or paths
 * confined to the --allow-path folders). */
#ifndef VSD_DAEMON_POLICY_H
#define VSD_DAEMON_POLICY_H
#include "reply.h"

/* 0 when path resolves (realpath) to a regular file under an --allow-path folder of cfg; the
 * resolved path goes to `resolved`. */
int vsdd_path_allowed(const vsdd_config *cfg, const char *path, char *resolved, size_t len);

/* Where a scene file field points: "blob:<hash>" (checked) or a path (frame pattern
 * expanded) confined to --allow-path. The source name goes to src. */
int vsdd_resolve_source(const vsdd_config *cfg, const char *field, const char *file, int frame, char *src, size_t len,
                        vsdd_err *e);

#endif
