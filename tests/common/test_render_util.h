/* test_render_util.h — helpers of the tests that render (test_crm, test_lbl): scenes from
 * ../shared/data, renders by a fresh renderer, the block relative RMSE `vsd compare`
 * reports, and the checks a fast method's comparison with `reference` makes. Failures are
 * CHECKs (test_common.h). */
#ifndef VSD_TEST_RENDER_UTIL_H
#define VSD_TEST_RENDER_UTIL_H
#include <stddef.h>
#include "vsd/render.h"
#include "vsd/scene.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#include "vsd/image.h"

/* img (width x height x 4) = method's Combined with (1 - keep_ind) of its VolumeInd taken
 * out (keep_ind < 0: no scattered light at all, black); alpha kept. The negative controls
 * of the method-vs-reference checks. */
void test_scattering_control(const vsd_framebuffer *method, float keep_ind, float *img);

/* The value of `key` in a render's method_info ("key=value ..."); -1 (and a failed CHECK)
 * when absent. */
double test_info(const vsd_render_stats *s, const char *key);
/* A scene file under ../shared/data, or JSON text, with --set style overrides. */
int test_load_scene(const char *rel, const char *const *ov, int nov, vsd_scene *sc);
int test_parse_scene(const char *json, const char *const *ov, int nov, vsd_scene *sc);
vsd_renderer *test_make_renderer(const vsd_scene *sc, const char *cache_dir);
/* One render of sc with density volume vol (and env, NULL: sc's map is not loaded) already
 * in memory, on `threads` CPU threads (0: all); NULL and a failed CHECK on an error. */
vsd_framebuffer *test_render_in_memory(const vsd_scene *sc, const vsd_volume *vol, const vsd_env *env, int threads);
int test_render(vsd_renderer *r, int frame, vsd_framebuffer **fb, vsd_render_stats *stats);
/* One render by a fresh renderer (in-memory volume / environment when given); NULL on failure. */
vsd_framebuffer *test_render_fresh(const vsd_scene *sc, const char *cache_dir, const vsd_volume *vol,
                                   const vsd_env *env, int frame, vsd_render_stats *stats);
/* sc must be refused: by vsd_renderer_create or by the render of frame sc->frames.start
 * (volume i from vols[i] in memory when given, nvols of them). A failed CHECK when it
 * renders; the error into err either way. */
void test_expect_render_error(const vsd_scene *sc, const vsd_volume *const *vols, int nvols, char *err, size_t errlen);
/* Relative RMSE of pass p of a against b after 4x4 block averages, as `vsd compare`. */
double test_rel_err(const vsd_framebuffer *a, const vsd_framebuffer *b, vsd_pass p);
double test_rel_err_planes(const float *a, const float *b, int w, int h, int ch);
size_t test_pass_floats(const vsd_framebuffer *fb, vsd_pass p);
/* Every pass bit for bit. */
int test_identical(const vsd_framebuffer *a, const vsd_framebuffer *b);
/* max |a - b| / max |b| over pass p. */
double test_max_rel_diff(const vsd_framebuffer *a, const vsd_framebuffer *b, vsd_pass p);
/* Sum of the green channel of an RGB (or RGBA) pass. */
double test_pass_sum(const vsd_framebuffer *fb, vsd_pass p);
/* Combined is VolumeDir + VolumeInd per pixel (transparent film, no emission). */
void test_check_pass_sum(const char *what, const vsd_framebuffer *fb);
/* Negative controls (multiple scattering removed, halved; no scattered light) scored against
 * ref's Combined must each fail `tol`. */
void test_check_controls(const char *what, const vsd_framebuffer *method, const vsd_framebuffer *ref, double tol);

/* Emission scattered once is VolumeDir, as in `reference` and Cycles: fire96 frame 48 at
 * 64x36 in a black world (all scattered light is emission's), `method` against a 256-spp
 * reference. Checks VolumeDir and VolumeInd's relative errors below tol_dir / tol_ind and
 * each pass's mean within ratio_dir / ratio_ind of the reference's (all of it in VolumeInd
 * scores VolumeDir 1.0). `label` heads the printout. */
void test_check_emission_split(const char *label, const char *method, double tol_dir, double tol_ind,
                               double ratio_dir, double ratio_ind);

/* EXR file bytes (a daemon's RESULT) decoded through a file in `dir` (named with `tag`)
 * against fb, every pass: the number of floats that differ bit for bit, -1 when the bytes
 * do not decode or a channel is missing. */
long test_exr_bytes_diff(const unsigned char *exr, size_t len, const vsd_framebuffer *fb, const char *dir,
                         const char *tag);

/* A homogeneous ball: 32^3 voxels over [0,2]^3 (voxel 1/16), density 1 within 12 voxels
 * (0.75) of the centre; with test_ball_json (medium density 4: optical radius 3, albedo
 * 0.9, g 0, a uniform white environment, an orthographic camera, 32x32, method crm) a few
 * scattering orders matter. */
vsd_volume *test_ball_volume(void);
extern const char *const test_ball_json;

#endif
