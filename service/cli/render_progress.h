/* render_progress.h — what `vsd render` prints while a sequence renders: the current
 * frame's stage and percentage, and the whole run's position, elapsed time and ETA. A bar
 * redrawn in place on a terminal; plain lines (every 10 %, and one per frame) in logs. */
#ifndef VSD_CLI_RENDER_PROGRESS_H
#define VSD_CLI_RENDER_PROGRESS_H

typedef struct render_progress {
    int tty, quiet;
    int frame;             /* the frame being rendered */
    int index, total;      /* it is the index-th (1-based) of `total` frames to render */
    double start_time;     /* when the first frame began */
    double frames_seconds; /* time spent on finished frames */
    int last_percent;
    int frame_ok;          /* the last frame finished */
    char last_stage[64];
} render_progress;

/* `total` frames will render (skipped ones not counted). */
void render_progress_init(render_progress *p, int quiet, int total);
void render_progress_begin_frame(void *user, int frame);
/* vsd_progress_fn: a stage's fraction of the current frame. */
void render_progress_update(void *user, const char *stage, float fraction);
/* The current frame is finished (ok) or failed: ends the bar's line, counts its time. */
void render_progress_end_frame(render_progress *p, int ok);
/* After the frame's own line: "done i/n frames (elapsed 1:02, ETA 3:04)" for a finished
 * frame, the line a log shows the whole run's position with. */
void render_progress_report(render_progress *p);

#endif
