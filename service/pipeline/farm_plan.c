/* Where a farm job's pieces live: the vsd that tasks run, their folder, their logs
 * (farm_slurm.h). Tasks run on other machines that share the file system, so every path
 * is absolute. */
#define _POSIX_C_SOURCE 200809L
#include "farm_slurm.h"
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* mkdir -p */
static int make_dirs(const char *path, char *err, size_t errlen)
{
    char buf[4096];
    size_t i, n = strlen(path);
    if (n >= sizeof buf) {
        snprintf(err, errlen, "log folder path too long");
        return -1;
    }
    memcpy(buf, path, n + 1);
    for (i = 1; i <= n; i++) {
        if (buf[i] != '/' && buf[i] != '\0') continue;
        buf[i] = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST) {
            snprintf(err, errlen, "cannot create the log folder %s: %s", buf, strerror(errno));
            return -1;
        }
        buf[i] = path[i];
    }
    return 0;
}

/* The `vsd` command that exec'ed this vsd-core (service/front sets $VSD_FRONT), so the
 * tasks run what the user ran; 0 when there is none. */
static int front_path(char *out, size_t len)
{
    const char *front = getenv("VSD_FRONT");
    if (!front || front[0] != '/' || strlen(front) >= len || access(front, X_OK) != 0) return 0;
    snprintf(out, len, "%s", front);
    return 1;
}

int vsd_farm_plan_locate(vsd_farm_plan *p, const char *job_path, const char *log_dir, char *err,
                         size_t errlen)
{
    struct stat st;
    if (!front_path(p->vsd_exe, sizeof p->vsd_exe)) {
        ssize_t n = readlink("/proc/self/exe", p->vsd_exe, sizeof p->vsd_exe - 1);
        if (n <= 0 || (size_t)n >= sizeof p->vsd_exe - 1) {
            snprintf(err, errlen, "cannot find this vsd executable (/proc/self/exe): %s",
                     n <= 0 ? strerror(errno) : "path too long");
            return -1;
        }
        p->vsd_exe[n] = '\0';
    }
    if (!getcwd(p->work_dir, sizeof p->work_dir)) {
        snprintf(err, errlen, "cannot read the current folder: %s", strerror(errno));
        return -1;
    }
    if (!log_dir) log_dir = "vsd-farm";
    if (log_dir[0] == '/') snprintf(p->log_dir, sizeof p->log_dir, "%s", log_dir);
    else if ((size_t)snprintf(p->log_dir, sizeof p->log_dir, "%s/%s", p->work_dir, log_dir) >= sizeof p->log_dir) {
        snprintf(err, errlen, "log folder path too long");
        return -1;
    }
    if (vsd_farm_sbatch_path_ok("current folder", p->work_dir, err, errlen) ||
        vsd_farm_sbatch_path_ok("log folder", p->log_dir, err, errlen) || make_dirs(p->log_dir, err, errlen))
        return -1;
    if (stat(p->log_dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        snprintf(err, errlen, "the log folder %s is not a folder", p->log_dir);
        return -1;
    }
    vsd_farm_job_name(job_path, p->job_name, sizeof p->job_name);
    return 0;
}
