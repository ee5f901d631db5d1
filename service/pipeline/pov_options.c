/* POV-Ray keys and switches onto a vsd render job (pov_options.h). */
#include "pov_options.h"
#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

void vsd_pov_source_init(vsd_pov_source *src, vsd_render_job *job, const char *base_dir)
{
    memset(src, 0, sizeof *src);
    src->job = job;
    src->antialias = -1;
    snprintf(src->base_dir, sizeof src->base_dir, "%s", base_dir);
}

int vsd_job_add_override(vsd_render_job *job, char *err, size_t errlen, const char *fmt, ...)
{
    va_list ap;
    char *slot;
    if (job->override_count >= VSD_JOB_MAX_OVERRIDES) {
        snprintf(err, errlen, "too many options (at most %d scene fields)", VSD_JOB_MAX_OVERRIDES);
        return -1;
    }
    slot = job->owned[job->override_count];
    va_start(ap, fmt);
    vsnprintf(slot, sizeof job->owned[0], fmt, ap);
    va_end(ap);
    job->overrides[job->override_count++] = slot;
    return 0;
}

int vsd_job_quote_path(const char *base_dir, const char *path, char *out, size_t outlen, char *err,
                       size_t errlen)
{
    if (!path[0]) {
        snprintf(err, errlen, "empty path");
        return -1;
    }
    if (strchr(path, '"') || strchr(path, '\\')) {
        snprintf(err, errlen, "%s: quotes and backslashes are not supported in paths", path);
        return -1;
    }
    if (path[0] == '/' || !base_dir[0]) snprintf(out, outlen, "\"%s\"", path);
    else snprintf(out, outlen, "\"%s/%s\"", base_dir, path);
    return 0;
}

static int parse_int(const char *what, const char *v, int *out, char *err, size_t errlen)
{
    char *end;
    long x;
    errno = 0;
    x = strtol(v, &end, 10);
    if (!*v || *end || errno || x < INT_MIN / 2 || x > INT_MAX / 2) {
        snprintf(err, errlen, "%s: expected a whole number, got '%s'", what, v);
        return -1;
    }
    *out = (int)x;
    return 0;
}

/* POV-Ray's booleans: on/off, true/false, yes/no, 1/0 (any case). */
static int parse_bool(const char *what, const char *v, int *out, char *err, size_t errlen)
{
    static const char *const yes[] = {"on", "true", "yes", "1"}, *const no[] = {"off", "false", "no", "0"};
    for (size_t i = 0; i < 4; i++) {
        if (strcasecmp(v, yes[i]) == 0) { *out = 1; return 0; }
        if (strcasecmp(v, no[i]) == 0) { *out = 0; return 0; }
    }
    snprintf(err, errlen, "%s: expected on or off, got '%s'", what, v);
    return -1;
}

/* A subset frame: a frame number, or with a '.' a fraction 0..1 of the sequence. */
static int set_subset(vsd_render_job *job, int end, const char *what, const char *v, char *err, size_t errlen)
{
    char *stop;
    double x;
    int fraction = strchr(v, '.') != NULL;
    errno = 0;
    x = strtod(v, &stop);
    if (!*v || *stop || errno || (fraction && (x < 0.0 || x > 1.0)) || (!fraction && (x < INT_MIN / 2 || x > INT_MAX / 2))) {
        snprintf(err, errlen, "%s: expected a frame number or a fraction 0.0-1.0, got '%s'", what, v);
        return -1;
    }
    if (end) { job->has_subset_end = 1; job->subset_end = x; job->subset_end_fraction = fraction; }
    else { job->has_subset_start = 1; job->subset_start = x; job->subset_start_fraction = fraction; }
    return 0;
}

static int set_output(vsd_pov_source *src, const char *v, char *err, size_t errlen)
{
    char quoted[VSD_PATH_LEN + 8];
    size_t n = strlen(v);
    vsd_render_job *job = src->job;
    if (vsd_job_quote_path(src->base_dir, v, quoted, sizeof quoted, err, errlen)) return -1;
    if (n && v[n - 1] == '/') {
        /* A folder: the file name comes from the scene's name once it is known. */
        if (vsd_job_add_override(job, err, errlen, "output.exr=%s", quoted)) return -1;
        job->output_dir_slot = job->override_count - 1;
        return 0;
    }
    return vsd_job_add_override(job, err, errlen, "output.exr=%s", quoted);
}

static int set_input(vsd_pov_source *src, const char *v, char *err, size_t errlen)
{
    char quoted[VSD_PATH_LEN + 8];
    if (vsd_job_quote_path(src->base_dir, v, quoted, sizeof quoted, err, errlen)) return -1;
    snprintf(src->job->scene_path, sizeof src->job->scene_path, "%.*s", (int)strlen(quoted) - 2, quoted + 1);
    return 0;
}

static int set_int_field(vsd_pov_source *src, const char *what, const char *field, const char *v, char *err,
                         size_t errlen)
{
    int x;
    if (parse_int(what, v, &x, err, errlen)) return -1;
    return vsd_job_add_override(src->job, err, errlen, "%s=%d", field, x);
}

static int set_file_type(const char *what, const char *v, char *err, size_t errlen)
{
    if (strcasecmp(v, "E") == 0) return 0;
    snprintf(err, errlen, "%s: vsd writes OpenEXR only (E), got '%s'", what, v);
    return -1;
}

static int set_antialias_depth(vsd_pov_source *src, const char *what, const char *v, char *err, size_t errlen)
{
    int d;
    if (parse_int(what, v, &d, err, errlen)) return -1;
    if (d < 1 || d > 9) {
        snprintf(err, errlen, "%s: expected 1-9 (POV-Ray's range), got %d", what, d);
        return -1;
    }
    src->antialias_depth = d;
    return 0;
}

/* "Key=Value" with a POV-Ray key, or a scene field with dots. */
static int apply_key(vsd_pov_source *src, const char *key, const char *v, char *err, size_t errlen)
{
    vsd_render_job *job = src->job;
    int b;
    if (strchr(key, '.')) return vsd_job_add_override(job, err, errlen, "%s=%s", key, v);
    if (strcasecmp(key, "Input_File_Name") == 0) return set_input(src, v, err, errlen);
    if (strcasecmp(key, "Output_File_Name") == 0) return set_output(src, v, err, errlen);
    if (strcasecmp(key, "Width") == 0) return set_int_field(src, key, "film.width", v, err, errlen);
    if (strcasecmp(key, "Height") == 0) return set_int_field(src, key, "film.height", v, err, errlen);
    if (strcasecmp(key, "Initial_Frame") == 0) return set_int_field(src, key, "frames.start", v, err, errlen);
    if (strcasecmp(key, "Final_Frame") == 0) return set_int_field(src, key, "frames.end", v, err, errlen);
    if (strcasecmp(key, "Subset_Start_Frame") == 0) return set_subset(job, 0, key, v, err, errlen);
    if (strcasecmp(key, "Subset_End_Frame") == 0) return set_subset(job, 1, key, v, err, errlen);
    if (strcasecmp(key, "Antialias_Depth") == 0) return set_antialias_depth(src, key, v, err, errlen);
    if (strcasecmp(key, "Output_File_Type") == 0) return set_file_type(key, v, err, errlen);
    if (strcasecmp(key, "Continue_Trace") == 0 || strcasecmp(key, "Antialias") == 0 ||
        strcasecmp(key, "Output_Alpha") == 0 || strcasecmp(key, "Verbose") == 0 ||
        strcasecmp(key, "Display") == 0) {
        if (parse_bool(key, v, &b, err, errlen)) return -1;
        if (strcasecmp(key, "Continue_Trace") == 0) job->resume = b;
        else if (strcasecmp(key, "Antialias") == 0) src->antialias = b;
        else if (strcasecmp(key, "Output_Alpha") == 0)
            return vsd_job_add_override(job, err, errlen, "film.transparent=%s", b ? "true" : "false");
        else if (strcasecmp(key, "Verbose") == 0) job->quiet = !b;
        /* Display: vsd opens no window (output.preview_png writes a picture instead). */
        return 0;
    }
    snprintf(err, errlen, "unknown key '%s' (docs/pipeline.md lists POV-Ray's keys vsd reads; a scene field "
             "is written with dots, e.g. render.samples=256)", key);
    return -1;
}

/* "+W640", "-C", "+KFI1", "+Oout/f_####.exr" (letters in any case). */
static int apply_switch(vsd_pov_source *src, const char *sw, char *err, size_t errlen)
{
    static const struct { const char *name, *key; } valued[] = {
        /* Longest names first: "+KFI" before any shorter prefix. */
        {"KFI", "Initial_Frame"}, {"KFF", "Final_Frame"}, {"SF", "Subset_Start_Frame"},
        {"EF", "Subset_End_Frame"}, {"W", "Width"}, {"H", "Height"},
        {"O", "Output_File_Name"}, {"I", "Input_File_Name"}, {"R", "Antialias_Depth"},
    };
    int on = sw[0] == '+';
    const char *body = sw + 1;
    if (strcasecmp(body, "C") == 0) { src->job->resume = on; return 0; }
    if (strcasecmp(body, "D") == 0) return 0; /* display: no window in vsd */
    if (strcasecmp(body, "V") == 0) { src->job->quiet = !on; return 0; }
    if (strcasecmp(body, "UA") == 0)
        return vsd_job_add_override(src->job, err, errlen, "film.transparent=%s", on ? "true" : "false");
    if (strcasecmp(body, "FE") == 0) {
        if (on) return 0;
        snprintf(err, errlen, "%s: vsd writes OpenEXR only", sw);
        return -1;
    }
    if (toupper((unsigned char)body[0]) == 'A' && (!body[1] || strchr("0123456789.", body[1]))) {
        src->antialias = on; /* "+A0.3": POV-Ray's threshold has no meaning for a path tracer */
        return 0;
    }
    for (size_t i = 0; i < sizeof valued / sizeof valued[0]; i++) {
        size_t n = strlen(valued[i].name);
        if (strncasecmp(body, valued[i].name, n) != 0 || !body[n]) continue;
        if (!on) {
            snprintf(err, errlen, "%s: write +%s%s", sw, valued[i].name, body + n);
            return -1;
        }
        return apply_key(src, valued[i].key, body + n, err, errlen);
    }
    snprintf(err, errlen, "unknown switch '%s' (docs/pipeline.md lists the switches vsd reads)", sw);
    return -1;
}

int vsd_pov_apply(vsd_pov_source *src, const char *item, char *err, size_t errlen)
{
    const char *eq;
    char key[256];
    if (item[0] == '+' || item[0] == '-') return apply_switch(src, item, err, errlen);
    eq = strchr(item, '=');
    if (!eq || eq == item) {
        snprintf(err, errlen, "expected Key=Value or a +switch, got '%s'", item);
        return -1;
    }
    snprintf(key, sizeof key, "%.*s", (int)(eq - item), item);
    return apply_key(src, key, eq + 1, err, errlen);
}

int vsd_pov_source_finish(vsd_pov_source *src, char *err, size_t errlen)
{
    /* A path tracer has no adaptive antialiasing: POV-Ray's depth d takes up to d² rays
     * per pixel, so it becomes d² samples; "off" is one ray per pixel. */
    if (src->antialias == 0) return vsd_job_add_override(src->job, err, errlen, "render.samples=1");
    if (src->antialias_depth)
        return vsd_job_add_override(src->job, err, errlen, "render.samples=%d",
                                    src->antialias_depth * src->antialias_depth);
    return 0;
}
