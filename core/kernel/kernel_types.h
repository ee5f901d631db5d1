/* kernel_types.h — the data every kernel sees, and the small vector maths they share.
 *
 * This folder is the common subset of C11 and CUDA C++ (docs/architecture.md §2): no globals, no
 * VLAs, no compound literals; every function is VSD_DEVICE. Scene data reaches kernels
 * through one `const vsd_kernel_data *` holding plain structs and flat arrays, so the CPU
 * backend passes host pointers and the CUDA backend passes the same layout with device
 * pointers. Nothing here owns memory. */
#ifndef VSD_KERNEL_TYPES_H
#define VSD_KERNEL_TYPES_H

#include <stdint.h>
#include <math.h>

#ifdef __CUDACC__
#define VSD_DEVICE __host__ __device__ inline
#define VSD_ALIGN16 __align__(16)
#else
#define VSD_DEVICE static inline
#define VSD_ALIGN16 __attribute__((aligned(16)))
#endif

#ifdef __cplusplus
#define VSD_STATIC_ASSERT(c, m) static_assert(c, m)
#else
#define VSD_STATIC_ASSERT(c, m) _Static_assert(c, m)
#endif

#define VSD_PI 3.14159265358979323846f
#define VSD_INF 1e30f

typedef struct vsd_f3 { float x, y, z; } vsd_f3;

/* min/max without libm's NaN rules, so they compile to single instructions (fminf and
 * fmaxf are library calls at -O2 without -ffinite-math-only) */
VSD_DEVICE float vsd_minf(float a, float b) { return a < b ? a : b; }
VSD_DEVICE float vsd_maxf(float a, float b) { return a > b ? a : b; }

VSD_DEVICE vsd_f3 f3(float x, float y, float z) { vsd_f3 r; r.x = x; r.y = y; r.z = z; return r; }
VSD_DEVICE vsd_f3 f3s(float s) { return f3(s, s, s); }
VSD_DEVICE vsd_f3 f3_add(vsd_f3 a, vsd_f3 b) { return f3(a.x + b.x, a.y + b.y, a.z + b.z); }
VSD_DEVICE vsd_f3 f3_sub(vsd_f3 a, vsd_f3 b) { return f3(a.x - b.x, a.y - b.y, a.z - b.z); }
VSD_DEVICE vsd_f3 f3_mul(vsd_f3 a, vsd_f3 b) { return f3(a.x * b.x, a.y * b.y, a.z * b.z); }
VSD_DEVICE vsd_f3 f3_scale(vsd_f3 a, float s) { return f3(a.x * s, a.y * s, a.z * s); }
VSD_DEVICE vsd_f3 f3_madd(vsd_f3 a, vsd_f3 b, float s) { return f3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
/* Trilinear between eight corner values, corner a at (a & 1, a >> 1 & 1, a >> 2): seven
 * lerps (the record and node lookups where every corner is set; their weighted mean
 * elsewhere). */
VSD_DEVICE vsd_f3 f3_trilerp(const vsd_f3 *v, float tx, float ty, float tz)
{
    vsd_f3 x00 = f3_madd(v[0], f3_sub(v[1], v[0]), tx), x10 = f3_madd(v[2], f3_sub(v[3], v[2]), tx);
    vsd_f3 x01 = f3_madd(v[4], f3_sub(v[5], v[4]), tx), x11 = f3_madd(v[6], f3_sub(v[7], v[6]), tx);
    vsd_f3 y0 = f3_madd(x00, f3_sub(x10, x00), ty), y1 = f3_madd(x01, f3_sub(x11, x01), ty);
    return f3_madd(y0, f3_sub(y1, y0), tz);
}
VSD_DEVICE float f3_dot(vsd_f3 a, vsd_f3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
VSD_DEVICE vsd_f3 f3_cross(vsd_f3 a, vsd_f3 b)
{
    return f3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
VSD_DEVICE vsd_f3 f3_normalize(vsd_f3 a)
{
    float l = sqrtf(f3_dot(a, a));
    return l > 0.0f ? f3_scale(a, 1.0f / l) : a;
}
VSD_DEVICE float f3_max_comp(vsd_f3 a) { return vsd_maxf(a.x, vsd_maxf(a.y, a.z)); }
VSD_DEVICE float f3_mean(vsd_f3 a) { return (a.x + a.y + a.z) * (1.0f / 3.0f); }
VSD_DEVICE float vsd_luminance(vsd_f3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
VSD_DEVICE float vsd_clampf(float v, float lo, float hi) { return vsd_minf(vsd_maxf(v, lo), hi); }

/* 3x4 affine matrix, row-major: p' = M[0..2] . (p,1) etc. */
typedef struct vsd_affine { float m[12]; } vsd_affine;

VSD_DEVICE vsd_f3 vsd_affine_point(const vsd_affine *a, vsd_f3 p)
{
    return f3(a->m[0] * p.x + a->m[1] * p.y + a->m[2] * p.z + a->m[3],
              a->m[4] * p.x + a->m[5] * p.y + a->m[6] * p.z + a->m[7],
              a->m[8] * p.x + a->m[9] * p.y + a->m[10] * p.z + a->m[11]);
}
VSD_DEVICE vsd_f3 vsd_affine_vector(const vsd_affine *a, vsd_f3 v)
{
    return f3(a->m[0] * v.x + a->m[1] * v.y + a->m[2] * v.z,
              a->m[4] * v.x + a->m[5] * v.y + a->m[6] * v.z,
              a->m[8] * v.x + a->m[9] * v.y + a->m[10] * v.z);
}

/* A brick grid as kernels see it (see vsd/volume.h for the layout). Ray parameters stay in
 * world units when a ray is carried into index space with vsd_affine_point/vector, because
 * the map is affine and the direction is not renormalised. */
typedef struct VSD_ALIGN16 vsd_kvolume {
    const int32_t *brick_slots;
    const float *voxels;
    const float *brick_max;   /* majorant of the (unscaled) field per brick cell */
    vsd_affine world_to_index;
    int32_t origin[3];
    int32_t dims[3];          /* 0,0,0 = empty */
    float scale;              /* multiplier: medium density, or emission strength */
    float step;               /* world length of about half a voxel (quadrature step) */
} vsd_kvolume;

/* Equirectangular environment with its importance-sampling tables. cdf_rows has height+1
 * entries (marginal over rows, top row first); cdf_cols has height*(width+1) entries (per
 * row conditional over columns). Both are normalised to end at 1. */
typedef struct VSD_ALIGN16 vsd_kenv {
    const float *rgb;
    const float *cdf_rows;
    const float *cdf_cols;
    int32_t width, height;
    float strength;
    float cos_rot, sin_rot;   /* Blender Mapping node Z rotation */
    float pdf_norm;           /* width*height / (2 pi^2 * sum of weights), see kernel_env.h */
    int32_t linear;           /* 1: bilinear between texel centres (Blender's "Linear"), 0: nearest */
} vsd_kenv;

typedef struct VSD_ALIGN16 vsd_kcamera {
    vsd_affine cam_to_world;  /* columns: right(+X), up(+Y), back(+Z), position */
    float tan_half_fov;       /* perspective: across the larger image dimension */
    float ortho_half_width;   /* orthographic: half the world width across the larger dimension */
    int32_t orthographic;
    int32_t width, height;
    float clip_start, clip_end;
    float pad_;
} vsd_kcamera;

typedef struct VSD_ALIGN16 vsd_kmedium {
    vsd_f3 albedo;            /* sigma_s / sigma_t per channel */
    float anisotropy;         /* HG g */
    vsd_f3 emission;          /* emission_color * emission_strength */
    int32_t has_emission;
} vsd_kmedium;

/* Several volumes in one scene (vsd_scene.volumes): each one's density (scale = its
 * medium's density), emission and material. kernel_volumes.h walks them together. */
#define VSD_KMAX_VOLUMES 16
typedef struct VSD_ALIGN16 vsd_kobject {
    vsd_kvolume density;
    vsd_kvolume emission;
    vsd_kmedium medium;
} vsd_kobject;

typedef struct VSD_ALIGN16 vsd_kernel_data {
    /* Volume 0 (the only one of most scenes), which methods that render one volume read: */
    vsd_kvolume density;      /* scale = medium density: sigma_t = scale * field */
    vsd_kvolume emission;     /* scale = 1; L_e = medium.emission * field */
    vsd_kenv env;
    vsd_kcamera camera;
    vsd_kmedium medium;
    /* Directional lights derived from the environment per frame (raymarch's fixed
     * importance-sampled directions, constellation's median-cut lights): per light 8 floats,
     * direction xyz, 0, then radiance weight rgb (already divided by count and pdf), 0. */
    const float *lights;
    /* The scene's lights[] (sun, point, spot): kernel_lights.h's layout, VSD_KLIGHT_FLOATS
     * per light; NULL when there are none. */
    const float *scene_lights;
    int32_t light_count;
    int32_t scene_light_count;
    int32_t transparent;      /* film: 1 = environment not composited behind */
    int32_t seed;
    int32_t max_bounces;
    float march_step;         /* ray-march step in world units (raymarch) */
    float march_stop;         /* view marches stop once transmittance is below this (0 = never) */
    /* Every volume of the scene, volume 0 included (its entry equals density, emission and
     * medium above); kernel_volumes.h reads these when volume_count > 1. Host memory: only
     * the CPU renders several volumes (renderer.c keeps such scenes off the GPU). */
    int32_t volume_count;
    const vsd_kobject *volumes;
    int32_t pad_[2];
} vsd_kernel_data;

VSD_STATIC_ASSERT(sizeof(vsd_kvolume) % 16 == 0, "vsd_kvolume must stay 16-byte aligned");
VSD_STATIC_ASSERT(sizeof(vsd_kenv) % 16 == 0, "vsd_kenv must stay 16-byte aligned");
VSD_STATIC_ASSERT(sizeof(vsd_kernel_data) % 16 == 0, "vsd_kernel_data must stay 16-byte aligned");

/* What one pixel sample produces; backends accumulate these into the framebuffer. */
typedef struct vsd_sample_result {
    vsd_f3 direct;            /* VolumeDir */
    vsd_f3 indirect;          /* VolumeInd */
    vsd_f3 emit;              /* Emit */
    vsd_f3 background;        /* environment seen through the volume (opaque film only) */
    float transmittance;      /* of the view ray through the whole volume */
    float depth;              /* first-collision distance, or VSD_INF */
} vsd_sample_result;

#endif
