/* `vsd render`'s command line, INI files and switches into one job (render_args.h). */
#define _POSIX_C_SOURCE 200809L
#include "render_args.h"
#include "frame_range.h"
#include "pov_ini.h"
#include "pov_options.h"
#include "vsd/render.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The CLI's exit codes (service/cli/commands.h) that parsing can return. */
enum { EXIT_USAGE = 2, EXIT_INPUT = 3 };

/* Options of the form --flag VALUE that set one scene field. */
static const struct { const char *flag, *key; } k_field_flags[] = {
    {"--method", "render.method"}, {"--width", "film.width"}, {"--height", "film.height"},
    {"--samples", "render.samples"}, {"--seed", "render.seed"}, {"--device", "render.device"},
    {"--threads", "render.threads"},
};
/* The other options that take a value. */
static const char *const k_other_valued[] = {"--set", "--frames", "--output", "-o", "--preview", "--token-file",
                                             "--cache-dir", "--max-voxels", NULL};

/* Every option that takes a value (so that a value is never read as a file). */
static int takes_value(const char *arg)
{
    for (size_t k = 0; k < sizeof k_field_flags / sizeof k_field_flags[0]; k++)
        if (strcmp(arg, k_field_flags[k].flag) == 0) return 1;
    for (const char *const *v = k_other_valued; *v; v++)
        if (strcmp(arg, *v) == 0) return 1;
    return 0;
}

static void absolute(const char *cwd, const char *path, char *out, size_t outlen)
{
    if (path[0] == '/' || !cwd[0]) snprintf(out, outlen, "%s", path);
    else snprintf(out, outlen, "%s/%s", cwd, path);
}

typedef struct ini_ctx {
    vsd_pov_source *src;
} ini_ctx;

static int on_ini_item(void *user, const char *item, int line, char *err, size_t errlen)
{
    (void)line;
    return vsd_pov_apply(((ini_ctx *)user)->src, item, err, errlen);
}

static int read_ini(vsd_render_job *job, const char *cwd, const char *spec)
{
    char abs_spec[VSD_PATH_LEN], dir[VSD_PATH_LEN], err[2048];
    vsd_pov_source src;
    ini_ctx ctx = {&src};
    char *slash;
    absolute(cwd, spec, abs_spec, sizeof abs_spec);
    vsd_pov_ini_path(abs_spec, dir, sizeof dir);
    snprintf(job->ini_path, sizeof job->ini_path, "%s", dir);
    slash = strrchr(dir, '/');
    if (slash) *slash = '\0';
    vsd_pov_source_init(&src, job, dir);
    if (vsd_pov_ini_read(abs_spec, on_ini_item, &ctx, err, sizeof err) || vsd_pov_source_finish(&src, err, sizeof err)) {
        fprintf(stderr, "vsd render: %s\n", err);
        return EXIT_INPUT;
    }
    return 0;
}

static int set_frames(vsd_render_job *job, const char *v, char *err, size_t errlen)
{
    int a, b;
    char why[256];
    if (vsd_parse_frame_range(v, &a, &b, why, sizeof why)) {
        snprintf(err, errlen, "--frames: %s", why);
        return -1;
    }
    return vsd_job_add_override(job, err, errlen, "frames.start=%d", a) ||
           vsd_job_add_override(job, err, errlen, "frames.end=%d", b);
}

/* One --flag VALUE of the command line. */
static int apply_valued(vsd_render_job *job, const char *cwd, const char *flag, const char *v, char *err,
                        size_t errlen)
{
    char quoted[VSD_PATH_LEN + 8];
    for (size_t k = 0; k < sizeof k_field_flags / sizeof k_field_flags[0]; k++)
        if (strcmp(flag, k_field_flags[k].flag) == 0)
            return vsd_job_add_override(job, err, errlen, "%s=%s", k_field_flags[k].key, v);
    if (strcmp(flag, "--set") == 0) return vsd_job_add_override(job, err, errlen, "%s", v);
    if (strcmp(flag, "--frames") == 0) {
        /* The frames to render, exactly: an INI file's subset no longer applies. */
        job->has_subset_start = job->has_subset_end = 0;
        return set_frames(job, v, err, errlen);
    }
    if (strcmp(flag, "--output") == 0 || strcmp(flag, "-o") == 0 || strcmp(flag, "--preview") == 0) {
        if (vsd_job_quote_path(cwd, v, quoted, sizeof quoted, err, errlen)) return -1;
        return vsd_job_add_override(job, err, errlen, "%s=%s",
                                    strcmp(flag, "--preview") == 0 ? "output.preview_png" : "output.exr", quoted);
    }
    if (strcmp(flag, "--max-voxels") == 0) {
        char *end = NULL;
        double n = strtod(v, &end);
        if (!end || *end || !(n >= 1.0 && n <= 1e15) || n != floor(n)) {
            snprintf(err, errlen, "--max-voxels: '%s' is not a whole number from 1 to 1e15", v);
            return -1;
        }
        job->max_voxels = (unsigned long long)n;
        return 0;
    }
    if (strcmp(flag, "--token-file") == 0) absolute(cwd, v, job->token_file, sizeof job->token_file);
    else if (strcmp(flag, "--cache-dir") == 0) {
        if (strcmp(v, "none") == 0) snprintf(job->cache_dir, sizeof job->cache_dir, "none");
        else absolute(cwd, v, job->cache_dir, sizeof job->cache_dir);
    }
    return 0;
}

/* An Output_File_Name folder gets "<scene name>_####.exr", as POV-Ray names frames after
 * the scene; known only once every source is read. */
static void finish_output_folder(vsd_render_job *job)
{
    char *slot, stem[256];
    const char *base = strrchr(job->scene_path, '/');
    const char *dot;
    size_t n;
    if (job->output_dir_slot < 0) return;
    base = base ? base + 1 : job->scene_path;
    dot = strrchr(base, '.');
    snprintf(stem, sizeof stem, "%.*s", dot ? (int)(dot - base) : (int)strlen(base), base);
    slot = job->owned[job->output_dir_slot];
    n = strlen(slot);
    if (n > 0 && slot[n - 1] == '"') slot[n - 1] = '\0';
    snprintf(slot + strlen(slot), sizeof job->owned[0] - strlen(slot), "%s_####.exr\"", stem);
}

int vsd_render_job_parse(int argc, char **argv, vsd_render_job *job)
{
    char cwd[VSD_PATH_LEN / 2], err[2048];
    vsd_pov_source cli;
    int i, rc, scene_on_command_line = 0;
    memset(job, 0, sizeof *job);
    job->output_dir_slot = -1;
    if (!getcwd(cwd, sizeof cwd)) cwd[0] = '\0';
    /* INI files first, whatever their place: the command line wins over them. */
    for (i = 1; i < argc; i++) {
        if (takes_value(argv[i])) { i++; continue; }
        if (argv[i][0] != '-' && argv[i][0] != '+' && vsd_pov_is_ini(argv[i]) && (rc = read_ini(job, cwd, argv[i])))
            return rc;
    }
    vsd_pov_source_init(&cli, job, cwd);
    for (i = 1; i < argc; i++) {
        const char *arg = argv[i];
        if (strcmp(arg, "--help") == 0 || strcmp(arg, "-h") == 0) {
            job->help = 1;
            return 0;
        }
        if (strcmp(arg, "--quiet") == 0 || strcmp(arg, "-q") == 0) { job->quiet = 1; continue; }
        if (strcmp(arg, "--continue") == 0) { job->resume = 1; continue; }
        if (strcmp(arg, "--remote") == 0 || strncmp(arg, "--remote=", 9) == 0) {
            job->remote = 1;
            snprintf(job->remote_address, sizeof job->remote_address, "%s", arg[8] == '=' ? arg + 9 : "");
            continue;
        }
        if (takes_value(arg)) {
            if (i + 1 >= argc) {
                fprintf(stderr, "vsd render: %s needs a value\n", arg);
                return EXIT_USAGE;
            }
            if (apply_valued(job, cwd, arg, argv[++i], err, sizeof err)) {
                fprintf(stderr, "vsd render: %s\n", err);
                return EXIT_USAGE;
            }
            continue;
        }
        if (strncmp(arg, "--", 2) == 0) {
            fprintf(stderr, "vsd render: unknown option '%s' (see vsd render --help)\n", arg);
            return EXIT_USAGE;
        }
        /* POV-Ray reads "Key=Value" on its command line as in an INI file. */
        if (arg[0] == '+' || arg[0] == '-' || strchr(arg, '=')) {
            if (vsd_pov_apply(&cli, arg, err, sizeof err)) {
                fprintf(stderr, "vsd render: %s\n", err);
                return EXIT_USAGE;
            }
            continue;
        }
        if (vsd_pov_is_ini(arg)) continue; /* read above */
        if (scene_on_command_line++) {
            fprintf(stderr, "vsd render: more than one scene file ('%s', '%s')\n", job->scene_path, arg);
            return EXIT_USAGE;
        }
        absolute(cwd, arg, job->scene_path, sizeof job->scene_path);
    }
    if (vsd_pov_source_finish(&cli, err, sizeof err)) {
        fprintf(stderr, "vsd render: %s\n", err);
        return EXIT_USAGE;
    }
    if (!job->scene_path[0]) {
        if (job->ini_path[0])
            fprintf(stderr, "vsd render: %s: no Input_File_Name, and no scene file on the command line\n",
                    job->ini_path);
        else
            job->usage_error = 1;
        return EXIT_USAGE;
    }
    finish_output_folder(job);
    return 0;
}

/* POV-Ray's subset of the sequence: a frame number, or a fraction of it with a '.'. */
static int subset_frame(const vsd_scene *s, double v, int fraction)
{
    if (!fraction) return (int)v;
    return s->frames.start + (int)floor(v * (s->frames.end - s->frames.start) + 0.5);
}

vsd_status vsd_render_job_scene(const vsd_render_job *job, vsd_scene *scene, char *err, size_t errlen)
{
    int first, last;
    vsd_status st = vsd_scene_load(job->scene_path, job->overrides, job->override_count, scene, err, errlen);
    if (st) return st;
    first = job->has_subset_start ? subset_frame(scene, job->subset_start, job->subset_start_fraction)
                                  : scene->frames.start;
    last = job->has_subset_end ? subset_frame(scene, job->subset_end, job->subset_end_fraction) : scene->frames.end;
    if (first < scene->frames.start || last > scene->frames.end || first > last)
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "the subset %d-%d (Subset_Start_Frame/Subset_End_Frame) is not inside the sequence %d-%d "
                        "(Initial_Frame/Final_Frame)", first, last, scene->frames.start, scene->frames.end);
    scene->frames.start = first;
    scene->frames.end = last;
    return VSD_OK;
}
