/* method_parts.h — a record-grid method over several volumes: a *part* per volume.
 *
 * A part is the method's own state, prepared with a frame context in which the part's
 * volume stands as volume 0 (kd.density, kd.emission, kd.medium; every volume stays in
 * kd.volumes) and ctx->part says which volume and which group it lights
 * (src/grids/volume_groups.h). The method builds its lighting for that volume as it does
 * for one, reading its group's summed medium where it builds grids (vsd_group_sigma) and the
 * other volumes' shadows where its lights reach the grid; the view reads every part's
 * record grid along one march over all volumes (kernel/kernel_record_grids.h). With one
 * volume nothing here runs: the method is its single-volume self.
 *
 * A method takes part in this by holding a vsd_method_parts in its state and, while
 * ctx->part.active is 0 and the scene has several volumes, handing its three stages to the
 * calls below (lbl, shgrid). */
#ifndef VSD_METHOD_PARTS_H
#define VSD_METHOD_PARTS_H
#include "method.h"

struct vsd_krecord_grid;

typedef struct vsd_method_parts {
    void **state;            /* [count] the parts' method states */
    uint32_t group[VSD_KMAX_VOLUMES];
    int count;
    /* A lighting change that no frame stage preceded (a material, the map, its strength or
     * rotation, the scene's lights) re-lights only the parts whose inputs it reaches: the
     * map and lights, and the materials of the part's group (of every volume with
     * `materials_of_all`, for a method whose part reads every volume's material, crm).
     * Another group's material edit leaves a part as it is: a part sees the other groups
     * through their extinction only, which is a frame-stage input. */
    uint64_t light_key[VSD_KMAX_VOLUMES];
    /* A new frame prepares again only the parts whose frame stage reads a volume that
     * changed: part i's key hashes its group and the frame inputs (ctx->volume_key) of the
     * volumes its method's frame stage reads (vsd_part_reads_fn); frame_gen[i] is the
     * renderer's frame generation when part i's frame stage last ran, the generation its
     * device arrays of that stage are keyed by. */
    uint64_t frame_key[VSD_KMAX_VOLUMES];
    uint64_t frame_gen[VSD_KMAX_VOLUMES];
    int frame_ran;           /* a frame stage ran since the last lighting stage */
    int reframed;            /* parts the last frame stage ran */
    int materials_of_all;
    int relit;               /* parts the last lighting stage ran */
} vsd_method_parts;

/* The volumes (bit j = volume j) whose frame inputs the method's prepare_frame reads for
 * the part of ctx (a part's context, its group set): its own volume for a method whose
 * frame stage builds from that alone, its group for one whose grid holds the group's
 * medium. NULL stands for every volume. */
typedef uint32_t (*vsd_part_reads_fn)(const vsd_frame_ctx *ctx);

/* The record grid part `state` shows this view (records baked toward ctx's camera where the
 * method bakes them); ctx is the part's. */
typedef vsd_status (*vsd_part_view_fn)(void *state, vsd_frame_ctx *ctx, struct vsd_krecord_grid *g, char *err,
                                       size_t errlen);

/* volume i's part of ctx (see the top) */
void vsd_part_ctx(const vsd_frame_ctx *ctx, const vsd_method_parts *p, int i, vsd_frame_ctx *out);
/* The group the context lights: a part's group, or volume 0 alone. */
uint32_t vsd_ctx_group(const vsd_frame_ctx *ctx);

/* m's prepare_frame for every volume's part whose inputs changed (`reads`, above; created
 * with `options` on first use, again when the volume count changes); the groups are found
 * anew each frame. Every part is lit again after it (a part's lighting marches every
 * volume's shadows). */
vsd_status vsd_parts_prepare_frame(vsd_method_parts *p, const vsd_method *m, const void *options,
                                   vsd_part_reads_fn reads, vsd_frame_ctx *ctx, char *err, size_t errlen);
vsd_status vsd_parts_prepare_lighting(vsd_method_parts *p, const vsd_method *m, vsd_frame_ctx *ctx, char *err,
                                      size_t errlen);
/* The view: every part's record grid by `view`, then one march over all volumes with n x n
 * rays per pixel, step and stop as vsd_record_grid_render. Fills ctx->info with the parts'
 * count and groups. */
vsd_status vsd_parts_render(const vsd_method_parts *p, vsd_part_view_fn view, vsd_frame_ctx *ctx,
                            vsd_framebuffer *fb, int n, double step, double stop, const vsd_view_sampling *vs,
                            int *samples, char *err, size_t errlen);
/* Destroys the parts (m->destroy); p is then empty. */
void vsd_parts_free(vsd_method_parts *p, const vsd_method *m);

#endif
