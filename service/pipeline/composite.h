/* composite.h — `vsd composite`: vsd's volume over a background plate (docs/povray.md).
 *
 * vsd's Combined is premultiplied: out = volume + (1 - volume.A) * plate, per channel, A
 * included. A plate is any EXR with R, G, B (and A; none = opaque) channels, e.g.
 * POV-Ray's +FE +UA output (premultiplied too), or a multilayer EXR's <layer>.Combined.
 *
 * Depth. Where the volume has a Depth pass and the plate a depth (a Z channel in the
 * plate, or a separate depth plate), each pixel is decided whole: when the plate's
 * surface is nearer than the volume's Depth (the first-interaction distance along the
 * ray), the plate wins and the volume is dropped there; otherwise the volume goes over
 * the plate. This is an approximation: smoke in front of a surface inside the volume is
 * dropped, and edge pixels do not blend. Depth out = min of both. The volume passes
 * (VolumeDir, VolumeInd, Emit, Transmittance) are copied where the volume is in front,
 * and zero (Transmittance one) where the plate wins. */
#ifndef VSD_PIPELINE_COMPOSITE_H
#define VSD_PIPELINE_COMPOSITE_H
#include <stddef.h>
#include "vsd/image.h"
#include "vsd/status.h"

/* A plate in memory: planes of width*height floats, row 0 at the top. a NULL = opaque,
 * depth NULL = none (distance along the view ray; >= VSD_DEPTH_EMPTY = nothing there). */
typedef struct vsd_plate {
    const float *r, *g, *b, *a, *depth;
} vsd_plate;

/* out = vol over plate (both sized as out). `present` = the vsd_pass bits vol holds;
 * returns in *plate_wins the pixels where depth put the plate in front (0 when either
 * side has no depth). out must not be vol. */
void vsd_composite_over(const vsd_framebuffer *vol, unsigned present, const vsd_plate *plate,
                        vsd_framebuffer *out, long *plate_wins);

typedef struct vsd_composite_options {
    const char *plate_depth;  /* EXR with the plate's depth ("Z", "*.Z", else "R"); 0 = none */
    int no_depth;             /* 1 = plain over even when both sides have depth */
} vsd_composite_options;

typedef struct vsd_composite_report {
    int width, height;
    int by_depth;             /* 1 when depth decided per pixel */
    long plate_wins;
    char layer[128];          /* the volume's layer, kept in OUT */
    char plate_channels[160]; /* which plate channels were used */
    char passes[160];         /* passes written */
    int output_error;         /* 1 when writing OUT failed (else a failure is the inputs') */
} vsd_composite_report;

/* Read both EXRs, composite, write OUT (vsd_exr_write: temporary file + rename).
 * Errors name the file and the problem: not readable, no <layer>.Combined.R/G/B/A in the
 * volume, no R/G/B in the plate (listing what it has), sizes that differ. */
vsd_status vsd_composite_files(const char *volume_exr, const char *plate_exr, const char *out_exr,
                               const vsd_composite_options *opt, vsd_composite_report *rep, char *err,
                               size_t errlen);

#endif
