/* Delta-M's scaled medium for lbl's lattice (lbl_delta_m.h). */
#include "lbl_delta_m.h"
#include <math.h>

/* a (1 - f) / (1 - mean f): the scaled albedo of one channel */
static float scaled_albedo(double a, double mean, double f)
{
    double d = 1.0 - mean * f;
    return (float)(d > 0.0 ? a * (1.0 - f) / d : 0.0);
}

void vsd_lbl_delta_m_cells(size_t cells, const float *sigma, double cell_world, const float *albedo_cells,
                           const float albedo[3], double f, float *sigma_out, float *collide_out,
                           float *albedo_cells_out, float albedo_out[3])
{
    const double mean0 = (albedo[0] + albedo[1] + albedo[2]) / 3.0;
    size_t c;
    int ch;
    for (ch = 0; ch < 3; ch++) albedo_out[ch] = scaled_albedo(albedo[ch], mean0, f);
    for (c = 0; c < cells; c++) {
        double mean = mean0, s;
        if (albedo_cells) {
            mean = (albedo_cells[c] + albedo_cells[cells + c] + albedo_cells[2 * cells + c]) / 3.0;
            for (ch = 0; ch < 3; ch++)
                albedo_cells_out[ch * cells + c] = scaled_albedo(albedo_cells[ch * cells + c], mean, f);
        }
        s = sigma[c] * (1.0 - mean * f);
        sigma_out[c] = (float)s;
        collide_out[c] = (float)(1.0 - exp(-s * cell_world));
    }
}
