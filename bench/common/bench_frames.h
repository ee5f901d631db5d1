/* bench_frames.h — the VDB sequences' frames for the benchmarks (header-only). */
#ifndef VSD_BENCH_FRAMES_H
#define VSD_BENCH_FRAMES_H
#include "vsd/scene.h"
#include <stdio.h>
#include <string.h>

/* The first scene frame after `from` whose volumes[0] file exists on disk (the sequences in
 * ../shared/data skip frames), 0 when none within 30 or the file is not a sequence. */
static inline int bench_next_frame(const vsd_scene *sc, int from)
{
    char path[sizeof sc->volumes[0].file + 16], err[256];
    int f;
    for (f = from + 1; f <= from + 30; f++) {
        FILE *fp;
        if (vsd_frame_path(sc->volumes[0].file, f + sc->volumes[0].frame_offset, path, sizeof path, err, sizeof err) ||
            !strcmp(path, sc->volumes[0].file))
            return 0;
        if ((fp = fopen(path, "rb"))) {
            fclose(fp);
            return f;
        }
    }
    return 0;
}

#endif
