/* bench_camera.h — camera moves shared by the benchmarks (header-only). */
#ifndef VSD_BENCH_CAMERA_H
#define VSD_BENCH_CAMERA_H
#include "vsd/scene.h"
#include <math.h>

/* camera-to-world `base` turned by `angle` radians about the world Z axis, into sc */
static inline void bench_orbit_camera(vsd_scene *sc, const double base[16], double angle)
{
    double c = cos(angle), s = sin(angle);
    int col;
    for (col = 0; col < 4; col++) {
        double x = base[col], y = base[4 + col];
        sc->camera.matrix[col] = c * x - s * y;
        sc->camera.matrix[4 + col] = s * x + c * y;
        sc->camera.matrix[8 + col] = base[8 + col];
    }
}

#endif
