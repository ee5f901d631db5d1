/* Temporary-file-and-rename writes (pov_file.h). */
#include "pov_file.h"
#include <errno.h>
#include <string.h>
#include <unistd.h>

vsd_status vsd_pov_file_open(vsd_pov_file *pf, const char *path, char *err, size_t errlen)
{
    memset(pf, 0, sizeof *pf);
    if (strlen(path) >= sizeof pf->path)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "%s: path too long", path);
    snprintf(pf->path, sizeof pf->path, "%s", path);
    snprintf(pf->tmp, sizeof pf->tmp, "%s.tmp-%ld", path, (long)getpid());
    pf->f = fopen(pf->tmp, "wb");
    if (!pf->f) return vsd_fail(VSD_ERR_IO, err, errlen, "%s: cannot write: %s", path, strerror(errno));
    return VSD_OK;
}

vsd_status vsd_pov_file_commit(vsd_pov_file *pf, char *err, size_t errlen)
{
    int bad = ferror(pf->f);
    int saved = errno;
    if (fclose(pf->f) != 0 && !bad) {
        bad = 1;
        saved = errno;
    }
    pf->f = NULL;
    if (bad) {
        remove(pf->tmp);
        return vsd_fail(VSD_ERR_IO, err, errlen, "%s: write failed: %s", pf->path, strerror(saved));
    }
    if (rename(pf->tmp, pf->path) != 0) {
        saved = errno;
        remove(pf->tmp);
        return vsd_fail(VSD_ERR_IO, err, errlen, "%s: cannot rename into place: %s", pf->path, strerror(saved));
    }
    return VSD_OK;
}

void vsd_pov_file_abort(vsd_pov_file *pf)
{
    if (pf->f) fclose(pf->f);
    pf->f = NULL;
    if (pf->tmp[0]) remove(pf->tmp);
}
