/* The job-array script (farm_slurm.h). The chunk arithmetic lives in the script, not in
 * per-task files, so one script serves every task and can be run by hand. */
#include "farm_slurm.h"
#include "vsd/render.h"
#include <string.h>

int vsd_farm_task_count(const vsd_farm_plan *p)
{
    return (int)(((long long)p->last - p->first + p->chunk) / p->chunk); /* no int overflow */
}

void vsd_farm_sh_quote(FILE *out, const char *s)
{
    fputc('\'', out);
    for (; *s; s++) {
        if (*s == '\'') fputs("'\\''", out);
        else fputc(*s, out);
    }
    fputc('\'', out);
}

/* Appends s[0..n) to out at *at, characters outside [A-Za-z0-9._-] as '_'. */
static void append_safe(char *out, size_t outlen, size_t *at, const char *s, size_t n)
{
    size_t i;
    for (i = 0; i < n && *at + 1 < outlen; i++) {
        char c = s[i];
        int ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || strchr("._-", c);
        out[(*at)++] = ok ? c : '_';
    }
    out[*at] = '\0';
}

void vsd_farm_job_name(const char *path, char *out, size_t outlen)
{
    const char *base = strrchr(path, '/'), *section;
    size_t n, at, i;
    if (outlen < 5) return;
    base = base ? base + 1 : path;
    section = strchr(base, '[');
    n = section ? (size_t)(section - base) : strlen(base);
    for (i = n; i > 1; i--) /* drop the extension: the last '.' but a leading one */
        if (base[i - 1] == '.') { n = i - 1; break; }
    at = (size_t)snprintf(out, outlen, "vsd-");
    append_safe(out, outlen, &at, base, n);
    if (section && section[1]) { /* "job.ini[Preview]" -> vsd-job-Preview: its own logs */
        size_t len = strcspn(section + 1, "]");
        append_safe(out, outlen, &at, "-", 1);
        append_safe(out, outlen, &at, section + 1, len);
    }
}

int vsd_farm_sbatch_path_ok(const char *what, const char *path, char *err, size_t errlen)
{
    if (strpbrk(path, " \t\n\r'\"\\%")) {
        snprintf(err, errlen, "%s '%s' has a space, quote, backslash or '%%', which #SBATCH lines cannot carry%s",
                 what, path, strcmp(what, "log folder") == 0 ? " (choose another with --log-dir)" : "");
        return -1;
    }
    return 0;
}

static void write_header(const vsd_farm_plan *p, FILE *out, int tasks)
{
    int i;
    fprintf(out,
            "#!/bin/sh\n"
            "# Written by `vsd farm slurm` (vsd %s): frames %d-%d in %d array tasks of %d frames.\n"
            "# Task i (SLURM_ARRAY_TASK_ID, 0..%d) renders frames %d+%d*i .. min(that+%d, %d) with\n"
            "# `vsd render ... --frames A-B --continue`, which skips frames already complete: submit\n"
            "# the same command again to render only what is missing. One task by hand:\n"
            "#   SLURM_ARRAY_TASK_ID=0 sh THIS_SCRIPT\n",
            vsd_version(), p->first, p->last, tasks, p->chunk, tasks - 1, p->first, p->chunk, p->chunk - 1,
            p->last);
    fprintf(out, "#SBATCH --job-name=%s\n", p->job_name);
    fprintf(out, "#SBATCH --array=0-%d\n", tasks - 1);
    fprintf(out, "#SBATCH --ntasks=1\n");
    if (p->cpus > 0) fprintf(out, "#SBATCH --cpus-per-task=%d\n", p->cpus);
    fprintf(out, "#SBATCH --chdir=%s\n", p->work_dir);
    /* One log per chunk, appended to by every attempt (re-submissions, requeues), so a
     * chunk's whole history is in one file. */
    fprintf(out, "#SBATCH --output=%s/%s-%%a.log\n", p->log_dir, p->job_name);
    fprintf(out, "#SBATCH --open-mode=append\n");
    /* --continue makes a re-run cheap and safe, so let Slurm requeue tasks of a failed node. */
    fprintf(out, "#SBATCH --requeue\n");
    if (p->partition) fprintf(out, "#SBATCH --partition=%s\n", p->partition);
    for (i = 0; i < p->sbatch_count; i++) fprintf(out, "#SBATCH %s\n", p->sbatch[i]);
}

int vsd_farm_slurm_script(const vsd_farm_plan *p, FILE *out, char *err, size_t errlen)
{
    int tasks = vsd_farm_task_count(p), i;
    if (vsd_farm_sbatch_path_ok("current folder", p->work_dir, err, errlen) ||
        vsd_farm_sbatch_path_ok("log folder", p->log_dir, err, errlen))
        return -1;
    write_header(p, out, tasks);
    fprintf(out, "\nfirst=%d last=%d chunk=%d tasks=%d\n", p->first, p->last, p->chunk, tasks);
    fputs("task=${SLURM_ARRAY_TASK_ID-}\n"
          "case $task in\n"
          "''|*[!0-9]*|0?*)\n"
          "    echo \"vsd farm: SLURM_ARRAY_TASK_ID must be an array task 0..$((tasks - 1)), got '$task'\" >&2\n"
          "    exit 2 ;;\n"
          "esac\n"
          "if [ \"$task\" -ge \"$tasks\" ]; then\n"
          "    echo \"vsd farm: SLURM_ARRAY_TASK_ID $task is past the last array task $((tasks - 1))\" >&2\n"
          "    exit 2\n"
          "fi\n"
          "a=$((first + task * chunk))\n"
          "b=$((a + chunk - 1))\n"
          "if [ \"$b\" -gt \"$last\" ]; then b=$last; fi\n"
          "echo \"vsd farm: task $task: frames $a-$b (job ${SLURM_JOB_ID:-none} on $(hostname) at $(date '+%Y-%m-%d %H:%M:%S'))\"\n",
          out);
    fputs("cd ", out);
    vsd_farm_sh_quote(out, p->work_dir);
    fputs(" || exit 1\nexec ", out);
    vsd_farm_sh_quote(out, p->vsd_exe);
    fputs(" render", out);
    if (p->cpus > 0) fprintf(out, " --threads %d", p->cpus); /* before the job's own: theirs win */
    for (i = 1; i < p->render_argc; i++) {
        fputc(' ', out);
        vsd_farm_sh_quote(out, p->render_argv[i]);
    }
    /* Last, so they win over the job's own: `vsd render --frames` also drops an INI file's
     * subset (Subset_Start_Frame), and --continue an INI's Continue_Trace=off or a -C. */
    fputs(" --frames \"$a-$b\" --continue\n", out);
    if (fflush(out) || ferror(out)) {
        snprintf(err, errlen, "could not write the script");
        return -1;
    }
    return 0;
}
