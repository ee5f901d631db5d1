/* bench_edits: what one interactive edit costs a live renderer (issue 32's targets).
 *
 *   bench_edits SCENE.json METHOD EDIT [COUNT] [WIDTH HEIGHT]
 *
 * Renders SCENE's first frame cold with METHOD at WIDTH x HEIGHT (default 1280 x 720), then
 * makes EDIT COUNT times (default 5) on the same renderer through vsd_renderer_set_scene and
 * renders again, as the daemon does with its kept renderer. Per edit it prints the wall
 * seconds of set_scene + render, the render's own seconds and the method's info (its
 * stages' seconds), then the median. EDIT, each alternating so every edit changes the scene:
 *   camera    a 10-degree turn about world Z (only the view pass runs again)
 *   rotation  the environment map turned by 0.5 rad about Z
 *   strength  the map's strength x 0.8, x 1.25, ...
 *   density   volumes[0]'s density x 0.8, x 1.25, ...
 *   albedo    volumes[0]'s red albedo x 0.9, / 0.9, ...
 *   g         volumes[0]'s anisotropy -0.1, +0.1, ...
 *   frame     the sequence's next file on disk and back (smoke128: frames 45 and 60)
 * bench_tte's camera, lighting and new-frame columns are the camera, rotation and frame
 * edits of a renderer it keeps; this tool shows each kind of edit and each stage. */
#include "bench_camera.h"
#include "bench_frames.h"
#include "vsd/clock.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Edit i (1-based) of kind `edit` on sc; *frame: the frame to render. 0 when unknown. */
static int make_edit(const char *edit, int i, vsd_scene *sc, const double base[16], int first, int second, int *frame)
{
    vsd_scene_medium *m = &sc->volumes[0].medium;
    const int odd = i & 1;
    *frame = first;
    if (!strcmp(edit, "camera")) bench_orbit_camera(sc, base, i * 10.0 * M_PI / 180.0);
    else if (!strcmp(edit, "rotation")) sc->environment.rotation_z += 0.5f;
    else if (!strcmp(edit, "strength")) sc->environment.strength *= odd ? 0.8f : 1.25f;
    else if (!strcmp(edit, "density")) m->density *= odd ? 0.8f : 1.25f;
    else if (!strcmp(edit, "albedo")) m->albedo[0] *= odd ? 0.9f : 1.0f / 0.9f;
    else if (!strcmp(edit, "g")) m->anisotropy += odd ? -0.1f : 0.1f;
    else if (!strcmp(edit, "frame")) *frame = odd ? second : first;
    else return 0;
    return 1;
}

int main(int argc, char **argv)
{
    const char *ov[3];
    char method[96], width[32], height[32], err[2048];
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    vsd_render_stats st;
    vsd_render_options ro;
    double base[16], t0, *walls;
    int count, i, frame, second = 0;
    if (argc < 4) {
        fprintf(stderr, "usage: bench_edits SCENE.json METHOD camera|rotation|strength|density|albedo|g|frame "
                        "[COUNT] [WIDTH HEIGHT]\n");
        return 2;
    }
    count = argc > 4 ? atoi(argv[4]) : 5;
    if (count < 1 || count > 1000) {
        fprintf(stderr, "bench_edits: COUNT %s: 1 to 1000\n", argv[4]);
        return 2;
    }
    snprintf(method, sizeof method, "render.method=\"%s\"", argv[2]);
    snprintf(width, sizeof width, "film.width=%d", argc > 6 ? atoi(argv[5]) : 1280);
    snprintf(height, sizeof height, "film.height=%d", argc > 6 ? atoi(argv[6]) : 720);
    ov[0] = method, ov[1] = width, ov[2] = height;
    if (vsd_scene_load(argv[1], ov, 3, &sc, err, sizeof err)) {
        fprintf(stderr, "bench_edits: %s\n", err);
        return 1;
    }
    if (!make_edit(argv[3], 0, &sc, sc.camera.matrix, 0, 0, &frame)) {
        fprintf(stderr, "bench_edits: unknown edit '%s'\n", argv[3]);
        return 2;
    }
    /* (edit 0 was a check of the name: reload the scene it may have changed) */
    if (vsd_scene_load(argv[1], ov, 3, &sc, err, sizeof err)) return 1;
    if (!strcmp(argv[3], "frame") && !(second = bench_next_frame(&sc, sc.frames.start))) {
        fprintf(stderr, "bench_edits: %s has no later VDB file to change to\n", argv[1]);
        return 1;
    }
    if (!(walls = malloc(sizeof *walls * (size_t)count))) return 1;
    memset(&ro, 0, sizeof ro);
    memcpy(base, sc.camera.matrix, sizeof base);
    t0 = vsd_clock_seconds();
    if (vsd_renderer_create(&sc, &ro, &r, err, sizeof err) || vsd_renderer_render(r, sc.frames.start, &fb, &st, err, sizeof err)) {
        fprintf(stderr, "bench_edits: %s\n", err);
        return 1;
    }
    printf("cold: %.3f s (%s)\n", vsd_clock_seconds() - t0, st.method_info);
    for (i = 1; i <= count; i++) {
        make_edit(argv[3], i, &sc, base, sc.frames.start, second, &frame);
        t0 = vsd_clock_seconds();
        if (vsd_renderer_set_scene(r, &sc, err, sizeof err) || vsd_renderer_render(r, frame, &fb, &st, err, sizeof err)) {
            fprintf(stderr, "bench_edits: edit %d: %s\n", i, err);
            return 1;
        }
        walls[i - 1] = vsd_clock_seconds() - t0;
        printf("%s %d: %.3f s (render %.3f s; %s)\n", argv[3], i, walls[i - 1], st.render_seconds, st.method_info);
        fflush(stdout);
    }
    qsort(walls, (size_t)count, sizeof *walls, cmp_double);
    printf("%s %s %s: median %.3f s of %d edits (%.3f-%.3f)\n", argv[1], argv[2], argv[3], walls[count / 2], count,
           walls[0], walls[count - 1]);
    free(walls);
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
    return 0;
}
