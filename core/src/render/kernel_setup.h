/* kernel_setup.h — host-side construction of the kernel data (kernel/kernel_types.h) from
 * the scene model: volumes with their world transforms, the camera, and the environment's
 * importance-sampling tables. The arrays pointed to stay owned by the volume, env or
 * vsd_env_tables they came from. */
#ifndef VSD_KERNEL_SETUP_H
#define VSD_KERNEL_SETUP_H
#include "vsd/scene.h"
#include "vsd/volume.h"
#include "vsd/env.h"
#include "kernel/kernel_types.h"

/* Marginal and conditional CDFs over texels weighted by luminance * sin(theta): the
 * texel's own luminance for VSD_ENV_CLOSEST; for VSD_ENV_LINEAR the integral over the
 * texel of the bilinear interpolant, which is the luminance filtered by
 * [1/8, 3/4, 1/8] in each direction (wrapping in u, clamped at the poles), so the
 * piecewise-constant pdf follows the map as it is evaluated. */
typedef struct vsd_env_tables {
    float *cdf_rows;   /* [height + 1] */
    float *cdf_cols;   /* [height * (width + 1)] */
} vsd_env_tables;

vsd_status vsd_env_tables_build(const vsd_env *env, int interpolation, vsd_env_tables *t, char *err,
                                size_t errlen);
void vsd_env_tables_free(vsd_env_tables *t);

void vsd_kenv_setup(vsd_kenv *ke, const vsd_env *env, const vsd_env_tables *t, int interpolation, float strength,
                    float rotation_z);
/* vol may be NULL (an absent volume: dims 0). object_matrix row-major 4x4. */
vsd_status vsd_kvolume_setup(vsd_kvolume *kv, const vsd_volume *vol, const double object_matrix[16],
                             float scale, char *err, size_t errlen);
void vsd_kcamera_setup(vsd_kcamera *kc, const vsd_scene *scene);
/* The scene's lights[] in kernel layout (kernel/kernel_lights.h) into out[VSD_KLIGHT_FLOATS *
 * VSD_MAX_LIGHTS]; returns how many. */
int vsd_kscene_lights_setup(float *out, const vsd_scene *scene);
/* A volume's material in kernel form (has_emission is left to the caller, who knows
 * whether the emission grid has anything in it). */
void vsd_kmedium_setup(vsd_kmedium *k, const vsd_scene_medium *m);
/* Volume 0's medium, film and camera from the scene (volumes and env set separately). */
void vsd_kernel_data_from_scene(vsd_kernel_data *kd, const vsd_scene *scene);

#endif
