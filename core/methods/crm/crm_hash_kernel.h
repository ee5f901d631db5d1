/* crm_hash_kernel.h — decoding the compressed density residual of compensated ray marching
 * (Zhou et al. 2008, §5.2): R = D - D~ quantised to 8 bits and stored in a perfect spatial
 * hash (Lefebvre & Hoppe 2006). Built by crm_residual_hash.c; read by the render kernels,
 * so this file is the common subset of C11 and CUDA C++.
 *
 * The hash (L&H §4): voxel p = (i,j,k) of the S stored voxels goes to hash-table slot
 *   h(p) = (h0(p) + Phi[h1(p)]) mod m,   h0(p) = p mod m,   h1(p) = p mod r   (per axis),
 * H is an m^3 table of int8 quantised values, Phi an r^3 table of offsets in [0,m)^3.
 *
 * Telling a stored voxel from an absent one: a perfect hash only says where a *stored* key
 * lives; any other voxel also lands on some slot, holding some other voxel's value. We keep a
 * 1-bit-per-voxel occupancy mask rather than storing the key in each entry, because
 *  - the residual is not surface-like: 5-50% of the voxels are stored, and a mask costs
 *    N/8 bytes against >= 4 bytes per stored key (a packed voxel index), so the mask is
 *    smaller whenever more than ~1/32 of the voxels are stored, and H stays 1 byte/entry;
 *  - the ray marcher mostly samples voxels with no residual: the mask rejects them with one
 *    32-bit load, without touching Phi and H (two dependent, incoherent loads on a GPU);
 *  - an absent voxel then decodes to exactly 0 by construction, whatever the hash does.
 *
 * Offsets are packed 10 bits per axis into one uint32 (m <= 1024, i.e. up to ~1e9 stored
 * voxels): one aligned load per lookup instead of three byte loads.
 *
 * Pointers are host or device addresses, whichever side the view is used on; the builder's
 * view (vsd_crm_hash_get_view) points to host memory. */
#ifndef VSD_CRM_HASH_KERNEL_H
#define VSD_CRM_HASH_KERNEL_H
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include "crm_rbf.h" /* VSD_CRM_FN */

/* Largest hash-table side the 10-bit offset packing can address. */
#define VSD_CRM_HASH_MAX_M 1024

typedef struct vsd_crm_hash_view {
    const uint32_t *occupancy; /* bit (n & 31) of word n >> 5 set iff voxel n = i + nx*(j + ny*k) is stored */
    const uint32_t *offsets;   /* [r^3], slot (x + r*(y + r*z)): ox | oy << 10 | oz << 20; NULL when K = 0 */
    const int8_t *table;       /* [m^3], slot (x + m*(y + m*z)): quantised residual; NULL when K = 0 */
    size_t n_occupancy;        /* words in occupancy = ceil(nx*ny*nz / 32) */
    size_t n_offsets;          /* r^3 (0 when K = 0) */
    size_t n_table;            /* m^3 (0 when K = 0) */
    int32_t nx, ny, nz;        /* grid size in voxels */
    int32_t m, r;              /* hash-table and offset-table sides (0 when K = 0) */
    float step;                /* dequantisation: R = q * step */
} vsd_crm_hash_view;

/* Dequantised residual of voxel (i,j,k); exactly 0 outside the grid or when not stored. */
VSD_CRM_FN float vsd_crm_residual(const vsd_crm_hash_view *h, int i, int j, int k)
{
    uint32_t n, off;
    int32_t m, r, x, y, z;
    if (i < 0 || j < 0 || k < 0 || i >= h->nx || j >= h->ny || k >= h->nz) return 0.0f;
    n = (uint32_t)i + (uint32_t)h->nx * ((uint32_t)j + (uint32_t)h->ny * (uint32_t)k);
    if (!((h->occupancy[n >> 5] >> (n & 31u)) & 1u)) return 0.0f;
    m = h->m;
    r = h->r;
    off = h->offsets[((size_t)(k % r) * (size_t)r + (size_t)(j % r)) * (size_t)r + (size_t)(i % r)];
    /* h0 + offset, both in [0, m): one conditional subtraction instead of a second modulo. */
    x = i % m + (int32_t)(off & 1023u);
    y = j % m + (int32_t)((off >> 10) & 1023u);
    z = k % m + (int32_t)((off >> 20) & 1023u);
    if (x >= m) x -= m;
    if (y >= m) y -= m;
    if (z >= m) z -= m;
    return (float)h->table[((size_t)z * (size_t)m + (size_t)y) * (size_t)m + (size_t)x] * h->step;
}

/* The residuals of the 8 voxels (i + a%2, j + (a/2)%2, k + a/4), a = 0..7, into c[a]: the
 * view march's per-step lookup. Each axis's two coordinates are reduced mod m and mod r
 * once (integer division is the lookup's main cost), not once per corner. */
VSD_CRM_FN void vsd_crm_residual_cell(const vsd_crm_hash_view *h, int i, int j, int k, float c[8])
{
    int32_t p[3][2], in[3][2], pm[3][2], pr[3][2], ax, b, a;
    p[0][0] = i; p[1][0] = j; p[2][0] = k;
    for (ax = 0; ax < 3; ax++) {
        int32_t n = ax == 0 ? h->nx : ax == 1 ? h->ny : h->nz;
        p[ax][1] = p[ax][0] + 1;
        for (b = 0; b < 2; b++) {
            in[ax][b] = p[ax][b] >= 0 && p[ax][b] < n;
            pm[ax][b] = in[ax][b] && h->m > 0 ? p[ax][b] % h->m : 0;
            pr[ax][b] = in[ax][b] && h->r > 0 ? p[ax][b] % h->r : 0;
        }
    }
    for (a = 0; a < 8; a++) {
        int32_t bx = a & 1, by = (a >> 1) & 1, bz = (a >> 2) & 1, x, y, z;
        uint32_t n, off;
        c[a] = 0.0f;
        if (!in[0][bx] || !in[1][by] || !in[2][bz]) continue;
        n = (uint32_t)p[0][bx] + (uint32_t)h->nx * ((uint32_t)p[1][by] + (uint32_t)h->ny * (uint32_t)p[2][bz]);
        if (!((h->occupancy[n >> 5] >> (n & 31u)) & 1u)) continue;
        off = h->offsets[((size_t)pr[2][bz] * (size_t)h->r + (size_t)pr[1][by]) * (size_t)h->r + (size_t)pr[0][bx]];
        x = pm[0][bx] + (int32_t)(off & 1023u);
        y = pm[1][by] + (int32_t)((off >> 10) & 1023u);
        z = pm[2][bz] + (int32_t)((off >> 20) & 1023u);
        if (x >= h->m) x -= h->m;
        if (y >= h->m) y -= h->m;
        if (z >= h->m) z -= h->m;
        c[a] = (float)h->table[((size_t)z * (size_t)h->m + (size_t)y) * (size_t)h->m + (size_t)x] * h->step;
    }
}

/* Trilinear residual at a point in voxel index space (voxel (i,j,k) at (i+.5, j+.5, k+.5)),
 * with voxels outside the grid taken as 0, like the density field itself (kernel_volume.h). */
VSD_CRM_FN float vsd_crm_residual_trilinear(const vsd_crm_hash_view *h, float x, float y, float z)
{
    float fx, fy, fz, tx, ty, tz, c[8], c00, c10, c01, c11, c0, c1;
    /* Beyond half a voxel outside the grid every corner is 0; this also keeps the float to
     * int conversion below in range and sends NaN coordinates to 0. */
    if (!(x > -0.5f && y > -0.5f && z > -0.5f && x < (float)h->nx + 0.5f && y < (float)h->ny + 0.5f &&
          z < (float)h->nz + 0.5f))
        return 0.0f;
    fx = floorf(x - 0.5f);
    fy = floorf(y - 0.5f);
    fz = floorf(z - 0.5f);
    tx = x - 0.5f - fx;
    ty = y - 0.5f - fy;
    tz = z - 0.5f - fz;
    vsd_crm_residual_cell(h, (int)fx, (int)fy, (int)fz, c);
    c00 = c[0] * (1.0f - tx) + c[1] * tx;
    c10 = c[2] * (1.0f - tx) + c[3] * tx;
    c01 = c[4] * (1.0f - tx) + c[5] * tx;
    c11 = c[6] * (1.0f - tx) + c[7] * tx;
    c0 = c00 * (1.0f - ty) + c10 * ty;
    c1 = c01 * (1.0f - ty) + c11 * ty;
    return c0 * (1.0f - tz) + c1 * tz;
}

#endif
