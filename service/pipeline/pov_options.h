/* POV-Ray's option names and switches mapped onto a vsd render job (docs/pipeline.md has
 * the table). One source of options is one INI file or the command line: within a source
 * later options win, and the sources apply in the order INI files, then command line. */
#ifndef VSD_PIPELINE_POV_OPTIONS_H
#define VSD_PIPELINE_POV_OPTIONS_H
#include "render_args.h"
#include <stddef.h>

typedef struct vsd_pov_source {
    vsd_render_job *job;
    char base_dir[VSD_PATH_LEN];  /* relative paths resolve here (the INI's folder or cwd) */
    int antialias;                /* -1 unset, 0 off (1 sample), 1 on */
    int antialias_depth;          /* 0 unset, else 1..9: depth² samples per pixel */
} vsd_pov_source;

void vsd_pov_source_init(vsd_pov_source *src, vsd_render_job *job, const char *base_dir);

/* One "Key=Value" (POV-Ray key, any case, or a scene field "render.samples=256") or one
 * switch ("+W640", "-C"). Returns 0, or -1 with the reason in err ("unknown key
 * 'Quality'", "Width: expected a whole number, got 'wide'"). */
int vsd_pov_apply(vsd_pov_source *src, const char *item, char *err, size_t errlen);

/* What a source decides only at its end (antialiasing into render.samples). */
int vsd_pov_source_finish(vsd_pov_source *src, char *err, size_t errlen);

/* Appends "key=value" (printf-style) to the job's overrides; -1 with err when full. */
int vsd_job_add_override(vsd_render_job *job, char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* `path` made absolute against base_dir (when relative) and JSON-quoted for an override
 * value; -1 with err for paths with quotes or backslashes. */
int vsd_job_quote_path(const char *base_dir, const char *path, char *out, size_t outlen, char *err,
                       size_t errlen);

#endif
