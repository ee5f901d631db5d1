/* Progress and ETA of `vsd render` (render_progress.h). */
#define _POSIX_C_SOURCE 200809L
#include "render_progress.h"
#include "vsd/clock.h"
#include <stdio.h>
#include <string.h>
#include <unistd.h>

void render_progress_init(render_progress *p, int quiet, int total)
{
    memset(p, 0, sizeof *p);
    p->tty = isatty(STDERR_FILENO);
    p->quiet = quiet;
    p->total = total;
    p->start_time = vsd_clock_seconds();
}

void render_progress_begin_frame(void *user, int frame)
{
    render_progress *p = user;
    p->frame = frame;
    p->index++;
    p->last_percent = -1;
    p->last_stage[0] = '\0';
}

/* "1:02:03", "4:05" or "12s". */
static void format_duration(double s, char *out, size_t len)
{
    long t = (long)(s + 0.5);
    if (t >= 3600) snprintf(out, len, "%ld:%02ld:%02ld", t / 3600, t / 60 % 60, t % 60);
    else if (t >= 60) snprintf(out, len, "%ld:%02ld", t / 60, t % 60);
    else snprintf(out, len, "%lds", t);
}

/* The run's ETA from the mean time of the finished frames; "" before one has finished
 * (a frame's stages take unequal shares of its time, so a fraction says little). */
static void format_eta(const render_progress *p, char *out, size_t len)
{
    int finished = p->index - 1;
    char d[32];
    out[0] = '\0';
    if (finished < 1 || p->total <= 1) return;
    format_duration(p->frames_seconds / finished * (p->total - finished) -
                        (vsd_clock_seconds() - p->start_time - p->frames_seconds),
                    d, sizeof d);
    snprintf(out, len, ", ETA %s", d[0] == '-' ? "0s" : d);
}

void render_progress_update(void *user, const char *stage, float fraction)
{
    render_progress *p = user;
    int percent = (int)(fraction * 100.0f + 0.5f);
    char elapsed[32], eta[48];
    if (p->quiet) return;
    if (percent == p->last_percent && strcmp(stage, p->last_stage) == 0) return;
    format_duration(vsd_clock_seconds() - p->start_time, elapsed, sizeof elapsed);
    format_eta(p, eta, sizeof eta);
    if (p->tty) {
        int bar = percent * 30 / 100, i;
        fprintf(stderr, "\r\033[Kframe %d (%d/%d) %-13s [", p->frame, p->index, p->total, stage);
        for (i = 0; i < 30; i++) fputc(i < bar ? '#' : '.', stderr);
        fprintf(stderr, "] %3d%%  %s%s", percent, elapsed, eta);
        fflush(stderr);
    } else if (percent / 10 != p->last_percent / 10 || strcmp(stage, p->last_stage) != 0) {
        fprintf(stderr, "frame %d (%d/%d) %s %d%% (elapsed %s%s)\n", p->frame, p->index, p->total, stage, percent,
                elapsed, eta);
    }
    p->last_percent = percent;
    snprintf(p->last_stage, sizeof p->last_stage, "%s", stage);
}

void render_progress_end_frame(render_progress *p, int ok)
{
    p->frames_seconds = vsd_clock_seconds() - p->start_time;
    p->frame_ok = ok;
    if (!p->quiet && p->tty && p->last_percent >= 0) fputc('\n', stderr);
}

void render_progress_report(render_progress *p)
{
    char elapsed[32], eta[48] = "";
    if (p->quiet || !p->frame_ok) return;
    format_duration(p->frames_seconds, elapsed, sizeof elapsed);
    if (p->index < p->total) {
        p->index++; /* the ETA counts this frame as finished */
        format_eta(p, eta, sizeof eta);
        p->index--;
    }
    fprintf(stderr, "done %d/%d frames (elapsed %s%s)\n", p->index, p->total, elapsed, eta);
}
