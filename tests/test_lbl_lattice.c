/* test_lbl_lattice.c — the two lighting passes of method `lbl` against physics:
 *   1. one lattice-Boltzmann step conserves the photons when nothing is absorbed
 *      (albedo 1; also with cell_light "path", where each direction's photons are also
 *      checked against the path's exits), and loses exactly the absorbed part
 *      albedo < 1 says (with the paper's cell light and with the path); with an
 *      anisotropic phase and the path, one node's outflow is the series of in-cell
 *      collisions it sums in closed form (the first collision's exits by quadrature over
 *      where it happened), in cubic cells and in cells shaped as boxes;
 *   2. the steady state in a homogeneous absorbing medium, far from the boundary, is the
 *      infinite-medium balance sum_i f_i = S / ((1 - albedo) p) with the paper's cell light
 *      (counted at the faces: x / p times the true fluence, x = sigma lambda); with the
 *      photons' path through the cell (cell_light "path") it is the true fluence,
 *      S / ((1 - albedo) x), for thin and thick cells and for cells shaped as boxes;
 *   3. the marching pass's transmittance in a homogeneous box along an axis is
 *      Beer-Lambert's exp(-sigma depth) at every cell centre, and the power its rays lose
 *      sums down a column to exactly 1 - T through the box (sigma T in each thin cell);
 *   4. an oblique light through the same box agrees with the exact path length to the
 *      box's face;
 *   5. the paper's blocked lattice (4^3 blocks, interface buffers) conserves photons,
 *      counting those waiting in the buffers, on a lattice that is not a multiple of 4;
 *   6. the blocked lattice's steady state against the global lattice's, one light in a
 *      homogeneous medium, two albedos (the paper's Fig. 6): the same steady state with
 *      one step per exchange and with four (fluence averaged over an iteration);
 *   7. Geist's D3Q18 lattice: a step with albedo 1 conserves the photons, and the steady
 *      state in an infinite homogeneous medium is the balance lbl_d3q18.h derives (the
 *      same check as 2);
 *   8. leaps over empty cells change no T;
 *   9. the march in rounds of a ray history (diffusion meanwhile) gives every record's T
 *      once, equal to the sequential march's;
 *  10. the phase readout's cone weights: 1/6 each for isotropic scattering, summing to 1,
 *      and each the integral of HG over its cube-face cone by an independent quadrature;
 *  11. the surface escape: nothing deep in the medium or in empty space, and at a flat
 *      face exactly the 98 directions' quadrature of the box (computed here from the
 *      geometry), and the half-space's escape less the lattice's one axis within 10% where
 *      that quadrature holds (x >= 1; it is 21% low for thin cells); on a lumpy medium of
 *      box-shaped cells (empty cells among optical depths 1e-4 to 3) the keep equals the
 *      sweep taken here cell by cell in double, and is the same bit for bit on 1 and 3
 *      threads;
 *  12. delta-M on the lattice keeps the infinite medium's absorption;
 *  13. a solve skips the rows of cells that neither collide nor have a source (their
 *      photons pass unchanged): its fluence equals, bit for bit, that of the stepper, which
 *      collides every cell, after as many steps, on a medium with empty space around it,
 *      an anisotropic phase and a source per direction;
 *  14. the Gauss-Seidel order (vsd_lbl_lattice_set_order): on a lumpy medium in a lattice
 *      that is not a cube (slices and runs of rows that do not divide evenly, empty cells,
 *      optical depths up to 4, an anisotropic phase, a source per direction, the surface
 *      escape's keep), it reaches the Jacobi steady state (both to tolerance 1e-7) in fewer
 *      steps, is the same bit for bit on 1 and 3 threads, and after a few steps is not the
 *      Jacobi state (it is another iteration, not the same one). */
#include "test_common.h"
#include "src/common/clock.h"
#include "methods/lbl/lbl_lattice.h"
#include "methods/lbl/lbl_march.h"
#include "methods/lbl/lbl_readout.h"
#include "methods/lbl/lbl_escape.h"
#include "methods/lbl/lbl_directions.h"
#include "methods/lbl/lbl_delta_m.h"
#include "kernel/kernel_phase.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A photon that arrived through a cell's face and collided inside (optical depth x): the
 * probability that, scattered on (forward), back or sideways along the lattice's axes, it
 * leaves the cell before it collides again — by quadrature over where it collided, an
 * independent check of lbl_lattice.c's closed forms. */
static void first_exits(double x, double exits[3])
{
    const int steps = 20000;
    double norm = 0.0, fw = 0.0, bw = 0.0;
    int k;
    for (k = 0; k < steps; k++) {
        double s = (k + 0.5) / steps, w = exp(-x * s);   /* collided at depth s (density x e^-xs) */
        norm += w;
        fw += w * exp(-x * (1.0 - s));
        bw += w * exp(-x * s);
    }
    exits[0] = fw / norm;
    exits[1] = bw / norm;
    exits[2] = (1.0 - exp(-x)) / x;   /* sideways: across a uniform position in the cell */
}

static void test_conservation(void)
{
    const int32_t res[3] = {8, 8, 8};
    vsd_lbl_lattice l;
    float collide[512], ones[3] = {1.0f, 1.0f, 1.0f}, half[3] = {0.5f, 0.5f, 0.5f};
    unsigned long long rng = 7;
    double before, after, absorbed = 0.0;
    size_t c;
    int i, ch, x, y, z;
    memset(&l, 0, sizeof l);
    CHECK(vsd_lbl_lattice_init(&l, res, NULL, NULL, 0) == VSD_OK);
    if (!l.f) return;
    for (c = 0; c < 512; c++) collide[c] = (float)(0.1 + 0.8 * test_urand(&rng));
    /* photons only two or more cells from the faces: none can stream out in one step */
    for (z = 2; z < 6; z++)
        for (y = 2; y < 6; y++)
            for (x = 2; x < 6; x++)
                for (i = 0; i < 6; i++)
                    for (ch = 0; ch < 3; ch++) l.f[((size_t)i * 3 + ch) * 512 + (z * 8 + y) * 8 + x] = (float)test_urand(&rng);
    before = vsd_lbl_lattice_total(&l, 0);
    vsd_lbl_lattice_steps(&l, collide, ones, NULL, 1);
    after = vsd_lbl_lattice_total(&l, 0);
    printf("[1] albedo 1: photons %.6f -> %.6f\n", before, after);
    CHECK_MSG(fabs(after - before) <= 1e-5 * before, "albedo 1 step: %.7g -> %.7g", before, after);
    /* albedo 0.5: the step loses (1 - albedo) p sum_j f_j at every node, exactly */
    before = vsd_lbl_lattice_total(&l, 1);
    for (c = 0; c < 512; c++) {
        double s = 0.0;
        for (i = 0; i < 6; i++) s += l.f[((size_t)i * 3 + 1) * 512 + c];
        absorbed += 0.5 * collide[c] * s;
    }
    vsd_lbl_lattice_steps(&l, collide, half, NULL, 1);
    after = vsd_lbl_lattice_total(&l, 1);
    printf("[1] albedo 0.5: photons %.6f -> %.6f, absorbed %.6f\n", before, after, absorbed);
    CHECK_MSG(fabs(before - absorbed - after) <= 1e-5 * before, "albedo 0.5 step: %.7g - %.7g != %.7g", before,
              absorbed, after);
    /* the photons' path through the cell: light born in a cell that collides there again
     * before it leaves is scattered again, none lost with albedo 1 */
    memset(l.f, 0, 6 * 3 * 512 * sizeof *l.f);
    for (z = 2; z < 6; z++)
        for (y = 2; y < 6; y++)
            for (x = 2; x < 6; x++)
                for (i = 0; i < 6; i++)   /* mostly along +x: forward, backward and sideways exits differ */
                    l.f[((size_t)i * 3) * 512 + (z * 8 + y) * 8 + x] = (float)test_urand(&rng) * (i == 0 ? 1.0f : 0.1f);
    vsd_lbl_lattice_set_cell_light(&l, VSD_LBL_CELL_PATH);
    before = vsd_lbl_lattice_total(&l, 0);
    /* With albedo 1 the in-cell escape esc = e / (1 - albedo (1 - e)) is 1 whatever the
     * exits, so the total alone cannot fail for them: check each direction's photons after
     * the step (they stream one cell and stay in the lattice). Per node, direction i gets
     * what passes, (1 - p) f_i; what the first collision scatters from j toward i (p f_j / 6)
     * times its exit (forward, backward or sideways: first_exits); and a sixth of all that
     * collides again, which with albedo 1 all leaves, evenly over the six directions. The
     * paper's cell light would give each direction p sum_j f_j / 6 instead. */
    {
        double want[6] = {0, 0, 0, 0, 0, 0}, paper[6] = {0, 0, 0, 0, 0, 0}, got[6], worst = 0.0, apart = 0.0;
        for (c = 0; c < 512; c++) {
            double x = -log(1.0 - collide[c]), exits[3], again = 0.0, s = 0.0;
            first_exits(x, exits);
            for (i = 0; i < 6; i++) s += l.f[((size_t)i * 3) * 512 + c];
            for (i = 0; i < 6; i++) {
                want[i] += (1.0 - collide[c]) * l.f[((size_t)i * 3) * 512 + c];
                paper[i] += (1.0 - collide[c]) * l.f[((size_t)i * 3) * 512 + c] + collide[c] * s / 6.0;
                for (ch = 0; ch < 6; ch++) {
                    double born = collide[c] * l.f[((size_t)ch * 3) * 512 + c] / 6.0,
                           exit = i == ch ? exits[0] : (i ^ 1) == ch ? exits[1] : exits[2];
                    want[i] += born * exit;
                    again += born * (1.0 - exit);
                }
            }
            for (i = 0; i < 6; i++) want[i] += again / 6.0;
        }
        vsd_lbl_lattice_steps(&l, collide, ones, NULL, 1);
        after = vsd_lbl_lattice_total(&l, 0);
        for (i = 0; i < 6; i++) {
            got[i] = 0.0;
            for (c = 0; c < 512; c++) got[i] += l.f[((size_t)i * 3) * 512 + c];
            worst = fmax(worst, fabs(got[i] - want[i]) / want[i]);
            apart = fmax(apart, fabs(paper[i] - want[i]) / want[i]);
        }
        printf("[1] albedo 1, path in the cell: photons %.6f -> %.6f; per direction within %.2g of the exits' "
               "split (the paper's cell light's split differs from it by up to %.3f)\n",
               before, after, worst, apart);
        CHECK_MSG(fabs(after - before) <= 1e-5 * before, "albedo 1 step, path: %.7g -> %.7g", before, after);
        /* float sums over 512 nodes: measured 4.6e-8 (the paper's even split is 0.021 off) */
        CHECK_MSG(worst < 1e-5, "albedo 1 step, path: a direction's photons off the exits' split by %.3g", worst);
        CHECK_MSG(apart > 100 * 1e-5, "the test's photons do not tell the exits' split from an even one (%.3g)", apart);
    }
    /* albedo 0.5 with the path: of what the first collision scatters toward each
     * direction, its exit probability (first_exits) leaves the cell; the rest collides
     * there again, scatters with the albedo and, born anywhere, leaves with
     * esc = e / (1 - albedo (1 - e)) (e = p / x); what does not leave is absorbed */
    before = vsd_lbl_lattice_total(&l, 0);
    absorbed = 0.0;
    for (c = 0; c < 512; c++) {
        double x = -log(1.0 - collide[c]), e = collide[c] / x, esc = e / (1.0 - 0.5 * (1.0 - e)), exits[3], out = 0.0,
               again = 0.0, s = 0.0;
        first_exits(x, exits);
        for (i = 0; i < 6; i++) s += l.f[((size_t)i * 3) * 512 + c];
        for (i = 0; i < 6; i++)
            for (ch = 0; ch < 6; ch++) {   /* from direction ch toward i, isotropic: a sixth each */
                double born = 0.5 * collide[c] * l.f[((size_t)ch * 3) * 512 + c] / 6.0,
                       exit = i == ch ? exits[0] : (i ^ 1) == ch ? exits[1] : exits[2];
                out += born * exit;
                again += born * (1.0 - exit);
            }
        absorbed += collide[c] * s - out - esc * 0.5 * again;
    }
    vsd_lbl_lattice_steps(&l, collide, half, NULL, 1);
    after = vsd_lbl_lattice_total(&l, 0);
    printf("[1] albedo 0.5, path in the cell: photons %.6f -> %.6f, absorbed %.6f\n", before, after, absorbed);
    CHECK_MSG(fabs(before - absorbed - after) <= 1e-5 * before, "albedo 0.5 step, path: %.7g - %.7g != %.7g", before,
              absorbed, after);
    vsd_lbl_lattice_free(&l);
}

/* The anisotropic step with the path in the cell, one node against the series it sums, in
 * a cell of the given shape (each axis's edge over the cube-equivalent edge): a photon
 * moving along axis a crosses x_a = x shape[a] (x = -ln(1 - p)) and passes with e^-x_a;
 * what the first collision scatters from j toward i, albedo p_a(j) P_ij f_j, leaves the cell
 * with its exit probability (first_exits of x along i's axis); the rest collides again, and
 * each later generation B (born anywhere, with the phase) leaves along i with e_i, the rest
 * colliding again: e o sum_k (albedo P D)^k B, D = 1 - e — summed here term by term with P
 * as a 6x6 matrix (with a source at the node, born as the later generations are). The
 * step streams node c's post-collision populations to its six neighbours, where they are
 * read back. And the readout's light in the cell (vsd_lbl_lattice_node_means, a second
 * implementation of the same transport, per node) absorbs what the step loses. */
static void test_in_cell_phase(const double shape[3], const char *label)
{
    const int32_t res[3] = {5, 5, 5};
    const size_t n = 125, centre = (2 * 5 + 2) * 5 + 2;
    const float forward = 0.62f, backward = 0.04f, side = 0.085f, albedo[3] = {0.97f, 0.6f, 1.0f};
    const size_t neighbour[6] = {centre + 1, centre - 1, centre + 5, centre - 5, centre + 25, centre - 25};
    float collide[125], f[6], src[6], mean[3][6];
    static float source[6 * 3 * 125];   /* per direction, only at the centre */
    double P[6][6];
    vsd_lbl_lattice l;
    unsigned long long rng = 11;
    int i, j, k, ch;
    memset(&l, 0, sizeof l);
    CHECK(vsd_lbl_lattice_init(&l, res, NULL, NULL, 0) == VSD_OK);
    if (!l.f) return;
    vsd_lbl_lattice_set_phase(&l, forward, backward, side);
    vsd_lbl_lattice_set_cell_light(&l, VSD_LBL_CELL_PATH);
    vsd_lbl_lattice_set_cell_shape(&l, shape);
    for (i = 0; i < 6; i++)
        for (j = 0; j < 6; j++) P[i][j] = i == j ? forward : (i ^ 1) == j ? backward : side;
    for (i = 0; i < (int)n; i++) collide[i] = 0.95f;   /* x = 3: most born light collides in the cell again */
    for (i = 0; i < 6; i++) f[i] = (float)(0.1 + test_urand(&rng));
    for (i = 0; i < 6; i++) src[i] = (float)(0.05 + 0.2 * test_urand(&rng));
    memset(source, 0, sizeof source);
    for (ch = 0; ch < 3; ch++)
        for (i = 0; i < 6; i++) {
            l.f[((size_t)i * 3 + ch) * n + centre] = f[i];
            source[((size_t)i * 3 + ch) * n + centre] = src[i];
        }
    /* the cell's light before the step, as the readout takes it */
    for (ch = 0; ch < 3; ch++) vsd_lbl_lattice_node_means(&l, collide, albedo, source, ch, centre, mean[ch]);
    vsd_lbl_lattice_steps(&l, collide, albedo, source, 1);
    for (ch = 0; ch < 3; ch++) {
        const double x = -log(1.0 - collide[centre]);
        double pa[6], e[6], exits[6][3], born[6], again[6], sum[6], worst = 0.0;
        for (i = 0; i < 6; i++) {
            const double xa = x * shape[i / 2];
            pa[i] = 1.0 - exp(-xa);
            e[i] = pa[i] / xa;
            first_exits(xa, exits[i]);
            sum[i] = 0.0;
        }
        for (i = 0; i < 6; i++) {
            again[i] = 0.0;
            for (j = 0; j < 6; j++) {
                double b = albedo[ch] * pa[j] * P[i][j] * f[j];
                double exit = i == j ? exits[i][0] : (i ^ 1) == j ? exits[i][1] : e[i];
                sum[i] += b * exit;
                again[i] += b * (1.0 - exit);
            }
        }
        for (i = 0; i < 6; i++) {
            born[i] = src[i];   /* the source is born at a uniform point, as what collides again */
            for (j = 0; j < 6; j++) born[i] += albedo[ch] * P[i][j] * again[j];
        }
        for (k = 0; k < 400; k++) {   /* albedo (1 - e) <= 0.69: the terms fall below 1e-60 */
            double next[6];
            for (i = 0; i < 6; i++) sum[i] += e[i] * born[i];
            for (i = 0; i < 6; i++) {
                next[i] = 0.0;
                for (j = 0; j < 6; j++) next[i] += albedo[ch] * P[i][j] * (1.0 - e[j]) * born[j];
            }
            memcpy(born, next, sizeof born);
        }
        for (i = 0; i < 6; i++) {
            double want = (1.0 - pa[i]) * f[i] + sum[i], got = l.f[((size_t)i * 3 + ch) * n + neighbour[i]];
            worst = fmax(worst, fabs(got - want) / want);
        }
        printf("[1] anisotropic step, path in the cell, %s, albedo %.2f: worst relative difference from the series "
               "%.2g\n",
               label, albedo[ch], worst);
        CHECK_MSG(worst < 1e-5, "%s, albedo %.2f: the step's outflow differs from the in-cell series by %.3g", label,
                  albedo[ch], worst);
        {
            /* the readout's cell light against the step: the light a step loses in the cell
             * (what arrived and was born there, less what left) is what its collisions
             * absorb, (1 - albedo) x sum_i mean_i, a collision per 1/sigma of path */
            double in = 0.0, out = 0.0, path = 0.0;
            for (i = 0; i < 6; i++) {
                in += (double)f[i] + src[i];
                out += l.f[((size_t)i * 3 + ch) * n + neighbour[i]];
                path += mean[ch][i];
            }
            printf("[1]   light lost in the step %.6f, absorbed along the readout's path %.6f\n", in - out,
                   (1.0 - albedo[ch]) * x * path);
            CHECK_MSG(fabs(in - out - (1.0 - albedo[ch]) * x * path) < 1e-5 * in,
                      "%s, albedo %.2f: the step loses %.6g, the readout's path absorbs %.6g", label, albedo[ch],
                      in - out, (1.0 - albedo[ch]) * x * path);
        }
    }
    vsd_lbl_lattice_free(&l);
}

/* The steady state in a homogeneous absorbing medium far from the boundary: D3Q6's
 * sum_i f_i = S / ((1 - albedo) p), D3Q18's balance of lbl_d3q18.h. */
static void test_infinite_medium(const vsd_lbl_layout *layout, int cell_light, float p, const double *shape,
                                 const char *label)
{
    const int32_t res[3] = {33, 33, 33};
    const size_t n = 33 * 33 * 33, centre = (16 * 33 + 16) * 33 + 16;
    const float albedo[3] = {0.5f, 0.3f, 0.0f};
    float *collide = malloc(n * sizeof *collide), *source = malloc(3 * n * sizeof *source);
    float *fluence = malloc(3 * n * sizeof *fluence);
    vsd_lbl_lattice l;
    vsd_lbl_diffusion_stats st;
    size_t c;
    int ch;
    memset(&l, 0, sizeof l);
    if (!collide || !source || !fluence) return;
    for (c = 0; c < n; c++) {
        collide[c] = p;
        for (ch = 0; ch < 3; ch++) source[ch * n + c] = 1.0f;
    }
    CHECK(vsd_lbl_lattice_init(&l, res, layout, NULL, 0) == VSD_OK);
    vsd_lbl_lattice_set_cell_light(&l, cell_light);
    vsd_lbl_lattice_set_cell_shape(&l, shape);
    CHECK(vsd_lbl_diffuse(&l, collide, albedo, source, 1e-7, 20000, 0, fluence, &st, NULL, 0) == VSD_OK);
    printf("%s infinite medium: %d steps (converged %d), centre fluence %.5f %.5f %.5f\n", label, st.steps,
           st.converged, fluence[centre], fluence[n + centre], fluence[2 * n + centre]);
    for (ch = 0; ch < 3; ch++) {
        const double pd = 1.0 - pow(1.0 - p, sqrt(2.0));
        const double x = -log(1.0 - p);
        const double want = layout && layout->d3q18              ? (0.5 / p + sqrt(2.0) * 0.5 / pd) / (1.0 - albedo[ch])
                            : cell_light == VSD_LBL_CELL_PATH ? 1.0 / ((1.0 - albedo[ch]) * x)
                                                              : 1.0 / ((1.0 - albedo[ch]) * p);
        CHECK_MSG(fabs(fluence[ch * n + centre] - want) < 0.01 * want, "%s channel %d: %.5f, infinite medium %.5f",
                  label, ch, fluence[ch * n + centre], want);
    }
    CHECK(st.converged);
    vsd_lbl_lattice_free(&l);
    free(collide);
    free(source);
    free(fluence);
}

/* [12] Delta-M's scaled cells (lbl_delta_m.h): sigma' = sigma (1 - a f), albedo' = a (1 - f) /
 * (1 - a f), so sigma_s' = a (1 - f) sigma and the absorption sigma (1 - a) is kept; an
 * infinite medium of scaled cells (path in the cell) fed the same isotropic source then
 * holds the same fluence, 1 / ((1 - a) sigma lambda) per unit source, as the unscaled one.
 * With RGB albedo the extinction's scale takes the channels' mean; per cell (albedo_cells)
 * the same numbers as for the one albedo. */
static void test_delta_m(void)
{
    const int32_t res[3] = {33, 33, 33};
    const size_t n = 33 * 33 * 33, centre = (16 * 33 + 16) * 33 + 16;
    const double f = 0.49, lambda = 0.05;   /* g 0.7 */
    const float grey[3] = {0.6f, 0.6f, 0.6f}, rgb[3] = {0.95f, 0.8f, 0.5f};
    float *sigma = malloc(n * sizeof *sigma), *sig2 = malloc(n * sizeof *sig2), *col = malloc(n * sizeof *col),
          *col2 = malloc(n * sizeof *col2), *source = malloc(3 * n * sizeof *source),
          *phi = malloc(3 * n * sizeof *phi), *phi2 = malloc(3 * n * sizeof *phi2),
          *cells = malloc(3 * n * sizeof *cells), *cells2 = malloc(3 * n * sizeof *cells2);
    float a2[3], a3[3];
    vsd_lbl_lattice l, l2;
    vsd_lbl_diffusion_stats st;
    size_t c;
    int ch;
    memset(&l, 0, sizeof l);
    memset(&l2, 0, sizeof l2);
    if (!sigma || !sig2 || !col || !col2 || !source || !phi || !phi2 || !cells || !cells2) return;
    for (c = 0; c < n; c++) {
        sigma[c] = 12.0f;
        col[c] = (float)(1.0 - exp(-12.0 * lambda));
        for (ch = 0; ch < 3; ch++) source[ch * n + c] = 1.0f, cells[ch * n + c] = rgb[ch];
    }
    /* the relations, RGB: the mean albedo scales the extinction */
    vsd_lbl_delta_m_cells(n, sigma, lambda, NULL, rgb, f, sig2, col2, NULL, a2);
    {
        const double mean = (0.95 + 0.8 + 0.5) / 3.0, want_sigma = 12.0 * (1.0 - mean * f);
        CHECK_MSG(fabs(sig2[centre] - want_sigma) < 1e-5 * want_sigma, "delta-M sigma %g, want %g", sig2[centre],
                  want_sigma);
        CHECK(fabs(col2[centre] - (1.0 - exp(-want_sigma * lambda))) < 1e-6);
        for (ch = 0; ch < 3; ch++)
            CHECK_MSG(fabs(a2[ch] * sig2[centre] - rgb[ch] * (1.0 - f) * 12.0) < 1e-4,
                      "delta-M sigma_s channel %d: %g, want a (1 - f) sigma %g", ch, a2[ch] * sig2[centre],
                      rgb[ch] * (1.0 - f) * 12.0);
    }
    /* per cell: the same numbers */
    vsd_lbl_delta_m_cells(n, sigma, lambda, cells, rgb, f, sig2, col2, cells2, a3);
    for (ch = 0; ch < 3; ch++) CHECK(cells2[ch * n + centre] == a2[ch]);
    /* grey: the absorption kept, so the infinite medium's fluence */
    vsd_lbl_delta_m_cells(n, sigma, lambda, NULL, grey, f, sig2, col2, NULL, a2);
    CHECK(vsd_lbl_lattice_init(&l, res, NULL, NULL, 0) == VSD_OK);
    CHECK(vsd_lbl_lattice_init(&l2, res, NULL, NULL, 0) == VSD_OK);
    vsd_lbl_lattice_set_cell_light(&l, VSD_LBL_CELL_PATH);
    vsd_lbl_lattice_set_cell_light(&l2, VSD_LBL_CELL_PATH);
    CHECK(vsd_lbl_diffuse(&l, col, grey, source, 1e-7, 20000, 0, phi, &st, NULL, 0) == VSD_OK);
    CHECK(vsd_lbl_diffuse(&l2, col2, a2, source, 1e-7, 20000, 0, phi2, &st, NULL, 0) == VSD_OK);
    printf("[12] delta-M (g 0.7, albedo 0.6): infinite medium fluence %.5f unscaled, %.5f scaled (albedo' %.4f, "
           "sigma' / sigma %.4f), want %.5f\n",
           phi[centre], phi2[centre], a2[0], sig2[centre] / 12.0, 1.0 / (0.4 * 12.0 * lambda));
    /* (albedo 0.6 keeps the diffusion length under 2 cells: the 33^3 box's faces lose nothing at its centre) */
    CHECK_MSG(fabs(phi2[centre] - phi[centre]) < 0.01 * phi[centre], "delta-M changed the absorption: %g against %g",
              phi2[centre], phi[centre]);
    CHECK(fabs(phi2[centre] - 1.0 / (0.4 * 12.0 * lambda)) < 0.01 / (0.4 * 12.0 * lambda));
    CHECK(a2[0] < grey[0] && sig2[centre] < 12.0f);
    vsd_lbl_lattice_free(&l);
    vsd_lbl_lattice_free(&l2);
    free(sigma), free(sig2), free(col), free(col2), free(source), free(phi), free(phi2), free(cells), free(cells2);
}

/* a 16^3 box of sigma 2 per world unit, cells of 1/16 world unit (identity-like grid) */
static void march_box(const float light_dir[3], float *trans, float *lost, int32_t *records)
{
    static float sigma[16 * 16 * 16];
    vsd_lbl_grid g;
    float lights[8] = {light_dir[0], light_dir[1], light_dir[2], 0.0f, 1.0f, 1.0f, 1.0f, 0.0f};
    int a;
    for (a = 0; a < 4096; a++) {
        sigma[a] = 2.0f;
        records[a] = a;
    }
    memset(&g, 0, sizeof g);   /* no refraction */
    g.res[0] = g.res[1] = g.res[2] = 16;
    g.sigma = sigma;
    memset(g.to_grid, 0, sizeof g.to_grid);
    g.to_grid[0] = g.to_grid[4] = g.to_grid[8] = 16.0;   /* 16 cells per world unit */
    CHECK(vsd_lbl_march_lights(&g, lights, 1, NULL, 0, 0.5f, 0.25f, records, 0, (const vsd_lbl_march_out[]){{trans, lost, NULL}}, NULL, NULL, 0) ==
          VSD_OK);
}

static void test_march(void)
{
    static float trans[4096], lost[4096];
    static int32_t records[4096];
    const float down[3] = {0.0f, 0.0f, 1.0f};   /* the light is above: rays travel along -z */
    const float oblique[3] = {0.6f, 0.0f, 0.8f};
    double worst = 0.0, worst_column = 0.0, worst_rate = 0.0;
    int x, y, z;
    march_box(down, trans, lost, records);
    /* interior cells (the box's sigma is trilinear between cell centres, so the outer half
     * cell tapers to 0): depth below the top face's last centre plus the tapered half cell,
     * [15.5, 16], whose sigma averages 3/4 of the box's: 0.375 cells */
    for (z = 1; z < 15; z++)
        for (y = 2; y < 14; y++)
            for (x = 2; x < 14; x++) {
                double depth = (15.5 - (z + 0.5)) / 16.0 + 0.375 / 16.0, want = exp(-2.0 * depth);
                double got = trans[(z * 16 + y) * 16 + x], e = fabs(got - want) / want;
                if (e > worst) worst = e;
            }
    printf("[3] axis-aligned light: worst relative error of T against Beer-Lambert %.4f\n", worst);
    CHECK_MSG(worst < 0.005, "marching T off by %.4f", worst);
    /* the lost power: down an interior column, what the rays lost (over E V) sums to the
     * column's cross-section over V, 16 per world unit, times 1 - T through the box (the
     * optical depth 15.75 cells of sigma 2 / 16, the tapered halves as above); in a thin
     * cell it is sigma T at its centre */
    for (y = 2; y < 14; y++)
        for (x = 2; x < 14; x++) {
            double column = 0.0, want = 16.0 * (1.0 - exp(-2.0 * 15.75 / 16.0));
            for (z = 0; z < 16; z++) column += lost[(z * 16 + y) * 16 + x];
            worst_column = fmax(worst_column, fabs(column - want) / want);
            for (z = 2; z < 14; z++) {
                const int c = (z * 16 + y) * 16 + x;
                worst_rate = fmax(worst_rate, fabs(lost[c] / (2.0 * trans[c]) - 1.0));
            }
        }
    printf("[3] axis-aligned light, lost power: worst column against 1 - T %.5f, worst cell against sigma T %.4f\n",
           worst_column, worst_rate);
    CHECK_MSG(worst_column < 1e-3, "the lost power of a column is off its 1 - T by %.4f", worst_column);
    CHECK_MSG(worst_rate < 0.01, "the lost power of a thin cell is off sigma T by %.4f", worst_rate);
    /* oblique: from a cell centre back toward the light the ray leaves through the top
     * face after (16 - zc) / 0.8 cells, through the +x side after (16 - xc) / 0.6; cells
     * clearly on the top's side: depth (15.5 - zc + 0.375) / 0.8 cells (the taper as above) */
    march_box(oblique, trans, lost, records);
    worst = 0.0;
    for (z = 1; z < 15; z++)
        for (y = 2; y < 14; y++)
            for (x = 1; x < 15; x++) {
                double zc = z + 0.5, xc = x + 0.5, want, got, e;
                if ((16.0 - zc) / 0.8 > (16.0 - xc) / 0.6 - 2.0) continue;
                want = exp(-2.0 / 16.0 * (15.5 - zc + 0.375) / 0.8);
                got = trans[(z * 16 + y) * 16 + x];
                e = fabs(got - want) / want;
                if (e > worst) worst = e;
            }
    printf("[4] oblique light: worst relative error of T %.4f\n", worst);
    CHECK_MSG(worst < 0.005, "oblique marching T off by %.4f", worst);
}

static void test_blocked_conservation(void)
{
    const int32_t res[3] = {10, 10, 10};
    const size_t n = 1000;
    float collide[1000], source[3000], ones[3] = {1.0f, 1.0f, 1.0f};
    unsigned long long rng = 11;
    double injected = 0.0, before, after;
    vsd_lbl_lattice l;
    size_t c;
    int x, y, z;
    memset(&l, 0, sizeof l);
    memset(source, 0, sizeof source);
    const vsd_lbl_layout two_steps = {2, 0};
    CHECK(vsd_lbl_lattice_init(&l, res, &two_steps, NULL, 0) == VSD_OK);
    for (c = 0; c < n; c++) collide[c] = (float)(0.1 + 0.8 * test_urand(&rng));
    /* sources at [4,5]^3, straddling the block faces at 4: two steps per iteration keep
     * everything inside the lattice, so with albedo 1 nothing may be lost */
    for (z = 4; z < 6; z++)
        for (y = 4; y < 6; y++)
            for (x = 4; x < 6; x++) {
                source[(z * 10 + y) * 10 + x] = (float)test_urand(&rng);
                injected += 2.0 * source[(z * 10 + y) * 10 + x];   /* injected at both steps */
            }
    vsd_lbl_lattice_steps(&l, collide, ones, source, 1);
    after = vsd_lbl_lattice_total(&l, 0);
    printf("[5] blocked, 2 steps per exchange: injected %.6f, in lattice and buffers %.6f\n", injected, after);
    CHECK_MSG(fabs(after - injected) <= 1e-5 * injected, "blocked injection: %.7g of %.7g", after, injected);
    before = after;
    vsd_lbl_lattice_steps(&l, collide, ones, NULL, 1);
    after = vsd_lbl_lattice_total(&l, 0);
    printf("[5] blocked, albedo 1, no source: %.6f -> %.6f\n", before, after);
    CHECK_MSG(fabs(after - before) <= 1e-5 * before, "blocked albedo 1 step: %.7g -> %.7g", before, after);
    vsd_lbl_lattice_free(&l);
}

/* The steady fluence of one lattice kind (block_steps 0 = global) for a light entering a
 * homogeneous 24^3 medium through a 6x6 patch of its -x face. */
static int steady(int block_steps, float albedo, float *fluence, vsd_lbl_diffusion_stats *st)
{
    const int32_t res[3] = {24, 24, 24};
    const size_t n = 24 * 24 * 24;
    static float collide[24 * 24 * 24], source[3 * 24 * 24 * 24];
    const float a[3] = {albedo, albedo, albedo};
    vsd_lbl_lattice l;
    size_t c;
    int y, z, ok;
    memset(&l, 0, sizeof l);
    memset(source, 0, sizeof source);
    for (c = 0; c < n; c++) collide[c] = 0.3f;
    for (z = 9; z < 15; z++)
        for (y = 9; y < 15; y++) source[(z * 24 + y) * 24 + 0] = source[n + (z * 24 + y) * 24 + 0] =
                                     source[2 * n + (z * 24 + y) * 24 + 0] = 1.0f;
    const vsd_lbl_layout layout = {block_steps, 0};
    ok = vsd_lbl_lattice_init(&l, res, &layout, NULL, 0) == VSD_OK &&
         vsd_lbl_diffuse(&l, collide, a, source, 1e-7, 40000, 0, fluence, st, NULL, 0) == VSD_OK;
    vsd_lbl_lattice_free(&l);
    return ok;
}

/* relative RMS difference of two fluences (channel 0) over the nodes the light reaches */
static double rms_difference(const float *a, const float *ref, size_t n)
{
    double num = 0.0, den = 0.0, peak = 0.0;
    size_t c;
    for (c = 0; c < n; c++)
        if (ref[c] > peak) peak = ref[c];
    for (c = 0; c < n; c++)
        if (ref[c] > 1e-3 * peak) {
            num += (double)(a[c] - ref[c]) * (a[c] - ref[c]);
            den += (double)ref[c] * ref[c];
        }
    return den > 0.0 ? sqrt(num / den) : 1.0;
}

static void test_blocked_against_global(void)
{
    static const float albedos[2] = {0.5f, 0.95f};
    /* Bounds: a delay at the faces does not change a time-invariant balance, and with
     * several steps per exchange the fluence averaged over an iteration obeys the same
     * averaged balance, so only the convergence tolerance (1e-7) separates the steady
     * states: measured below 1e-5 for both (docs/methods/lbl.md, Fig. 6), bounded at 1e-4.
     * What blocking costs is steps: 1.2x (one per exchange) to 1.7x (four). */
    static const double bound[2] = {1e-4, 1e-4};
    const size_t n = 24 * 24 * 24;
    float *global = malloc(3 * n * sizeof *global), *blocked = malloc(3 * n * sizeof *blocked);
    vsd_lbl_diffusion_stats sg, sb;
    int a, k;
    static const int steps_per_exchange[2] = {1, 4};
    if (!global || !blocked) return;
    for (a = 0; a < 2; a++) {
        CHECK(steady(0, albedos[a], global, &sg));
        for (k = 0; k < 2; k++) {
            double d;
            CHECK(steady(steps_per_exchange[k], albedos[a], blocked, &sb));
            d = rms_difference(blocked, global, n);
            printf("[6] albedo %.2f: global %d steps %.3f s; blocked (%d per exchange) %d steps %.3f s; "
                   "relative RMS difference %.2e\n",
                   albedos[a], sg.steps, sg.seconds, steps_per_exchange[k], sb.steps, sb.seconds, d);
            CHECK_MSG(d <= bound[k], "blocked (%d per exchange), albedo %.2f: %.5f from the global lattice (bound %g)",
                      steps_per_exchange[k], albedos[a], d, bound[k]);
            CHECK(sb.converged);
        }
    }
    free(global);
    free(blocked);
}

static void test_d3q18(void)
{
    const vsd_lbl_layout q18 = {0, 1};
    const int32_t small[3] = {10, 10, 10};
    const float ones[3] = {1.0f, 1.0f, 1.0f};
    float *collide = malloc(1000 * sizeof *collide), *source = calloc(3000, sizeof *source);
    unsigned long long rng = 5;
    double injected = 0.0, before, after;
    vsd_lbl_lattice l;
    size_t c;
    int x, y, z;
    if (!collide || !source) {
        free(collide);
        free(source);
        return;
    }
    /* conservation: a source in the middle of a 10^3 lattice, albedo 1, two steps (a
     * diagonal moves one cell along each of two axes, so nothing reaches a face) */
    memset(&l, 0, sizeof l);
    CHECK(vsd_lbl_lattice_init(&l, small, &q18, NULL, 0) == VSD_OK);
    for (c = 0; c < 1000; c++) collide[c] = (float)(0.1 + 0.8 * test_urand(&rng));
    for (z = 4; z < 6; z++)
        for (y = 4; y < 6; y++)
            for (x = 4; x < 6; x++) {
                source[(z * 10 + y) * 10 + x] = (float)test_urand(&rng);
                injected += source[(z * 10 + y) * 10 + x];
            }
    vsd_lbl_lattice_steps(&l, collide, ones, source, 1);
    before = vsd_lbl_lattice_total(&l, 0);
    vsd_lbl_lattice_steps(&l, collide, ones, NULL, 1);
    after = vsd_lbl_lattice_total(&l, 0);
    printf("[7] D3Q18: injected %.6f, after one step %.6f, after another (albedo 1) %.6f\n", injected, before, after);
    CHECK_MSG(fabs(before - injected) <= 1e-5 * injected, "D3Q18 injection: %.7g of %.7g", before, injected);
    CHECK_MSG(fabs(after - before) <= 1e-5 * before, "D3Q18 albedo 1 step: %.7g -> %.7g", before, after);
    vsd_lbl_lattice_free(&l);
    free(collide);
    free(source);
}

/* Part 8: leaps over empty cells (lbl_march.h, empty_d2) change nothing: a 40^3 grid, a
 * ball of medium (radius 6 cells) off its centre, records on the ball's cells only; the
 * transmittance toward an oblique directional light and toward a point light outside the
 * box, with and without leaps, bit for bit; and the leaps do skip steps (the march is
 * faster by a margin). */
enum { BALL_N = 40 };
static float ball_sigma[BALL_N * BALL_N * BALL_N];
static int32_t ball_records[BALL_N * BALL_N * BALL_N];
static const float ball_light[8] = {0.48f, 0.6f, 0.64f, 0.0f, 1.0f, 1.0f, 1.0f, 0.0f};

/* The grid of parts 8 and 9 (a ball off the centre of a 40^3 grid, world = grid / 10) and
 * its point light at grid (-8, 20, 30); returns the record count. */
static int32_t ball_setup(vsd_lbl_grid *g, float point[16])
{
    const int32_t N = BALL_N;
    int32_t x, y, z, rec = 0, i;
    for (z = 0; z < N; z++)
        for (y = 0; y < N; y++)
            for (x = 0; x < N; x++) {
                double dx = x + 0.5 - 24, dy = y + 0.5 - 15, dz = z + 0.5 - 22;
                size_t c = ((size_t)z * N + y) * N + x;
                ball_sigma[c] = dx * dx + dy * dy + dz * dz < 36.0 ? 1.5f : 0.0f;
                ball_records[c] = ball_sigma[c] > 0.0f ? rec++ : -1;
            }
    memset(point, 0, 16 * sizeof *point);
    point[0] = -0.8f, point[1] = 2.0f, point[2] = 3.0f, point[3] = 1.0f, point[4] = point[5] = point[6] = 1.0f;
    memset(g, 0, sizeof *g);
    g->res[0] = g->res[1] = g->res[2] = N;
    g->sigma = ball_sigma;
    g->to_grid[0] = g->to_grid[4] = g->to_grid[8] = 10.0;
    for (i = 0; i < 12; i++) g->world_to_grid.m[i] = g->grid_to_world.m[i] = 0.0f;
    g->world_to_grid.m[0] = g->world_to_grid.m[5] = g->world_to_grid.m[10] = 10.0f;
    g->grid_to_world.m[0] = g->grid_to_world.m[5] = g->grid_to_world.m[10] = 0.1f;
    return rec;
}

static void test_leaps(void)
{
    enum { N = BALL_N };
    static float d2[N * N * N], with[2][N * N * N], without[2][N * N * N];
    const int32_t *records = ball_records;
    const float *lights = ball_light;
    float point[16];
    vsd_lbl_grid g;
    int32_t rec = ball_setup(&g, point), i;
    double t_with, t_without;
    CHECK(vsd_lbl_empty_distance(g.res, ball_sigma, records, 0, d2));
    t_without = vsd_clock_seconds();
    CHECK(vsd_lbl_march_lights(&g, lights, 1, point, 1, 0.25f, 0.25f, records, 1, (const vsd_lbl_march_out[]){{without[0], NULL, without[1]}}, NULL, NULL, 0) ==
          VSD_OK);
    t_without = vsd_clock_seconds() - t_without;
    g.empty_d2 = d2;
    t_with = vsd_clock_seconds();
    CHECK(vsd_lbl_march_lights(&g, lights, 1, point, 1, 0.25f, 0.25f, records, 1, (const vsd_lbl_march_out[]){{with[0], NULL, with[1]}}, NULL, NULL, 0) == VSD_OK);
    t_with = vsd_clock_seconds() - t_with;
    printf("[8] leaps over empty cells: %d records, T identical: directional %s, point %s; %.3f s -> %.3f s\n", rec,
           memcmp(with[0], without[0], (size_t)rec * sizeof(float)) ? "NO" : "yes",
           memcmp(with[1], without[1], (size_t)rec * sizeof(float)) ? "NO" : "yes", t_without, t_with);
    CHECK_MSG(memcmp(with[0], without[0], (size_t)rec * sizeof(float)) == 0, "leaps changed the directional light's T");
    CHECK_MSG(memcmp(with[1], without[1], (size_t)rec * sizeof(float)) == 0, "leaps changed the point light's T");
    {
        /* and the ball is lit: its near side sees T near 1, some cells are shadowed */
        double lo = 1.0, hi = 0.0;
        for (i = 0; i < rec; i++) {
            lo = fmin(lo, with[0][i]);
            hi = fmax(hi, with[0][i]);
        }
        CHECK_MSG(hi > 0.8 && lo < 0.3, "the ball's T spans %.3f..%.3f (optical diameter 1.8)", lo, hi);
    }
    CHECK_MSG(t_with < 0.5 * t_without, "leaps did not shorten the march (%.3f s against %.3f s)", t_with, t_without);
}

/* Part 8b: two media along the same rays (vsd_lbl_grid.sigma2, delta-M's true and scaled
 * extinction): each medium's T, lost power and point T are, to the bit, what its own march
 * gives, also where the denser one's rays die (T < 1e-4) long before the other's; a ray
 * history with two media is refused. */
static void test_two_media(void)
{
    enum { N = BALL_N };
    static float d2[N * N * N], dense[N * N * N], alone[2][3][N * N * N], both[2][3][N * N * N];
    float point[16];
    vsd_lbl_grid g;
    int32_t rec = ball_setup(&g, point), i;
    int m, q, dead[2] = {0, 0};
    vsd_lbl_overlap ov = {4, NULL, NULL, NULL, 0};
    char err[256];
    for (i = 0; i < N * N * N; i++) dense[i] = 8.0f * ball_sigma[i];   /* optical diameter 14 */
    CHECK(vsd_lbl_empty_distance(g.res, ball_sigma, ball_records, 0, d2));
    g.empty_d2 = d2;
    for (m = 0; m < 2; m++) {
        g.sigma = m ? ball_sigma : dense;
        CHECK(vsd_lbl_march_lights(&g, ball_light, 1, point, 1, 1.0f, 0.5f, ball_records, 2,
                                   (const vsd_lbl_march_out[]){{alone[m][0], alone[m][1], alone[m][2]}}, NULL, NULL,
                                   0) == VSD_OK);
    }
    g.sigma = dense;
    g.sigma2 = ball_sigma;
    CHECK(vsd_lbl_march_lights(&g, ball_light, 1, point, 1, 1.0f, 0.5f, ball_records, 2,
                               (const vsd_lbl_march_out[]){{both[0][0], both[0][1], both[0][2]},
                                                           {both[1][0], both[1][1], both[1][2]}},
                               NULL, NULL, 0) == VSD_OK);
    for (m = 0; m < 2; m++) {
        for (i = 0; i < rec; i++) dead[m] += alone[m][0][i] == 0.0f;
        for (q = 0; q < 3; q++)
            CHECK_MSG(memcmp(alone[m][q], both[m][q], (size_t)rec * sizeof(float)) == 0,
                      "medium %d's %s along shared rays differs from its own march", m,
                      q == 0 ? "T" : q == 1 ? "lost power" : "point light's T");
    }
    printf("[8b] two media along the same rays: %d records, each medium's T, lost power and point T as its own "
           "march's; cells no ray reached alive: dense %d, thin %d\n", rec, dead[0], dead[1]);
    CHECK_MSG(dead[0] > 0 && dead[1] == 0, "the dense medium's rays should die inside the ball and the thin one's "
              "not (%d, %d cells unreached)", dead[0], dead[1]);
    CHECK(vsd_lbl_march_lights(&g, ball_light, 1, point, 1, 1.0f, 0.5f, ball_records, 2,
                               (const vsd_lbl_march_out[]){{both[0][0], NULL, both[0][2]}, {both[1][0], NULL, both[1][2]}},
                               &ov, err, sizeof err) == VSD_ERR_INVALID);
}

/* Part 9: marching in rounds with the diffusion meanwhile (lbl_march.h, vsd_lbl_overlap):
 * on part 8's ball, with leaps, a ray history of 4 steps gives each record's T exactly once
 * per light, handed to the deposit with the value stored, equal to the sequential march's
 * up to the order of the float sums; `during` runs once per round, and there are several. */
typedef struct overlap_probe {
    int during_calls, bad_light;
    unsigned char *seen;     /* [2 lights][records] */
    const float *stored[2];
    int32_t records;
    double worst_handed;     /* largest |handed T - stored T| */
} overlap_probe;

static void probe_during(void *user) { ((overlap_probe *)user)->during_calls++; }

static void probe_deposit(void *user, int light, size_t cell, int32_t rec, float t, float lost)
{
    overlap_probe *p = user;
    (void)cell;
    (void)lost;
    if (light < 0 || light > 1 || rec < 0 || rec >= p->records) {
        p->bad_light++;
        return;
    }
    p->seen[(size_t)light * p->records + rec]++;
    p->worst_handed = fmax(p->worst_handed, fabs(t - p->stored[light][rec]));
}

static void test_overlap(void)
{
    enum { N = BALL_N };
    static float d2[N * N * N], seq[2][N * N * N], rounds[2][N * N * N];
    float point[16];
    vsd_lbl_grid g;
    int32_t rec = ball_setup(&g, point), i;
    overlap_probe p;
    vsd_lbl_overlap ov;
    double worst = 0.0;
    int once = 1;
    CHECK(vsd_lbl_empty_distance(g.res, ball_sigma, ball_records, 0, d2));
    g.empty_d2 = d2;
    CHECK(vsd_lbl_march_lights(&g, ball_light, 1, point, 1, 0.25f, 0.25f, ball_records, 2, (const vsd_lbl_march_out[]){{seq[0], NULL, seq[1]}},
                               NULL, NULL, 0) == VSD_OK);
    memset(&p, 0, sizeof p);
    p.seen = calloc(2 * (size_t)rec, 1);
    p.stored[0] = rounds[0];
    p.stored[1] = rounds[1];
    p.records = rec;
    ov.history = 4;
    ov.during = probe_during;
    ov.deposit = probe_deposit;
    ov.user = &p;
    ov.rounds = 0;
    CHECK(p.seen != NULL);
    if (!p.seen) return;
    CHECK(vsd_lbl_march_lights(&g, ball_light, 1, point, 1, 0.25f, 0.25f, ball_records, 2, (const vsd_lbl_march_out[]){{rounds[0], NULL, rounds[1]}},
                               &ov, NULL, 0) == VSD_OK);
    for (i = 0; i < rec; i++) {
        worst = fmax(worst, fabs(rounds[0][i] - seq[0][i]) / fmax(seq[0][i], 1e-3));
        worst = fmax(worst, fabs(rounds[1][i] - seq[1][i]) / fmax(seq[1][i], 1e-3));
        once &= p.seen[i] == 1 && p.seen[rec + i] == 1;
    }
    printf("[9] rounds of 4 steps: %d rounds, during %d times, every record's T handed once: %s, "
           "worst T against the sequential march %.2g (relative), handed against stored %.2g\n",
           ov.rounds, p.during_calls, once ? "yes" : "NO", worst, p.worst_handed);
    CHECK_MSG(ov.rounds >= 8, "a ray history of 4 steps took %d rounds over a 40^3 grid", ov.rounds);
    CHECK_MSG(p.during_calls == ov.rounds, "during ran %d times in %d rounds", p.during_calls, ov.rounds);
    CHECK_MSG(once && p.bad_light == 0, "a record's T was handed to the deposit other than once per light");
    CHECK_MSG(p.worst_handed == 0.0, "the deposit got a T other than the one stored (by %.3g)", p.worst_handed);
    CHECK_MSG(worst < 1e-5, "rounds changed T by %.3g relative to the sequential march", worst);
    /* a history of 0 is not a history */
    ov.history = 0;
    CHECK(vsd_lbl_march_lights(&g, ball_light, 1, point, 1, 0.25f, 0.25f, ball_records, 2, (const vsd_lbl_march_out[]){{rounds[0], NULL, rounds[1]}},
                               &ov, NULL, 0) == VSD_ERR_INVALID);
    free(p.seen);
}

/* Part 10: lbl_readout.h's weights. The independent quadrature: a midpoint grid in
 * (cos theta, phi) about the z axis, each point given to the cone of its largest component. */
static void test_readout(void)
{
    static vsd_lbl_readout t;
    const vsd_f3 ds[3] = {{0.0625f, 0.0625f, -1.0f}, {0.3f, -0.8f, 0.2f}, {-1.0f, 0.55f, 0.3f}};
    float w[6];
    double worst_iso = 0.0, worst_sum = 0.0, worst_cone = 0.0;
    int k, i;
    t.g = NAN;
    vsd_lbl_readout_build(&t, 0.0f);
    for (k = 0; k < 3; k++) {
        vsd_lbl_readout_weights(&t, ds[k], w);
        for (i = 0; i < 6; i++) worst_iso = fmax(worst_iso, fabs(w[i] - 1.0 / 6.0));
    }
    vsd_lbl_readout_build(&t, 0.7f);
    for (k = 0; k < 3; k++) {
        double sum = 0.0;
        vsd_lbl_readout_weights(&t, ds[k], w);
        for (i = 0; i < 6; i++) sum += w[i];
        worst_sum = fmax(worst_sum, fabs(sum - 1.0));
    }
    {
        /* d = (1/16, 1/16, -1), the centre of a table cell: light moving along +z scatters
         * toward the eye most */
        enum { NU = 1200, NP = 2400 };
        vsd_f3 d = f3_normalize(ds[0]);
        double ref[6] = {0, 0, 0, 0, 0, 0}, total = 0.0;
        int a, b;
        for (a = 0; a < NU; a++)
            for (b = 0; b < NP; b++) {
                double mu = -1.0 + (a + 0.5) * 2.0 / NU, ph = (b + 0.5) * 2.0 * 3.14159265358979 / NP;
                double r = sqrt(1.0 - mu * mu), o[3] = {r * cos(ph), r * sin(ph), mu};
                int ax = fabs(o[0]) >= fabs(o[1]) ? (fabs(o[0]) >= fabs(o[2]) ? 0 : 2) : (fabs(o[1]) >= fabs(o[2]) ? 1 : 2);
                double h = vsd_hg_eval((float)-(o[0] * d.x + o[1] * d.y + o[2] * d.z), 0.7f);
                ref[2 * ax + (o[ax] < 0.0)] += h;
                total += h;
            }
        vsd_lbl_readout_weights(&t, ds[0], w);
        for (i = 0; i < 6; i++) worst_cone = fmax(worst_cone, fabs(w[i] - ref[i] / total));
        printf("[10] readout g 0.7, view along -z: +z cone %.4f (quadrature %.4f), sides %.4f, -z %.4f\n", w[4],
               ref[4] / total, w[0], w[5]);
        CHECK_MSG(w[4] > 0.6 && w[4] > 10.0 * w[5], "the cone toward the eye weighs %.3f, the one away %.3f", w[4], w[5]);
    }
    printf("[10] readout: isotropic off 1/6 by %.2g, sums off 1 by %.2g, cones against quadrature %.2g\n", worst_iso,
           worst_sum, worst_cone);
    CHECK_MSG(worst_iso < 1e-6, "isotropic cone weights off 1/6 by %.3g", worst_iso);
    CHECK_MSG(worst_sum < 1e-5, "cone weights sum off 1 by %.3g", worst_sum);
    CHECK_MSG(worst_cone < 0.005, "cone weights off the quadrature by %.4f", worst_cone);
}

/* E_2(t) = integral over [1, inf) of e^(-t u) / u^2 du, by the substitution u = 1/s: the
 * integral over (0, 1] of e^(-t/s) ds (midpoint rule) */
static double expint2(double t)
{
    const int n = 200000;
    double sum = 0.0;
    int k;
    for (k = 0; k < n; k++) sum += exp(-t / ((k + 0.5) / n));
    return sum / n;
}

/* The surface escape (lbl_escape.h) in a homogeneous 33^3 box of optical depth x per cell:
 * nothing lost deep inside or in empty space. At the middle of a face the loss is
 * P - P_lattice, P = sum over the 98 lattice vectors v of share_v T_v, P_lattice the six
 * axes' mean T; in a homogeneous box T_v = exp(-sigma |path from the cell's centre to the
 * box along v|) exactly (the sweep adds sigma x step per cell and the fraction of a step up
 * to the box), and share_v is each vector's solid angle (the Fibonacci points nearest it),
 * so that value is computed here from the geometry alone: escape_quadrature. The loss must
 * equal it to float rounding (measured within 5.3e-8 at x = 0.2, 1 and 3; bound 1e-4).
 * Against the truth, the half-space's 1/2 E_2(x/2) - e^(-x/2)/6, the 98 directions are off
 * by their own quadrature error: 21% low at x = 0.2 (measured 0.166 against 0.211: the
 * sideways vectors' shares straddle the horizon, where thin medium lets light out;
 * docs/methods/lbl.md), so the old 25% tolerance sat just above a known 21% discrepancy.
 * The half-space check is kept where the quadrature holds, x >= 1 (measured +6.6% at x = 1:
 * 0.0663 against 0.0622; both 0 at x = 3), within 10%; at x = 0.2 the quadrature's bias is
 * printed, not checked. */
#define ESC_TOL 1e-4
static double escape_quadrature(double x)
{
    enum { FIB = 16384 };
    static int vec[98][3];
    double share[98], p[3] = {16.5, 16.5, 32.5}, sphere = 0.0, axes = 0.0;
    int k = 0, v, a, vx, vy, vz;
    for (vz = -2; vz <= 2; vz++)
        for (vy = -2; vy <= 2; vy++)
            for (vx = -2; vx <= 2; vx++) {
                int g = abs(vx) > abs(vy) ? abs(vx) : abs(vy);
                g = abs(vz) > g ? abs(vz) : g;
                /* no common factor: not all even, and not (0, 0, 0) */
                if (g == 0 || ((vx | vy | vz) & 1) == 0) continue;
                vec[k][0] = vx, vec[k][1] = vy, vec[k][2] = vz;
                k++;
            }
    CHECK(k == 98);
    memset(share, 0, sizeof share);
    for (k = 0; k < FIB; k++) {
        double z = 1.0 - (2.0 * k + 1.0) / FIB, r = sqrt(1.0 - z * z), ph = k * 2.399963229728653, best = -2.0;
        double q[3] = {r * cos(ph), r * sin(ph), z};
        int arg = 0;
        for (v = 0; v < 98; v++) {
            double c = (q[0] * vec[v][0] + q[1] * vec[v][1] + q[2] * vec[v][2]) /
                       sqrt((double)(vec[v][0] * vec[v][0] + vec[v][1] * vec[v][1] + vec[v][2] * vec[v][2]));
            if (c > best) best = c, arg = v;
        }
        share[arg] += 1.0 / FIB;
    }
    for (v = 0; v < 98; v++) {
        double len = sqrt((double)(vec[v][0] * vec[v][0] + vec[v][1] * vec[v][1] + vec[v][2] * vec[v][2])), dist = 1e30;
        for (a = 0; a < 3; a++) {
            double u = vec[v][a] / len;
            if (u > 0) dist = fmin(dist, (33.0 - p[a]) / u);
            if (u < 0) dist = fmin(dist, p[a] / -u);
        }
        sphere += share[v] * exp(-x * dist);
        if (abs(vec[v][0]) + abs(vec[v][1]) + abs(vec[v][2]) == 1) axes += exp(-x * dist) / 6.0;
    }
    return sphere - axes;
}

static void test_escape(void)
{
    const int32_t res[3] = {33, 33, 33};
    const size_t n = 33 * 33 * 33, centre = (16 * 33 + 16) * 33 + 16, face = (32 * 33 + 16) * 33 + 16;
    const double xs[3] = {0.2, 1.0, 3.0};
    float *sigma = malloc(n * sizeof *sigma), *keep = malloc(n * sizeof *keep);
    size_t c;
    int k;
    if (!sigma || !keep) return;
    for (c = 0; c < n; c++) sigma[c] = 0.0f;
    CHECK(vsd_lbl_escape_keep(res, sigma, 0.1, NULL, 2, keep));
    for (c = 0; c < n; c++) CHECK_MSG(fabsf(keep[c] - 1.0f) < 1e-5f, "empty space keeps %g", (double)keep[c]);
    for (k = 0; k < 3; k++) {
        const double half_space = 0.5 * expint2(0.5 * xs[k]) - exp(-0.5 * xs[k]) / 6.0;
        const double quad = fmax(escape_quadrature(xs[k]), 0.0);
        double got;
        for (c = 0; c < n; c++) sigma[c] = (float)(xs[k] / 0.1);   /* cells of 0.1 world units */
        CHECK(vsd_lbl_escape_keep(res, sigma, 0.1, NULL, 2, keep));
        got = 1.0 - keep[face];
        printf("[11] surface escape, x = %.1f per cell: deep inside lost %.2g; a face's middle lost %.5f, the 98 "
               "directions' quadrature of the box %.5f (off by %.2g), the half-space 1/2 E_2(x/2) - e^(-x/2)/6 %.4f "
               "(quadrature %+.1f%%)\n",
               xs[k], 1.0 - keep[centre], got, quad, got - quad, half_space, 100.0 * (quad / half_space - 1.0));
        CHECK_MSG(1.0 - keep[centre] < 1e-6, "x %.1f: %.3g lost deep in the medium", xs[k], 1.0 - keep[centre]);
        CHECK_MSG(fabs(got - quad) < ESC_TOL, "x %.1f: a face loses %.5f, the 98 directions' quadrature %.5f", xs[k], got,
                  quad);
        if (xs[k] >= 1.0)
            CHECK_MSG(fabs(got - fmax(half_space, 0.0)) < 0.10 * fmax(half_space, 0.005),
                      "x %.1f: a face loses %.4f, the half-space %.4f", xs[k], got, half_space);
    }
    free(sigma);
    free(keep);
}

/* [11]'s lumpy medium: the escape's sweep along every vector cell by cell in double (the
 * header's definition: the optical depth out of the box along each vector, centre to centre
 * with sigma averaged, half a step to the face) against the rows the library sweeps. */
static void test_escape_lumpy(void)
{
    enum { L = 19 };
    static const double shape[3] = {1.25, 1.0, 0.8};
    const int32_t res[3] = {L, L - 3, L + 2};
    const size_t n = (size_t)res[0] * res[1] * res[2];
    float *sigma = malloc(n * sizeof *sigma), *keep = malloc(n * sizeof *keep), *keep1 = malloc(n * sizeof *keep1);
    double *tau = malloc(n * sizeof *tau), *sphere = calloc(n, sizeof *sphere), *axes = calloc(n, sizeof *axes), worst = 0.0;
    vsd_lbl_directions dirs;
    unsigned rng = 777u;
    size_t c;
    int v, differ = 0;
    if (!sigma || !keep || !keep1 || !tau || !sphere || !axes) return;
    for (c = 0; c < n; c++) {
        rng = rng * 1664525u + 1013904223u;
        sigma[c] = (rng >> 8) % 3 == 0 ? 0.0f : (float)(1e-4 * pow(10.0, 4.5 * ((rng >> 12) % 1000) / 1000.0) / 0.1);
    }
    vsd_lbl_directions_make(shape, &dirs);
    for (v = 0; v < VSD_LBL_VECTORS; v++) {
        const int *d = dirs.d[v], out[3] = {-d[0], -d[1], -d[2]};
        const double step = dirs.len[v] * 0.1;
        int32_t start[3], dir[3], x, y, z;
        vsd_lbl_sweep_order(res, out, start, dir);
        for (z = start[2]; z >= 0 && z < res[2]; z += dir[2])
            for (y = start[1]; y >= 0 && y < res[1]; y += dir[1])
                for (x = start[0]; x >= 0 && x < res[0]; x += dir[0]) {
                    const int32_t p[3] = {x, y, z}, q[3] = {x + d[0], y + d[1], z + d[2]};
                    const size_t here = ((size_t)z * res[1] + y) * res[0] + x;
                    int a, inside = 1;
                    for (a = 0; a < 3; a++) inside &= q[a] >= 0 && q[a] < res[a];
                    if (inside) {
                        const size_t next = ((size_t)q[2] * res[1] + q[1]) * res[0] + q[0];
                        tau[here] = tau[next] + 0.5 * ((double)sigma[here] + sigma[next]) * step;
                    } else {
                        double frac = 1.0;
                        for (a = 0; a < 3; a++)
                            if (d[a]) frac = fmin(frac, (d[a] > 0 ? res[a] - 0.5 - p[a] : p[a] + 0.5) / abs(d[a]));
                        tau[here] = frac * sigma[here] * step;
                    }
                    sphere[here] += dirs.share[v] * exp(-tau[here]);
                    if (abs(d[0]) + abs(d[1]) + abs(d[2]) == 1) axes[here] += exp(-tau[here]) / 6.0;
                }
    }
    CHECK(vsd_lbl_escape_keep(res, sigma, 0.1, shape, 3, keep));
    CHECK(vsd_lbl_escape_keep(res, sigma, 0.1, shape, 1, keep1));
    for (c = 0; c < n; c++) {
        worst = fmax(worst, fabs(keep[c] - (1.0 - fmax(0.0, sphere[c] - axes[c]))));
        differ += keep[c] != keep1[c];
    }
    printf("[11] surface escape on a lumpy medium of box-shaped cells: keep within %.2g of the sweep in double\n", worst);
    CHECK_MSG(worst < 2e-6, "[11] a lumpy medium's keep is %.3g from the sweep in double", worst);
    CHECK_MSG(differ == 0, "[11] 1 and 3 threads: %d cells' keep differ", differ);
    free(sigma), free(keep), free(keep1), free(tau), free(sphere), free(axes);
}

static void test_empty_rows(void)
{
    enum { M = 20 };
    const int32_t res[3] = {M, M, M};
    const size_t n = (size_t)M * M * M;
    const float albedo[3] = {0.9f, 0.8f, 0.7f};
    float *col = calloc(n, sizeof *col), *source = calloc(18 * n, sizeof *source), *a = malloc(3 * n * sizeof *a),
          *b = malloc(3 * n * sizeof *b);
    vsd_lbl_lattice la, lb;
    vsd_lbl_stepper *st = NULL;
    vsd_lbl_diffusion_stats stats;
    size_t c, empty_rows = 0, differ = 0;
    int x, y, z, i;
    memset(&la, 0, sizeof la);
    memset(&lb, 0, sizeof lb);
    if (!col || !source || !a || !b) goto done;
    /* a slab of medium in x 5..14, y 4..9, z 6..15, a source along +x in two of its cells
     * and one in empty space (so a row with only a source is collided too) */
    for (z = 6; z < 16; z++)
        for (y = 4; y < 10; y++)
            for (x = 5; x < 15; x++) col[((size_t)z * M + y) * M + x] = 0.4f;
    for (i = 0; i < 3; i++) {
        source[(size_t)i * n + ((size_t)8 * M + 6) * M + 7] = 1.0f;
        source[(size_t)(3 + i) * n + ((size_t)12 * M + 8) * M + 12] = 0.5f;
        source[(size_t)i * n + ((size_t)2 * M + 17) * M + 3] = 0.25f;
    }
    for (c = 0; c < n; c += M) {
        int any = 0;
        for (x = 0; x < M; x++) any |= col[c + x] != 0.0f;
        empty_rows += !any;
    }
    CHECK(vsd_lbl_lattice_init(&la, res, NULL, NULL, 0) == VSD_OK && vsd_lbl_lattice_init(&lb, res, NULL, NULL, 0) == VSD_OK);
    vsd_lbl_lattice_set_cell_light(&la, VSD_LBL_CELL_PATH);
    vsd_lbl_lattice_set_cell_light(&lb, VSD_LBL_CELL_PATH);
    vsd_lbl_lattice_set_phase(&la, 0.5f, 0.05f, 0.1125f);
    vsd_lbl_lattice_set_phase(&lb, 0.5f, 0.05f, 0.1125f);
    vsd_lbl_lattice_set_source_per_direction(&la);
    vsd_lbl_lattice_set_source_per_direction(&lb);
    /* tolerance 0: the solve runs its 24 steps */
    CHECK(vsd_lbl_diffuse(&la, col, albedo, source, 0.0, 24, 1, a, &stats, NULL, 0) == VSD_OK && stats.steps == 24);
    CHECK(vsd_lbl_stepper_new(&lb, col, albedo, source, &st, NULL, 0) == VSD_OK);
    CHECK(st && vsd_lbl_stepper_run(st, 24, 1) == VSD_OK);
    vsd_lbl_stepper_free(st);
    /* no steps: the fluence of the state the stepper left */
    CHECK(vsd_lbl_diffuse(&lb, col, albedo, source, 0.0, 0, 1, b, &stats, NULL, 0) == VSD_OK && stats.steps == 0);
    for (c = 0; c < 3 * n; c++) differ += a[c] != b[c];
    printf("[13] %zu of %d rows without medium: the skipping solve and the stepper differ in %zu of %zu values "
           "(fluence at the source %.4f)\n",
           empty_rows, M * M, differ, 3 * n, (double)a[((size_t)8 * M + 6) * M + 7]);
    CHECK_MSG(empty_rows > (size_t)M * M / 2, "only %zu empty rows: the test skips nothing", empty_rows);
    CHECK_MSG(differ == 0 && a[((size_t)8 * M + 6) * M + 7] > 0.0f, "the skipping solve differs in %zu values", differ);
done:
    vsd_lbl_lattice_free(&la);
    vsd_lbl_lattice_free(&lb);
    free(col), free(source), free(a), free(b);
}

static void test_gauss_seidel(void)
{
    const int32_t res[3] = {19, 21, 42};
    const size_t n = (size_t)res[0] * res[1] * res[2];
    const float albedo[3] = {0.95f, 0.8f, 0.5f};
    float *col = calloc(n, sizeof *col), *keep = malloc(n * sizeof *keep), *source = calloc(18 * n, sizeof *source);
    float *jac = malloc(3 * n * sizeof *jac), *gs1 = malloc(3 * n * sizeof *gs1), *gs3 = malloc(3 * n * sizeof *gs3);
    vsd_lbl_lattice l;
    vsd_lbl_diffusion_stats sj, s1, s3;
    unsigned long long rng = 77;
    double worst = 0.0, worst_cell = 0.0, peak = 0.0, early = 0.0;
    size_t c, differ = 0;
    int x, y, z, k;
    memset(&l, 0, sizeof l);
    if (!col || !keep || !source || !jac || !gs1 || !gs3) goto done;
    /* a lumpy blob (p up to 1 - e^-4) in empty space, sources per direction in a few cells */
    for (z = 0; z < res[2]; z++)
        for (y = 0; y < res[1]; y++)
            for (x = 0; x < res[0]; x++) {
                const double dx = (x - 9.0) / 8.0, dy = (y - 10.0) / 9.0, dz = (z - 21.0) / 19.0;
                const double r2 = dx * dx + dy * dy + dz * dz, u = test_urand(&rng);
                c = ((size_t)z * res[1] + y) * res[0] + x;
                col[c] = r2 < 1.0 && u > 0.15 ? (float)(1.0 - exp(-4.0 * u * (1.0 - r2))) : 0.0f;
                keep[c] = (float)(0.7 + 0.3 * test_urand(&rng));
            }
    for (k = 0; k < 12; k++) {
        c = (size_t)(test_urand(&rng) * (double)n);
        source[(size_t)((k % 6) * 3 + k % 3) * n + c] = 1.0f + (float)k;
    }
    CHECK(vsd_lbl_lattice_init(&l, res, NULL, NULL, 0) == VSD_OK);
    vsd_lbl_lattice_set_cell_light(&l, VSD_LBL_CELL_PATH);
    vsd_lbl_lattice_set_phase(&l, 0.5f, 0.05f, 0.1125f);
    vsd_lbl_lattice_set_source_per_direction(&l);
    vsd_lbl_lattice_set_keep(&l, keep);
    CHECK(vsd_lbl_diffuse(&l, col, albedo, source, 1e-7, 20000, 1, jac, &sj, NULL, 0) == VSD_OK && sj.converged);
    /* the same lattice from the zero state in the other order, on 1 and 3 threads */
    vsd_lbl_lattice_free(&l);
    CHECK(vsd_lbl_lattice_init(&l, res, NULL, NULL, 0) == VSD_OK);
    vsd_lbl_lattice_set_cell_light(&l, VSD_LBL_CELL_PATH);
    vsd_lbl_lattice_set_phase(&l, 0.5f, 0.05f, 0.1125f);
    vsd_lbl_lattice_set_source_per_direction(&l);
    vsd_lbl_lattice_set_keep(&l, keep);
    vsd_lbl_lattice_set_order(&l, VSD_LBL_ORDER_GAUSS_SEIDEL);
    CHECK(vsd_lbl_diffuse(&l, col, albedo, source, 1e-7, 20000, 1, gs1, &s1, NULL, 0) == VSD_OK && s1.converged);
    memset(l.f, 0, n * 18 * sizeof *l.f);
    CHECK(vsd_lbl_diffuse(&l, col, albedo, source, 1e-7, 20000, 3, gs3, &s3, NULL, 0) == VSD_OK);
    for (c = 0; c < 3 * n; c++) peak = fmax(peak, jac[c]);
    for (c = 0; c < 3 * n; c++) {
        worst = fmax(worst, fabs(gs1[c] - jac[c]) / peak);
        if (jac[c] > 1e-3 * peak) worst_cell = fmax(worst_cell, fabs(gs1[c] - jac[c]) / jac[c]);
        differ += memcmp(&gs1[c], &gs3[c], sizeof(float)) != 0;
    }
    /* eight steps of each from zero: another iteration, so another state */
    memset(l.f, 0, n * 18 * sizeof *l.f);
    CHECK(vsd_lbl_diffuse(&l, col, albedo, source, 0.0, 8, 1, gs3, &s3, NULL, 0) == VSD_OK);
    vsd_lbl_lattice_set_order(&l, VSD_LBL_ORDER_JACOBI);
    memset(l.f, 0, n * 18 * sizeof *l.f);
    CHECK(vsd_lbl_diffuse(&l, col, albedo, source, 0.0, 8, 1, gs1, &s3, NULL, 0) == VSD_OK);
    for (c = 0; c < 3 * n; c++) early = fmax(early, fabs(gs3[c] - gs1[c]) / peak);
    printf("[14] Gauss-Seidel order: %d steps against Jacobi's %d, fluence within %.2g of the peak (%.2g of the "
           "cell's own above a thousandth of it); 1 and 3 threads differ in %zu values; after 8 steps the two orders "
           "differ by %.3f of the peak\n",
           s1.steps, sj.steps, worst, worst_cell, differ, early);
    CHECK_MSG(worst < 1e-5 && worst_cell < 1e-4, "[14] the Gauss-Seidel steady state is %.3g of the peak (%.3g of a "
              "cell's own) from Jacobi's", worst, worst_cell);
    CHECK_MSG(s1.steps * 4 <= sj.steps * 3, "[14] Gauss-Seidel took %d steps, Jacobi %d: not a quarter fewer",
              s1.steps, sj.steps);
    CHECK_MSG(differ == 0, "[14] 1 and 3 threads: %zu fluence values differ", differ);
    CHECK_MSG(early > 1e-3, "[14] after 8 steps the orders agree to %.3g: the order is not applied", early);
done:
    vsd_lbl_lattice_free(&l);
    free(col), free(keep), free(source), free(jac), free(gs1), free(gs3);
}

int main(void)
{
    test_readout();
    test_escape();
    test_escape_lumpy();
    test_overlap();
    test_leaps();
    test_two_media();
    test_conservation();
    {
        static const double cubes[3] = {1.0, 1.0, 1.0}, boxes[3] = {1.6, 1.0, 1.0 / 1.6};
        test_in_cell_phase(cubes, "cubic cells");
        test_in_cell_phase(boxes, "cells 1.6 x 1 x 1/1.6");
    }
    test_infinite_medium(NULL, VSD_LBL_CELL_FACES, 0.6f, NULL, "[2] D3Q6, faces");
    test_infinite_medium(NULL, VSD_LBL_CELL_PATH, 0.6f, NULL, "[2] D3Q6, path (x 0.92)");
    test_infinite_medium(NULL, VSD_LBL_CELL_PATH, 0.3f, NULL, "[2] D3Q6, path (x 0.36)");
    test_infinite_medium(NULL, VSD_LBL_CELL_PATH, 0.99f, NULL, "[2] D3Q6, path (x 4.6)");
    {
        /* cells shaped as boxes: the same fluence, collisions per path being sigma whatever the axis */
        static const double boxes[3] = {1.6, 1.0, 1.0 / 1.6};
        test_infinite_medium(NULL, VSD_LBL_CELL_PATH, 0.6f, boxes, "[2] D3Q6, path, cells 1.6 x 1 x 1/1.6 (x 0.92)");
    }
    test_march();
    test_delta_m();
    test_blocked_conservation();
    test_blocked_against_global();
    test_d3q18();
    {
        const vsd_lbl_layout q18 = {0, 1};
        test_infinite_medium(&q18, VSD_LBL_CELL_FACES, 0.6f, NULL, "[7] D3Q18");
    }
    test_empty_rows();
    test_gauss_seidel();
    return test_finish("test_lbl_lattice");
}
