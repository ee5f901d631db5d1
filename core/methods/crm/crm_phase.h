/* crm_phase.h — a phase function as its Legendre (band) coefficients chi_l, for the
 * successive orders and their single scattering J_1.
 *
 * Why not HG's g alone: delta-M (Wiscombe 1977) keeping bands 0..n-1 writes the phase as
 * f delta(forward) + (1 - f) p', f = g^n, whose p' has chi'_l = (g^l - f) / (1 - f). With
 * n = 2 that is HG(g / (1 + g)) exactly, so a g was enough; with n = 3 (the orders' J in
 * bands 0-2, `ms_bands` 3) p' is no HG: chi'_1 = g (1 + g) / (1 + g + g^2), chi'_2 = g^2 /
 * (1 + g + g^2). Everything that scatters for the orders (the nodes' single scattering, the
 * lights' bands, the orders' gather) takes these coefficients. */
#ifndef VSD_CRM_PHASE_H
#define VSD_CRM_PHASE_H

enum { CRM_PHASE_BANDS = 4 };

/* The band l of SH coefficient q = l (l + 1) + m */
static inline int vsd_crm_sh_band(int q)
{
    int l = 0;
    while ((l + 1) * (l + 1) <= q) l++;
    return l;
}

typedef struct vsd_crm_phase {
    double chi[CRM_PHASE_BANDS]; /* band l's coefficient: the convolution scales band l by it */
} vsd_crm_phase;

/* Henyey-Greenstein: chi_l = g^l */
static inline vsd_crm_phase vsd_crm_phase_hg(double g)
{
    vsd_crm_phase p;
    double gl = 1.0;
    for (int l = 0; l < CRM_PHASE_BANDS; l++, gl *= g) p.chi[l] = gl;
    return p;
}

/* delta-M's forward fraction with bands 0..bands-1 kept: g^bands */
static inline double vsd_crm_delta_m_fraction(double g, int bands)
{
    double f = 1.0;
    for (int l = 0; l < bands; l++) f *= g;
    return f;
}

/* delta-M's scaled phase p' of HG g with bands 0..bands-1 kept: (g^l - f) / (1 - f) for
 * those bands, 0 above (what p' has there is not carried: for l >= bands it is <= 0) */
static inline vsd_crm_phase vsd_crm_phase_delta_m(double g, int bands)
{
    vsd_crm_phase p = vsd_crm_phase_hg(g);
    double f = vsd_crm_delta_m_fraction(g, bands);
    for (int l = 0; l < CRM_PHASE_BANDS; l++) p.chi[l] = l < bands ? (p.chi[l] - f) / (1.0 - f) : 0.0;
    /* bands 0-1: HG(g / (1 + g)), in that form (the orders' bands 0-1 ran it so before
     * band 2: the same bits) */
    if (bands == 2) p.chi[1] = g / (1.0 + g);
    return p;
}

#endif
