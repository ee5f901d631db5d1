/* File plumbing shared by every reader and writer of the module: sniffing a file's first
 * bytes, and writing through "<path>.tmp-<pid>" + rename() so a crash mid-write never
 * leaves a truncated frame under the real name (rename is atomic within one folder). */
#define _POSIX_C_SOURCE 200809L
#include "src/image/imageio_internal.h"
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

vsd_status vsd_io_read_head(const char *path, unsigned char *buf, size_t n, size_t *got,
                            char *err, size_t errlen)
{
    *got = 0;
    if (!path || !*path)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "no file name given");
    FILE *f = fopen(path, "rb");
    if (!f)
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot open '%s': %s", path, strerror(errno));
    *got = fread(buf, 1, n, f);
    int failed = ferror(f);
    int e = errno;
    fclose(f);
    if (failed) /* e.g. EISDIR: a folder opens fine on Linux but cannot be read */
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot read '%s': %s", path, strerror(e));
    return VSD_OK;
}

vsd_status vsd_io_tmp_open(vsd_io_tmpfile *t, const char *path, char *err, size_t errlen)
{
    t->fd = -1;
    t->tmp[0] = '\0';
    if (!path || !*path)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "no output file name given");
    if (strlen(path) >= sizeof t->path)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "output path too long: '%.80s...'", path);
    snprintf(t->path, sizeof t->path, "%s", path);
    snprintf(t->tmp, sizeof t->tmp, "%s.tmp-%ld", path, (long)getpid());
    /* O_EXCL: a leftover of a crashed run with a recycled pid is reported, never reused
     * half-written; 0666 lets the umask decide, like any other output file. */
    t->fd = open(t->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (t->fd < 0) {
        int e = errno;
        t->tmp[0] = '\0';
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot write '%s': %s", path, strerror(e));
    }
    return VSD_OK;
}

vsd_status vsd_io_tmp_commit(vsd_io_tmpfile *t, char *err, size_t errlen)
{
    /* fsync before rename: otherwise a power cut can leave the new name pointing at an
     * empty file on some file systems, which is exactly what the temp file is meant to avoid. */
    if (fsync(t->fd) != 0 && errno != EINVAL) {
        int e = errno;
        vsd_io_tmp_abort(t);
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot write '%s': %s", t->path, strerror(e));
    }
    int rc = close(t->fd);
    t->fd = -1;
    if (rc != 0 || rename(t->tmp, t->path) != 0) {
        int e = errno;
        vsd_io_tmp_abort(t);
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot write '%s': %s", t->path, strerror(e));
    }
    t->tmp[0] = '\0';
    return VSD_OK;
}

void vsd_io_tmp_abort(vsd_io_tmpfile *t)
{
    if (t->fd >= 0)
        close(t->fd);
    t->fd = -1;
    if (t->tmp[0])
        unlink(t->tmp);
    t->tmp[0] = '\0';
}
