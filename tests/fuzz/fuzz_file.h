/* fuzz_file.h — the loaders under test take a path, so each input becomes a file: one
 * memfd per process (no disk I/O, nothing left behind), rewritten per input and named
 * through /proc/self/fd/N, which open(), stat() and std::ifstream all accept. */
#ifndef VSD_FUZZ_FILE_H
#define VSD_FUZZ_FILE_H
#ifndef _GNU_SOURCE
#define _GNU_SOURCE
#endif
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

/* The path of a file holding exactly data[0..size); NULL when the memfd cannot be made. */
static inline const char *vsd_fuzz_file(const uint8_t *data, size_t size)
{
    static int fd = -1;
    static char path[64];
    size_t done = 0;
    if (fd < 0) {
        fd = memfd_create("vsd-fuzz-input", MFD_CLOEXEC);
        if (fd < 0) return NULL;
        snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    }
    if (ftruncate(fd, 0) != 0) return NULL;
    while (done < size) {
        ssize_t n = pwrite(fd, data + done, size - done, (off_t)done);
        if (n <= 0) return NULL;
        done += (size_t)n;
    }
    return path;
}
#endif
