/* Which frames of a sequence are done, missing or failed (`vsd farm status`,
 * docs/farm.md), from the files alone, so it works the same for any farm or none:
 *   done    the EXR is complete and was rendered from this scene (VSD_FRAME_DONE);
 *   failed  the EXR is there but not usable: it does not read (VSD_FRAME_BROKEN) or was
 *           rendered from another scene (VSD_FRAME_STALE); or there is no EXR but a
 *           "<exr>.tmp-<pid>" that a render killed while writing it left behind;
 *   missing no EXR and no such leftover: never rendered, or the render stopped before
 *           writing (a task killed mid-frame leaves nothing on disk).
 * A frame being written at that very moment also shows its temporary file, so it reads as
 * failed until the rename that ends the write. */
#ifndef VSD_PIPELINE_FARM_STATUS_H
#define VSD_PIPELINE_FARM_STATUS_H
#include "vsd/scene.h"
#include <stdio.h>

typedef enum vsd_farm_state {
    VSD_FARM_DONE = 0,
    VSD_FARM_MISSING,
    VSD_FARM_FAILED
} vsd_farm_state;

/* The state of scene->output.exr for `frame`; `why` gets the reason ("complete", "no file",
 * "pixels do not read: ...", "left f_0007.exr.tmp-123 from a render killed while writing").
 * Leaves nothing behind and changes no file. */
vsd_farm_state vsd_farm_frame_state(const vsd_scene *scene, int frame, char *why, size_t whylen);

typedef struct vsd_farm_counts {
    int done, missing, failed;
} vsd_farm_counts;

/* Prints the summary of frames first..last to out:
 *   done     9  1-6,9-11
 *   missing  2  7-8          (tasks 2  when chunk > 0: the array tasks that hold them)
 *   failed   1  12
 *   frame 12: failed: <why>
 * and fills *counts. Returns 0, or -1 when out of memory. */
int vsd_farm_status_report(const vsd_scene *scene, int first, int last, int chunk, FILE *out,
                            vsd_farm_counts *counts);

#endif
