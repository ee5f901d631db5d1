/* test_lbl_first_flight.c — lbl's first flight along 98 directions (lbl_first_flight.h):
 *   1. in a homogeneous medium far from the boundary the first flight's path per cell is
 *      S / x (the fluence of light born at rate S that travels 1/sigma: x = sigma lambda),
 *      and every birth collides in the cell it came from on average (births = albedo S),
 *      in cubic cells and in cells shaped as boxes, thin and thick;
 *   2. one birth at the centre of a homogeneous box: what collides plus what leaves the
 *      box, the latter computed here from the vectors' geometry, is the birth (energy);
 *   3. births with a direction: nothing reaches the cells behind a source that sends its
 *      light along +x, light does reach the cells ahead of it, and the cone phase passes
 *      on every collision (forward + backward + 4 side = 1: births = albedo collisions);
 *   4. the surface: what a birth in the box's face cell loses to the outside against the
 *      half-space's mean of 1/2 E_2 over the cell's depth (the vectors' quadrature is low at
 *      the horizon and for the vectors two cells tall: within 30%, and above the six axes'). */
#include "test_common.h"
#include "methods/lbl/lbl_first_flight.h"
#include "methods/lbl/lbl_directions.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { N = 33 };
#define CELLS ((size_t)N * N * N)
#define AT(x, y, z) (((size_t)(z) * N + (y)) * N + (x))

static float sigma[CELLS], source[18 * CELLS], births[18 * CELLS], paths[18 * CELLS];

static vsd_lbl_first_flight setup(double x, const double *shape, int per_direction)
{
    vsd_lbl_first_flight in;
    size_t c;
    memset(&in, 0, sizeof in);
    in.res[0] = in.res[1] = in.res[2] = N;
    for (c = 0; c < CELLS; c++) sigma[c] = (float)(x / 0.1);   /* cells of 0.1 world units */
    in.sigma = sigma;
    in.cell_world = 0.1;
    in.shape = shape;
    in.source = source;
    in.per_direction = per_direction;
    in.albedo[0] = in.albedo[1] = in.albedo[2] = 0.8f;
    in.forward = in.backward = in.side = 1.0f / 6.0f;
    return in;
}

static double path_sum(size_t c, int ch)
{
    double s = 0.0;
    int i;
    for (i = 0; i < 6; i++) s += paths[((size_t)i * 3 + ch) * CELLS + c];
    return s;
}

static void test_infinite(double x, const double *shape, const char *label)
{
    vsd_lbl_first_flight in = setup(x, shape, 0);
    char err[256];
    size_t c;
    const size_t centre = AT(16, 16, 16);
    for (c = 0; c < 3 * CELLS; c++) source[c] = 1.0f;
    CHECK(vsd_lbl_first_flight_run(&in, 2, births, paths, err, sizeof err) == VSD_OK);
    CHECK_MSG(fabs(path_sum(centre, 1) * x - 1.0) < 1e-3, "[1] %s: path S / x: %g, expected %g", label,
              path_sum(centre, 1), 1.0 / x);
    CHECK_MSG(fabs(births[CELLS + centre] - 0.8) < 1e-3, "[1] %s: births %g, expected albedo S = 0.8", label,
              (double)births[CELLS + centre]);
}

/* the share of one birth at `from` that leaves the homogeneous box (optical depth x per cube
 * cell): along each vector, out of its own segment (e) and through the cells after it */
static double escape_from(const int from[3], double x, const vsd_lbl_directions *dirs)
{
    double out = 0.0;
    int v, a;
    for (v = 0; v < VSD_LBL_VECTORS; v++) {
        const double xv = x * dirs->len[v], e = -expm1(-xv) / xv;
        int m = 1 << 20;
        for (a = 0; a < 3; a++) {
            const int d = dirs->d[v][a];
            if (d > 0) m = m < (N - 1 - from[a]) / d ? m : (N - 1 - from[a]) / d;
            if (d < 0) m = m < from[a] / -d ? m : from[a] / -d;
        }
        out += dirs->share[v] * e * exp(-xv * m);
    }
    return out;
}

static void test_energy(double x, const int from[3], const char *label, double *escaped)
{
    vsd_lbl_first_flight in = setup(x, NULL, 0);
    vsd_lbl_directions dirs;
    char err[256];
    double collided = 0.0, expect;
    size_t c;
    in.albedo[0] = in.albedo[1] = in.albedo[2] = 1.0f;
    memset(source, 0, sizeof source);
    source[AT(from[0], from[1], from[2])] = 1.0f;
    CHECK(vsd_lbl_first_flight_run(&in, 2, births, paths, err, sizeof err) == VSD_OK);
    for (c = 0; c < CELLS; c++) collided += births[c];
    vsd_lbl_directions_make(NULL, &dirs);
    expect = 1.0 - escape_from(from, x, &dirs);
    *escaped = 1.0 - collided;   /* the sweep's own */
    CHECK_MSG(fabs(collided - expect) < 1e-5, "[2] %s: collided %.7f, the birth less what leaves %.7f", label, collided,
              expect);
}

/* the births of a source sending red light along +x from the centre, summed over cells and
 * cones, with the albedo and cone phase given */
static double born_along_x(float albedo, float forward, float backward, float side)
{
    vsd_lbl_first_flight in = setup(0.05, NULL, 1);
    char err[256];
    double born = 0.0;
    size_t c;
    int i;
    in.albedo[0] = albedo, in.forward = forward, in.backward = backward, in.side = side;
    memset(source, 0, sizeof source);
    source[(0 * 3 + 0) * CELLS + AT(16, 16, 16)] = 1.0f;   /* cone +x, red */
    CHECK(vsd_lbl_first_flight_run(&in, 2, births, paths, err, sizeof err) == VSD_OK);
    for (c = 0; c < CELLS; c++)
        for (i = 0; i < 6; i++) born += births[((size_t)i * 3) * CELLS + c];
    return born;
}

static void test_direction(void)
{
    /* albedo 1 and a phase that keeps every collision: the births are what collided */
    const double collided = born_along_x(1.0f, 1.0f / 6.0f, 1.0f / 6.0f, 1.0f / 6.0f);
    /* forward 0.5 + backward 0.1 + 4 sides of 0.1 = 1, albedo 0.8 */
    const double born = born_along_x(0.8f, 0.5f, 0.1f, 0.1f);
    double behind = 0.0;
    int x, y, z;
    for (z = 0; z < N; z++)
        for (y = 0; y < N; y++)
            for (x = 0; x < 16; x++) behind += path_sum(AT(x, y, z), 0);
    CHECK_MSG(behind == 0.0, "[3] light behind a source along +x: %g", behind);
    CHECK_MSG(path_sum(AT(24, 16, 16), 0) > 0.0 && path_sum(AT(24, 16, 16), 1) == 0.0,
              "[3] the cell ahead: red %g, green %g", path_sum(AT(24, 16, 16), 0), path_sum(AT(24, 16, 16), 1));
    CHECK_MSG(collided > 0.05 && collided < 0.95, "[3] collided %g of the birth (x 0.05 per cell, 16 cells out)",
              collided);
    CHECK_MSG(fabs(born - 0.8 * collided) < 1e-4 * collided, "[3] born again %.7f, albedo x collided %.7f", born,
              0.8 * collided);
}

/* A birth spread evenly over the depth of a face cell (optical depth x) leaves a half-space
 * with the mean of 1/2 E_2 over that depth, (1/2 - E_3(x)) / (2 x). The 98 vectors'
 * quadrature is low there, the more so the thicker the cell: the directions near the horizon,
 * half of which leave through the face, go to vectors that run along it, and a vector two
 * cells tall (1, 0, 2) takes its whole segment in the face cell where a ray leaves after
 * half of it (measured 0.87x, 0.81x and 0.74x at x = 0.3, 1 and 3). The six axes alone give
 * (1 - e^-x) / (6 x): 0.43x, 0.54x, 0.65x. */
static void test_surface(double x, double half_space)
{
    const int face[3] = {16, 16, 32}, centre[3] = {16, 16, 16};
    const double axes = -expm1(-x) / (6.0 * x);
    double at_face, deep;
    test_energy(x, face, "a birth in a face cell", &at_face);
    test_energy(x, centre, "a birth at the centre", &deep);
    CHECK_MSG(deep < 0.1 * at_face, "[4] x %g: a birth 16 cells deep leaves %g, one at the face %g", x, deep, at_face);
    CHECK_MSG(at_face > 0.7 * half_space && at_face < 1.05 * half_space && at_face > axes * 1.1,
              "[4] x %g: a face cell's birth leaves %g (%.3fx the half-space's %g; the six axes' %g)", x, at_face,
              at_face / half_space, half_space, axes);
    printf("[4] x %g: a face cell's birth leaves %.4f, the half-space %.4f (%.3fx), the six axes %.4f\n", x, at_face,
           half_space, at_face / half_space, axes);
}

int main(void)
{
    static const double boxes[3] = {1.6, 1.0, 1.0 / 1.6};
    const int corner[3] = {0, 0, 0}, centre[3] = {16, 16, 16};
    double esc;
    test_infinite(0.5, NULL, "cubes, x 0.5");
    test_infinite(2.0, NULL, "cubes, x 2");
    test_infinite(0.5, boxes, "cells 1.6 x 1 x 1/1.6, x 0.5");
    test_energy(0.3, centre, "x 0.3, centre", &esc);
    test_energy(0.3, corner, "x 0.3, corner", &esc);
    test_direction();
    test_surface(0.3, 0.33326);   /* E_3(0.3) = 0.30004 */
    test_surface(1.0, 0.19515);   /* E_3(1) = 0.10969 */
    test_surface(3.0, 0.081845);  /* E_3(3) = 0.0089306 */
    return test_finish("test_lbl_first_flight");
}
