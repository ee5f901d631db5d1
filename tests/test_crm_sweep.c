/* crm's sweep (core/methods/crm/crm_sweep.h): the light arriving at every cell from one
 * direction, in one pass over the cells.
 *  (a) a uniform medium of scattered light J: J (1 - e^-tau) with tau the optical depth to
 *      the grid's far face (the medium ends half a cell past the last cell centres), along
 *      an axis and along an oblique direction (the upstream light interpolated between
 *      four cells at every step);
 *  (b) extinction varying from cell to cell (empty cells among them) under one J: J (1 - the
 *      transmittance through every step's mean extinction): an empty end takes the other
 *      end's J instead of dimming the step;
 *  (c) a point of emission in empty space along an oblique direction: every plane of cells
 *      past it holds its light (E times one step) whatever the interpolation spread it
 *      over, centred where the direction leads;
 *  (d) optically thick cells: each cell gets its own J (the light of the first mean free
 *      path), not its neighbour's. */
#include "test_common.h"
#include "methods/crm/crm_sweep.h"
#include <math.h>
#include <stdlib.h>

static size_t idx(const int32_t r[3], int i, int j, int k) { return ((size_t)k * r[1] + j) * r[0] + i; }

static void normalize(double v[3])
{
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v[0] /= n;
    v[1] /= n;
    v[2] /= n;
}

int main(void)
{
    const int32_t r[3] = {40, 24, 12};
    const size_t n = (size_t)r[0] * r[1] * r[2];
    float *sigma = calloc(n, sizeof *sigma), *scat = calloc(3 * n, sizeof *scat), *emit = calloc(3 * n, sizeof *emit);
    float *rad = calloc(3 * n, sizeof *rad);
    const double wpc = 0.25; /* world units per cell length */
    const float J[3] = {1.0f, 0.5f, 0.25f};
    size_t q;
    int i, j, k, c;
    if (!sigma || !scat || !emit || !rad) return 1;

    /* (a) uniform medium, sigma 2 per world unit (0.5 per cell) */
    for (q = 0; q < n; q++) {
        sigma[q] = 2.0f;
        for (c = 0; c < 3; c++) scat[3 * q + c] = sigma[q] * J[c];
    }
    {
        double axis[3] = {0.0, 1.0, 0.0}, oblique[3] = {-0.45, 0.8, 0.0}, worst = 0.0;
        vsd_crm_sweep(r, sigma, scat, NULL, axis, wpc, rad);
        for (j = 0; j < r[1]; j++) {
            double tau = 2.0 * wpc * (r[1] - 1 - j + 0.5);
            for (c = 0; c < 3; c++) {
                double want = J[c] * (1.0 - exp(-tau)), got = rad[3 * idx(r, 7, j, 3) + c];
                if (fabs(got - want) / want > worst) worst = fabs(got - want) / want;
            }
        }
        printf("(a) uniform, along +y: largest relative error %.2e\n", worst);
        CHECK_MSG(worst < 1e-5, "uniform slab along an axis off by %.3g", worst);
        normalize(oblique);
        worst = 0.0;
        vsd_crm_sweep(r, sigma, scat, NULL, oblique, wpc, rad);
        /* cells none of whose upstream reads reach column 0, whose own upstream corner
         * -1 lies outside the grid (each step reads the columns i - 1 and i) */
        for (j = 0; j < r[1]; j++)
            for (i = 0; i < r[0]; i++) {
                double steps = r[1] - 1 - j, tau = 2.0 * wpc * (steps + 0.5) / oblique[1];
                if (i - steps < 1) continue;
                for (c = 0; c < 3; c++) {
                    double want = J[c] * (1.0 - exp(-tau)), got = rad[3 * idx(r, i, j, 2) + c];
                    if (fabs(got - want) / want > worst) worst = fabs(got - want) / want;
                }
            }
        printf("(a) uniform, oblique: largest relative error %.2e\n", worst);
        CHECK_MSG(worst < 1e-5, "uniform slab along an oblique direction off by %.3g", worst);
    }

    /* (b) extinction varying along x (with empty cells), J the same everywhere */
    for (i = 0; i < r[0]; i++)
        for (j = 0; j < r[1]; j++)
            for (k = 0; k < r[2]; k++) {
                q = idx(r, i, j, k);
                sigma[q] = (i % 7 == 3 || i % 11 == 5) ? 0.0f : 0.5f + 3.0f * (float)((i * 37) % 13) / 13.0f;
                for (c = 0; c < 3; c++) scat[3 * q + c] = sigma[q] * J[c];
            }
    {
        double dir[3] = {-1.0, 0.0, 0.0}, tau = 0.0, worst = 0.0;
        vsd_crm_sweep(r, sigma, scat, NULL, dir, wpc, rad);
        /* light from -x: cell 0 first, each cell's step toward i - 1 (none before cell 0) */
        for (i = 0; i < r[0]; i++) {
            double sm = 0.5 * (sigma[idx(r, i, 5, 2)] + (i > 0 ? sigma[idx(r, i - 1, 5, 2)] : 0.0));
            tau += sm * wpc;
            for (c = 0; c < 3; c++) {
                double want = J[c] * (1.0 - exp(-tau)), got = rad[3 * idx(r, i, 5, 2) + c];
                double e = want > 0.0 ? fabs(got - want) / want : fabs(got);
                if (e > worst) worst = e;
            }
        }
        printf("(b) varying extinction with empty cells: largest relative error %.2e\n", worst);
        CHECK_MSG(worst < 1e-5, "varying extinction under one J off by %.3g", worst);
    }

    /* (c) emission at one cell of empty space, light from direction v */
    for (q = 0; q < 3 * n; q++) scat[q] = emit[q] = 0.0f;
    for (q = 0; q < n; q++) sigma[q] = 0.0f;
    {
        const int hi = 30, hj = 20, hk = 9;
        double v[3] = {0.55, 0.8, 0.2}, t, worst = 0.0, worst_centre = 0.0;
        normalize(v);
        t = 1.0 / v[1];
        for (c = 0; c < 3; c++) emit[3 * idx(r, hi, hj, hk) + c] = 4.0f * J[c];
        vsd_crm_sweep(r, sigma, scat, emit, v, wpc, rad);
        /* the light goes against v: planes j < hj, the plane hj - s about s steps away */
        for (j = hj - 1; j >= hj - 8; j--) {
            double sum[3] = {0.0, 0.0, 0.0}, cx = 0.0, cz = 0.0, s = hj - j;
            for (k = 0; k < r[2]; k++)
                for (i = 0; i < r[0]; i++) {
                    q = idx(r, i, j, k);
                    for (c = 0; c < 3; c++) sum[c] += rad[3 * q + c];
                    cx += rad[3 * q] * i;
                    cz += rad[3 * q] * k;
                }
            for (c = 0; c < 3; c++) {
                double want = 4.0 * J[c] * t * wpc;
                if (fabs(sum[c] - want) / want > worst) worst = fabs(sum[c] - want) / want;
            }
            cx /= sum[0];
            cz /= sum[0];
            if (fabs(cx - (hi - v[0] * t * s)) > worst_centre) worst_centre = fabs(cx - (hi - v[0] * t * s));
            if (fabs(cz - (hk - v[2] * t * s)) > worst_centre) worst_centre = fabs(cz - (hk - v[2] * t * s));
        }
        printf("(c) a point of emission: each plane's light within %.2e, its centre within %.2e cells\n", worst,
               worst_centre);
        CHECK_MSG(worst < 1e-5, "a plane past the emission holds %.3g too much or too little", worst);
        CHECK_MSG(worst_centre < 1e-3, "the beam's centre is %.3g cells off the direction", worst_centre);
        for (c = 0; c < 3; c++) CHECK_NEAR(rad[3 * idx(r, hi, hj + 1, hk) + c], 0.0, 0.0); /* nothing upstream */
    }

    /* (d) optically thick cells (sigma 4000 per world unit: 1000 a cell), J varying along x */
    for (i = 0; i < r[0]; i++)
        for (j = 0; j < r[1]; j++)
            for (k = 0; k < r[2]; k++) {
                q = idx(r, i, j, k);
                sigma[q] = 4000.0f;
                for (c = 0; c < 3; c++) scat[3 * q + c] = sigma[q] * J[c] * (float)(1 + i % 5);
            }
    {
        double dir[3] = {0.3, 0.1, 0.0}, worst = 0.0;
        normalize(dir);
        vsd_crm_sweep(r, sigma, scat, NULL, dir, wpc, rad);
        for (i = 0; i < r[0]; i++)
            for (c = 0; c < 3; c++) {
                double want = J[c] * (1 + i % 5), got = rad[3 * idx(r, i, 10, 3) + c];
                if (fabs(got - want) / want > worst) worst = fabs(got - want) / want;
            }
        printf("(d) thick cells: each cell's own J within %.2e\n", worst);
        /* the far end's share is about 1 / tau: 1e-3 of a J at most 5x the cell's own */
        CHECK_MSG(worst < 5e-3, "thick cells read their neighbours' J: %.3g off their own", worst);
    }
    free(sigma);
    free(scat);
    free(emit);
    free(rad);
    return test_finish("test_crm_sweep");
}
