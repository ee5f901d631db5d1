/* test_lbl_sweep.c — lbl's directional lights swept through the cells (lbl_sweep.h):
 *   1. a homogeneous box lit along an axis: T at every centre is Beer-Lambert over its depth
 *      (half a cell of the face cell, then whole cells), to float rounding (24 exps of 1e-7); the lost power
 *      of a column sums to its 1 - T over the cell's length (energy), and a thin cell's is
 *      sigma T; a second medium of half the sigma, swept alongside, gives T^(1/2);
 *   2. the same box lit obliquely (0.6, 0, 0.8), off an axis and off a cell diagonal, so
 *      every layer interpolates: still Beer-Lambert where the light came in through the top
 *      (but in the face cells it leaves by, whose centre lies between two rays, one of them
 *      beside the box);
 *   3. a Gaussian ball of extinction, lit obliquely: T against the closed form of the
 *      ball's optical depth (erfc), and against the paper's rays (lbl_march.h) on the same
 *      cells: the sweep within 0.025 where T > 0.05, and no further off than the rays;
 *   4. a blocker in empty space: the shadow's deficit, sum over a layer of 1 - T, is the
 *      same in every layer below it (nothing in vacuum takes light out of a beam or puts it
 *      back: the interpolation spreads the shadow, and only spreads it);
 *   5. records in their own order, and cells without one: each record gets its own cell's
 *      T, and the records of a light with no direction get 0. */
#include "test_common.h"
#include "methods/lbl/lbl_sweep.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { N = 24 };
#define CELLS ((size_t)N * N * N)
#define AT(x, y, z) (((size_t)(z) * N + (y)) * N + (x))

static float sigma[CELLS], sigma2[CELLS], trans[2 * CELLS], lost[2 * CELLS], trans2[2 * CELLS], rays[CELLS];
static int32_t records[CELLS];

/* cells of 1/N world units, the lights in the grid's axes */
static vsd_lbl_grid grid(int second)
{
    vsd_lbl_grid g;
    memset(&g, 0, sizeof g);
    g.res[0] = g.res[1] = g.res[2] = N;
    g.sigma = sigma;
    g.sigma2 = second ? sigma2 : NULL;
    g.to_grid[0] = g.to_grid[4] = g.to_grid[8] = N;
    return g;
}

static void light(float *l, double x, double y, double z)
{
    memset(l, 0, 8 * sizeof *l);
    l[0] = (float)x, l[1] = (float)y, l[2] = (float)z;
    l[4] = l[5] = l[6] = 1.0f;
}

static void test_axis(void)
{
    vsd_lbl_grid g = grid(1);
    float l[8];
    double worst = 0.0, worst2 = 0.0, worst_column = 0.0, worst_rate = 0.0;
    const double s = 2.0;   /* per world unit: 1/12 a cell */
    size_t c;
    int x, y, z;
    for (c = 0; c < CELLS; c++) sigma[c] = (float)s, sigma2[c] = (float)(0.5 * s), records[c] = (int32_t)c;
    light(l, 0.0, 0.0, 1.0);   /* above: the light travels along -z */
    CHECK(vsd_lbl_sweep_lights(&g, l, 1, records, (int32_t)CELLS, 2,
                               (const vsd_lbl_march_out[]){{trans, lost, NULL}, {trans2, NULL, NULL}}, NULL, 0) == VSD_OK);
    for (z = 0; z < N; z++)
        for (y = 0; y < N; y++)
            for (x = 0; x < N; x++) {
                const double depth = (N - (z + 0.5)) / N, want = exp(-s * depth);
                worst = fmax(worst, fabs(trans[AT(x, y, z)] / want - 1.0));
                worst2 = fmax(worst2, fabs(trans2[AT(x, y, z)] / sqrt(want) - 1.0));
                worst_rate = fmax(worst_rate, fabs(lost[AT(x, y, z)] / (s * trans[AT(x, y, z)]) - 1.0));
            }
    for (y = 0; y < N; y++)
        for (x = 0; x < N; x++) {
            double column = 0.0, want = N * -expm1(-s);
            for (z = 0; z < N; z++) column += lost[AT(x, y, z)];
            worst_column = fmax(worst_column, fabs(column / want - 1.0));
        }
    printf("[1] down an axis: T off Beer-Lambert by %.2e (half sigma %.2e), a column's loss off 1 - T by %.2e, a thin "
           "cell's off sigma T by %.2e\n",
           worst, worst2, worst_column, worst_rate);
    CHECK_MSG(worst < 5e-6 && worst2 < 5e-6, "T off Beer-Lambert by %g (second medium %g)", worst, worst2);
    CHECK_MSG(worst_column < 1e-5, "a column's lost power off its 1 - T by %g", worst_column);
    /* x = 1/12: 2 sinh(x/2)/x - 1 = x^2/24 = 2.9e-4 */
    CHECK_MSG(worst_rate < 4e-4, "a thin cell's lost power off sigma T by %g", worst_rate);
}

static void test_oblique(void)
{
    vsd_lbl_grid g = grid(0);
    float l[8];
    double worst = 0.0;
    int x, y, z, n = 0, wx = -1, wz = -1;
    size_t c;
    for (c = 0; c < CELLS; c++) sigma[c] = 2.0f, records[c] = (int32_t)c;
    light(l, 0.6, 0.0, 0.8);
    CHECK(vsd_lbl_sweep_lights(&g, l, 1, records, (int32_t)CELLS, 1, (const vsd_lbl_march_out[]){{trans, NULL, NULL}},
                               NULL, 0) == VSD_OK);
    for (z = 0; z < N; z++)
        for (y = 0; y < N; y++)
            for (x = 0; x < N; x++) {
                /* back toward the light the ray leaves by the top after (N - zc) / 0.8 cells,
                 * by the +x side after (N - xc) / 0.6: cells clearly on the top's side (the
                 * interpolation reads one cell beside the ray) */
                const double zc = z + 0.5, xc = x + 0.5, want = exp(-2.0 / N * (N - zc) / 0.8);
                if ((N - zc) / 0.8 > (N - xc) / 0.6 - 2.0) continue;
                /* and not in the face cells the light leaves by: their centre lies between
                 * rays a cell apart, one of which ran beside the box (sigma 0 there) */
                if (x == 0) continue;
                if (fabs(trans[AT(x, y, z)] / want - 1.0) > worst) wx = x, wz = z;
                worst = fmax(worst, fabs(trans[AT(x, y, z)] / want - 1.0));
                n++;
            }
    printf("[2] oblique: T off Beer-Lambert by %.2e over %d cells (the worst at x %d, z %d)\n", worst, n, wx, wz);
    CHECK_MSG(n > 1000 && worst < 5e-6, "oblique T off Beer-Lambert by %g (%d cells)", worst, n);
}

/* A ball sigma0 exp(-r^2 / 2 r0^2) (cells) about the box's centre: the optical depth from
 * cell centre p toward the light w (unit), in world units of 1/N per cell. */
static double ball_depth(double s0, double r0, const double p[3], const double w[3])
{
    const double m = N / 2.0;
    double q[3] = {p[0] - m, p[1] - m, p[2] - m}, t0 = q[0] * w[0] + q[1] * w[1] + q[2] * w[2];
    double d2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - t0 * t0;
    /* int_0^inf exp(-((t + t0)^2 + d^2) / 2 r0^2) dt, cells, then 1/N world per cell */
    return s0 * exp(-d2 / (2.0 * r0 * r0)) * r0 * sqrt(M_PI / 2.0) * erfc(t0 / (r0 * sqrt(2.0))) / N;
}

static void test_ball(void)
{
    vsd_lbl_grid g = grid(0);
    const double s0 = 60.0, r0 = 3.5, w[3] = {0.3, -0.5, sqrt(1.0 - 0.09 - 0.25)};
    float l[8];
    double worst = 0.0, worst_rays = 0.0, deepest = 1.0;
    int x, y, z, n = 0;
    light(l, w[0], w[1], w[2]);
    for (z = 0; z < N; z++)
        for (y = 0; y < N; y++)
            for (x = 0; x < N; x++) {
                const double dx = x + 0.5 - N / 2.0, dy = y + 0.5 - N / 2.0, dz = z + 0.5 - N / 2.0;
                sigma[AT(x, y, z)] = (float)(s0 * exp(-(dx * dx + dy * dy + dz * dz) / (2.0 * r0 * r0)));
                records[AT(x, y, z)] = (int32_t)AT(x, y, z);
            }
    CHECK(vsd_lbl_sweep_lights(&g, l, 1, records, (int32_t)CELLS, 2, (const vsd_lbl_march_out[]){{trans, NULL, NULL}},
                               NULL, 0) == VSD_OK);
    CHECK(vsd_lbl_march_lights(&g, l, 1, NULL, 0, 0.25f, 0.25f, records, 2, (const vsd_lbl_march_out[]){{rays, NULL, NULL}},
                               NULL, NULL, 0) == VSD_OK);
    for (z = 0; z < N; z++)
        for (y = 0; y < N; y++)
            for (x = 0; x < N; x++) {
                const double p[3] = {x + 0.5, y + 0.5, z + 0.5}, want = exp(-ball_depth(s0, r0, p, w));
                if (want < 0.05) continue;
                deepest = fmin(deepest, want);
                worst = fmax(worst, fabs(trans[AT(x, y, z)] - want));
                worst_rays = fmax(worst_rays, fabs(rays[AT(x, y, z)] - want));
                n++;
            }
    printf("[3] Gaussian ball (peak optical depth across %.1f): T within %.4f of the closed form (the rays %.4f) over %d "
           "cells, T down to %.3f\n",
           s0 * r0 * sqrt(2.0 * M_PI) / N, worst, worst_rays, n, deepest);
    CHECK_MSG(deepest < 0.1, "the ball casts no deep shadow (T >= %g): the test tests nothing", deepest);
    CHECK_MSG(worst < 0.025 && worst <= worst_rays, "swept T off the ball's closed form by %g (the rays %g)", worst,
              worst_rays);
}

static void test_blocker(void)
{
    vsd_lbl_grid g = grid(0);
    float l[8];
    double first = 0.0, worst = 0.0;
    int x, y, z;
    size_t c;
    for (c = 0; c < CELLS; c++) sigma[c] = 0.0f, records[c] = (int32_t)c;
    for (y = 10; y < 13; y++)
        for (x = 10; x < 13; x++) sigma[AT(x, y, 20)] = 100.0f;   /* 4 cells of optical depth each */
    light(l, -0.3, 0.45, 0.84);
    CHECK(vsd_lbl_sweep_lights(&g, l, 1, records, (int32_t)CELLS, 1, (const vsd_lbl_march_out[]){{trans, NULL, NULL}},
                               NULL, 0) == VSD_OK);
    /* the layers from the second below the blocker down to where the shadow, sliding
     * 0.36 and 0.54 cells a layer, still lies inside the box */
    for (z = 18; z >= 8; z--) {
        double deficit = 0.0;
        for (y = 0; y < N; y++)
            for (x = 0; x < N; x++) deficit += 1.0 - trans[AT(x, y, z)];
        if (z == 18) first = deficit;
        worst = fmax(worst, fabs(deficit / first - 1.0));
    }
    printf("[4] a blocker's shadow: deficit %.4f cells, the same in 11 layers to %.2e\n", first, worst);
    CHECK_MSG(first > 8.0, "the blocker's shadow holds %g cells of deficit (9 opaque cells)", first);
    CHECK_MSG(worst < 1e-4, "the shadow's deficit changes in vacuum by %g", worst);
}

static void test_records(void)
{
    vsd_lbl_grid g = grid(0);
    float l[16], ordered[CELLS];
    int32_t count = 0, r;
    size_t c;
    double worst = 0.0;
    int zeros = 1;
    for (c = 0; c < CELLS; c++) sigma[c] = 1.0f + (float)(c % 7), records[c] = (int32_t)c;
    light(l, 0.2, 0.7, -0.5);
    CHECK(vsd_lbl_sweep_lights(&g, l, 1, records, (int32_t)CELLS, 1, (const vsd_lbl_march_out[]){{ordered, NULL, NULL}},
                               NULL, 0) == VSD_OK);
    /* every third cell a record, numbered from the far end; two lights, the second with
     * no direction */
    for (c = CELLS; c-- > 0;) records[c] = c % 3 == 0 ? count++ : -1;
    light(l + 8, 0.0, 0.0, 0.0);
    light(l, 0.2, 0.7, -0.5);
    CHECK(vsd_lbl_sweep_lights(&g, l, 2, records, count, 2, (const vsd_lbl_march_out[]){{trans, NULL, NULL}}, NULL, 0) ==
          VSD_OK);
    for (c = 0; c < CELLS; c++) {
        if ((r = records[c]) < 0) continue;
        worst = fmax(worst, fabs(trans[2 * (size_t)r] - ordered[c]));
        zeros &= trans[2 * (size_t)r + 1] == 0.0f;
    }
    printf("[5] %d records in their own order: off their cells' T by %g; the light with no direction gives %s\n", count,
           worst, zeros ? "0" : "something");
    CHECK_MSG(worst == 0.0, "a record's T is not its cell's (off by %g)", worst);
    CHECK_MSG(zeros, "a light with no direction reached a record");
}

int main(void)
{
    test_axis();
    test_oblique();
    test_ball();
    test_blocker();
    test_records();
    return test_finish("test_lbl_sweep");
}
