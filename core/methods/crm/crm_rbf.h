/* crm_rbf.h — the radial basis functions of compensated ray marching (Zhou et al. 2008, §4).
 * The density D is approximated by D~(x) = sum_l w_l exp(-(|x - c_l| / r_l)^2), each term cut
 * off beyond 3 r_l (the paper's support, where the Gaussian is below 1.3e-4 of its peak).
 *
 * Coordinates are the volume's *voxel index space*: voxel (i,j,k) of the dense grid holds
 * D at point (i + 0.5, j + 0.5, k + 0.5), so centres and radii are in voxels and the
 * renderer maps them to world space with the volume's index-to-world transform. Weights
 * are in the grid's density units (before the scene's density scale).
 * Common subset of C11 and CUDA C++ so the render kernels can evaluate RBFs too. */
#ifndef VSD_CRM_RBF_H
#define VSD_CRM_RBF_H
#ifdef __CUDACC__
#define VSD_CRM_FN __host__ __device__ static inline
#else
#define VSD_CRM_FN static inline
#endif
#include <math.h>

/* The paper's support radius in units of r. */
#define VSD_CRM_SUPPORT 3.0f

typedef struct vsd_crm_rbf {
    float c[3]; /* centre, voxel index space */
    float r;    /* radius, voxels */
    float w;    /* weight, density units */
} vsd_crm_rbf;

/* A set of RBFs; owned arrays are freed by vsd_crm_rbfs_free (crm_fit.h). */
typedef struct vsd_crm_rbfs {
    vsd_crm_rbf *rbf;
    int count;
} vsd_crm_rbfs;

/* A dense density grid: value of voxel (i,j,k) is d[i + nx * (j + ny * k)]. Not owned. */
typedef struct vsd_crm_dense {
    int nx, ny, nz;
    const float *d;
} vsd_crm_dense;

/* w * B(x) at a point in voxel index space; 0 beyond the support. */
VSD_CRM_FN float vsd_crm_rbf_eval(const vsd_crm_rbf *b, float x, float y, float z)
{
    float dx = x - b->c[0], dy = y - b->c[1], dz = z - b->c[2];
    float q = (dx * dx + dy * dy + dz * dz) / (b->r * b->r);
    return q < VSD_CRM_SUPPORT * VSD_CRM_SUPPORT ? b->w * expf(-q) : 0.0f;
}

#endif
