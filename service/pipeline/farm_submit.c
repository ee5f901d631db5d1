/* Handing the script to Slurm's sbatch (farm_slurm.h). sbatch keeps our stdout and stderr,
 * so its "Submitted batch job N" and its errors reach the user unchanged. */
#define _POSIX_C_SOURCE 200809L
#include "farm_slurm.h"
#include <errno.h>
#include <spawn.h>
#include <string.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

int vsd_farm_sbatch(const char *script_path, char *err, size_t errlen)
{
    char *argv[3];
    pid_t pid;
    int rc, status;
    argv[0] = "sbatch";
    argv[1] = (char *)script_path;
    argv[2] = NULL;
    fflush(stdout);
    fflush(stderr);
    rc = posix_spawnp(&pid, "sbatch", NULL, NULL, argv, environ);
    if (rc != 0) {
        snprintf(err, errlen, "cannot run sbatch: %s%s", strerror(rc),
                 rc == ENOENT ? " (is Slurm installed and sbatch on PATH?)" : "");
        return -1;
    }
    while (waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR) {
            snprintf(err, errlen, "waiting for sbatch: %s", strerror(errno));
            return -1;
        }
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return 0;
    if (WIFEXITED(status) && WEXITSTATUS(status) == 127) {
        /* glibc's posix_spawnp may report a failed exec only as the child's status 127. */
        snprintf(err, errlen, "cannot run sbatch (is Slurm installed and sbatch on PATH?)");
        return -1;
    }
    if (WIFEXITED(status))
        snprintf(err, errlen, "sbatch failed with exit status %d (its message is above)", WEXITSTATUS(status));
    else
        snprintf(err, errlen, "sbatch was killed by signal %d", WIFSIGNALED(status) ? WTERMSIG(status) : 0);
    return -1;
}

int vsd_farm_script_file(const vsd_farm_plan *p, char *path, size_t pathlen, char *err, size_t errlen)
{
    char tmp[4200];
    FILE *f;
    int rc;
    if ((size_t)snprintf(path, pathlen, "%s/%s.sbatch", p->log_dir, p->job_name) >= pathlen) {
        snprintf(err, errlen, "script path too long");
        return -1;
    }
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", path, (long)getpid());
    if (!(f = fopen(tmp, "w"))) {
        snprintf(err, errlen, "cannot write %s: %s", tmp, strerror(errno));
        return -1;
    }
    rc = vsd_farm_slurm_script(p, f, err, errlen);
    if (fclose(f) != 0 && rc == 0) {
        snprintf(err, errlen, "cannot write %s: %s", tmp, strerror(errno));
        rc = -1;
    }
    if (rc == 0 && rename(tmp, path) != 0) {
        snprintf(err, errlen, "cannot rename %s to %s: %s", tmp, path, strerror(errno));
        rc = -1;
    }
    if (rc != 0) remove(tmp);
    return rc;
}
