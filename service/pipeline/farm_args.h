/* `vsd farm slurm|status` command lines: the farm's own options taken out, everything
 * else kept, in order, as the `vsd render` arguments every array task runs with
 * (docs/farm.md). */
#ifndef VSD_PIPELINE_FARM_ARGS_H
#define VSD_PIPELINE_FARM_ARGS_H
#include <stddef.h>

#define VSD_FARM_MAX_ARGS 512
#define VSD_FARM_MAX_SBATCH 32

typedef struct vsd_farm_args {
    const char *frames;      /* --frames A-B: the sequence to split; NULL = the job's own range */
    int chunk;               /* --chunk N: frames per array task; 0 = not given */
    const char *partition;   /* --partition P; NULL = the cluster's default */
    int cpus;                /* --cpus N: CPUs per task (and render threads); 0 = not given */
    const char *log_dir;     /* --log-dir DIR; NULL = "vsd-farm" */
    const char *sbatch[VSD_FARM_MAX_SBATCH]; /* --sbatch OPT (repeatable): extra #SBATCH lines */
    int sbatch_count;
    int submit;              /* --submit */
    int help;                /* --help / -h */
    /* `vsd render`'s argv: render_argv[0] = "render", then the arguments that were not the
     * farm's own, unchanged and in their order. Pointers into the caller's argv. */
    char *render_argv[VSD_FARM_MAX_ARGS];
    int render_argc;
} vsd_farm_args;

/* Splits argv (argv[0] = the subcommand, "slurm" or "status"). Farm options accept
 * "--opt VALUE" and "--opt=VALUE". Returns 0, or -1 with err naming the option ("--chunk:
 * expected a whole number of frames >= 1, got '0'"). Render options are not checked here:
 * vsd_render_job_parse does that on render_argv. */
int vsd_farm_args_split(int argc, char **argv, vsd_farm_args *fa, char *err, size_t errlen);

#endif
