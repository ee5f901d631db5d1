/* vsd/lighting.h — an environment map as a light constellation: N directional lights that
 * stand for the map (Navarro et al. 2009 §3; Debevec's median cut, or k-means).
 *
 * Each light holds a direction in the map's own frame (texture space: the frame in which
 * kernel_env.h looks texels up before the Z rotation), the RGB power it stands for —
 * the integral of the map's radiance over the solid angle of its region, strength 1 — and
 * that solid angle. The regions partition the sphere, so the powers sum to the map's
 * integral exactly (up to float rounding). Lights whose region is black are dropped, so
 * `count` may be below the number asked for (never above).
 *
 * Strength and rotation are not baked in: vsd_constellation_kernel_lights() turns the
 * constellation into kernel lights for any strength and Z rotation without recomputing it.
 *
 * Ownership: vsd_constellation_build() fills a caller-owned struct whose `lights` array
 * vsd_constellation_free() releases. */
#ifndef VSD_LIGHTING_H
#define VSD_LIGHTING_H
#include <stdint.h>
#include "vsd/status.h"
#include "vsd/env.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef enum vsd_lights_method {
    VSD_LIGHTS_MEDIAN_CUT = 0,  /* equal-energy regions (Debevec 2005, solid-angle weighted) */
    VSD_LIGHTS_KMEANS = 1       /* Lloyd iterations from the median-cut lights: unequal energy,
                                   more regular spacing */
} vsd_lights_method;

typedef struct vsd_env_light {
    float dir[3];          /* unit direction, texture space (rotation 0) */
    float power[3];        /* RGB, integral of radiance over the region (W/m^2-like units) */
    float solid_angle;     /* steradians of the region */
} vsd_env_light;

typedef struct vsd_light_constellation {
    int count;
    vsd_env_light *lights;
    /* With sub-lights (vsd_constellation_build_grouped): each light's region cut again by
     * the same median cut into sub_count lights in all, sub_group[i] the light whose region
     * sub-light i lies in; the sub-lights of a light sum to its power. Else 0 / NULL. */
    int sub_count;
    vsd_env_light *sub;
    int *sub_group;
    double total_power[3]; /* the map's integral (sum of the lights' powers, in double) */
} vsd_light_constellation;

/* Split `env` into at most n lights (1..65536). */
vsd_status vsd_constellation_build(const vsd_env *env, int n, vsd_lights_method method,
                                   vsd_light_constellation *out, char *err, size_t errlen);
/* The same n lights, and each light's region cut into per_group (1..64) sub-lights: a
 * method that keeps one shadow per light can still weigh the phase function over the
 * sub-lights' finer directions (lbl: the record grid's sub-lights). per_group 1 = none;
 * median cut only (k-means lights get none). */
vsd_status vsd_constellation_build_grouped(const vsd_env *env, int n, int per_group, vsd_lights_method method,
                                           vsd_light_constellation *out, char *err, size_t errlen);
void vsd_constellation_free(vsd_light_constellation *c);

/* A 64-bit hash of the map's size and texel bits: a constellation is reused only for
 * identical content (an address alone could be reused by a new map). */
uint64_t vsd_env_content_hash(const vsd_env *env);

/* The map's integral over the sphere, RGB (exact texel solid angles, strength 1). */
void vsd_env_integral(const vsd_env *env, double rgb[3]);

/* Unit texture-space direction of the centre of texel (col, row). */
void vsd_env_texel_direction(const vsd_env *env, int col, int row, float dir[3]);

/* Kernel lights (8 floats each: world direction xyz, 0, weight rgb, 0 — the layout of
 * vsd_kernel_data.lights) for the environment's strength and rotation_z: the world
 * direction is Rz(-rotation_z) applied to the texture direction (kernel_env.h's mapping),
 * the weight is power * strength. out holds 8 * (c->count + c->sub_count) floats: the
 * lights, then the sub-lights with their light's index in the 8th float. */
void vsd_constellation_kernel_lights(const vsd_light_constellation *c, float strength, float rotation_z,
                                     float *out);

/* A constellation kept across lighting changes (the methods that use one: constellation,
 * lbl): rebuilt only when the map's content (vsd_env_content_hash), the light count or the
 * method changes; the kernel lights (`lights`, `count` of them, 8 floats each) re-derived
 * for the strength and rotation on every update. Zero-initialise; free with
 * vsd_constellation_cache_free. */
typedef struct vsd_constellation_cache {
    vsd_light_constellation cons;
    uint64_t key;
    int n, per_group, method, valid;
    float *lights;           /* count lights, then sub_count sub-lights (kernel layout) */
    int count, sub_count;
} vsd_constellation_cache;

vsd_status vsd_constellation_cache_update(vsd_constellation_cache *c, const vsd_env *env, int n,
                                          vsd_lights_method method, float strength, float rotation_z, char *err,
                                          size_t errlen);
/* The same with sub-lights (vsd_constellation_build_grouped). */
vsd_status vsd_constellation_cache_update_grouped(vsd_constellation_cache *c, const vsd_env *env, int n, int per_group,
                                                  vsd_lights_method method, float strength, float rotation_z,
                                                  char *err, size_t errlen);
void vsd_constellation_cache_free(vsd_constellation_cache *c);

#ifdef __cplusplus
}
#endif
#endif
