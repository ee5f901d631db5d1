/* pov_export.h — `vsd export pov`: a vsd scene as POV-Ray files (docs/povray.md).
 *
 * For frames first..last, in outdir:
 *   NAME_density_####.df3, NAME_emission_####.df3   the grids (df3.h) of a one-volume scene;
 *   NAME_vI_density_####.df3, NAME_vI_emission_####.df3   those of volumes[I] when the
 *                                                    scene has several (#### = scene frame)
 *   NAME_####.inc                                    declares vsd_volume: every volume's
 *                                                    media (pov_volume.h)
 *   NAME_camera.inc                                  the camera (pov_camera.h)
 *   NAME.pov, NAME.ini                               a scene using them, and the frame range
 * POV-Ray restricts file access to its working folder by default: run it inside outdir. */
#ifndef VSD_PIPELINE_POV_EXPORT_H
#define VSD_PIPELINE_POV_EXPORT_H
#include <stddef.h>
#include <stdint.h>
#include "vsd/scene.h"
#include "vsd/volume.h"

typedef struct vsd_pov_export_options {
    const char *name;     /* file name prefix ([A-Za-z0-9_.-]); 0 or "" = "vsd" */
    int first, last;      /* frame range, inclusive */
} vsd_pov_export_options;

typedef struct vsd_pov_export_report {
    int frames;                 /* frames written */
    uint64_t negative_voxels;   /* written as 0, over all frames and grids */
    char last_inc[1024];        /* path of the last frame's .inc */
    char pov[1024], ini[1024];  /* paths of the .pov and .ini */
    int output_error;           /* 1 when a failure was in writing (else it is the input's) */
} vsd_pov_export_report;

/* Check (and create, one level) outdir; VSD_ERR_IO naming it when it is not a writable
 * folder. */
vsd_status vsd_pov_prepare_dir(const char *outdir, char *err, size_t errlen);

/* One frame from grids already in memory: density[i] and emission[i] (NULL: no emission
 * media) of scene->volumes[i], i < scene->volume_count. Writes every volume's df3 files
 * and NAME_####.inc (a media block per volume, with its own material and volume.matrix). */
vsd_status vsd_pov_export_frame_volumes(const vsd_scene *scene, int frame, const vsd_volume *const *density,
                                        const vsd_volume *const *emission, const char *outdir, const char *name,
                                        vsd_pov_export_report *rep, char *err, size_t errlen);

/* The same for scene->volumes[0] alone, as a one-volume scene (file names without a
 * volume index), whatever scene->volume_count is. */
vsd_status vsd_pov_export_frame(const vsd_scene *scene, int frame, const vsd_volume *density,
                                const vsd_volume *emission, const char *outdir, const char *name,
                                vsd_pov_export_report *rep, char *err, size_t errlen);

/* NAME_camera.inc, NAME.pov and NAME.ini. `floor_z` is the Blender height of the demo
 * floor (the volume's lowest world z). */
vsd_status vsd_pov_export_scene_files(const vsd_scene *scene, const vsd_pov_export_options *opt,
                                      double floor_z, const double centre[3], double extent,
                                      const char *outdir, vsd_pov_export_report *rep, char *err, size_t errlen);

/* The whole export: for each frame and each volume, the grids loaded from the volume's
 * file at vsd_scene_volume_frame() (its emission grid only when it names one and its
 * emission_strength > 0). In a scene of several volumes a load error reads
 * "volumes[I] (FILE): what went wrong". */
vsd_status vsd_pov_export(const vsd_scene *scene, const vsd_pov_export_options *opt, const char *outdir,
                          vsd_pov_export_report *rep, char *err, size_t errlen);

#endif
