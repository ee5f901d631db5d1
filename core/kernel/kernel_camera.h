/* kernel_camera.h — primary rays of a Blender camera: looks down local -Z with +Y up; the
 * field of view (or orthographic scale) spans the larger image dimension (sensor fit AUTO).
 * (jx, jy) in [0,1) place the ray inside the pixel: a one-pixel box filter, as Cycles'
 * Box filter of width 1. Row 0 is the top of the image. */
#ifndef VSD_KERNEL_CAMERA_H
#define VSD_KERNEL_CAMERA_H
#include "kernel_types.h"

VSD_DEVICE void vsd_camera_ray(const vsd_kcamera *c, int32_t px, int32_t py, float jx, float jy,
                               vsd_f3 *origin, vsd_f3 *dir)
{
    float half = 0.5f * (float)(c->width > c->height ? c->width : c->height);
    float sx = ((float)px + jx - 0.5f * (float)c->width) / half;
    float sy = (0.5f * (float)c->height - ((float)py + jy)) / half;
    const float *m = c->cam_to_world.m;
    vsd_f3 right = f3(m[0], m[4], m[8]), up = f3(m[1], m[5], m[9]), back = f3(m[2], m[6], m[10]);
    vsd_f3 pos = f3(m[3], m[7], m[11]);
    if (c->orthographic) {
        *origin = f3_add(pos, f3_add(f3_scale(right, sx * c->ortho_half_width), f3_scale(up, sy * c->ortho_half_width)));
        *dir = f3_normalize(f3_scale(back, -1.0f));
    } else {
        *origin = pos;
        *dir = f3_normalize(f3_sub(f3_add(f3_scale(right, sx * c->tan_half_fov), f3_scale(up, sy * c->tan_half_fov)), back));
    }
}

#endif
