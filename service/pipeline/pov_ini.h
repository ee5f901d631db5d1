/* POV-Ray INI files as pipelines write them (docs/pipeline.md): "Key=Value" lines and
 * switch lines ("+W640 +H360"), ';' comments, and [Section] labels. As in POV-Ray,
 * "job.ini" reads the lines before the first label and "job.ini[Name]" those lines plus
 * the section [Name] (labels match without regard to case). */
#ifndef VSD_PIPELINE_POV_INI_H
#define VSD_PIPELINE_POV_INI_H
#include <stddef.h>

/* One option of the file: `item` is "Key=Value" (spaces around '=' removed, quotes around
 * the value removed) or a single switch ("+W640"); `line` its line number. Returns 0, or
 * -1 with a message in err (the reader adds the file and line). */
typedef int (*vsd_pov_item_fn)(void *user, const char *item, int line, char *err, size_t errlen);

/* Reads `spec` ("path.ini" or "path.ini[Section]"). Returns 0, or -1 with err naming the
 * file and line ("job.ini:7: unknown key 'Quality'"), a missing file, or a section that
 * is not in the file. */
int vsd_pov_ini_read(const char *spec, vsd_pov_item_fn fn, void *user, char *err, size_t errlen);

/* Is this command-line argument an INI file ("*.ini" or "*.ini[Section]", any case)? */
int vsd_pov_is_ini(const char *arg);

/* The file part of `spec` (without "[Section]") into out. */
void vsd_pov_ini_path(const char *spec, char *out, size_t outlen);

#endif
