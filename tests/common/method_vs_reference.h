/* method_vs_reference.h — the one harness a fast method's comparison with `reference` goes
 * through (test_crm, test_lbl, test_constellation, test_shgrid; issue 29 item 6).
 *
 * A comparison renders the reference twice, with two seeds, in the same run. The method is
 * scored against their mean, and the mean's own noise is measured from the same two images:
 *   error = rel(method, (a + b) / 2)      noise = rel(a, (a + b) / 2) = |a - b| / 2
 * with rel the block relative RMSE of `vsd compare` (4 x 4 block means, RMSE over the mean
 * |reference|; vsd_block_rel_rmse). The metric is linear in the difference, and (a - b) / 2
 * has the same variance as the mean's deviation from the converged image, so `noise` is the
 * noise the comparison carries (not the pair difference, which is 2x it).
 *
 * Each checked pass has a tolerance fixed by the test (a constant beside the measurement it
 * is justified by). The harness fails the test when
 *   - error >= tolerance ("<what> <pass>: error ... >= tolerance ..."),
 *   - tolerance < 3 x noise ("tolerance ... below 3x the reference noise ...": the test
 *     would be scoring the reference's noise, not the method; raise the reference's samples
 *     or the tolerance) — the tolerance is NOT derived from the noise: a noisier reference
 *     would otherwise loosen the test silently,
 *   - a negative control scores under the tolerance ("... cannot fail: control ..."): the
 *     method's own pass scaled by control_scale (an error of known size), and for the
 *     scattering methods the controls of mvr_check_scattering_controls.
 * Every comparison prints one line with error, noise, 3x noise, tolerance and controls. */
#ifndef VSD_METHOD_VS_REFERENCE_H
#define VSD_METHOD_VS_REFERENCE_H
#include "vsd/render.h"
#include "vsd/scene.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#include "vsd/image.h"

/* What to render: a scene file under ../shared/data (`file`) or JSON text (`json`), an
 * in-memory density (`vol`, may be NULL) and environment (`env`, may be NULL), a frame. */
typedef struct mvr_scene {
    const char *file;
    const char *json;
    const vsd_volume *vol;
    const vsd_env *env;
    int frame;
} mvr_scene;

/* The two references (seeds 1 and 7, `spp` samples each) and their mean. */
typedef struct mvr_refs {
    vsd_framebuffer *a, *b, *mean;
    int spp;
} mvr_refs;

/* One pass's comparison. */
typedef struct mvr_result {
    double err, noise, tol, control;
    int ok; /* err < tol, tol >= 3 noise and the control failing */
} mvr_result;

/* The scene with `ov` (--set overrides) and render.method=reference, render.samples=spp and
 * the two seeds appended. Returns 0 (and a failed CHECK) when a render fails. */
int mvr_render_references(const mvr_scene *s, const char *const *ov, int nov, int spp, mvr_refs *refs);
/* The same scene rendered once with `ov` as they are (the method's render). NULL on failure. */
vsd_framebuffer *mvr_render(const mvr_scene *s, const char *const *ov, int nov, const char *cache_dir,
                            vsd_render_stats *stats);
void mvr_refs_free(mvr_refs *refs);

/* Block relative RMSE of pass p of img against the mean reference. */
double mvr_error(const vsd_framebuffer *img, const mvr_refs *refs, vsd_pass p);
/* The noise of the mean reference in pass p: rel(a, mean). */
double mvr_noise(const mvr_refs *refs, vsd_pass p);

/* The check described above for pass p: error < tol, tol >= 3 noise, and the method's pass
 * scaled by control_scale (e.g. 0.8: a fifth of the light lost) scoring >= tol. `what`
 * heads the printed line and the messages ("smoke64 crm"). */
mvr_result mvr_check(const char *what, const vsd_framebuffer *method, const mvr_refs *refs, vsd_pass p, double tol,
                     double control_scale);

/* A control image of pass p (`planes`, the pass's channel count per pixel) that must score
 * >= tol against the mean reference: fails the test as "cannot fail" otherwise. Returns its
 * error. */
double mvr_check_control(const char *what, const char *control, const float *planes, const mvr_refs *refs, vsd_pass p,
                         double tol);

/* The scattering methods' controls on Combined, made from the method's own passes:
 * multiple scattering removed (Combined - VolumeInd), halved, and albedo 0 (no scattered
 * light, alpha kept); each must score >= tol. Also checks Combined = VolumeDir + VolumeInd
 * (transparent film, no emission), which the controls rely on. */
void mvr_check_scattering_controls(const char *what, const vsd_framebuffer *method, const mvr_refs *refs, double tol);

#endif
