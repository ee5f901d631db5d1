/* lbl_first_flight.h — the first flight of the lattice's births, swept along 98 directions
 * instead of streamed along the six axes (option `first_flight`).
 *
 * Why: on the D3Q6 lattice a photon moves only along the axes, so the light the marching
 * pass deposits (what the medium scatters out of the lights' beams, and the emission)
 * reaches its next collision along six directions. Where the medium is thin and its shape
 * is not a box — a plume rising from a dense base, the rim of a low-albedo smoke, a fire's
 * light on the smoke around it — the six axes put that second collision in the wrong place:
 * gaffer's top quarter 1.49x the reference's VolumeInd, rot_lowalb's rim bright
 * (docs/methods/lbl.md). The first flight carries most of the light in exactly those media
 * (thin or absorbing: few photons scatter a third time), so it is taken along the 98
 * directions of lbl_directions.h, and the lattice diffuses only what collides after it.
 *
 * Along each vector a birth of power S_v (the births' share of that vector's solid angle,
 * or of its cone's for births with a direction: radiance constant over the cone, as the
 * lattice's collisions and the view's readout take it) travels the line of cells one vector apart;
 * each cell owns a segment of the vector's length, of optical depth x = sigma len:
 *     P_out = P_in e^-x + S_v e,     e = (1 - e^-x) / x (a birth at a uniform point)
 *     collisions = P_in (1 - e^-x) + S_v (1 - e)  = x path / len
 *     path = len (P_in e + S_v (1 - e) / x)
 * exact in total (every birth collides or leaves the box), and in a uniform medium the
 * path per cell is S / sigma, the fluence of the first flight. The collisions are born
 * again with the albedo and the lattice's cone phase (forward, backward, side shares of the
 * cone they arrived in): the source the lattice then diffuses. The paths, per cone, are the
 * first flight's light for the view (added to vsd_lbl_lattice_node_means' populations).
 *
 * One sweep per vector serves every cone it falls in (its light is the same in each, only
 * weighed by its part of the cone), row by row of cells along x with its own vectorised
 * exp (lbl_exp.h); the collisions are taken from the paths at the end (sigma lambda times
 * them), not kept per sweep. The threads share each vector's sweep: rows that light along it
 * passes between form chains, and whole chains go to one thread, so the result is the same
 * bit for bit on any number of threads. */
#ifndef VSD_LBL_FIRST_FLIGHT_H
#define VSD_LBL_FIRST_FLIGHT_H
#include <stdint.h>
#include "vsd/status.h"

typedef struct vsd_lbl_first_flight {
    int32_t res[3];
    const float *sigma;        /* [cells] extinction per world unit (the lattice's medium) */
    double cell_world;         /* the cube-equivalent cell edge, world units */
    const double *shape;       /* each axis's edge over it, or NULL for cubes */
    const float *source;       /* births: [3][cells] isotropic, or [6][3][cells] per cone */
    int per_direction;         /* which of the two source holds (births come out the same way) */
    const float *albedo_cells; /* [3][cells], or NULL for albedo */
    float albedo[3];
    float forward, backward, side; /* a collision's cone shares (per_direction only) */
} vsd_lbl_first_flight;

/* births: the collisions after the first flight born again, in the source's layout (may be
 * in->source itself: written once every sweep has read it; NULL = the paths alone); paths:
 * [6][3][cells] the first flight's photons' path per cone (+x, -x, +y, -y, +z, -z), in
 * cube-equivalent cells, the units of vsd_lbl_lattice_node_means. */
vsd_status vsd_lbl_first_flight_run(const vsd_lbl_first_flight *in, int threads, float *births, float *paths,
                                    char *err, size_t errlen);

#endif
