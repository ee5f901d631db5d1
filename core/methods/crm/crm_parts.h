/* crm_parts.h — crm over several volumes: a part per volume (src/method/method_parts.h),
 * each crm's one-volume state with its node grid in its volume's index space (over its
 * group's box, below), plus what a part needs beyond one volume:
 *   - every volume's medium on its nodes (the mixture: summed extinction, sigma_s / sigma_t
 *     as the albedo the successive orders scatter with, summed emission), so overlapping
 *     volumes shadow and light each other inside the box as one medium does;
 *   - the shadows of what lies outside the box: each node's optical depth toward each sky
 *     direction gains the depth through the volumes beyond the box's exit;
 *   - the view: one march over all volumes mixing the parts' sources
 *     (crm_volumes_kernel.h).
 * A part's node grid covers its *group* (src/grids/volume_groups.h: the volumes whose media
 * overlap its own) and the volumes near it, not only its own box: the light one volume
 * sends another (a flame's glow on the smoke over it, a cloud's on the smoke below it) is
 * carried by the orders only where both lie inside one grid,
 * and the view mixes the parts' multiple scattering by sigma_i / sigma, which sums back to
 * the mixture's only where every part's grid saw the same medium. On the issue-30 scene the
 * smoke's grid over its own box left the fire's light below it out (VolumeInd 6% dark over
 * the fire and smoke), and the cloud's light on the smoke's top (docs/methods/crm.md,
 * "Several volumes").
 * A part's own single scattering keeps its volume's albedo and phase (the view weights it
 * by sigma_i / sigma); its multiple scattering is the mixture's at each node, which the
 * same weights sum back to the mixture. */
#ifndef VSD_CRM_PARTS_H
#define VSD_CRM_PARTS_H
#include "src/method/method.h"
#include "crm_kernel.h"
#include "crm_node_single.h"

/* The box of the part's node grid, in its volume's index space (voxels; dims multiples of
 * 8, the brick box's units): the volume's own brick box (origin, dims on entry) grown to
 * hold the world boxes of the other members of its group (ctx->part.group) and of the
 * volumes near it (vsd_volumes_near, src/grids/volume_groups.h). */
void vsd_crm_part_box(const vsd_frame_ctx *ctx, int32_t origin[3], int32_t dims[3]);

/* Whether every other volume whose box meets the node box (index space, as
 * vsd_crm_part_box's) has the part's own anisotropy: delta-M scales the whole grid's medium
 * with the part's phase (crm_orders.h), which is only right for one phase. */
int vsd_crm_part_one_phase(const vsd_frame_ctx *ctx, const int32_t origin[3], const int32_t dims[3]);

/* Per node of a part's grid (node_res; n2w: node coordinates to world), the mean over the
 * node's cell (3 x 3 x 3 samples, as the one-volume node density) of every volume's summed
 * sigma_t, divided by `scale` (the part's own sigma_t per unit density, > 0, so that
 * scale * density is the mixture's extinction and the node-grid stages run unchanged);
 * albedo[3 * node]: the mixture's sigma_s / sigma_t there (the medium's own where no
 * volume has density); emission (NULL = not wanted): the summed emitted radiance per unit
 * length, 3 floats per node. */
void vsd_crm_part_medium(const vsd_frame_ctx *ctx, const int32_t node_res[3], const vsd_affine *n2w, float scale,
                         float *density, float *albedo, float *emission);

/* Adds to each of c's optical depths (unscaled: the part's density units) the depth through
 * the volumes along the same ray from where it leaves the node grid's box (origin, dims:
 * vsd_crm_part_box's), over `scale`; step: the march step in world units. */
vsd_status vsd_crm_part_shadows(const vsd_frame_ctx *ctx, vsd_crm_node_depths *c, const vsd_affine *n2w,
                                const int32_t origin[3], const int32_t dims[3], float scale, float step, int threads,
                                char *err, size_t errlen);

/* The view over all parts (parts[i] goes with volume i, its node pass done; count =
 * ctx->kd.volume_count), n x n rays per pixel: on the CPU threads with host parts, or on
 * ctx->cuda with parts made device structs by vsd_crm_part_device. */
vsd_status vsd_crm_parts_view(vsd_frame_ctx *ctx, vsd_framebuffer *fb, const vsd_kcrm *parts, int count, int n,
                              const vsd_view_sampling *vs, int *samples, char *err, size_t errlen);

#endif
