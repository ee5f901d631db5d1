/* The loader child: forked by the loader zygote (loader_zygote.c) for one decode. It
 * limits itself before it opens the file (it is still only our own code until then):
 * address space (--loader-mb), no core files, a seccomp filter (loader_sandbox.c); then it
 * decodes with the same function the in-process loader uses and writes the result to
 * fd 3 (loader_wire.c). It leaves with _exit: the decoders' static destructors have
 * nothing to do that the exit does not.
 *
 * Test hook: VSD_TEST_LOADER_CRASH=MODE[:TEXT][,MODE[:TEXT]...] (MODE segv, hang or oom;
 * applies to sources whose name contains TEXT, all when absent) makes this child crash,
 * hang or allocate without bound before decoding. Only the child reads it, so a daemon
 * with --loader inprocess ignores it. */
#define _GNU_SOURCE
#include "loader.h"
#include "loader_sandbox.h"
#include "loader_wire.h"
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#define RESULT_FD 3

/* The hook's mode for this source ("" = none). */
static void test_hook_mode(const char *src, char *mode, size_t len)
{
    const char *spec = getenv("VSD_TEST_LOADER_CRASH");
    char buf[1024], *save = NULL, *item;
    mode[0] = '\0';
    if (!spec || !spec[0]) return;
    snprintf(buf, sizeof buf, "%s", spec);
    for (item = strtok_r(buf, ",", &save); item; item = strtok_r(NULL, ",", &save)) {
        char *colon = strchr(item, ':');
        if (colon) *colon = '\0';
        if (!colon || strstr(src, colon + 1)) {
            snprintf(mode, len, "%s", item);
            return;
        }
    }
}

/* Misbehave as a broken decoder would. Returns only for an unknown mode, or for oom once
 * the allocation failed (with e filled, as the VDB reader reports std::bad_alloc). */
static int run_test_hook(const char *mode, const char *src, uint64_t limit_mb, vsdd_err *e)
{
    if (strcmp(mode, "segv") == 0) {
        raise(SIGSEGV);
    } else if (strcmp(mode, "hang") == 0) {
        for (;;) pause(); /* until the parent's deadline kills us */
    } else if (strcmp(mode, "oom") == 0) {
        /* touch 16 MiB blocks until malloc fails; stop at 2 GiB so a missing limit shows up
         * in the message instead of in the machine's OOM killer */
        uint64_t mib = 0;
        for (;;) {
            char *p = mib < 2048 ? malloc(16u << 20) : NULL;
            if (!p) break;
            memset(p, 1, 16u << 20);
            mib += 16;
        }
        return vsdd_fail(e, VSD_E_INPUT, "%s: out of memory while reading (test hook: %llu MiB allocated, --loader-mb %llu)",
                         src, (unsigned long long)mib, (unsigned long long)limit_mb);
    }
    return 0;
}

static void limit_self(uint64_t mb)
{
    struct rlimit rl;
    rl.rlim_cur = rl.rlim_max = 0;
    setrlimit(RLIMIT_CORE, &rl);
    rl.rlim_cur = rl.rlim_max = (rlim_t)(mb << 20);
    setrlimit(RLIMIT_AS, &rl);
}

void vsdd_loader_child_run(const vsdd_load_req *req)
{
    char mode[16], sandbox_err[256];
    int rc;
    vsdd_err e = {NULL, ""};
    limit_self(req->mb);
    if (vsdd_sandbox_enter(sandbox_err, sizeof sandbox_err))
        fprintf(stderr, "vsd serve: loader: no seccomp filter: %s\n", sandbox_err);
    test_hook_mode(req->src, mode, sizeof mode);
    if (mode[0] && run_test_hook(mode, req->src, req->mb, &e)) /* the same way out as a decoder's error */
        _exit(vsdd_wire_put_error(RESULT_FD, &e) ? 4 : 0);
    if (req->kind == VSDD_WIRE_VOLUME) {
        vsd_volume *v = NULL;
        rc = vsdd_decode_volume(req->src, req->path, req->name, req->index, req->limit, &v, &e)
                 ? vsdd_wire_put_error(RESULT_FD, &e)
                 : vsdd_wire_put_volume(RESULT_FD, v);
    } else if (req->kind == VSDD_WIRE_ENV) {
        vsd_env *env = NULL;
        rc = vsdd_decode_env(req->src, req->path, req->name, req->limit, &env, &e) ? vsdd_wire_put_error(RESULT_FD, &e)
                                                                                : vsdd_wire_put_env(RESULT_FD, env);
    } else {
        vsdd_fail(&e, VSD_E_INTERNAL, "loader: unknown kind %d", req->kind);
        rc = vsdd_wire_put_error(RESULT_FD, &e);
    }
    _exit(rc ? 4 : 0);
}
