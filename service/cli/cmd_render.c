/* `vsd render`: scene file (or POV-Ray INI) + overrides in, one EXR (+ optional PNG) per frame out,
 * rendered in-process through the library's vsd_renderer (the daemon uses the same). */
#define _POSIX_C_SOURCE 200809L
#include "commands.h"
#include "vsd/render.h"
#include "render_remote.h"
#include "render_progress.h"
#include "render_args.h"
#include "render_common.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* --continue: which frames of the range still need rendering. Checked once before the
 * run, so that the ETA counts only the frames that will render. */
typedef struct frame_plan {
    int first, count, to_render;
    unsigned char *skip;   /* [count]: 1 = complete for this scene, not rendered again */
} frame_plan;

static int plan_skip_frame(void *user, int frame)
{
    const frame_plan *plan = user;
    return plan->skip && plan->skip[frame - plan->first];
}

/* Every frame of the range renders, or with --continue those not complete; reports what
 * it skips and why, and why an existing file renders again. */
static int plan_frames(const vsd_scene *scene, const vsd_render_job *job, frame_plan *plan)
{
    int i, counts[4] = {0, 0, 0, 0};
    plan->first = scene->frames.start;
    plan->count = scene->frames.end - scene->frames.start + 1;
    plan->to_render = plan->count;
    plan->skip = NULL;
    if (!job->resume) return 0;
    plan->skip = calloc((size_t)plan->count, 1);
    if (!plan->skip) {
        fprintf(stderr, "vsd render: --continue: out of memory for %d frames\n", plan->count);
        return -1;
    }
    for (i = 0; i < plan->count; i++) {
        char why[1024];
        vsd_frame_output_state state = vsd_frame_output_check(scene, plan->first + i, why, sizeof why);
        counts[state]++;
        plan->skip[i] = state == VSD_FRAME_DONE;
        plan->to_render -= plan->skip[i];
        if (job->quiet) continue;
        if (state == VSD_FRAME_DONE) fprintf(stderr, "frame %d: skipped, %s\n", plan->first + i, why);
        else if (state != VSD_FRAME_MISSING) fprintf(stderr, "frame %d: renders again: %s\n", plan->first + i, why);
    }
    if (!job->quiet)
        fprintf(stderr, "--continue: %d of %d frames complete and skipped; %d to render (%d missing, %d broken, "
                        "%d from another scene)\n",
                counts[VSD_FRAME_DONE], plan->count, plan->to_render, counts[VSD_FRAME_MISSING],
                counts[VSD_FRAME_BROKEN], counts[VSD_FRAME_STALE]);
    return 0;
}

/* --cache-dir, or the per-user default (vsd_default_cache_dir); "none" = no cache. */
static const char *cache_dir(const vsd_render_job *job, char *buf, size_t len)
{
    if (job->cache_dir[0]) return strcmp(job->cache_dir, "none") == 0 ? NULL : job->cache_dir;
    return vsd_default_cache_dir(buf, len);
}

static void print_frame_done(int frame, const char *path, const char *note, const vsd_render_stats *stats)
{
    printf("frame %d: %s  (%s, %d spp, load %.2fs, prepare %.2fs, render %.2fs, %d threads)\n", frame, path,
           stats->method, stats->samples, stats->load_seconds, stats->prepare_seconds, stats->render_seconds,
           stats->threads);
    if (note[0]) printf("  preview: %s\n", note);
    if (stats->method_info[0]) printf("  %s: %s\n", stats->method, stats->method_info);
    fflush(stdout);
}

static int render_frames(const vsd_scene *scene, const vsd_render_job *job, const frame_plan *plan,
                         volatile int *cancel)
{
    char cache[VSD_PATH_LEN];
    render_progress prog;
    vsd_render_options ro = {0};
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    char err[2048];
    vsd_status st;
    int frame, rc = VSD_EXIT_OK;
    if (plan->to_render == 0) return VSD_EXIT_OK;
    render_progress_init(&prog, job->quiet, plan->to_render);
    ro.progress = render_progress_update;
    ro.user = &prog;
    ro.cancel = cancel;
    ro.cache_dir = cache_dir(job, cache, sizeof cache);
    ro.max_voxels = job->max_voxels;
    st = vsd_renderer_create(scene, &ro, &r, err, sizeof err);
    if (st) {
        fprintf(stderr, "vsd render: %s\n", err);
        return vsd_exit_code_for(st, 0);
    }
    for (frame = scene->frames.start; frame <= scene->frames.end && !st; frame++) {
        int writing = 0;
        vsd_render_stats stats;
        char path[VSD_PATH_LEN], note[512];
        if (plan_skip_frame((void *)plan, frame)) continue;
        render_progress_begin_frame(&prog, frame);
        st = vsd_renderer_render(r, frame, &fb, &stats, err, sizeof err);
        if (!st) {
            writing = 1;
            st = vsd_write_frame_outputs(scene, frame, fb, &stats, path, sizeof path, note, sizeof note, err, sizeof err);
        }
        render_progress_end_frame(&prog, st == VSD_OK);
        if (st) {
            fprintf(stderr, "vsd render: frame %d: %s\n", frame, err);
            rc = vsd_exit_code_for(st, writing);
            break;
        }
        if (!job->quiet) print_frame_done(frame, path, note, &stats);
        render_progress_report(&prog);
        if (stats.warnings[0]) fprintf(stderr, "vsd render: frame %d: warning: %s\n", frame, stats.warnings);
    }
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
    return rc;
}

int vsd_cmd_render(int argc, char **argv)
{
    static vsd_render_job job; /* large: its override strings */
    vsd_scene scene;
    frame_plan plan;
    volatile int *cancel;
    int rc = vsd_render_job_parse(argc, argv, &job);
    vsd_render_job_print_usage(&job);
    if (rc || job.help) return rc;
    if ((rc = vsd_cli_job_scene(&job, &scene)) != 0) return rc;
    if (plan_frames(&scene, &job, &plan)) return VSD_EXIT_RENDER_FAILED;
    cancel = vsd_cli_cancel_on_sigint();
    rc = job.remote ? vsd_render_job_remote(&scene, &job, plan.to_render, plan_skip_frame, &plan, cancel)
                    : render_frames(&scene, &job, &plan, cancel);
    free(plan.skip);
    return rc;
}
