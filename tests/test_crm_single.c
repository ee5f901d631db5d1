#define _POSIX_C_SOURCE 200809L   /* clock_gettime */
/* crm single scattering in SH (core/methods/crm/crm_single.h, Zhou et al. 2008 §5.3):
 *  (a) the unit RBF's optical-depth table against the analytic depth at the centre and
 *      against projections of numerically integrated line integrals (1D ZH and full 3D,
 *      which pins the rotation direction: the depth lies towards the RBF);
 *  (b) J_ss at an RBF's own centre under a constant sky (closed form) and at a centre next
 *      to another RBF against brute-force integration over the sphere, plus the
 *      transmittance vector against exp* of the numerically projected optical depth;
 *  (c) sigma = 0 gives albedo * L for every g;
 *  (d) g = 0.6 under a narrow lobe against brute force, and the forward-scattering sign;
 *  (e) invalid inputs; then timings for 100 / 400 / 1000 RBFs at order 4. */
#include "test_common.h"
#include "methods/crm/crm_single.h"
#include "methods/crm/crm_phase.h"
#include <math.h>
#include <stdlib.h>
#include <time.h>

#define PI 3.14159265358979323846

static unsigned long long rng_state = 987654321;
static double urand(void) { return test_urand(&rng_state); }
static void random_dir(double d[3]) { test_random_dir(&rng_state, d); }

/* Optical depth (per unit sigma) of a set of RBFs from p outwards along unit w: Simpson's
 * rule over each RBF's chord through its 3r support sphere — independent of the erf form
 * the table uses. 256 intervals over at most 6r: error ~1e-9 relative. */
static double line_depth(const vsd_crm_rbf *b, int n, const double p[3], const double w[3])
{
    double sum = 0.0;
    int i, k;
    for (i = 0; i < n; i++) {
        double u[3] = {p[0] - b[i].c[0], p[1] - b[i].c[1], p[2] - b[i].c[2]}, r = b[i].r;
        double bd = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
        double disc = bd * bd - (u[0] * u[0] + u[1] * u[1] + u[2] * u[2] - 9.0 * r * r), t0, t1, h, s = 0;
        if (disc <= 0) continue;
        t0 = fmax(0.0, -bd - sqrt(disc));
        t1 = -bd + sqrt(disc);
        if (t1 <= t0) continue;
        h = (t1 - t0) / 256;
        for (k = 0; k <= 256; k++) {
            double t = t0 + k * h, x[3] = {u[0] + t * w[0], u[1] + t * w[1], u[2] + t * w[2]};
            double f = exp(-(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) / (r * r));
            s += f * (k == 0 || k == 256 ? 1 : (k & 1) ? 4 : 2);
        }
        sum += b[i].w * s * h / 3;
    }
    return sum;
}

/* ---- (a) the table ---- */

typedef struct unit_ctx { double q; } unit_ctx;
/* T_u at cosine z to the axis towards a unit RBF at distance q (on +Z). */
static double unit_depth_z(double z, void *u)
{
    vsd_crm_rbf b = {{0, 0, 0}, 1, 1};
    double q = ((unit_ctx *)u)->q, p[3] = {0, 0, -q}, w[3] = {sqrt(fmax(0, 1 - z * z)), 0, z};
    return line_depth(&b, 1, p, w);
}

typedef struct set_ctx { const vsd_crm_rbf *b; int n; double p[3]; double sigma; } set_ctx;
static double set_depth_fn(const double d[3], void *u)
{
    set_ctx *c = u;
    return line_depth(c->b, c->n, c->p, d);
}

static double vec_norm(const double *v, int n)
{
    double s = 0;
    int i;
    for (i = 0; i < n; i++) s += v[i] * v[i];
    return sqrt(s);
}

static void test_table(const vsd_crm_od_table *t)
{
    const int n = t->order;
    const double half = sqrt(PI) / 2 * erf(3.0);
    double zh[VSD_SH_MAX_ORDER], sh[VSD_SH_MAX_COEFFS], axis[3], d[3];
    double qs[] = {0.37, 1.3, 2.6, 2.999, 3.4, 7.7, 40.0, 400.0};
    int i, k, l;

    /* the theta map is monotonic, continuous at the support (pi/2) and inverts */
    CHECK_NEAR(vsd_crm_od_theta(0), PI, 1e-15);
    CHECK_NEAR(vsd_crm_od_theta(3), PI / 2, 1e-15);
    CHECK_NEAR(vsd_crm_od_theta(3 + 1e-12), PI / 2, 1e-5);
    for (i = 1; i < 100; i++) {
        double q = 0.1 * i;
        CHECK(vsd_crm_od_theta(q) < vsd_crm_od_theta(q - 0.1));
        CHECK_NEAR(vsd_crm_od_distance(vsd_crm_od_theta(q)), q, 1e-9 * q);
    }

    /* at the centre: isotropic, half the line integral through the centre */
    CHECK_NEAR(t->zh[(t->angles - 1) * n], sqrt(4 * PI) * half, 1e-12);
    for (l = 1; l < n; l++) CHECK_NEAR(t->zh[(t->angles - 1) * n + l], 0, 1e-12);
    vsd_crm_od_lookup(t, 0.0, zh);
    for (k = 0; k < 5; k++) {
        random_dir(axis);
        random_dir(d);
        vsd_sh_zh_rotate(n, zh, axis, sh);
        CHECK_NEAR(vsd_sh_reconstruct(n, sh, d), half, 1e-12);
    }

    /* 1D: the interpolated ZH and the exact one against the projection of Simpson line
     * integrals (2000 Gauss nodes resolve even the 4.3 degree cone at q = 40). The table's
     * interpolation error was measured over q in [0, 1000] at 256 entries: <= 2.3e-4 of the
     * ZH's norm (worst next to the centre), 3e-5 beyond the support. */
    for (i = 0; i < (int)(sizeof qs / sizeof qs[0]); i++) {
        unit_ctx u = {qs[i]};
        double ref[VSD_SH_MAX_ORDER], ex[VSD_SH_MAX_ORDER], e_tab = 0, e_ex = 0, nr;
        vsd_sh_zh_project(n, qs[i] > 100 ? 8000 : 2000, unit_depth_z, &u, ref);
        vsd_crm_od_lookup(t, qs[i], zh);
        vsd_crm_od_zh_exact(n, qs[i], ex);
        nr = vec_norm(ref, n);
        for (l = 0; l < n; l++) {
            e_tab = fmax(e_tab, fabs(zh[l] - ref[l]) / nr);
            e_ex = fmax(e_ex, fabs(ex[l] - ref[l]) / nr);
        }
        printf("table q = %6.3f: |zh| %.3e, relative error: table %.1e, direct %.1e\n", qs[i], nr, e_tab, e_ex);
        CHECK_MSG(e_tab < 5e-4, "q %g: table error %g", qs[i], e_tab);
        CHECK_MSG(e_ex < 2e-5, "q %g: direct ZH error %g", qs[i], e_ex);
    }
    /* far away the ZH is the whole (3r-truncated) Gaussian's mass M seen in one direction:
     * zh_l -> M / q^2 * y_l0(+Z), M = pi^(3/2) erf(3) - 6 pi exp(-9) (4.4e-4 below the
     * untruncated pi^(3/2)); the corrections are O(l^2 / q^2) */
    {
        double mass = pow(PI, 1.5) * erf(3.0) - 6 * PI * exp(-9.0), q = 5000.0;
        vsd_crm_od_lookup(t, q, zh);
        for (l = 0; l < n; l++) {
            double e = mass / (q * q) * sqrt((2 * l + 1) / (4 * PI));
            CHECK_NEAR(zh[l], e, 1e-4 * e);
        }
    }

    /* 3D: a scaled, weighted RBF seen from a point; the SH of its numerically integrated
     * optical depth equals w r rot(T_u(d/r)) rotated towards the RBF, not away from it */
    for (k = 0; k < 3; k++) {
        double qk[3] = {0.6, 2.2, 5.0};
        vsd_crm_rbf b = {{3.0f, -2.0f, 7.5f}, 2.5f, 0.8f};
        set_ctx c;
        double ref[VSD_SH_MAX_COEFFS], got[VSD_SH_MAX_COEFFS], e = 0, nr;
        random_dir(axis);
        c.b = &b; c.n = 1;
        for (i = 0; i < 3; i++) c.p[i] = b.c[i] - qk[k] * b.r * axis[i];
        vsd_sh_project_fn(n, 300, set_depth_fn, &c, ref);
        vsd_crm_od_lookup(t, qk[k], zh);
        vsd_sh_zh_rotate(n, zh, axis, got);
        for (i = 0; i < n * n; i++) got[i] *= b.w * b.r;
        nr = vec_norm(ref, n * n);
        for (i = 0; i < n * n; i++) e = fmax(e, fabs(got[i] - ref[i]) / nr);
        printf("3D RBF at %.1f radii: relative SH error %.1e\n", qk[k], e);
        CHECK_MSG(e < 1e-3, "3D optical depth at q %g: %g", qk[k], e);
    }
}

/* ---- single scattering ---- */

static void const_env(int n, const double L[3], double *env)
{
    int c;
    for (c = 0; c < 3 * n * n; c++) env[c] = 0;
    for (c = 0; c < 3; c++) env[c * n * n] = L[c] * sqrt(4 * PI);
}

static double hg(double cs, double g)
{
    double den = 1 + g * g - 2 * g * cs;
    return (1 - g * g) / (4 * PI * den * sqrt(den));
}

/* Brute force J_ss(p, w_o) = albedo int L_in(w_i) tau(w_i) hg((-w_i) . w_o) dw_i with
 * L_in the reconstruction of env_sh (the lighting the method is given) and tau from the
 * exact line integrals; Gauss-Legendre (nq) x 2nq azimuths. Also returns the mean of tau. */
typedef struct brute { int nq; double *dirs, *wts, *tau; long count; } brute;

static void brute_init(brute *bf, int nq, const vsd_crm_rbf *b, int nb, const double p[3], double sigma)
{
    double *x = malloc(sizeof(double) * nq), *w = malloc(sizeof(double) * nq);
    long i, k, m = 0;
    bf->nq = nq;
    bf->count = (long)nq * 2 * nq;
    bf->dirs = malloc(sizeof(double) * 3 * bf->count);
    bf->wts = malloc(sizeof(double) * bf->count);
    bf->tau = malloc(sizeof(double) * bf->count);
    vsd_sh_gauss_legendre(nq, x, w);
    for (i = 0; i < nq; i++)
        for (k = 0; k < 2 * nq; k++, m++) {
            double phi = 2 * PI * (k + 0.5) / (2 * nq), s = sqrt(1 - x[i] * x[i]);
            double *d = bf->dirs + 3 * m;
            d[0] = s * cos(phi); d[1] = s * sin(phi); d[2] = x[i];
            bf->wts[m] = w[i] * 2 * PI / (2 * nq);
            bf->tau[m] = exp(-sigma * line_depth(b, nb, p, d));
        }
    free(x);
    free(w);
}

static void brute_free(brute *bf) { free(bf->dirs); free(bf->wts); free(bf->tau); }

static void brute_j(const brute *bf, int n, const double *env, double albedo, int c, double g,
                    const double wo[3], double *j)
{
    long m;
    double s = 0;
    for (m = 0; m < bf->count; m++) {
        const double *d = bf->dirs + 3 * m;
        double L = vsd_sh_reconstruct(n, env + c * n * n, d);
        s += bf->wts[m] * L * bf->tau[m] * hg(-(d[0] * wo[0] + d[1] * wo[1] + d[2] * wo[2]), g);
    }
    *j = albedo * s;
}

static double brute_mean_tau(const brute *bf)
{
    long m;
    double s = 0;
    for (m = 0; m < bf->count; m++) s += bf->wts[m] * bf->tau[m];
    return s / (4 * PI);
}

static void test_own_centre(const vsd_crm_od_table *t)
{
    const int n = t->order;
    vsd_crm_rbf b = {{20.0f, 21.0f, 22.0f}, 3.0f, 0.9f};
    vsd_crm_rbfs set = {&b, 1};
    double L[3] = {1.5, 0.7, 0.2}, albedo[3] = {0.9, 0.5, 1.0}, env[3 * VSD_SH_MAX_COEFFS];
    double j[3 * VSD_SH_MAX_COEFFS], tau[VSD_SH_MAX_COEFFS], sigma = 0.4, gs[] = {0.0, 0.6, -0.3};
    double expect_tau = exp(-sigma * b.w * b.r * sqrt(PI) / 2 * erf(3.0));
    int gi, k, c;
    const_env(n, L, env);
    for (gi = 0; gi < 3; gi++) {
        char err[256] = "";
        CHECK(vsd_crm_single_scatter(&set, sigma, albedo, gs[gi], n, env, t, j, tau, err, sizeof err) == VSD_OK);
        /* a constant times an isotropic tau: exp* of a constant and its triple product
         * with a constant are exact, so only rounding remains */
        CHECK_NEAR(tau[0], expect_tau * sqrt(4 * PI), 1e-12);
        for (k = 0; k < 6; k++) {
            double wo[3], rgb[3];
            random_dir(wo);
            vsd_crm_eval_sh_rgb(n, j, wo, rgb);
            for (c = 0; c < 3; c++) CHECK_NEAR(rgb[c], albedo[c] * L[c] * expect_tau, 1e-12);
        }
    }
}

/* (b) two RBFs, J at the second centre (and the first) under a constant sky, g = 0:
 * J = albedo L <tau>, the mean transmittance over the sphere. */
static void test_pair(const vsd_crm_od_table *t)
{
    const int n = t->order, n2 = n * n;
    vsd_crm_rbf b[2] = {{{10.0f, 10.0f, 10.0f}, 2.0f, 1.0f}, {{0, 0, 0}, 1.5f, 0.7f}};
    vsd_crm_rbfs set = {b, 2};
    double dir[3], L[3] = {1, 2, 0.5}, albedo[3] = {0.8, 0.8, 0.6}, env[3 * VSD_SH_MAX_COEFFS];
    double j[2 * 3 * VSD_SH_MAX_COEFFS], tau[2 * VSD_SH_MAX_COEFFS], sigmas[] = {0.15, 0.5};
    int i, si, l;
    random_dir(dir);
    for (i = 0; i < 3; i++) b[1].c[i] = (float)(b[0].c[i] + 2.2 * b[0].r * dir[i]);
    const_env(n, L, env);
    for (si = 0; si < 2; si++) {
        double sigma = sigmas[si];
        CHECK(vsd_crm_single_scatter(&set, sigma, albedo, 0.0, n, env, t, j, tau, NULL, 0) == VSD_OK);
        for (l = 0; l < 2; l++) {
            set_ctx c;
            brute bf;
            double od[VSD_SH_MAX_COEFFS], ref_tau[VSD_SH_MAX_COEFFS], e = 0, mean, got, wo[3] = {0, 0, 1}, rgb[3];
            c.b = b; c.n = 2;
            for (i = 0; i < 3; i++) c.p[i] = b[l].c[i];
            /* the transmittance vector is exp* of the projected optical depth: compare
             * with exp* applied to the numerical projection (checks the sum, the
             * rotations and the own-centre term; exp* itself is the library's) */
            vsd_sh_project_fn(n, 60, set_depth_fn, &c, od);
            for (i = 0; i < n2; i++) od[i] *= -sigma;
            vsd_sh_exp(t->exp, od, ref_tau);
            for (i = 0; i < n2; i++) e = fmax(e, fabs(tau[l * n2 + i] - ref_tau[i]));
            CHECK_MSG(e < 1e-3 * ref_tau[0], "centre %d sigma %g: tau vector error %g", l, sigma, e);
            /* against the brute-force mean transmittance */
            brute_init(&bf, 64, b, 2, c.p, sigma);
            mean = brute_mean_tau(&bf);
            vsd_crm_eval_sh_rgb(n, j + l * 3 * n2, wo, rgb);
            got = rgb[1] / (albedo[1] * L[1]);
            printf("pair, centre %d, sigma %.2f: |f^| %.2f, mean tau brute %.5f, SH %.5f (%+.2f%%); "
                   "tau vector error %.1e\n", l, sigma, vec_norm(od + 1, n2 - 1), mean, got,
                   100 * (got - mean) / mean, e);
            /* the gap is exp*'s (Ren et al.'s linear fit on the order-4 optical depth), which
             * the library bounds by 8% of the vector for |f^| < 1 (tests/test_sh.c); on the
             * mean it measured <= 0.13% here (|f^| <= 0.9), so 1% */
            CHECK_MSG(fabs(got - mean) < 0.01 * mean, "centre %d sigma %g: <tau> %g vs %g", l, sigma, got, mean);
            CHECK_NEAR(rgb[0] / (albedo[0] * L[0]), got, 1e-12);
            brute_free(&bf);
        }
    }
}

/* (c) sigma = 0: the medium is transparent, J = albedo L for any g and direction. */
static void test_transparent(const vsd_crm_od_table *t)
{
    const int n = t->order, n2 = n * n;
    vsd_crm_rbf b[3] = {{{1, 2, 3}, 2, 5}, {{4, 2, 3}, 1, 3}, {{1, 6, 3}, 4, 0.5f}};
    vsd_crm_rbfs set = {b, 3};
    double L[3] = {0.3, 1, 4}, albedo[3] = {1, 0.25, 0.5}, env[3 * VSD_SH_MAX_COEFFS];
    double j[3 * 3 * VSD_SH_MAX_COEFFS], gs[] = {-0.5, 0, 0.6, 0.95}, sig[] = {0, 1e-9};
    int gi, si, l, k, c;
    const_env(n, L, env);
    for (si = 0; si < 2; si++)
        for (gi = 0; gi < 4; gi++) {
            CHECK(vsd_crm_single_scatter(&set, sig[si], albedo, gs[gi], n, env, t, j, NULL, NULL, 0) == VSD_OK);
            for (l = 0; l < 3; l++)
                for (k = 0; k < 3; k++) {
                    double wo[3], rgb[3];
                    random_dir(wo);
                    vsd_crm_eval_sh_rgb(n, j + l * 3 * n2, wo, rgb);
                    for (c = 0; c < 3; c++) CHECK_NEAR(rgb[c], albedo[c] * L[c], 1e-7 * L[c]);
                }
        }
    (void)n2;
}

/* (d) g = 0.6 under the order-n projection of a narrow lobe (vMF, kappa 20) plus a dim
 * sky, at a centre inside a cluster of three RBFs, against brute force. */
typedef struct lobe { double axis[3], kappa, base; } lobe;
static double lobe_fn(const double d[3], void *u)
{
    lobe *v = u;
    double c = d[0] * v->axis[0] + d[1] * v->axis[1] + d[2] * v->axis[2];
    return v->base + v->kappa / (2 * PI * (1 - exp(-2 * v->kappa))) * exp(v->kappa * (c - 1));
}

static void test_anisotropic(const vsd_crm_od_table *t)
{
    const int n = t->order, n2 = n * n;
    vsd_crm_rbf b[3] = {{{30, 30, 30}, 3, 0.6f}, {{34, 31, 29}, 2, 0.8f}, {{31, 26, 33}, 2.5f, 0.4f}};
    vsd_crm_rbfs set = {b, 3};
    double albedo[3] = {0.9, 0.7, 0.5}, env[3 * VSD_SH_MAX_COEFFS], j[3 * 3 * VSD_SH_MAX_COEFFS];
    double sigma = 0.3, gs[] = {0.6, -0.6};
    lobe lb;
    int gi, c, i, k;
    random_dir(lb.axis);
    lb.kappa = 20;
    lb.base = 0.05;
    vsd_sh_project_fn(n, 40, lobe_fn, &lb, env);
    for (c = 1; c < 3; c++)
        for (i = 0; i < n2; i++) env[c * n2 + i] = env[i] * (c == 1 ? 0.5 : 2.0);
    for (gi = 0; gi < 2; gi++) {
        double g = gs[gi], worst = 0, jmax = 0, fwd[3], back[3], bfwd, bback;
        brute bf;
        double minus_axis[3] = {-lb.axis[0], -lb.axis[1], -lb.axis[2]}, p[3] = {b[0].c[0], b[0].c[1], b[0].c[2]};
        CHECK(vsd_crm_single_scatter(&set, sigma, albedo, g, n, env, t, j, NULL, NULL, 0) == VSD_OK);
        brute_init(&bf, 64, b, 3, p, sigma);
        /* forward scattering (g > 0) sends the lobe's light on, away from the lobe: the
         * peak is at w_o = -axis */
        vsd_crm_eval_sh_rgb(n, j, minus_axis, fwd);
        vsd_crm_eval_sh_rgb(n, j, lb.axis, back);
        brute_j(&bf, n, env, albedo[0], 0, g, minus_axis, &bfwd);
        brute_j(&bf, n, env, albedo[0], 0, g, lb.axis, &bback);
        if (g > 0) CHECK(fwd[0] > 2 * back[0] && bfwd > 2 * bback);
        else CHECK(back[0] > 2 * fwd[0] && bback > 2 * bfwd);
        for (k = 0; k < 12; k++) {
            double wo[3], rgb[3], ref;
            if (k == 0) memcpy(wo, minus_axis, sizeof wo);
            else if (k == 1) memcpy(wo, lb.axis, sizeof wo);
            else random_dir(wo);
            vsd_crm_eval_sh_rgb(n, j, wo, rgb);
            for (c = 0; c < 3; c++) {
                brute_j(&bf, n, env, albedo[c], c, g, wo, &ref);
                worst = fmax(worst, fabs(rgb[c] - ref) / (c == 0 ? 1 : c == 1 ? 0.5 : 2.0));
                jmax = fmax(jmax, fabs(ref) / (c == 0 ? 1 : c == 1 ? 0.5 : 2.0));
            }
        }
        printf("anisotropic g = %+.1f: J forward %.4f / backward %.4f (brute %.4f / %.4f); "
               "worst error %.1f%% of max J\n", g, fwd[0], back[0], bfwd, bback, 100 * worst / jmax);
        /* order 4 truncates the product L tau and the HG lobe (band 4 would keep g^4 = 13%
         * of itself), and exp* adds its fit error; measured 1.7% of the peak here, so 5% */
        CHECK_MSG(worst < 0.05 * jmax, "g %g: worst error %g of %g", g, worst, jmax);
        brute_free(&bf);
    }
}

/* The pair-symmetric, threaded accumulation equals the plain per-centre sum of eq. 11's
 * optical depths, sum_h w_h r_h rot(T_u(|c_h - c_l| / r_h), (c_h - c_l) / |.|), for a set
 * big enough to run on several threads (each thread adds its own pairs). */
static void test_accumulation(const vsd_crm_od_table *t)
{
    const int n = t->order, n2 = n * n, count = 300;
    vsd_crm_rbf *b = malloc(sizeof *b * count);
    double *j = malloc(sizeof(double) * 3 * n2 * count), *tau = malloc(sizeof(double) * n2 * count);
    double env[3 * VSD_SH_MAX_COEFFS], L[3] = {1, 1, 1}, albedo[3] = {1, 1, 1}, sigma = 0.02, worst = 0;
    vsd_crm_rbfs set = {b, count};
    int i, l, h;
    for (i = 0; i < count; i++) {
        b[i].c[0] = (float)(40 * urand()); b[i].c[1] = (float)(40 * urand()); b[i].c[2] = (float)(40 * urand());
        b[i].r = (float)(1 + 4 * urand());
        b[i].w = (float)(urand() - 0.2);   /* a few negative weights too */
    }
    b[7] = b[3];                            /* coincident centres take the isotropic path */
    const_env(n, L, env);
    CHECK(vsd_crm_single_scatter(&set, sigma, albedo, 0.2, n, env, t, j, tau, NULL, 0) == VSD_OK);
    for (l = 0; l < count; l++) {
        double od[VSD_SH_MAX_COEFFS] = {0}, ref[VSD_SH_MAX_COEFFS];
        for (h = 0; h < count; h++) {
            double a[3] = {(double)b[h].c[0] - b[l].c[0], (double)b[h].c[1] - b[l].c[1],
                           (double)b[h].c[2] - b[l].c[2]};
            double d = vec_norm(a, 3), zh[VSD_SH_MAX_ORDER], rot[VSD_SH_MAX_COEFFS], z[3] = {0, 0, 1};
            vsd_crm_od_lookup(t, d / b[h].r, zh);
            if (d > 0) for (i = 0; i < 3; i++) a[i] /= d;
            vsd_sh_zh_rotate(n, zh, d > 0 ? a : z, rot);
            for (i = 0; i < n2; i++) od[i] += (double)b[h].w * b[h].r * rot[i];
        }
        for (i = 0; i < n2; i++) od[i] *= -sigma;
        vsd_sh_exp(t->exp, od, ref);
        for (i = 0; i < n2; i++) worst = fmax(worst, fabs(tau[l * n2 + i] - ref[i]));
    }
    CHECK_MSG(worst < 1e-12, "threaded pair accumulation differs from the plain sum by %g", worst);
    free(b);
    free(j);
    free(tau);
}

/* (e) invalid inputs name the problem. */
static void test_invalid(const vsd_crm_od_table *t)
{
    const int n = t->order;
    vsd_crm_rbf b = {{1, 2, 3}, 2, 1};
    vsd_crm_rbfs set = {&b, 1}, bad = {NULL, 3};
    vsd_crm_od_table *tt = (vsd_crm_od_table *)1;
    double albedo[3] = {0.5, 0.5, 0.5}, env[3 * VSD_SH_MAX_COEFFS] = {0}, j[3 * VSD_SH_MAX_COEFFS];
    char err[256];
    err[0] = 0;
    CHECK(vsd_crm_od_table_create(0, 256, &tt, err, sizeof err) == VSD_ERR_INVALID);
    CHECK(tt == NULL);
    CHECK_CONTAINS(err, "SH order 0 out of range");
    CHECK(vsd_crm_od_table_create(9, 256, &tt, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "SH order 9");
    CHECK(vsd_crm_od_table_create(4, 8, &tt, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "angles 8 out of range");
    CHECK(vsd_crm_od_table_create(4, 256, NULL, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "out is NULL");

#define SS(set_, sig_, alb_, g_, ord_, env_, tab_, j_) \
    vsd_crm_single_scatter(set_, sig_, alb_, g_, ord_, env_, tab_, j_, NULL, err, sizeof err)
    CHECK(SS(&set, 0.1, albedo, 0, 9, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "SH order 9 out of range 1..8");
    CHECK(SS(&set, 0.1, albedo, 0, 3, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "does not match the table's order");
    CHECK(SS(&set, 0.1, albedo, 0, n, env, NULL, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "table is NULL");
    CHECK(SS(NULL, 0.1, albedo, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "rbfs is NULL");
    CHECK(SS(&bad, 0.1, albedo, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "count 3 and no array");
    CHECK(SS(&set, 0.1, albedo, 0, n, NULL, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "env_sh is NULL");
    CHECK(SS(&set, 0.1, albedo, 0, n, env, t, NULL) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "j_ss (output) is NULL");
    CHECK(SS(&set, 0.1, NULL, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "albedo is NULL");
    CHECK(SS(&set, -0.1, albedo, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "sigma_per_voxel -0.1 must be finite and >= 0");
    CHECK(SS(&set, NAN, albedo, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "sigma_per_voxel nan");
    albedo[1] = 1.5;   /* more light out than in: rejected, as the scene file does */
    CHECK(SS(&set, 0.1, albedo, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "albedo[1] 1.5 out of range 0..1");
    albedo[1] = 0.5;
    CHECK(SS(&set, 0.1, albedo, 1.0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "anisotropy g 1 out of range (-1, 1)");
    env[5] = INFINITY;
    CHECK(SS(&set, 0.1, albedo, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "env_sh[5] is not finite");
    env[5] = 0;
    b.r = 0;
    CHECK(SS(&set, 0.1, albedo, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "RBF 0 radius 0 must be finite and > 0");
    b.r = 2;
    b.c[1] = NAN;
    CHECK(SS(&set, 0.1, albedo, 0, n, env, t, j) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "RBF 0 has a non-finite centre or weight");
    b.c[1] = 2;
    /* no RBFs is valid and writes nothing */
    set.count = 0;
    CHECK(SS(&set, 0.1, albedo, 0, n, env, t, j) == VSD_OK);
#undef SS
}

/* Timings at order 4 for random RBF sets in a 64^3 box (radii 1.5..4.5 voxels). */
static void test_timing(const vsd_crm_od_table *t)
{
    const int n = t->order, n2 = n * n, counts[] = {100, 400, 1000};
    double env[3 * VSD_SH_MAX_COEFFS], L[3] = {1, 1, 1}, albedo[3] = {0.8, 0.8, 0.8};
    int ci, i;
    const_env(n, L, env);
    env[2] = 0.5;   /* some direction, so the triple product is not trivial */
    for (ci = 0; ci < 3; ci++) {
        int count = counts[ci];
        vsd_crm_rbf *b = malloc(sizeof *b * count);
        double *j = malloc(sizeof(double) * 3 * n2 * count), secs, worst = 0;
        vsd_crm_rbfs set = {b, count};
        struct timespec t0, t1;
        for (i = 0; i < count; i++) {
            b[i].c[0] = (float)(64 * urand()); b[i].c[1] = (float)(64 * urand()); b[i].c[2] = (float)(64 * urand());
            b[i].r = (float)(1.5 + 3 * urand());
            b[i].w = (float)(0.2 + urand());
        }
        clock_gettime(CLOCK_MONOTONIC, &t0);
        CHECK(vsd_crm_single_scatter(&set, 0.05, albedo, 0.3, n, env, t, j, NULL, NULL, 0) == VSD_OK);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        secs = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
        /* the transmittance only removes light: J's mean is at most albedo * <L> */
        for (i = 0; i < count; i++) worst = fmax(worst, j[(size_t)i * 3 * n2] / sqrt(4 * PI));
        printf("timing: %4d RBFs at order %d: %.3f s\n", count, n, secs);
        CHECK(worst <= albedo[0] * 1.0 + 1e-9);
        CHECK(secs < 10.0);   /* generous on a shared machine; the target is well under 1 s */
        free(b);
        free(j);
    }
}

/* crm_phase.h: delta-M's split f delta + (1 - f) p' keeps HG's bands below `bands` (f + (1 -
 * f) chi'_l = g^l: the orders' scattering of the light they carry is HG's), leaves nothing
 * of p' in band `bands` (f = g^bands is all of HG's there), and with bands 2 p' is HG(g /
 * (1 + g)), the form the orders ran before band 2. */
static void test_phase_bands(void)
{
    const double gs[] = {-0.4, 0.2, 0.6, 0.7, 0.9};
    for (size_t i = 0; i < sizeof gs / sizeof gs[0]; i++)
        for (int bands = 2; bands <= 3; bands++) {
            const double g = gs[i], f = vsd_crm_delta_m_fraction(g, bands);
            const vsd_crm_phase hg = vsd_crm_phase_hg(g), p = vsd_crm_phase_delta_m(g, bands);
            CHECK_MSG(fabs(f - pow(g, bands)) < 1e-15, "g %g, %d bands: f %.17g, g^bands %.17g", g, bands, f,
                      pow(g, bands));
            for (int l = 0; l < CRM_PHASE_BANDS; l++)
                CHECK_MSG(fabs(hg.chi[l] - pow(g, l)) < 1e-15, "HG g %g band %d: %.17g", g, l, hg.chi[l]);
            for (int l = 0; l < bands; l++)
                CHECK_MSG(fabs(f + (1.0 - f) * p.chi[l] - hg.chi[l]) < 1e-14,
                          "g %g, %d bands: band %d of f delta + (1 - f) p' is %.17g, HG's %.17g", g, bands, l,
                          f + (1.0 - f) * p.chi[l], hg.chi[l]);
            CHECK_MSG(p.chi[bands] == 0.0, "g %g, %d bands: p' keeps %.3g in band %d", g, bands, p.chi[bands], bands);
            if (bands == 2) CHECK(fabs(p.chi[1] - g / (1.0 + g)) < 1e-15);
        }
}

int main(void)
{
    vsd_crm_od_table *t = NULL;
    char err[256] = "";
    CHECK(vsd_crm_od_table_create(4, 256, &t, err, sizeof err) == VSD_OK);
    if (!t) {
        fprintf(stderr, "table: %s\n", err);
        return test_finish("test_crm_single");
    }
    test_phase_bands();
    test_table(t);
    test_own_centre(t);
    test_pair(t);
    test_transparent(t);
    test_anisotropic(t);
    test_accumulation(t);
    test_invalid(t);
    test_timing(t);
    vsd_crm_od_table_destroy(t);
    return test_finish("test_crm_single");
}
