/* volume_groups.h — which of a scene's volumes share lighting grids.
 *
 * A method that caches its lighting on a grid (lbl's lattice, the record grids) gives each
 * volume its own grid, in its own index space, over the volume's *group*: the volumes whose
 * media overlap it (transitively). Inside a group the grids hold every member's extinction
 * and emission, so a smoke around a fire is lit by the flame and shadows it; between
 * groups the shadows are marched through the other groups' volumes (kernel_volumes.h) and
 * the light of near groups comes in as the method carries it (below), so two small volumes
 * 100 m apart never share a grid and nothing is allocated for the space between them.
 *
 * Two volumes are in one group when their media overlap: some point where both have
 * density (or emission) — found by probing the common boxes of their non-empty bricks.
 * Boxes alone would group a cloud with the smoke whose box only grazes its empty corner.
 * Volumes that are near but do not overlap stay apart: lbl's six lattice directions would
 * carry light across the empty space between them as beams along the axes (the ray effect
 * of a discrete-ordinates solve): on the issue-30 scene a cloud 0.1 m above a fire's smoke
 * got an orange streak straight above the flame that `reference` does not show
 * (docs/design-notes.md, "Several volumes"). The light near groups send each other enters
 * lbl's lattices at their faces instead (lbl_exchange.h); crm's grids, whose orders gather
 * 48 directions, take the near volumes in (crm_parts.h). */
#ifndef VSD_VOLUME_GROUPS_H
#define VSD_VOLUME_GROUPS_H
#include <stdint.h>
#include "kernel/kernel_types.h"

/* group[i] = the bit mask of volume i's group (bit j: volume j), for kd's volumes (one
 * volume: group[0] = 1). Empty volumes are groups of their own. */
void vsd_volume_groups(const vsd_kernel_data *kd, uint32_t group[VSD_KMAX_VOLUMES]);

/* World box of a volume's non-empty bricks (density and emission): 0 when it has none. */
int vsd_kobject_world_box(const vsd_kobject *o, double lo[3], double hi[3]);

/* Within a group: the summed sigma_t of its volumes at p, and their summed emission (each
 * volume's colour times its grid). One volume (kd->volume_count <= 1): kd's volume 0. */
float vsd_group_sigma(const vsd_kernel_data *kd, uint32_t group, vsd_f3 p);
vsd_f3 vsd_group_emission(const vsd_kernel_data *kd, uint32_t group, vsd_f3 p);
/* The group's summed sigma_t at p (returned) and its summed sigma_s per channel into
 * scatter[3] (sigma_i albedo_i). */
float vsd_group_scattering(const vsd_kernel_data *kd, uint32_t group, vsd_f3 p, double scatter[3]);
int vsd_group_emits(const vsd_kernel_data *kd, uint32_t group);
/* Whether volumes i and j of kd lie near each other: the gap between their world boxes
 * (non-empty bricks) at most half the largest extent of either box. Near volumes light
 * each other where a method carries it (crm's grids take them in, crm_parts.h; lbl's
 * parts send each other light through their grids' faces, lbl_exchange.h), where far ones
 * only shadow each other (two smokes 100 m apart keep grids of their own size). */
int vsd_volumes_near(const vsd_kernel_data *kd, int i, int j);
/* Whether some volume outside the group lies near one of its members. */
int vsd_group_near_outside(const vsd_kernel_data *kd, uint32_t group);

/* Whether some volume lies outside the group (then its grids need the shadows below). */
int vsd_group_has_outside(const vsd_kernel_data *kd, uint32_t group);

/* The shadows the volumes outside `group` cast on a grid of the group: each record's
 * transmittance toward each directional light (light_trans, and the power its rays lost,
 * light_lost, when not NULL: [records][dir_count]; dir_lights 8 floats each, the direction
 * toward the light first) and toward each point or spot light (local_trans
 * [records][local_count], kernel_lights.h layout) times the transmittance through those
 * volumes along the same ray (kernel_volumes.h, vsd_kvolumes_march_transmittance). */
void vsd_group_shadow_records(const vsd_kernel_data *kd, uint32_t group, const float *record_pos, int records,
                              const float *dir_lights, int dir_count, const float *local_lights, int local_count,
                              float *light_trans, float *light_lost, float *local_trans, int threads);

#endif
