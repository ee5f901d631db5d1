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

/* [5]'s reference: lbl_first_flight.h's recurrence along each vector and cone, in double */
static double ref_paths[18 * CELLS], ref_births[18 * CELLS];

static void reference_flight(const vsd_lbl_first_flight *in)
{
    static double pout[3 * CELLS], hit[18 * CELLS];
    vsd_lbl_directions dirs;
    double cone_share[6] = {0};
    int v, i, b, ch;
    vsd_lbl_directions_make(in->shape, &dirs);
    memset(ref_paths, 0, sizeof ref_paths);
    memset(hit, 0, sizeof hit);
    for (v = 0; v < VSD_LBL_VECTORS; v++)
        for (i = 0; i < 6; i++) cone_share[i] += dirs.share[v] * dirs.cone[v][i];
    for (v = 0; v < VSD_LBL_VECTORS; v++) {
        const int *d = dirs.d[v];
        int32_t start[3], step[3], x, y, z;
        vsd_lbl_sweep_order(in->res, d, start, step);
        for (z = start[2]; z >= 0 && z < N; z += step[2])
            for (y = start[1]; y >= 0 && y < N; y += step[1])
                for (x = start[0]; x >= 0 && x < N; x += step[0]) {
                    const size_t c = AT(x, y, z);
                    const int ux = x - d[0], uy = y - d[1], uz = z - d[2];
                    const int inside = ux >= 0 && uy >= 0 && uz >= 0 && ux < N && uy < N && uz < N;
                    const double xo = sigma[c] * dirs.len[v] * in->cell_world;
                    const double tr = exp(-xo), e = xo > 1e-5 ? -expm1(-xo) / xo : 1.0 - xo / 2,
                                 h = xo > 1e-5 ? (1.0 - e) / xo : 0.5 - xo / 6;
                    for (ch = 0; ch < 3; ch++) {
                        const double p_in = inside ? pout[(size_t)ch * CELLS + AT(ux, uy, uz)] : 0.0;
                        double src = 0.0;
                        for (b = 0; b < 6; b++)
                            src += source[((size_t)b * 3 + ch) * CELLS + c] * dirs.share[v] * dirs.cone[v][b] / cone_share[b];
                        pout[(size_t)ch * CELLS + c] = p_in * tr + src * e;
                        for (i = 0; i < 6; i++) {
                            ref_paths[((size_t)i * 3 + ch) * CELLS + c] += dirs.cone[v][i] * dirs.len[v] * (p_in * e + src * h);
                            hit[((size_t)i * 3 + ch) * CELLS + c] += dirs.cone[v][i] * (p_in * (1.0 - tr) + src * (1.0 - e));
                        }
                    }
                }
    }
    for (ch = 0; ch < 3; ch++)
        for (size_t c = 0; c < CELLS; c++) {
            double sum = 0.0;
            for (i = 0; i < 6; i++) sum += hit[((size_t)i * 3 + ch) * CELLS + c];
            for (i = 0; i < 6; i++) {
                const double own = hit[((size_t)i * 3 + ch) * CELLS + c], back = hit[((size_t)(i ^ 1) * 3 + ch) * CELLS + c];
                ref_births[((size_t)i * 3 + ch) * CELLS + c] =
                    in->albedo[ch] * (in->side * (sum - own - back) + in->forward * own + in->backward * back);
            }
        }
}

/* the largest difference of a against b over the largest of b */
static double worst(const float *a, const double *b, size_t count)
{
    double diff = 0.0, top = 0.0;
    size_t c;
    for (c = 0; c < count; c++) {
        diff = fmax(diff, fabs(a[c] - b[c]));
        top = fmax(top, fabs(b[c]));
    }
    return top > 0.0 ? diff / top : diff;
}

static void test_lumpy(void)
{
    static const double boxes[3] = {1.3, 1.0, 1.0 / 1.3};
    static float paths1[18 * CELLS], births1[18 * CELLS];
    vsd_lbl_first_flight in = setup(0.0, boxes, 1);
    char err[256];
    unsigned rng = 12345u;
    double wp, wb;
    size_t c;
    int differ = 0;
    for (c = 0; c < CELLS; c++) {
        const int x = (int)(c % N), z = (int)(c / ((size_t)N * N));
        rng = rng * 1664525u + 1013904223u;
        /* a third empty, the rest from optical depth 1e-4 to 3 per cell, thicker with z */
        sigma[c] = (rng >> 8) % 3 == 0 ? 0.0f : (float)(1e-3 * pow(10.0, 4.5 * ((rng >> 12) % 1000) / 1000.0) * (1 + z) / N / 0.1);
        if (x > 20 && x < 24) sigma[c] = 0.0f;   /* a gap of empty cells across the box */
    }
    for (c = 0; c < 18 * CELLS; c++) {
        rng = rng * 1664525u + 1013904223u;
        source[c] = (rng >> 8) % 5 == 0 ? (float)((rng >> 12) % 1000) / 1000.0f : 0.0f;
    }
    in.albedo[0] = 0.9f, in.albedo[1] = 0.6f, in.albedo[2] = 0.3f;
    in.forward = 0.5f, in.backward = 0.1f, in.side = 0.1f;
    reference_flight(&in);
    CHECK(vsd_lbl_first_flight_run(&in, 3, births, paths, err, sizeof err) == VSD_OK);
    wp = worst(paths, ref_paths, 18 * CELLS), wb = worst(births, ref_births, 18 * CELLS);
    CHECK_MSG(wp < 2e-5 && wb < 2e-5, "[5] a lumpy medium against the recurrence in double: paths %.3g, births %.3g", wp, wb);
    printf("[5] a lumpy medium against the recurrence in double: paths %.3g, births %.3g of the largest\n", wp, wb);
    CHECK(vsd_lbl_first_flight_run(&in, 1, births1, paths1, err, sizeof err) == VSD_OK);
    for (c = 0; c < 18 * CELLS; c++) differ += paths1[c] != paths[c] || births1[c] != births[c];
    CHECK_MSG(differ == 0, "[5] 1 and 3 threads: %d values differ", differ);
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
    test_lumpy();
    return test_finish("test_lbl_first_flight");
}
