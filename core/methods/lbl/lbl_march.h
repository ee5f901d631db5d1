/* lbl_march.h — the marching pass of Bernabei et al. 2012 (§III-B): light rays start
 * outside the medium's box and march through it from each light (parallel rays for a
 * directional light, rays from the position of a point or spot light), and the
 * transmittance they carry is left behind in the cells they cross. Straight rays leap over
 * empty cells to just before the medium (empty_d2).
 *
 * Per light k (world direction w_k toward the light, so the rays travel along -w_k): a
 * square lattice of parallel rays `spacing` cells apart on the plane across -w_k covers the
 * grid's bounding sphere; each ray is clipped to the grid's box and marched in steps of
 * `step` cells, midpoints, the optical depth summed from the cells' sigma_t (trilinear
 * between cell centres, 0 outside). At every midpoint the ray's transmittance there is
 * splatted onto the eight surrounding cell centres with trilinear weights (the paper's
 * deposit into the diffusion volume, Fig. 3; the transfer's blending is the weighted sum);
 * a cell's T_k is the weighted mean of what reached it (0 where nothing did: every ray
 * through it had died, T < 1e-4). With spacing and step <= 1 every cell centre inside the
 * box gets weight from some ray.
 *
 * With refraction the rays bend by the ray equation (kernel/kernel_refract.h) from where
 * they enter the box. The T deposit stays the weighted mean of the transmittance of the
 * rays through a cell: where bent rays converge (a caustic) that light is not
 * concentrated, only redirected — a limit of this form; the lost power (below) is each
 * ray's own, so it does concentrate.
 *
 * Grid coordinates: cell (i,j,k) spans [i, i+1) x ..., its centre at +0.5 (the record
 * grid's, src/grids/record_grid.h). */
#ifndef VSD_LBL_MARCH_H
#define VSD_LBL_MARCH_H
#include <stdint.h>
#include "vsd/status.h"
#include "kernel/kernel_types.h"

typedef struct vsd_lbl_grid {
    int32_t res[3];
    const float *sigma;      /* [res x*y*z] sigma_t per world unit at the cell centres */
    /* NULL, or a second extinction marched along the same rays at once (delta-M's scaled
     * one: the corners, leaps and ray setup done once for both; empty_d2 must know the
     * cells where either has medium); a ray goes on while either T is worth it, each T
     * stopping as it would alone, so each medium's result is what its own march gives, to
     * the bit */
    const float *sigma2;
    double to_grid[9];       /* world direction -> grid displacement per world unit (row-major) */
    /* refraction (medium.ior != 1), or NULL: the rays then bend by the n field, stepping in
     * world space between the grid's and the world's coordinates */
    const struct vsd_krefract *refract;
    vsd_affine world_to_grid, grid_to_world;
    /* NULL, or [cells] the squared distance (in cells, centre to centre) to the nearest cell
     * with medium or a record (vsd_lbl_empty_distance): straight rays leap over the steps
     * that cannot reach one — the paper starts its rays just before the medium, from a
     * depth map — with the same steps and the same result as marching them */
    const float *empty_d2;
} vsd_lbl_grid;

/* A directional light's travel through g (light: kernel layout, its direction toward the
 * light first): u, the unit direction in grid units, away from the light, and len, the grid
 * units per world unit along it (a grid length d along u is d / len world units). 0 when the
 * light has no direction. The march's parallel rays and the sweeps (lbl_sweep.h) share it. */
int vsd_lbl_light_travel(const vsd_lbl_grid *g, const float *light, float u[3], double *len);

/* The squared distance map of vsd_lbl_grid.empty_d2 into d2 [cells]: 0 where sigma > 0 or
 * cell_record >= 0. Returns 0 when out of memory. */
int vsd_lbl_empty_distance(const int32_t res[3], const float *sigma, const int32_t *cell_record, int threads,
                           float *d2);

/* Marching and diffusion overlapped (the paper's Fig. 1a, §III-B "ray history"): the rays
 * of all lights in a batch advance `history` steps per round (the paper's k), each light's
 * front — the t along its rays before which no step is still to come, less the splat's
 * reach — sweeping through the cells; after each round the cells behind the fronts are
 * final, their T stored and handed to `deposit` (the paper's transfer into the diffusion
 * volume), and while the next round marches `during` runs on a thread of its own (the
 * lattice's steps on the source deposited so far). Parallel rays' t is measured from the
 * plane across them through the box's centre, a point light's from the light. Bent rays
 * (refraction) have no front: their lights are transferred whole, in the first round. A
 * batch holds as many lights as VSD_LBL_OVERLAP_BYTES of accumulators allow. */
#define VSD_LBL_OVERLAP_BYTES ((size_t)256 << 20)
typedef struct vsd_lbl_overlap {
    int history;             /* steps per ray per round, >= 1 */
    void (*during)(void *user);   /* may be NULL */
    /* a record's final T from light `light` (directional lights first, then the points),
     * and the power its rays lost in the cell (as `lost` of vsd_lbl_march_lights; 0 when
     * that is NULL, NAN for the points); called on the calling thread between rounds,
     * never while `during` runs */
    void (*deposit)(void *user, int light, size_t cell, int32_t rec, float t, float lost);
    void *user;
    int rounds;              /* out: rounds marched */
} vsd_lbl_overlap;

/* What a march gives for one medium (the fields as below). */
typedef struct vsd_lbl_march_out {
    float *trans;
    float *lost;             /* or NULL */
    float *point_trans;
} vsd_lbl_march_out;

/* lights: kernel layout (8 floats: world direction xyz toward the light, 0, weight rgb, 0);
 * points: the scene's point and spot lights (kernel/kernel_lights.h layout: world position
 * first), marched by rays from the position, without refraction (the scene refuses lights
 * through a refracting medium); cell_record: the record of each cell, -1 for none (the
 * record grid's); trans[r * light_count + k] and point_trans[r * point_count + k]: the
 * transmittance from light k to record r's cell centre; lost[r * light_count + k] (or
 * NULL): the power directional light k's rays lost in record r's cell over E V (E the
 * light's irradiance, V a cell's world volume), each step's loss shared among the eight
 * cells around its middle by their part of its extinction — sigma T per world length
 * where the cell is thin, and exact in total: what a cell scatters is albedo E V lost,
 * however thick it is. out[0]: sigma's trans, lost and point_trans; out[1]: sigma2's, when
 * the grid has it. threads: CPU threads (0 = all).
 * overlap: NULL marches each light whole on the threads, one after another (the same T up
 * to the order of the float sums); a ray history marches sigma alone (no sigma2). */
vsd_status vsd_lbl_march_lights(const vsd_lbl_grid *g, const float *lights, int light_count, const float *points,
                                int point_count, float spacing, float step, const int32_t *cell_record, int threads,
                                const vsd_lbl_march_out *out, vsd_lbl_overlap *overlap, char *err, size_t errlen);

#endif
