/* env_lights.h — a fixed set of K directional lights standing for the environment,
 * importance-sampled from its tables with a stratified, deterministic sequence: the
 * raymarch baseline uses them so its image is noise-free (the same directions for every
 * pixel), as Navarro et al.'s brute-force reference does. Layout: see vsd_kernel_data.lights. */
#ifndef VSD_ENV_LIGHTS_H
#define VSD_ENV_LIGHTS_H
#include "vsd/status.h"
#include "kernel/kernel_types.h"

/* out: 8*count floats. Weights are radiance / (count * pdf), so summing phase * T * weight
 * over the lights estimates the in-scattering integral. */
void vsd_env_importance_lights(const vsd_kenv *env, int count, float *out);

#endif
