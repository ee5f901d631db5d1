/* pov_camera.h — Blender/vsd world and camera in POV-Ray's terms (docs/povray.md).
 *
 * Axes. vsd's world is Blender's: right-handed, Z up. POV-Ray's is left-handed, Y up.
 * The export maps a Blender point (x, y, z) to the POV-Ray point <x, z, y>: swapping two
 * axes is a mirror, which turns the right-handed frame into a left-handed one, and puts
 * Blender's up (+Z) on POV-Ray's up (+Y). Lengths and angles are kept, so densities per
 * unit length and fields of view need no change.
 *
 * Camera. vsd's ray through image point (sx, sy), sx, sy in [-1, 1] across the image, is
 * forward + sx*hw*right + sy*hh*up with hw, hh the half extents of the image plane at
 * distance 1 (tan(fov/2) across the larger image dimension, scaled by the aspect for the
 * other). POV-Ray's perspective ray is direction + x*right + y*up with x, y in
 * [-1/2, 1/2]: so direction = forward (unit), right = 2*hw*right, up = 2*hh*up, all
 * mapped through the axis swap. The mirrored right/up/forward frame is left-handed as
 * POV-Ray's own default camera is, so nothing is flipped. The .inc computes hw and hh from
 * POV-Ray's image_width and image_height, so +W/+H keep vsd's framing. */
#ifndef VSD_PIPELINE_POV_CAMERA_H
#define VSD_PIPELINE_POV_CAMERA_H
#include <stdio.h>
#include "vsd/scene.h"

/* Blender (x, y, z) -> POV-Ray <x, z, y>; also for directions. */
void vsd_pov_from_blender(const double b[3], double p[3]);

/* Print an affine row-major 4x4 (column vectors, POV-Ray world) as POV-Ray's
 * `matrix <...>` (row vectors: twelve numbers, the transposed 3x3 then the translation). */
void vsd_pov_print_matrix(FILE *f, const double m[16]);

/* The camera .inc: declares vsd_cam_location / _direction / _right / _up (unit vectors,
 * POV-Ray world), vsd_cam_half_w / _half_h from image_width and image_height, the
 * camera itself and vsd_depth_texture (a texture whose colour is the distance from the
 * camera, for a depth plate). */
void vsd_pov_write_camera(FILE *f, const vsd_scene *scene);

#endif
