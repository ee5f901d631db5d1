/* crm_residual_hash.h — building the compressed density residual of compensated ray
 * marching (Zhou et al. 2008, §5.2; plain text in ../shared/papers/001_…txt).
 *
 * R = D - D~ (density minus its RBF approximation) is quantised to 8 bits with a uniform
 * step (the paper: "8-bit quantization to be sufficient"); voxels that quantise to 0 are not
 * stored, and the K stored ones go into a perfect spatial hash (Lefebvre & Hoppe 2006):
 *  - hash table H of m^3 int8 entries, m = ceil(cbrt(K)) (the tightest cube, as L&H);
 *  - offset table Phi of r^3 entries, r starting at ceil(cbrt(K/3)) + 9 — the paper's change
 *    to L&H's cbrt(K/6), because residual voxels fill the volume rather than a surface —
 *    raised to the next value coprime with m (L&H: with gcd(m, r) = 1 the pair (h0, h1) is
 *    one-to-one over blocks of (m r)^3 voxels, so fewer voxels collide unavoidably);
 *  - L&H's greedy construction: offset slots in order of decreasing bucket size (the voxels
 *    sharing h1), each given the first offset that sends its whole bucket to free H slots.
 * When the assignment fails, the sizes grow, alternately m by one (while m^3 <= 1.25 K) and r
 * by about 12% (more buckets with fewer voxels each; always r once m is at its slack). After
 * VSD_CRM_HASH_MAX_GROWTHS failures the build gives up with an error naming K, m and r. The
 * build is deterministic (fixed seed).
 *
 * Decoding (lookups, trilinear) is in crm_hash_kernel.h, shared with the CUDA kernels.
 * Ownership: vsd_crm_hash_build allocates the object; vsd_crm_hash_destroy frees it; a view
 * borrows its arrays and is valid until then. */
#ifndef VSD_CRM_RESIDUAL_HASH_H
#define VSD_CRM_RESIDUAL_HASH_H
#include <stddef.h>
#include <stdint.h>
#include "vsd/status.h"
#include "crm_hash_kernel.h"

/* Failed offset assignments tolerated before the build gives up. */
#define VSD_CRM_HASH_MAX_GROWTHS 12
/* m grows past ceil(cbrt(K)) only while m^3 <= this x K. */
#define VSD_CRM_HASH_LOAD_SLACK 1.25

typedef struct vsd_crm_hash vsd_crm_hash;

typedef struct vsd_crm_hash_stats {
    size_t voxels;        /* nx * ny * nz */
    size_t stored;        /* K: voxels whose quantised residual is not 0 */
    size_t clamped;       /* voxels with |R| / step > 127, saturated to +-127 (0 with the auto step) */
    int m;                /* hash-table side (final); 0 when K = 0 */
    int r;                /* offset-table side (final); 0 when K = 0 */
    int m_initial;        /* ceil(cbrt(K)) */
    int r_initial;        /* ceil(cbrt(K/3)) + 9 (or params.r_initial), raised to be coprime with m_initial */
    int attempts;         /* offset assignments tried (1 = the first sizes worked) */
    size_t bytes;         /* occupancy mask + offset table + hash table */
    float quant_step;     /* R = q * quant_step */
    double build_seconds; /* wall time of vsd_crm_hash_build (quantisation included) */
} vsd_crm_hash_stats;

/* Tuning for tests and experiments; vsd_crm_hash_build uses the defaults below. */
typedef struct vsd_crm_hash_params {
    int max_growths;   /* failed assignments tolerated (default VSD_CRM_HASH_MAX_GROWTHS) */
    int r_initial;     /* 0 = the paper's ceil(cbrt(K/3)) + 9; else this (still made coprime) */
    uint64_t seed;     /* where each bucket's search for a free slot starts (default fixed) */
} vsd_crm_hash_params;

/* The defaults vsd_crm_hash_build uses. */
vsd_crm_hash_params vsd_crm_hash_default_params(void);

/* Quantise R (nx*ny*nz floats, voxel (i,j,k) at i + nx*(j + ny*k)) into q (same count):
 * q = round(R / step) (half away from zero) clamped to [-127, 127]. quant_step 0 = auto,
 * max|R| / 127 (1 when R is all 0, where nothing is stored and any step decodes to 0).
 * Writes the step used, the count of nonzero q and of saturated voxels (each may be NULL).
 * NaN or infinite R, a negative/NaN/infinite step or a bad size is VSD_ERR_INVALID. */
vsd_status vsd_crm_quantise_residual(int nx, int ny, int nz, const float *residual, float quant_step, int8_t *q,
                                     float *step_out, size_t *stored_out, size_t *clamped_out, char *err,
                                     size_t errlen);

/* Quantise and hash R (as vsd_crm_quantise_residual). *out is NULL on error. */
vsd_status vsd_crm_hash_build(int nx, int ny, int nz, const float *residual, float quant_step, vsd_crm_hash **out,
                              char *err, size_t errlen);
/* The same with explicit tuning (NULL = defaults). */
vsd_status vsd_crm_hash_build_ex(int nx, int ny, int nz, const float *residual, float quant_step,
                                 const vsd_crm_hash_params *params, vsd_crm_hash **out, char *err, size_t errlen);

vsd_crm_hash_view vsd_crm_hash_get_view(const vsd_crm_hash *h);
vsd_crm_hash_stats vsd_crm_hash_get_stats(const vsd_crm_hash *h);
size_t vsd_crm_hash_stored(const vsd_crm_hash *h);      /* K */
int vsd_crm_hash_table_side(const vsd_crm_hash *h);     /* m */
int vsd_crm_hash_offset_side(const vsd_crm_hash *h);    /* r */
size_t vsd_crm_hash_bytes(const vsd_crm_hash *h);
float vsd_crm_hash_quant_step(const vsd_crm_hash *h);
double vsd_crm_hash_build_seconds(const vsd_crm_hash *h);

/* NULL is fine. */
void vsd_crm_hash_destroy(vsd_crm_hash *h);

#endif
