/* fibonacci_sphere.h — point k of n on the unit sphere's Fibonacci lattice: equal areas,
 * z stratified in n bands, the longitude turned by the golden angle each step. The fixed
 * direction sets of lbl (the cone integrals, the surface escape's solid angles, the light
 * between groups) take their points from here. */
#ifndef VSD_FIBONACCI_SPHERE_H
#define VSD_FIBONACCI_SPHERE_H
#include <math.h>

static inline void vsd_fibonacci_point(int k, int n, double p[3])
{
    const double z = 1.0 - (2.0 * k + 1.0) / n, r = sqrt(1.0 - z * z), phi = k * 2.399963229728653;
    p[0] = r * cos(phi);
    p[1] = r * sin(phi);
    p[2] = z;
}

#endif
