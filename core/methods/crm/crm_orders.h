/* crm_orders.h — multiple scattering by successive orders on a coarse grid: the option
 * `multiple: "orders"` (default), beside the paper's diffusion (eq. 13 at the RBF centres,
 * "rbf").
 *
 * Why: diffusion (the paper's, and one on this grid with a vacuum boundary that was tried
 * and dropped) assumes many scattering events; at our smoke's albedo (0.85)
 * and thickness they give a third of the reference's VolumeInd (docs/methods/crm.md). Here
 * the scattered light is followed order by order, as a path tracer would: the first
 * `fine_orders` on the nodes themselves (J_1 holds the shadows' edges and the medium's
 * detail, which the first gather carries into J_2), the rest on a grid `coarse` nodes apart
 * (each later order is a sum over more paths, and smooth):
 *     J_1       the single-scattering source's bands 0-2 (`ms_bands` 3; 0-1 with 2; band 0
 *               alone when g = 0)
 *     L_k(x,w)  = integral over s of tau(x, x + s w) sigma_t(x + s w) J_k(x + s w, -w) ds
 *     J_k+1(x, w_o) = albedo * (4 pi / M) sum over M HEALPix directions w of L_k(x, w)
 *                     p(w_o . -w), kept as order-3 SH: by Funk-Hecke, band l of HG is g^l,
 *                     so coefficient (l, m) gains g^l Y_lm(-w) L_k(x, w) (delta-M's
 *                     scaled phase: chi'_l, crm_phase.h)
 * L_k toward each direction taken on the nodes by one sweep over them (crm_sweep.h: each
 * node's light from its upstream neighbours'; 0.24 s an order on smoke128 against 1.1 s
 * marched), on the coarse grid by marches (sweeps there made the dense cumulus' VolumeInd
 * 22% off: the cells are twice as thick and its 20 orders compound each one's error), or
 * everywhere by marches (`sweep` 0): each march stepping one cell with sigma_t and sigma
 * J taken trilinearly, J evaluated at
 * the cells toward -w (negative values of the truncated SH clamped to 0: with bands above 0
 * one gather pass per direction, so every pass reads 4 floats per cell as the isotropic
 * one does; the emission alone, isotropic, takes one pass), stopping where the
 * transmittance is below 1e-3 or the ray leaves the grid. Orders are added until one adds
 * less than `tolerance` of the sum (band 0), or `max_orders`; the rest is closed with each
 * band's geometric tail from its own ratio of the last two orders (band 0's below albedo
 * < 1, so it converges; bands 1 and 2 at most band 0's: crm_orders.c). Phase: with
 * anisotropy 0 every J is isotropic (band 0 only, the cheaper march); else bands 0-2 (or
 * 0-1) carry the forward scattering order after order (the isotropic form measured 18.2% on
 * cloud128_interior, g 0.5, against 9.4% with bands 0-1; band 2 took cloud256 from 9.3% to
 * 4.9%: docs/methods/crm.md). J_ms = sum over k >= 2 of J_k is written into the fine
 * nodes' multiple-scattering SH (CRM_MS_N) — less the
 * emission scattered once (the first order's gather of the emission alone), which is added
 * to the single-scattering bands instead: Cycles counts it as direct light (VolumeDir),
 * docs/design-notes.md "Passes". */
#ifndef VSD_CRM_ORDERS_H
#define VSD_CRM_ORDERS_H
#include <stdint.h>
#include "vsd/status.h"

typedef struct vsd_crm_orders_stats {
    int orders;          /* orders computed (k = 2 .. orders + 1) */
    int fine_orders;     /* of which on the nodes themselves (fine_orders, or coarse 1) */
    double tail;         /* fraction of J_ms that came from the geometric tail */
    int32_t res[3];      /* coarse grid */
    double seconds;
} vsd_crm_orders_stats;

/* node_res/to_node: the fine node grid (crm_source_grid.h) and the world-direction to
 * node-displacement matrix (crm_node_single.h); sigma_t:
 * per fine node (world units); nodes, valid: the source grid, whose single-scattering bands
 * 0..bands-1 are J_1 and whose multiple-scattering part (and CRM_NODE_MULTIPLE bit) is
 * overwritten; anisotropy: HG's g for the orders (0 = isotropic, band 0 only); bands: 2
 * (J in bands 0-1) or 3 (0-2).
 * emission: per fine node, 3 floats, the emitted radiance per unit length (world units), or
 * NULL; albedo: the medium's, with which the single scattering (J_1) was computed;
 * node_albedo: NULL, or per fine node 3 floats, the albedo the orders scatter with there
 * (several overlapping volumes: sigma_s / sigma_t of their mixture); coarse: fine nodes per
 * coarse cell (>= 1); fine_orders: how many of the first orders run on the nodes themselves
 * before the rest go on to the coarse grid (0: all on the coarse grid); sweep: each gather
 * by one sweep per direction over the cells (crm_sweep.h) instead of a march from every
 * cell toward every direction; directions: HEALPix
 * count (12 nside^2).
 * j1: the nodes (CRM_NODE_FLOATS layout) J_1's bands are read from, or NULL: `nodes`.
 * delta: delta-M scaling of the phase for g > 0 (crm_orders.c, delta_m): the orders run the
 * scaled problem (f = g^bands: sigma_t (1 - a f), a (1 - f) / (1 - a f), the phase's band l
 * (g^l - f) / (1 - f), crm_phase.h), whose J_1 j1 must then hold (crm.c), and J_ms goes
 * back to the true phase for the view. */
vsd_status vsd_crm_orders(const int32_t node_res[3], const double to_node[9], const float *sigma_t,
                          const float *emission, const double albedo[3], const float *node_albedo, double anisotropy,
                          int bands, const float *j1, int delta, float *nodes, uint8_t *valid, int coarse,
                          int fine_orders, int sweep, int directions, int max_orders, double tolerance, int threads,
                          vsd_crm_orders_stats *stats, char *err,
                          size_t errlen);

#endif
