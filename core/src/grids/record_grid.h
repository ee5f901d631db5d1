/* record_grid.h — the grid of lighting records that kernel/kernel_record_grid.h reads:
 * `cells` cells per axis over the density's box (the union of its non-empty 8^3 bricks,
 * index space), a record at the centre of every non-empty cell. Built per volume frame by
 * shgrid (Delalandre et al. 2013, §4.2) and by constellation's cached shadows.
 *
 * A cell is empty when every brick it overlaps has majorant 0 (exact), or, with probes
 * k > 0, when k^3 probes of the density inside it all read 0 (the paper's Fig. 5 test).
 * Ownership: vsd_record_grid_build fills a caller-owned struct; vsd_record_grid_free
 * releases its arrays. */
#ifndef VSD_RECORD_GRID_H
#define VSD_RECORD_GRID_H
#include "kernel/kernel_types.h"
#include "vsd/status.h"

typedef struct vsd_record_grid {
    int32_t res[3];               /* cells per axis; 0 when the volume is empty */
    vsd_affine world_to_grid;     /* cell (i,j,k) spans [i, i+1) x ... */
    int32_t *cell_record;         /* [res x*y*z], x fastest: record index, -1 = empty cell */
    float *record_pos;            /* [count * 4]: the cell centres, world space */
    int32_t count;
} vsd_record_grid;

vsd_status vsd_record_grid_build(const vsd_kvolume *v, int cells, int probes, vsd_record_grid *g, char *err,
                                 size_t errlen);
/* The same over v and other volumes (a group of overlapping or near volumes, each lighting
 * grid of the group covering them all): the box in v's index space grows to hold the
 * others' boxes, and a cell is empty when it is empty in every volume. With no others it
 * is vsd_record_grid_build. */
vsd_status vsd_record_grid_build_over(const vsd_kvolume *v, const vsd_kvolume *const *others, int other_count,
                                      int cells, int probes, vsd_record_grid *g, char *err, size_t errlen);
/* Cubic cells (in v's index space) following the box's shape: `cells` of them along its
 * longest axis, as many as fit along the others (the last cell may overhang the box). */
vsd_status vsd_record_grid_build_shaped(const vsd_kvolume *v, int cells, int probes, vsd_record_grid *g, char *err,
                                        size_t errlen);
void vsd_record_grid_free(vsd_record_grid *g);
/* The thinnest slab of a cell in world units (row a of world_to_grid is scaled by 1 / the
 * cell's extent along grid axis a); infinite for an empty grid. */
double vsd_record_grid_cell_world(const vsd_record_grid *g);

/* Isotropic phase: every record's in-scattered RGB (the SH term and the lights' term of
 * g, whose kind must not be BAKED), evaluated once with the view pass's own function;
 * *out (malloc'd, 3 floats per record) is then the records of a BAKED grid, which a
 * camera change reads without redoing any lighting. */
struct vsd_krecord_grid;
vsd_status vsd_record_grid_bake(const struct vsd_krecord_grid *g, float **out, char *err, size_t errlen);

/* Any phase: every record's in-scattered RGB toward this view's camera (g->kd's), the
 * phase taken at the direction from the camera to the record (the camera's axis when it
 * is orthographic). A ray through a cell sees its records within cell size / distance of
 * that direction, a fraction of a degree at our framings; the march then reads one RGB
 * triple per corner instead of summing the lights per record it crosses. record_pos: the
 * grid's (4 floats per record); out: 3 floats per record, their logs when g->interp is
 * VSD_RECORDS_LOG_TRILINEAR (set the grid's records_log to read them). */
void vsd_record_grid_bake_view(const struct vsd_krecord_grid *g, const float *record_pos, int threads, float *out);
/* g read from `baked` (vsd_record_grid_bake_view's output, for g's interpolation) instead of
 * its lights: the march then sums nothing per record it crosses. */
void vsd_record_grid_use_baked(struct vsd_krecord_grid *g, const float *baked);
/* The same, and with the same per-record phase weights (the bake's cost) the lights' term
 * of a second set of transmittances, light_trans2 and local_trans2 (g's layout), into out2
 * (3 floats per record, linear): lbl's delta-M forward light (lbl_delta_m.h). */
/* The lights' term alone with other transmittances (g's layout), linear: what the pair's
 * second output holds, where no bake of g itself goes with it (a device view). */
void vsd_record_grid_bake_view_lights(const struct vsd_krecord_grid *g, const float *record_pos, int threads,
                                      const float *light_trans, const float *local_trans, float *out);
void vsd_record_grid_bake_view_pair(const struct vsd_krecord_grid *g, const float *record_pos, int threads, float *out,
                                    const float *light_trans2, const float *local_trans2, float *out2);

/* The view pass of every record-grid method, on the CPU tiles or the CUDA device of ctx:
 * n x n rays per pixel through the shared march with a step of `step` world units (0 = the
 * smallest voxel: the records are interpolated anyway, and against half a voxel VolumeDir
 * moved at most 0.03 points on smoke128 and cloud256 while the view took half the time,
 * docs/tte.md), stopping below transmittance `stop`. g->kd must be &ctx->kd. */
struct vsd_frame_ctx;
struct vsd_framebuffer;
struct vsd_view_sampling;
/* vs: adaptive view sampling (method.h), NULL = every pixel. */
vsd_status vsd_record_grid_render(struct vsd_frame_ctx *ctx, struct vsd_framebuffer *fb, const struct vsd_krecord_grid *g,
                                  int n, double step, double stop, const struct vsd_view_sampling *vs, int *samples,
                                  char *err, size_t errlen);
/* The same with g's records baked toward this view's camera first (vsd_record_grid_bake_view
 * into a buffer of its own, then vsd_record_grid_use_baked on a copy of g): the CPU view of
 * shgrid's and constellation's `view_bake`. record_pos: the grid's record positions. */
vsd_status vsd_record_grid_render_baked(struct vsd_frame_ctx *ctx, struct vsd_framebuffer *fb,
                                        const struct vsd_krecord_grid *g, const float *record_pos, int n, double step,
                                        double stop, const struct vsd_view_sampling *vs, int *samples, char *err,
                                        size_t errlen);

/* The same view over several volumes (kernel_record_grids.h): grids[i] lights ctx's
 * volume i; count must be ctx->kd.volume_count. */
vsd_status vsd_record_grids_render(struct vsd_frame_ctx *ctx, struct vsd_framebuffer *fb, const struct vsd_krecord_grid *grids,
                                   int count, int n, double step, double stop, const struct vsd_view_sampling *vs,
                                   int *samples, char *err, size_t errlen);

#endif
