/* `vsd farm slurm|status`: render a sequence as a Slurm job array, and see which frames
 * are done. The work is in service/pipeline/farm_*.c; this file reads the command line
 * and reports (docs/farm.md). */
#include "commands.h"
#include "farm_args.h"
#include "farm_slurm.h"
#include "farm_status.h"
#include "frame_range.h"
#include "pov_ini.h"
#include "render_args.h"
#include "vsd/render.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void farm_usage(FILE *f)
{
    fprintf(f,
            "usage: vsd farm slurm SCENE.json|JOB.ini --chunk N [--frames A-B] [farm options] [render options]\n"
            "       vsd farm status SCENE.json|JOB.ini [--frames A-B] [--chunk N] [render options]\n"
            "\n"
            "slurm   print an sbatch job-array script: array task i (SLURM_ARRAY_TASK_ID, 0..N-1)\n"
            "        runs this vsd's `render` with the same render options on its chunk of frames,\n"
            "        with --continue, so submitting the same command again renders only the\n"
            "        frames still missing\n"
            "  --frames A-B       the sequence to split (default: the job's own frames)\n"
            "  --chunk N          frames per array task\n"
            "  --partition P      Slurm partition (default: the cluster's)\n"
            "  --cpus N           CPUs per task, and render threads (default: Slurm's, and all cores)\n"
            "  --sbatch OPT       one more #SBATCH line, e.g. --sbatch --time=2:00:00 (repeatable)\n"
            "  --log-dir DIR      task logs DIR/vsd-NAME-<task>.log (default ./vsd-farm, created)\n"
            "  --submit           write DIR/vsd-NAME.sbatch and pass it to sbatch\n"
            "status  which frames are done (complete EXR of this scene), failed (an EXR that does not\n"
            "        read or is of another scene, or a temporary file a killed write left) or missing;\n"
            "        takes the same command line as `slurm`. Exit 0 when every frame is done, 1 if not.\n"
            "\n"
            "Every other option is `vsd render`'s (vsd render --help). Tasks run in the current\n"
            "folder, which every node must see at the same path.\n");
}

typedef struct farm_job {
    vsd_farm_args args;
    vsd_render_job job;
    vsd_scene scene;
    int first, last;
} farm_job;

/* The command line into a loaded job and its frame range. Returns -1 to go on, else the
 * exit status (after the message). */
static int load(int argc, char **argv, farm_job *fj)
{
    const char *sub = argv[0];
    char err[2048];
    int rc;
    if (vsd_farm_args_split(argc, argv, &fj->args, err, sizeof err)) {
        fprintf(stderr, "vsd farm %s: %s\n", sub, err);
        return VSD_EXIT_USAGE;
    }
    if (fj->args.help) {
        farm_usage(stdout);
        return VSD_EXIT_OK;
    }
    if (fj->args.render_argc < 2) {
        fprintf(stderr, "vsd farm %s: no scene file or INI file\n\n", sub);
        farm_usage(stderr);
        return VSD_EXIT_USAGE;
    }
    rc = vsd_render_job_parse(fj->args.render_argc, fj->args.render_argv, &fj->job);
    vsd_render_job_print_usage(&fj->job);
    if (fj->job.help) return VSD_EXIT_OK;
    if (rc != 0) {
        fprintf(stderr, "vsd farm %s: options that are not the farm's own go to `vsd render` "
                        "(see vsd farm --help)\n", sub);
        return rc;
    }
    if (vsd_render_job_scene(&fj->job, &fj->scene, err, sizeof err) != VSD_OK) {
        fprintf(stderr, "vsd farm %s: %s\n", sub, err);
        return VSD_EXIT_INPUT;
    }
    fj->first = fj->scene.frames.start;
    fj->last = fj->scene.frames.end;
    if (fj->args.frames && vsd_parse_frame_range(fj->args.frames, &fj->first, &fj->last, err, sizeof err)) {
        fprintf(stderr, "vsd farm %s: --frames: %s\n", sub, err);
        return VSD_EXIT_USAGE;
    }
    if (fj->first != fj->last && !strchr(fj->scene.output.exr, '#')) {
        fprintf(stderr, "vsd farm %s: the output %s has no #### for the frame number, so every frame "
                        "would write the same file (give --output NAME_####.exr)\n", sub, fj->scene.output.exr);
        return VSD_EXIT_USAGE;
    }
    return -1;
}

/* What names the job: the INI argument as given, with its [Section], else the scene. */
static const char *job_spec(const farm_job *fj)
{
    int i;
    if (!fj->job.ini_path[0]) return fj->job.scene_path;
    for (i = 1; i < fj->args.render_argc; i++)
        if (fj->args.render_argv[i][0] != '-' && fj->args.render_argv[i][0] != '+' &&
            vsd_pov_is_ini(fj->args.render_argv[i]))
            return fj->args.render_argv[i];
    return fj->job.ini_path;
}

static int farm_slurm(farm_job *fj)
{
    vsd_farm_plan plan;
    char err[2048], path[4300];
    const char *job_path = job_spec(fj);
    memset(&plan, 0, sizeof plan);
    if (!fj->args.chunk) {
        fprintf(stderr, "vsd farm slurm: --chunk N is needed (frames per array task)\n");
        return VSD_EXIT_USAGE;
    }
    plan.first = fj->first;
    plan.last = fj->last;
    plan.chunk = fj->args.chunk;
    plan.partition = fj->args.partition;
    plan.cpus = fj->args.cpus;
    plan.sbatch = fj->args.sbatch;
    plan.sbatch_count = fj->args.sbatch_count;
    plan.render_argv = fj->args.render_argv;
    plan.render_argc = fj->args.render_argc;
    if (vsd_farm_plan_locate(&plan, job_path, fj->args.log_dir, err, sizeof err)) {
        fprintf(stderr, "vsd farm slurm: %s\n", err);
        return VSD_EXIT_USAGE; /* a folder the user can change: --log-dir, or cd */
    }
    if (!fj->args.submit) {
        if (vsd_farm_slurm_script(&plan, stdout, err, sizeof err)) {
            fprintf(stderr, "vsd farm slurm: %s\n", err);
            return VSD_EXIT_USAGE;
        }
        return VSD_EXIT_OK;
    }
    if (vsd_farm_script_file(&plan, path, sizeof path, err, sizeof err)) {
        fprintf(stderr, "vsd farm slurm: %s\n", err);
        return VSD_EXIT_USAGE;
    }
    fprintf(stderr, "vsd farm slurm: frames %d-%d in %d array tasks of %d; script %s; logs %s/%s-<task>.log\n",
            plan.first, plan.last, vsd_farm_task_count(&plan), plan.chunk, path, plan.log_dir, plan.job_name);
    if (vsd_farm_sbatch(path, err, sizeof err)) {
        fprintf(stderr, "vsd farm slurm: %s\n", err);
        return VSD_EXIT_RENDER_FAILED;
    }
    return VSD_EXIT_OK;
}

static int farm_status(farm_job *fj)
{
    vsd_farm_counts c;
    printf("frames %d-%d of %s\n", fj->first, fj->last, fj->scene.output.exr);
    if (vsd_farm_status_report(&fj->scene, fj->first, fj->last, fj->args.chunk, stdout, &c)) {
        fprintf(stderr, "vsd farm status: out of memory\n");
        return VSD_EXIT_RENDER_FAILED;
    }
    return c.done == fj->last - fj->first + 1 ? VSD_EXIT_OK : VSD_EXIT_RENDER_FAILED;
}

int vsd_cmd_farm(int argc, char **argv)
{
    farm_job *fj;
    int rc, slurm;
    if (argc < 2 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "help") == 0) {
        farm_usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? VSD_EXIT_USAGE : VSD_EXIT_OK;
    }
    slurm = strcmp(argv[1], "slurm") == 0;
    if (!slurm && strcmp(argv[1], "status") != 0) {
        fprintf(stderr, "vsd farm: unknown farm command '%s' (slurm or status)\n", argv[1]);
        return VSD_EXIT_USAGE;
    }
    /* The job and scene are large (hundreds of KiB of override slots): not on the stack. */
    if (!(fj = calloc(1, sizeof *fj))) {
        fprintf(stderr, "vsd farm: out of memory\n");
        return VSD_EXIT_RENDER_FAILED;
    }
    rc = load(argc - 1, argv + 1, fj);
    if (rc < 0) rc = slurm ? farm_slurm(fj) : farm_status(fj);
    free(fj);
    return rc;
}
