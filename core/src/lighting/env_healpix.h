/* env_healpix.h — an environment map averaged over the pixels of a HEALPix grid (RING
 * order, world frame: the map's Z rotation and strength applied as kernel_env.h does).
 * Methods that integrate the sky over a few hundred directions use it instead of a
 * low-order SH of the map, whose ringing and blur spread a small sun or a lamp over the
 * sphere before it is shadowed: shgrid's product form, crm's single scattering. */
#ifndef VSD_ENV_HEALPIX_H
#define VSD_ENV_HEALPIX_H
#include "vsd/env.h"
#include "kernel/kernel_types.h"

/* out[4 * pix] = the radiance (RGB, then 0) averaged over HEALPix pixel pix (solid-angle
 * weighted over the texels whose centres fall in it); pixels no texel centre reaches (maps
 * coarser than the grid) take the map at their centre. 12 nside^2 pixels. Returns 0 when
 * out of memory (out untouched). */
int vsd_env_healpix_radiance(const vsd_env *env, const vsd_kenv *ke, long nside, float *out);

#endif
