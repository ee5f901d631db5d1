/* A deny list, not an allow list: the decoders' libraries (OpenVDB, TBB, Blosc, OpenEXR,
 * OCIO) make too many different calls to enumerate safely, but a decoder has no business
 * starting programs or processes, opening sockets, tracing or signalling other processes
 * (the daemon runs as the same user) or opening files for writing. Those calls fail with
 * EPERM; everything else the rlimits and the parent's deadline bound. Threads stay
 * allowed (clone with CLONE_THREAD); clone3, whose flags a filter cannot read, answers
 * ENOSYS so that glibc falls back to clone. */
#define _GNU_SOURCE
#include "loader_sandbox.h"
#include <errno.h>
#include <fcntl.h>
#include <linux/audit.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <sched.h>
#include <stdio.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <unistd.h>

#if defined(__x86_64__)
#define SANDBOX_ARCH AUDIT_ARCH_X86_64
#elif defined(__aarch64__)
#define SANDBOX_ARCH AUDIT_ARCH_AARCH64
#endif

#ifdef SANDBOX_ARCH
#define LD_NR BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(struct seccomp_data, nr))
/* the low 32 bits of argument i (both architectures are little-endian) */
#define LD_ARG(i) BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(struct seccomp_data, args[i]))
#define RET(v) BPF_STMT(BPF_RET | BPF_K, (v))
#define ALLOW RET(SECCOMP_RET_ALLOW)
#define EPERM_ RET(SECCOMP_RET_ERRNO | EPERM)
#define DENY(nr) BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, (nr), 0, 1), EPERM_
/* nr: allowed when (arg i & mask) == 0 */
#define DENY_BITS(nr, i, mask) \
    BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, (nr), 0, 4), LD_ARG(i), BPF_JUMP(BPF_JMP | BPF_JSET | BPF_K, (mask), 1, 0), \
        ALLOW, EPERM_
/* nr: allowed when (arg i & mask) != 0 */
#define NEED_BITS(nr, i, mask) \
    BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, (nr), 0, 4), LD_ARG(i), BPF_JUMP(BPF_JMP | BPF_JSET | BPF_K, (mask), 0, 1), \
        ALLOW, EPERM_
/* nr: allowed when arg i == value (this process) */
#define ONLY_SELF(nr, i, value) \
    BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, (nr), 0, 4), LD_ARG(i), BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, (value), 0, 1), \
        ALLOW, EPERM_
#define WRITE_FLAGS (O_WRONLY | O_RDWR | O_CREAT | O_TRUNC | O_APPEND)
#endif

int vsdd_sandbox_enter(char *err, size_t errlen)
{
#ifdef SANDBOX_ARCH
    const unsigned self = (unsigned)getpid();
    struct sock_filter filter[] = {
        BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(struct seccomp_data, arch)),
        BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, SANDBOX_ARCH, 1, 0),
        RET(SECCOMP_RET_KILL_PROCESS),
        LD_NR,
#if defined(__x86_64__)
        BPF_JUMP(BPF_JMP | BPF_JGE | BPF_K, 0x40000000u, 0, 1), EPERM_, /* the x32 ABI */
        DENY(__NR_fork), DENY(__NR_vfork), DENY(__NR_creat),
        DENY_BITS(__NR_open, 1, WRITE_FLAGS),
#endif
        DENY(__NR_execve), DENY(__NR_execveat), DENY(__NR_ptrace),
        DENY(__NR_process_vm_readv), DENY(__NR_process_vm_writev),
        DENY(__NR_socket), DENY(__NR_socketpair), DENY(__NR_connect), DENY(__NR_bind), DENY(__NR_listen),
        DENY(__NR_accept), DENY(__NR_accept4),
        BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, __NR_clone3, 0, 1), RET(SECCOMP_RET_ERRNO | ENOSYS),
        NEED_BITS(__NR_clone, 0, CLONE_THREAD),
        ONLY_SELF(__NR_kill, 0, self),
        ONLY_SELF(__NR_tgkill, 0, self),
        DENY(__NR_tkill),
        DENY_BITS(__NR_openat, 2, WRITE_FLAGS),
        BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, __NR_openat2, 0, 1), RET(SECCOMP_RET_ERRNO | ENOSYS),
        ALLOW,
    };
    struct sock_fprog prog = {(unsigned short)(sizeof filter / sizeof filter[0]), filter};
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 || prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, &prog) != 0) {
        snprintf(err, errlen, "%s", strerror(errno));
        return -1;
    }
    return 0;
#else
    snprintf(err, errlen, "not built for this architecture");
    return -1;
#endif
}
