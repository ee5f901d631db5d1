/* pov_file.h — files of the POV-Ray export written whole or not at all: each is written
 * to "<path>.tmp-<pid>" and renamed over <path> on success (as vsd's EXR writer does), so
 * an interrupted export never leaves a half file that POV-Ray would parse. */
#ifndef VSD_PIPELINE_POV_FILE_H
#define VSD_PIPELINE_POV_FILE_H
#include <stdio.h>
#include "vsd/status.h"

typedef struct vsd_pov_file {
    FILE *f;
    char path[1100];
    char tmp[1140];
} vsd_pov_file;

/* Open the temporary file ("wb"). VSD_ERR_IO naming the path when it cannot be created. */
vsd_status vsd_pov_file_open(vsd_pov_file *pf, const char *path, char *err, size_t errlen);
/* Close and rename; on any write error remove the temporary file and return VSD_ERR_IO. */
vsd_status vsd_pov_file_commit(vsd_pov_file *pf, char *err, size_t errlen);
/* Close and remove the temporary file (an error path). */
void vsd_pov_file_abort(vsd_pov_file *pf);

#endif
