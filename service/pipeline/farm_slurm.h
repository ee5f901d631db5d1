/* The sbatch job-array script of `vsd farm slurm` (docs/farm.md): array task i
 * (SLURM_ARRAY_TASK_ID, 0..N-1) renders frames first+i*chunk .. min(that+chunk-1, last)
 * with `vsd render <the job's options> --frames A-B --continue`, so a re-submitted array
 * renders only what is missing. Slurm schedules; nothing here does. */
#ifndef VSD_PIPELINE_FARM_SLURM_H
#define VSD_PIPELINE_FARM_SLURM_H
#include <stddef.h>
#include <stdio.h>

typedef struct vsd_farm_plan {
    int first, last, chunk;          /* the sequence and frames per task */
    char vsd_exe[4096];              /* absolute path of the vsd every task runs */
    char work_dir[4096];             /* absolute: tasks cd here, where the command was typed */
    char log_dir[4096];              /* absolute: <log_dir>/<job_name>-<task>.log */
    char job_name[128];              /* [A-Za-z0-9._-] only */
    const char *partition;           /* NULL = the cluster's default */
    int cpus;                        /* >0: --cpus-per-task and `vsd render --threads` */
    const char *const *sbatch;       /* extra "#SBATCH <opt>" lines */
    int sbatch_count;
    char *const *render_argv;        /* `vsd render`'s arguments, [0] = "render" */
    int render_argc;
} vsd_farm_plan;

/* Fills vsd_exe (the `vsd` command that ran this vsd-core, $VSD_FRONT, else this process's own
 * executable, /proc/self/exe), work_dir (the current
 * folder), log_dir (`log_dir` or "vsd-farm", made absolute and created: Slurm does not
 * create the folder of --output and would lose the log) and job_name (from job_path).
 * Returns 0, or -1 with err. */
int vsd_farm_plan_locate(vsd_farm_plan *p, const char *job_path, const char *log_dir, char *err,
                         size_t errlen);

/* Array tasks: ceil((last - first + 1) / chunk). */
int vsd_farm_task_count(const vsd_farm_plan *p);

/* Writes the script to out. Returns 0, or -1 with err: a path that Slurm's #SBATCH lines
 * cannot carry (whitespace, quotes, '%', backslash), or a write error. */
int vsd_farm_slurm_script(const vsd_farm_plan *p, FILE *out, char *err, size_t errlen);

/* sbatch splits #SBATCH lines at whitespace and expands '%' patterns in --output, so the
 * paths written there (`what`: "current folder", "log folder") must have neither. Returns
 * 0, or -1 with err naming the path. */
int vsd_farm_sbatch_path_ok(const char *what, const char *path, char *err, size_t errlen);

/* `s` quoted for sh: in single quotes, each ' written as '\''. */
void vsd_farm_sh_quote(FILE *out, const char *s);

/* A job name from the scene or INI path: "vsd-" + its file name without extension, and
 * "-Section" for "job.ini[Section]"; characters other than [A-Za-z0-9._-] become '_'. */
void vsd_farm_job_name(const char *path, char *out, size_t outlen);

/* Writes the script to <log_dir>/<job_name>.sbatch (through a temporary name, so an
 * interrupted write never leaves half a script to submit) and its path into path. Returns 0, or -1 with err. */
int vsd_farm_script_file(const vsd_farm_plan *p, char *path, size_t pathlen, char *err, size_t errlen);

/* Runs `sbatch script_path`; sbatch's own output and errors go to this process's stdout and
 * stderr. Returns 0 when sbatch accepted the job, else -1 with err ("cannot run sbatch:
 * No such file or directory (is Slurm installed and on PATH?)", "sbatch failed with exit
 * status 1 (its message is above)"). */
int vsd_farm_sbatch(const char *script_path, char *err, size_t errlen);

#endif
