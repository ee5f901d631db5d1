/* lbl_delta_m.h — delta-M scaling (Wiscombe 1977) of lbl's lattice for forward-peaked media.
 *
 * The six cones carry HG's forward peak as light kept along an axis: at g 0.7 a collision
 * sends 72 % of what it scatters into its own cone (lbl_readout.h), so forward light that
 * should go on along the light's way goes on along the nearest axis instead, and reaches
 * the eye as the cone's light (docs/methods/lbl.md, "Delta-M on the lattice"). Delta-M takes
 * the peak f = g^2 of the phase as no scattering at all: the lattice solves the scaled
 * problem, extinction sigma (1 - a f), albedo a (1 - f) / (1 - a f), phase g / (1 + g), fed
 * by the scaled problem's first scattering (the lights marched through the scaled
 * extinction). What the scaled problem calls unscattered but the true one scattered forward,
 * E (T' - T) per light and record, is read toward the eye with the true phase into
 * VolumeInd, and the lattice's light is read with the true phase too. VolumeDir stays the
 * true single scattering (the records' T). The surface escape (lbl_escape.h) of the scaled
 * lattice is the scaled medium's: a birth near the surface leaves through sigma (1 - a f).
 *
 * With RGB albedo the extinction's scale takes the channels' mean a (one march serves the
 * three), as crm's delta-M does; the albedo's scale is then per channel. */
#ifndef VSD_LBL_DELTA_M_H
#define VSD_LBL_DELTA_M_H
#include <stddef.h>

/* The scaled cells: sigma_out = sigma (1 - a f) per world unit, collide_out = 1 -
 * exp(-sigma_out cell_world), and the albedo a (1 - f) / (1 - a f): per cell into
 * albedo_cells_out ([3][cells]) when albedo_cells ([3][cells]) is given, else the one albedo
 * into albedo_out. */
void vsd_lbl_delta_m_cells(size_t cells, const float *sigma, double cell_world, const float *albedo_cells,
                           const float albedo[3], double f, float *sigma_out, float *collide_out,
                           float *albedo_cells_out, float albedo_out[3]);

#endif
