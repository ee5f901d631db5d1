/* A `vsd render` job from its command line: scene file or POV-Ray-style INI file, vsd
 * options, POV-Ray switches (+W640 +KFF240 ...). One parser for `vsd render` and for
 * `vsd farm`, which forwards a job's options to every task. Precedence: command line over
 * INI file over scene file (docs/pipeline.md). */
#ifndef VSD_PIPELINE_RENDER_ARGS_H
#define VSD_PIPELINE_RENDER_ARGS_H
#include "vsd/scene.h"
#include <stdio.h>

#define VSD_JOB_MAX_OVERRIDES 256

typedef struct vsd_render_job {
    char scene_path[VSD_PATH_LEN];   /* the scene JSON (argument, or the INI's Input_File_Name) */
    char ini_path[VSD_PATH_LEN];     /* "" = no INI file */
    /* "key.path=value" overrides in the order vsd_scene_load applies them (later wins). */
    const char *overrides[VSD_JOB_MAX_OVERRIDES];
    char owned[VSD_JOB_MAX_OVERRIDES][VSD_PATH_LEN + 64];
    int override_count;
    int quiet;
    int resume;                      /* --continue, +C, Continue_Trace=on */
    int remote;                      /* --remote[=SOCKET|HOST:PORT] */
    char remote_address[VSD_PATH_LEN]; /* "" = default socket */
    char token_file[VSD_PATH_LEN];
    char cache_dir[VSD_PATH_LEN];    /* --cache-dir; "" = the default */
    unsigned long long max_voxels;   /* --max-voxels; 0 = the renderer's default */
    int help;                        /* --help was asked: nothing else to do but print usage */
    int usage_error;                 /* no scene named: parse returned EXIT_USAGE, print usage */
    /* Subset_Start_Frame / Subset_End_Frame (+SF/+EF): frame numbers, or fractions of the
       sequence when written with a '.' (POV-Ray's rule); applied by vsd_render_job_scene. */
    int has_subset_start, has_subset_end;
    double subset_start, subset_end;
    int subset_start_fraction, subset_end_fraction;
    /* An Output_File_Name that names a folder: filled in at the end of parsing with the
       scene's name (POV-Ray's rule), at this index of overrides; -1 = none. */
    int output_dir_slot;
} vsd_render_job;

/* Parse `vsd render`'s arguments (argv[0] is "render"). Returns 0, or a VSD_EXIT_* code
 * after printing the error (naming the option, or the INI file and line) to stderr. It
 * prints no usage: with job->help or job->usage_error set the caller prints it
 * (vsd_render_job_print_usage), so the parser links without the method registry.
 * Paths given on the command line or in an INI file are made absolute (the command
 * line's against the current folder, the INI's against the INI's folder). */
int vsd_render_job_parse(int argc, char **argv, vsd_render_job *job);

/* The job's scene: vsd_scene_load of scene_path with the overrides. */
vsd_status vsd_render_job_scene(const vsd_render_job *job, vsd_scene *scene, char *err,
                                size_t errlen);

/* `vsd render --help` (render_usage.c: it lists the registry's methods). */
void vsd_render_job_usage(FILE *f);
/* The usage the parse asked for: to stdout after --help, to stderr when no scene was named. */
void vsd_render_job_print_usage(const vsd_render_job *job);

#endif
