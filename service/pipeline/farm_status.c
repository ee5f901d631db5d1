/* Done, missing, failed frames from what is on disk (farm_status.h). */
#define _POSIX_C_SOURCE 200809L
#include "farm_status.h"
#include "vsd/render.h"
#include <dirent.h>
#include <stdlib.h>
#include <string.h>

/* The name of a "<base>.tmp-<digits>" entry in the EXR's folder into `found`, if any:
 * what io_file.c's write-then-rename leaves when its process dies mid-write. */
static int leftover_tmp(const char *exr, char *found, size_t foundlen)
{
    char dir[VSD_PATH_LEN], prefix[VSD_PATH_LEN + 8];
    const char *slash = strrchr(exr, '/');
    DIR *d;
    struct dirent *e;
    size_t n;
    int hit = 0;
    if (slash) snprintf(dir, sizeof dir, "%.*s", (int)(slash - exr), exr);
    else snprintf(dir, sizeof dir, ".");
    if (!dir[0]) snprintf(dir, sizeof dir, "/");
    n = (size_t)snprintf(prefix, sizeof prefix, "%s.tmp-", slash ? slash + 1 : exr);
    if (!(d = opendir(dir))) return 0;
    while (!hit && (e = readdir(d))) {
        const char *p = e->d_name + n;
        if (strncmp(e->d_name, prefix, n) != 0 || !*p) continue;
        while (*p >= '0' && *p <= '9') p++;
        if (*p) continue;
        snprintf(found, foundlen, "%s", e->d_name);
        hit = 1;
    }
    closedir(d);
    return hit;
}

vsd_farm_state vsd_farm_frame_state(const vsd_scene *scene, int frame, char *why, size_t whylen)
{
    char exr[VSD_PATH_LEN], tmp[256], ferr[256];
    switch (vsd_frame_output_check(scene, frame, why, whylen)) {
    case VSD_FRAME_DONE: return VSD_FARM_DONE;
    case VSD_FRAME_STALE: case VSD_FRAME_BROKEN: return VSD_FARM_FAILED;
    case VSD_FRAME_MISSING: break;
    }
    if (vsd_frame_path(scene->output.exr, frame, exr, sizeof exr, ferr, sizeof ferr) == VSD_OK &&
        leftover_tmp(exr, tmp, sizeof tmp)) {
        snprintf(why, whylen, "no file, but %s left by a render killed while writing it", tmp);
        return VSD_FARM_FAILED;
    }
    return VSD_FARM_MISSING;
}

/* "1-6,9-11" from the ascending numbers v[0..n). */
static void print_runs(FILE *out, const int *v, int n)
{
    int i = 0;
    while (i < n) {
        int j = i;
        while (j + 1 < n && v[j + 1] == v[j] + 1) j++;
        fprintf(out, "%s%d", i ? "," : "", v[i]);
        if (j > i) fprintf(out, "-%d", v[j]);
        i = j + 1;
    }
}

static void print_state_line(FILE *out, const char *name, const int *frames, int n, int first, int chunk,
                             int *scratch)
{
    int i, tasks = 0;
    fprintf(out, "%-8s %d", name, n);
    if (n == 0) {
        fputc('\n', out);
        return;
    }
    fputs("  ", out);
    print_runs(out, frames, n);
    if (chunk > 0) {
        /* The array tasks that hold these frames: what to re-run by hand, if one wants. */
        for (i = 0; i < n; i++) {
            int t = (frames[i] - first) / chunk;
            if (!tasks || scratch[tasks - 1] != t) scratch[tasks++] = t;
        }
        fprintf(out, "  (array task%s ", tasks > 1 ? "s" : "");
        print_runs(out, scratch, tasks);
        fputc(')', out);
    }
    fputc('\n', out);
}

int vsd_farm_status_report(const vsd_scene *scene, int first, int last, int chunk, FILE *out,
                           vsd_farm_counts *counts)
{
    int n = last - first + 1, f;
    /* Frames by state, one list each, plus room for the task numbers of one list. */
    int *lists = malloc(sizeof(int) * (size_t)n * 4);
    int *by[3];
    char *details = NULL;
    size_t details_len = 0;
    FILE *why_lines = open_memstream(&details, &details_len);
    memset(counts, 0, sizeof *counts);
    if (!lists || !why_lines) {
        free(lists);
        if (why_lines) fclose(why_lines);
        free(details);
        return -1;
    }
    by[VSD_FARM_DONE] = lists;
    by[VSD_FARM_MISSING] = lists + n;
    by[VSD_FARM_FAILED] = lists + 2 * n;
    for (f = first; f <= last; f++) {
        char why[512];
        vsd_farm_state s = vsd_farm_frame_state(scene, f, why, sizeof why);
        int *count = s == VSD_FARM_DONE ? &counts->done : s == VSD_FARM_MISSING ? &counts->missing : &counts->failed;
        by[s][(*count)++] = f;
        if (s == VSD_FARM_FAILED) fprintf(why_lines, "frame %d: failed: %s\n", f, why);
    }
    fclose(why_lines);
    print_state_line(out, "done", by[VSD_FARM_DONE], counts->done, first, 0, lists + 3 * n);
    print_state_line(out, "missing", by[VSD_FARM_MISSING], counts->missing, first, chunk, lists + 3 * n);
    print_state_line(out, "failed", by[VSD_FARM_FAILED], counts->failed, first, chunk, lists + 3 * n);
    if (details) fputs(details, out);
    free(details);
    free(lists);
    return 0;
}
