/* bench_cycles.h — render a vsd scene file with Blender Cycles (tests/cycles/cycles_scene.py)
 * and read back Cycles' own timings from the EXR's header (header-only; shared by vsd_bench
 * and bench_tte). Needs _POSIX_C_SOURCE 200809L, tests/cycles on the include path (for
 * run_logged.h) and vsd_lib. */
#ifndef VSD_BENCH_CYCLES_H
#define VSD_BENCH_CYCLES_H
#include "run_logged.h"
#include "vsd/clock.h"
#include "vsd/image.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* "MM:SS.ss" or "HH:MM:SS.ss" (Blender's render-time stamps) -> seconds */
static inline double bench_parse_clock(const char *s)
{
    double parts[3] = {0, 0, 0};
    int n = 0;
    while (*s && n < 3) {
        char *end;
        parts[n++] = strtod(s, &end);
        if (*end != ':') break;
        s = end + 1;
    }
    if (n == 3) return parts[0] * 3600 + parts[1] * 60 + parts[2];
    if (n == 2) return parts[0] * 60 + parts[1];
    return parts[0];
}

typedef struct bench_cycles_result {
    int ok, samples;
    double render, sync, wall;   /* Cycles' path tracing and scene sync (its EXR header), the whole process */
} bench_cycles_result;

/* One Cycles render of scene_path at w x h, spp samples, seed (0: the script's default)
 * into out (EXR), Blender's output into log, the script's timings into tjson. */
static inline void bench_run_cycles(const char *blender, const char *script, const char *scene_path, const char *out,
                                    const char *log, const char *tjson, int w, int h, int spp, int seed,
                                    bench_cycles_result *cr)
{
    char s_w[16], s_h[16], s_spp[16], s_seed[16], val[64], err[256];
    char *argv[26];
    int n = 0, rc;
    double t0 = vsd_clock_seconds();
    memset(cr, 0, sizeof *cr);
    snprintf(s_w, sizeof s_w, "%d", w);
    snprintf(s_h, sizeof s_h, "%d", h);
    snprintf(s_spp, sizeof s_spp, "%d", spp);
    snprintf(s_seed, sizeof s_seed, "%d", seed);
    unlink(out);
    argv[n++] = (char *)blender;
    n = cycles_scene_args(argv, n, script, scene_path, out, s_w, s_h, s_spp, seed ? s_seed : NULL, tjson);
    argv[n] = NULL;
    rc = run_logged(argv, log);
    cr->wall = vsd_clock_seconds() - t0;
    if (rc != 0 || access(out, R_OK) != 0) {
        fprintf(stderr, "Cycles failed (status %d), see %s\n", rc, log);
        return;
    }
    cr->samples = spp;
    if (vsd_exr_read_attr(out, "cycles.ViewLayer.render_time", val, sizeof val, err, sizeof err) == VSD_OK)
        cr->render = bench_parse_clock(val);
    if (vsd_exr_read_attr(out, "cycles.ViewLayer.synchronization_time", val, sizeof val, err, sizeof err) == VSD_OK)
        cr->sync = bench_parse_clock(val);
    if (vsd_exr_read_attr(out, "cycles.ViewLayer.samples", val, sizeof val, err, sizeof err) == VSD_OK)
        cr->samples = atoi(val);
    cr->ok = cr->render > 0;
}

#endif
