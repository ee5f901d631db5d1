/* crm_lights.h — crm's extracted lights (option `lights`, default path `single: "grid"`):
 * the map's brightest texels (a sun, studio lamps, windows) taken out of the sky the node
 * grid's SH carries and lit exactly, as shgrid's and lbl's records do.
 *
 * Why: the node grid's single scattering is L_in tau projected on order-4 SH and
 * convolved with HG. A small source times its shadow is close to a delta, which order 4
 * blurs over tens of degrees and rings around, and HG's lobe at g 0.6-0.7 is cut at band 3:
 * crm's VolumeDir was 30-70% off on cloud256 (a small sun) and the issue-30 scene (studio
 * lamps), the largest of its errors (docs/methods/crm.md). Here each node keeps the
 * transmittance T_k toward each of K directional lights standing for the bright texels
 * (a median cut of those texels only, src/lighting/env_bright.h), marched through the node
 * grid as the sky's 108 directions are; the view's node pass adds
 *     sum_k albedo E_k T_k HG(-w_k . w_o)
 * with the exact phase to the SH term, which then carries only the smooth remainder of the
 * map. The successive orders read J_1's bands 0-2, so the lights' single scattering is put
 * into those bands for them (Funk-Hecke: band l of HG is g^l, coefficient (l, m) gains
 * albedo E_k T_k g^l Y_lm(-w_k)) and taken out again before the view reads the nodes. */
#ifndef VSD_CRM_LIGHTS_H
#define VSD_CRM_LIGHTS_H
#include <stdint.h>
#include "vsd/env.h"
#include "vsd/lighting.h"
#include "vsd/status.h"
#include "crm_phase.h"
#include "crm_node_single.h"

/* the most lights the option allows */
#define VSD_CRM_MAX_LIGHTS 64

typedef struct vsd_crm_lights {
    /* the split, kept while the map's content, the count and the threshold stand */
    uint64_t key;
    int max, split_valid;
    double threshold, fraction;   /* fraction: the map's luminance share the lights took */
    vsd_env rest;                 /* the map without the bright texels (rgb owned) */
    vsd_light_constellation bright;
    /* this lighting's: world directions and kernel lights for the strength and rotation */
    int count;
    double *dirs;                 /* [3 * count] */
    float *power;                 /* [3 * count] E_k, strength applied */
    vsd_crm_node_depths depths;   /* every node with density toward every light */
    float *tr;                    /* [nodes * count] exp(-scale od); 0 at nodes without density */
    size_t tr_nodes;
    long long marches;            /* times the depths were marched, not reused */
} vsd_crm_lights;

/* Splits env (max lights above threshold times its mean luminance; max 0 = none) unless
 * the last split stands, and sets the lights' world directions and powers for this
 * strength and Z rotation. Returns the map the SH sky is to carry: the remainder, or env
 * itself when no light was taken. */
vsd_status vsd_crm_lights_update(vsd_crm_lights *l, const vsd_env *env, int max, double threshold, float strength,
                                 float rotation_z, const vsd_env **sky, char *err, size_t errlen);

/* The depths toward the lights (kept while grid, transform, directions and a scale at
 * least the marched one stand: vsd_crm_node_depths_update), *marched set when marched
 * again; the caller adds the other volumes' shadows then (crm_parts.h). */
vsd_status vsd_crm_lights_march(vsd_crm_lights *l, const int32_t res[3], const double to_node[9], const float *density,
                                float scale, int threads, int *marched, char *err, size_t errlen);

/* tr = exp(-scale od) for every node (0 where it has no density). */
vsd_status vsd_crm_lights_transmittance(vsd_crm_lights *l, float scale, char *err, size_t errlen);

/* Adds sign * the lights' single scattering (with `albedo` and the phase) to the first n2
 * coefficients (4: bands 0-1, 9: bands 0-2) of every lit node's single-scattering SH
 * (CRM_NODE_FLOATS layout): sign +1 before the successive orders read J_1, -1 after. */
void vsd_crm_lights_bands(const vsd_crm_lights *l, const double albedo[3], const vsd_crm_phase *phase, int n2,
                          float sign, float *nodes);

/* The view's lights (kernel layout of crm_kernel.h: world direction xyz, 0, albedo E rgb,
 * 0), 8 * l->count floats. */
void vsd_crm_lights_view(const vsd_crm_lights *l, const double albedo[3], float *out);

void vsd_crm_lights_free(vsd_crm_lights *l);

#endif
