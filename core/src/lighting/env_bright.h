/* env_bright.h — an environment map split into its brightest texels, stood for by a few
 * directional lights, and the smooth remainder a low-order SH can hold.
 *
 * Why: a sun, a studio lamp or a window is the one thing order-2..4 SH cannot carry: its
 * projection blurs it over tens of degrees and rings below zero elsewhere, and a method
 * that shadows or phase-weights that blur gets the shadow's and the lobe's truncation
 * error at the one direction that matters. Methods that take the bright texels out and
 * light them exactly (shgrid's and crm's `lights`) keep the SH for what is left. */
#ifndef VSD_ENV_BRIGHT_H
#define VSD_ENV_BRIGHT_H
#include "vsd/env.h"
#include "vsd/lighting.h"
#include "vsd/status.h"

/* Texels whose luminance is above `threshold` times the map's mean luminance over the
 * sphere (solid-angle weighted) go into at most `max_lights` median-cut lights (texture
 * frame, equal energy: a compact sun gets all of them) in *bright; *rest becomes a copy of
 * env with those texels black (its rgb owned by the caller: free(rest->rgb)); *fraction the
 * luminance share taken. A map with no texel above the threshold gives bright->count 0 and
 * rest equal to env. On failure *rest and *bright hold nothing to free. */
vsd_status vsd_env_split_bright(const vsd_env *env, double threshold, int max_lights, vsd_env *rest,
                                vsd_light_constellation *bright, double *fraction, char *err, size_t errlen);

#endif
