/* Method `lbl` (Bernabei, Hakke-Patil, Banterle, Di Benedetto, Ganovelli, Pattanaik,
 * Scopigno 2012): light marching from the light sources plus lattice-Boltzmann diffusion
 * for the multiple scattering, on one grid of cells over the density's box.
 *   prepare_frame     the cell grid (src/grids/record_grid.h: a record at the centre of
 *                     every non-empty cell) and each cell's sigma_t (the mean of 27
 *                     samples of the density): the paper's material volume (§III-A);
 *   prepare_lighting  the environment as directional lights (the light constellation,
 *                     vsd/lighting.h, rebuilt only when the map's content changes), the
 *                     scene's suns among them, and its point and spot lights; the
 *                     marching pass (§III-B, lbl_march.h): each light's transmittance at
 *                     every cell (rays from a point light's position; a directional
 *                     light's by one sweep of the cells, lbl_sweep.h); the first-scattered
 *                     light deposited per cell; beyond the paper its first flight to the
 *                     next collision along 98 directions (lbl_first_flight.h), what collides
 *                     there born again as the lattice's source; the diffusion pass (§III-C, lbl_lattice.h)
 *                     to convergence, warm-started from the last solve; beyond the paper
 *                     the lattice scatters with the medium's phase over its six
 *                     directions' cones, the deposit included (lbl_readout.h);
 *   render            the view pass (§III-D) on the record grid's shared view march:
 *                     VolumeDir from the lights' term, sum_k T_k sum_{s in k} HG(d . w_s)
 *                     E_s over each light's sub-lights (the direct deposit, with the phase
 *                     function: our media are not isotropic), VolumeInd from the diffused
 *                     light, the six populations weighed by the phase toward the eye
 *                     (the paper: phi / 4pi), plus Emit, Transmittance and Depth.
 * With medium.ior != 1 the frame stage also builds the n field (src/grids/refraction.h)
 * and the light and view rays bend through it (lbl_march.c, lbl_kernel.h; CPU only).
 * The paper's 4^3 blocks (lbl_blocked.c) and the D3Q18 lattice (lbl_d3q18.c) are options.
 * Marching and diffusion overlap in rounds of a ray history (option `history`, the paper's
 * k; off by default: slower on the CPU). Not built yet (issue 14): a device path for the
 * lighting stages (the unbent view runs on CUDA through the record grid).
 * docs/methods/lbl.md has the measurements. */
#include "src/method/method.h"
#include "src/grids/record_grid.h"
#include "src/render/kernel_setup.h"
#include "kernel/kernel_record_grid.h"
#include "vsd/lighting.h"
#include "kernel/kernel_lights.h"
#include "src/common/clock.h"
#include "lbl_march.h"
#include "lbl_lattice.h"
#include "lbl_kernel.h"
#include "lbl_readout.h"
#include "src/grids/refraction.h"
#include "lbl_escape.h"
#include "lbl_exchange.h"
#include "lbl_delta_m.h"
#include "lbl_first_flight.h"
#include "lbl_sweep.h"
#include "src/lighting/radiance_cache.h"
#include "device/cpu/cpu_tiles.h"
#include "src/grids/volume_groups.h"
#include "src/method/method_parts.h"
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846
#define LBL_MAX_SUB_LIGHTS 16

/* the albedo of the emission's own solve: its light before any scattering */
static const float no_scattering[3] = {0.0f, 0.0f, 0.0f};

typedef struct lbl_options {
    int lights, cells, max_steps, interp, pixel_samples, view_bake, block_steps, lattice, leaps, history, sub_lights, readout, lattice_phase, cell_light, light_deposit, light_march, cell_shape, escape, exchange, delta_m, first_flight, lattice_order;
    double ray_spacing, light_step, tolerance, slice, early_termination;
    vsd_view_sampling view;
} lbl_options;

static const char *const lbl_lattice_names[] = {"d3q6", "d3q18", NULL};
static const char *const lbl_readout_names[] = {"isotropic", "phase", NULL};
static const char *const lbl_phase_names[] = {"isotropic", "hg", NULL};
/* in VSD_LBL_CELL_FACES.. order */
static const char *const lbl_cell_light_names[] = {"faces", "path", NULL};
/* in VSD_LBL_ORDER_JACOBI.. order */
static const char *const lbl_order_names[] = {"jacobi", "gauss-seidel", NULL};
enum { LBL_DEPOSIT_CENTRE, LBL_DEPOSIT_LOST };
static const char *const lbl_light_march_names[] = {"rays", "sweep", NULL};
enum { LBL_MARCH_RAYS, LBL_MARCH_SWEEP };
static const char *const lbl_deposit_names[] = {"centre", "lost", NULL};
enum { LBL_SHAPE_CUBES, LBL_SHAPE_BOXES };
static const char *const lbl_shape_names[] = {"cubes", "boxes", NULL};
enum { LBL_PHASE_ISOTROPIC, LBL_PHASE_HG };
enum { LBL_READOUT_ISOTROPIC, LBL_READOUT_PHASE };

/* in VSD_RECORDS_NEAREST.. order */
static const char *const lbl_interp_names[] = {"nearest", "trilinear", "log", NULL};

/* What readout, lattice_phase and cell_light choose between exists only on the global D3Q6
 * lattice; the blocked and the D3Q18 lattices have their own light in a cell. */
static const vsd_option_when lbl_on_global_d3q6[] = {
    {"block_steps", 0, 0, NULL}, {"lattice", 0, 0, "d3q6"}, {NULL, 0, 0, NULL}};
/* cell_shape and surface_escape shape the light's path through a cell (cell_light "path"). */
static const vsd_option_when lbl_on_cell_path[] = {
    {"block_steps", 0, 0, NULL}, {"lattice", 0, 0, "d3q6"}, {"cell_light", 0, 0, "path"}, {NULL, 0, 0, NULL}};
/* The blocked lattice is the paper's D3Q6 only. */
static const vsd_option_when lbl_on_global[] = {{"block_steps", 0, 0, NULL}, {NULL, 0, 0, NULL}};

static const vsd_option_spec lbl_option_rows[] = {
    {"lights", VSD_OPT_INT, 1, VSD_RECORDS_MAX_LIGHTS, 64, NULL,
     "the environment as N directional lights (median-cut constellation)", offsetof(lbl_options, lights), 0, NULL, NULL},
    {"sub_lights", VSD_OPT_INT, 1, LBL_MAX_SUB_LIGHTS, 8, NULL,
     "each light's region of the map cut again into N: the view weighs the phase function over their directions, "
     "the shadow stays the light's (1 = the light's own direction only)",
     offsetof(lbl_options, sub_lights), 0, NULL, NULL},
    {"cells", VSD_OPT_INT, 4, 256, 64, NULL,
     "lattice cells per axis over the density's box (the material, marching and diffusion volumes)",
     offsetof(lbl_options, cells), 0, NULL, NULL},
    {"ray_spacing", VSD_OPT_NUMBER, 0.25, 1, 1, NULL, "light rays' spacing across their direction, in cells",
     offsetof(lbl_options, ray_spacing), 0, NULL, NULL},
    {"light_step", VSD_OPT_NUMBER, 0.25, 1, 1, NULL, "light rays' integration step (the paper's delta), in cells",
     offsetof(lbl_options, light_step), 0, NULL, NULL},
    {"leaps", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "light rays leap over empty cells to just before the medium (the same result; 0 = march every step)",
     offsetof(lbl_options, leaps), 0, NULL, NULL},
    {"history", VSD_OPT_INT, 0, 4096, 0, NULL,
     "light rays advance this many steps per round while the lattice diffuses 8 steps on what they have left so far "
     "(the paper's ray history k, Fig. 1a; its best was 16); 0 = march every light, then diffuse (faster on the CPU: "
     "docs/methods/lbl.md, Table I)",
     offsetof(lbl_options, history), 0, NULL, NULL},
    {"tolerance", VSD_OPT_NUMBER, 1e-7, 0.1, 3e-3, NULL,
     "diffusion: stop when the probes' fluence has less than this (relative) still to change",
     offsetof(lbl_options, tolerance), 0, NULL, NULL},
    {"max_steps", VSD_OPT_INT, 8, 100000, 4000, NULL, "diffusion: at most this many lattice steps",
     offsetof(lbl_options, max_steps), 0, NULL, NULL},
    {"block_steps", VSD_OPT_INT, 0, 64, 0, NULL,
     "diffusion: 0 = one global lattice; n = the paper's 4^3 blocks with interface buffers, n steps per "
     "exchange (docs/methods/lbl.md, Fig. 6)",
     offsetof(lbl_options, block_steps), 0, NULL, NULL},
    {"lattice", VSD_OPT_CHOICE, 0, 0, 0, lbl_lattice_names,
     "diffusion: the paper's 6 axis directions (d3q6), or Geist et al.'s 18 with the in-plane diagonals (d3q18, "
     "3x the memory; not with block_steps)",
     offsetof(lbl_options, lattice), 0, NULL, .when = lbl_on_global},
    {"lattice_phase", VSD_OPT_CHOICE, 0, 0, LBL_PHASE_HG, lbl_phase_names,
     "diffusion: the paper's isotropic scattering, or the medium's phase (Henyey-Greenstein) on the six directions' "
     "cones, first scattering included (D3Q6 global lattice; lbl_readout.h)",
     offsetof(lbl_options, lattice_phase), 0, NULL, .when = lbl_on_global_d3q6},
    {"delta_m", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "diffusion: delta-M scaling of a forward-peaked phase (g > 0; with lattice_phase \"hg\", readout \"phase\" and "
     "no ray history): the lattice solves the problem without HG's forward peak, the light it leaves out is read "
     "toward the eye with the true phase (lbl_delta_m.h)",
     offsetof(lbl_options, delta_m), 0, NULL, .when = lbl_on_global_d3q6},
    {"exchange", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "several volumes: the light each group of volumes sends the near ones enters their lattices at the faces "
     "(D3Q6 global lattice; lbl_exchange.h)",
     offsetof(lbl_options, exchange), 0, NULL, .when = lbl_on_global_d3q6},
    {"cell_light", VSD_OPT_CHOICE, 0, 0, VSD_LBL_CELL_PATH, lbl_cell_light_names,
     "diffusion: the light in a cell, the paper's photons counted at the faces they arrive at with what is born "
     "there leaving whole, or each photon's path through the cell, born light crossing the rest of it (global "
     "D3Q6 lattice; lbl_lattice.h, docs/methods/lbl.md)",
     offsetof(lbl_options, cell_light), 0, NULL, .when = lbl_on_global_d3q6},
    {"lattice_order", VSD_OPT_CHOICE, 0, 0, VSD_LBL_ORDER_GAUSS_SEIDEL, lbl_order_names,
     "diffusion: every node steps from the last step's populations (the paper's jacobi), or the rows of nodes in "
     "turn, each colliding with what the rows before it sent it in the same step (gauss-seidel: the same steady "
     "state in a quarter to a third fewer steps; global D3Q6 lattice; lbl_lattice.h)",
     offsetof(lbl_options, lattice_order), 0, NULL, .when = lbl_on_global_d3q6},
    {"light_deposit", VSD_OPT_CHOICE, 0, 0, LBL_DEPOSIT_LOST, lbl_deposit_names,
     "marching: what a cell scatters out of a directional light's rays, the paper's albedo E T p lambda^2 with the "
     "rays' T at its centre, or albedo E times the power the rays lost in it (exact for thick cells; lbl_march.h)",
     offsetof(lbl_options, light_deposit), 0, NULL, NULL},
    {"light_march", VSD_OPT_CHOICE, 0, 0, LBL_MARCH_SWEEP, lbl_light_march_names,
     "marching: each directional light's transmittance to the cells by the paper's parallel rays (ray_spacing, "
     "light_step), or by one sweep of the cells' layers across its direction (lbl_sweep.h; about 3x cheaper); point and "
     "spot lights, refraction and a ray history always take the rays",
     offsetof(lbl_options, light_march), 0, NULL, NULL},
    {"cell_shape", VSD_OPT_CHOICE, 0, 0, LBL_SHAPE_BOXES, lbl_shape_names,
     "diffusion, with cell_light \"path\": every cell taken as the cube of its volume (as the paper's lattice), or as "
     "the box it is, light crossing sigma times each axis's own edge (docs/methods/lbl.md, \"Cells that are not "
     "cubes\")",
     offsetof(lbl_options, cell_shape), 0, NULL, .when = lbl_on_cell_path},
    {"surface_escape", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "diffusion, with cell_light \"path\": what is born near the medium's surface loses at once the light that "
     "leaves it in every outward direction beyond what the six axes carry out (lbl_escape.h)",
     offsetof(lbl_options, escape), 0, NULL, .when = lbl_on_cell_path},
    {"first_flight", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "diffusion, with cell_light \"path\": the light the marching pass deposits (and the emission) travels to its next "
     "collision along 98 directions, not the six axes; the lattice diffuses what collides after it "
     "(lbl_first_flight.h)",
     offsetof(lbl_options, first_flight), 0, NULL, .when = lbl_on_cell_path},
    {"readout", VSD_OPT_CHOICE, 0, 0, LBL_READOUT_PHASE, lbl_readout_names,
     "view: the diffused light toward the eye, the paper's isotropic fluence / 4pi, or the phase function over the "
     "lattice's six directions (D3Q6 global lattice; lbl_readout.h)",
     offsetof(lbl_options, readout), 0, NULL, .when = lbl_on_global_d3q6},
    {"interpolation", VSD_OPT_CHOICE, 0, 0, VSD_RECORDS_LOG_TRILINEAR, lbl_interp_names,
     "view: the direct light between cell centres, nearest, trilinear, or trilinear in log radiance",
     offsetof(lbl_options, interp), 0, NULL, NULL},
    {"slice", VSD_OPT_NUMBER, 0, 1e30, 0, NULL, "view march step, world units (0 = a voxel)",
     offsetof(lbl_options, slice), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL, NULL},
    {"view_bake", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "CPU view: the lights' term per record once per view, phase at the camera-to-record direction (0 = per ray)",
     offsetof(lbl_options, view_bake), 0, NULL, NULL},
    VSD_OPTION_EARLY_TERMINATION(lbl_options, "view ray"),
    VSD_OPTION_PIXEL_SAMPLES(lbl_options),
    VSD_OPTION_VIEW_SPACING(lbl_options, view.spacing, view.threshold),
};

typedef struct lbl_state {
    lbl_options opt;
    /* frame: the cells and their material */
    vsd_record_grid rg;
    float *sigma;                 /* [cells] sigma_t per world unit */
    float *collide;               /* [cells] collision probability per lattice step */
    /* one volume: [cells] the cells' mean of the density grid itself (medium.density 1), from
     * which sigma and collide are made for the density they hold (sigma_density), so that a
     * density edit re-lights without a new frame stage (density_in_lighting); NULL for a
     * part, whose cells sum their group's media */
    float *field;
    float sigma_density;
    float *empty_d2;              /* [cells] squared distance to the medium (lbl_march.h) */
    /* [cells] what the lattice keeps of each birth (lbl_escape.h) through the cells' own
     * medium, or NULL: made by the first lighting that reads it (with delta-M and no
     * emission none does). dm_keep: the same through delta-M's scaled medium, made again
     * only when that medium (dm_sigma) differs from dm_keep_sigma, the one it was made for:
     * a map rotation keeps it; an albedo or anisotropy edit, of this volume or of another
     * whose medium its cells mix (albedo_cells), makes it again. */
    float *keep, *dm_keep, *dm_keep_sigma;
    /* [3][cells] a part's: each cell's albedo, the scattering share of its group's summed
     * extinction (several volumes of different albedo in its cells), or NULL */
    float *albedo_cells;
    vsd_lbl_readout readout;      /* the phase's cone weights (readout "phase") */
    /* the medium the lattice solves (lighting stage): the cells' own, or with delta-M the
     * scaled problem's (lbl_delta_m.h), whose arrays are dm_* */
    const float *lat_sigma, *lat_collide, *lat_albedo_cells, *lat_keep;
    float lat_albedo[3];
    float *dm_sigma, *dm_collide, *dm_albedo_cells;
    vsd_lbl_readout readout_dm;   /* the scaled phase's cone shares (delta-M) */
    /* with delta-M, [records * dir_count] and [records * local_count]: T' - T, the light
     * the true problem scattered forward and the scaled one calls unscattered (VolumeInd) */
    float *fwd_trans, *fwd_local;
    float *ms6;                   /* [records][6][3] the populations as cone radiances, or NULL */
    float *ms_view;               /* [records][3] their light toward this view's eye */
    double cell_world;            /* edge of a cube of a cell's world volume */
    double cell_shape[3];         /* each grid axis's cell edge (world) over cell_world */
    double g2w[16];               /* grid -> world (the record grid's world_to_grid inverted) */
    /* lighting */
    vsd_constellation_cache cc;   /* the environment's lights, kernel layout */
    /* the directional lights: the environment's, then the scene's suns (8 floats each, the
     * record grid's layout); the scene's point and spot lights (kernel_lights.h layout) */
    /* the directional lights (the map's, then the scene's suns), then sub_count sub-lights
     * (kernel_record_grid.h: the phase over finer directions, the shadow the light's) */
    float dir_lights[8 * VSD_RECORDS_MAX_LIGHTS * (1 + LBL_MAX_SUB_LIGHTS)];
    int dir_count, sub_count;
    float local_lights[VSD_KLIGHT_FLOATS * VSD_MAX_LIGHTS];
    int local_count;
    float *light_trans;           /* [records * dir_count] */
    float *light_lost;            /* [records * dir_count] the power the rays lost (lbl_march.h), or NULL */
    float *local_trans;           /* [records * local_count] transmittance times falloff */
    float *source;                /* [3][cells], or with source_dirs [6][3][cells] */
    int source_dirs;              /* the source per direction: the lattice scatters with the phase
                                     (lattice_phase "hg"), or light comes in at its faces */
    int receives;                 /* a part with near volumes outside its group: their light comes
                                     in at the lattice's faces (lbl_exchange.h) */
    vsd_lbl_exchange exchange;    /* a receiving part's: the other groups seen from its faces */
    /* [records][exchange.count][3]: the scattered light of each kept direction reaching the
     * record (irradiance, E T), read toward the eye per view with the volume's lobe */
    float *exchange_irr;
    float dir_shares[VSD_RECORDS_MAX_LIGHTS][6];  /* each directional light's light_shares */
    float *fluence;               /* [3][cells] */
    /* with first_flight (lbl_first_flight.h), [6][3][cells]: the first flight's photons' path
     * per cone, of the lattice's births (ff_paths, the lattice then diffusing what collides
     * after it) and of the emission alone (ff_paths_e, in place of its albedo-0 lattice) */
    float *ff_paths, *ff_paths_e;
    float *ms;                    /* [records * 3] VolumeInd source per unit sigma_s */
    /* with emission: the emission alone (source_e), its fluence before any scattering
       (fluence_e, its first flight, or without it a lattice solve with albedo 0) and that fluence per record (emission_once, the
       emission scattered once toward the camera: VolumeDir, as Cycles counts it) */
    float *source_e, *fluence_e, *emission_once;
    vsd_lbl_lattice lattice_e;    /* the warm start of the emission's solve */
    float *view_baked;            /* [records * 3] the lights' term toward this view's camera */
    vsd_lbl_lattice lattice;      /* kept between lighting changes: the warm start */
    vsd_lbl_diffusion_stats diffusion;
    double march_seconds;         /* with a ray history, the lattice's steps meanwhile too */
    double flight_seconds;        /* the first flight's sweeps (births and emission) */
    int history_rounds, history_steps; /* the overlap's rounds, and the lattice steps during them */
    int emission_steps;           /* lattice steps of the emission's solve (0: no emission) */
    vsd_refraction_field refraction; /* medium.ior != 1: the view rays bend (lbl_kernel.h) */
    /* several volumes: a part per volume, each lighting its volume on a grid over the
     * volume's group with every member's extinction and emission (src/method/method_parts.h) */
    vsd_method_parts parts;
} lbl_state;

static vsd_status lbl_create(void **state, const vsd_scene *scene, const void *options, char *err, size_t errlen)
{
    lbl_state *s = calloc(1, sizeof *s);
    (void)scene;
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    s->opt = *(const lbl_options *)options;
    s->readout.g = NAN;
    s->readout_dm.g = NAN;
    *state = s;
    return VSD_OK;
}

static void free_lighting(lbl_state *s)
{
    free(s->light_trans);
    free(s->light_lost);
    s->light_lost = NULL;
    free(s->local_trans);
    s->local_trans = NULL;
    free(s->source);
    free(s->fluence);
    free(s->ms);
    free(s->view_baked);
    free(s->ms6);
    free(s->ms_view);
    s->ms6 = s->ms_view = NULL;
    free(s->ff_paths), free(s->ff_paths_e);
    s->ff_paths = s->ff_paths_e = NULL;
    free(s->source_e);
    free(s->fluence_e);
    free(s->emission_once);
    s->light_trans = s->source = s->fluence = s->ms = s->view_baked = NULL;
    s->source_e = s->fluence_e = s->emission_once = NULL;
    s->emission_steps = 0;
    vsd_lbl_exchange_free(&s->exchange);
    free(s->exchange_irr);
    s->exchange_irr = NULL;
    free(s->dm_sigma), free(s->dm_collide), free(s->dm_albedo_cells);
    free(s->fwd_trans), free(s->fwd_local);
    s->dm_sigma = s->dm_collide = s->dm_albedo_cells = s->fwd_trans = s->fwd_local = NULL;
    s->lat_sigma = s->lat_collide = s->lat_albedo_cells = s->lat_keep = NULL;
}

static void free_frame(lbl_state *s)
{
    vsd_refraction_free(&s->refraction);
    vsd_record_grid_free(&s->rg);
    free(s->sigma);
    free(s->collide);
    free(s->field);
    s->field = NULL;
    free(s->empty_d2);
    free(s->keep);
    free(s->dm_keep);
    free(s->dm_keep_sigma);
    free(s->albedo_cells);
    s->sigma = s->collide = s->empty_d2 = s->keep = s->dm_keep = s->dm_keep_sigma = s->albedo_cells = NULL;
    free_lighting(s);
}

static size_t cell_count(const lbl_state *s) { return (size_t)s->rg.res[0] * s->rg.res[1] * s->rg.res[2]; }

/* grid -> world into s->g2w, and the world edge of a cell (cube root of its volume) */
static vsd_status grid_to_world(lbl_state *s, char *err, size_t errlen)
{
    const double *o = s->g2w;
    double m[16];
    int a;
    for (a = 0; a < 12; a++) m[a] = s->rg.world_to_grid.m[a];
    m[12] = m[13] = m[14] = 0.0;
    m[15] = 1.0;
    if (!vsd_mat4_invert(m, s->g2w)) return vsd_fail(VSD_ERR_INVALID, err, errlen, "lbl: the volume's transform is singular");
    s->cell_world = cbrt(fabs(o[0] * (o[5] * o[10] - o[6] * o[9]) - o[1] * (o[4] * o[10] - o[6] * o[8]) +
                              o[2] * (o[4] * o[9] - o[5] * o[8])));
    for (a = 0; a < 3; a++) s->cell_shape[a] = sqrt(o[a] * o[a] + o[4 + a] * o[4 + a] + o[8 + a] * o[8 + a]) / s->cell_world;
    return VSD_OK;
}

/* the world point at grid coordinates (x, y, z) */
static vsd_f3 grid_point(const lbl_state *s, double x, double y, double z)
{
    const double *g = s->g2w;
    return f3((float)(g[0] * x + g[1] * y + g[2] * z + g[3]), (float)(g[4] * x + g[5] * y + g[6] * z + g[7]),
              (float)(g[8] * x + g[9] * y + g[10] * z + g[11]));
}

/* The 27 samples of cell (x, y, z), k = 0..26: the centres of its 3^3 sub-cells. The
 * cells' extinction and a part's mixed albedo take the same ones. */
static vsd_f3 cell_sample(const lbl_state *s, int32_t x, int32_t y, int32_t z, int k)
{
    return grid_point(s, x + (k / 9 + 0.5) / 3.0, y + (k / 3 % 3 + 0.5) / 3.0, z + (k % 3 + 0.5) / 3.0);
}

/* The cells of slices [z0, z1) (items of vsd_cpu_run_each), each on its own by `cell`: a
 * frame's 27 lookups per cell took 0.3 s on one thread at 64^3. */
typedef struct cells_job {
    lbl_state *s;
    const vsd_frame_ctx *ctx;
    void (*cell)(const struct cells_job *j, int32_t x, int32_t y, int32_t z, size_t c);
} cells_job;

static void cell_slices(void *user, int z0, int y0, int z1, int y1)
{
    const cells_job *j = user;
    const int32_t *res = j->s->rg.res;
    int32_t x, y, z;
    size_t c;
    (void)y0, (void)y1;
    for (z = z0, c = (size_t)z0 * res[1] * res[0]; z < z1; z++)
        for (y = 0; y < res[1]; y++)
            for (x = 0; x < res[0]; x++, c++) j->cell(j, x, y, z, c);
}

/* a corrupt grid's absurd values (scale x 3e38 overflows to inf) stay finite here: inf - inf
 * in the trilinear lookups would turn the light into NaN; a cell of 1e20 per unit length is
 * opaque all the same */
#define LBL_SIGMA_MAX 1e20

/* Cell c's extinction per unit length, capped (above), and its collision probability per
 * lattice step. */
static void set_cell_medium(lbl_state *s, size_t c, double sigma)
{
    s->sigma[c] = (float)fmin(sigma, LBL_SIGMA_MAX);
    s->collide[c] = (float)(1.0 - exp(-s->sigma[c] * s->cell_world));
}

/* A part's cell: sigma_t, the mean of its 27 samples of its group's media. */
static void cell_sigma(const cells_job *j, int32_t x, int32_t y, int32_t z, size_t c)
{
    lbl_state *s = j->s;
    const uint32_t group = vsd_ctx_group(j->ctx);
    double sum = 0.0;
    int k;
    for (k = 0; k < 27; k++) sum += vsd_group_sigma(&j->ctx->kd, group, cell_sample(s, x, y, z, k));
    set_cell_medium(s, c, sum / 27.0);
}

/* One volume: the cell's mean of the grid itself (the job's kd at density 1). */
static void cell_field(const cells_job *j, int32_t x, int32_t y, int32_t z, size_t c)
{
    lbl_state *s = j->s;
    double sum = 0.0;
    int k;
    for (k = 0; k < 27; k++) sum += vsd_kvolume_at(&j->ctx->kd.density, cell_sample(s, x, y, z, k));
    s->field[c] = (float)fmin(sum / 27.0, LBL_SIGMA_MAX);
}

/* One volume: sigma and collide for medium.density `density` from the cells' field. */
static void apply_density(lbl_state *s, float density)
{
    const size_t n = cell_count(s);
    size_t c;
    for (c = 0; c < n; c++) set_cell_medium(s, c, (double)density * s->field[c]);
    s->sigma_density = density;
}

/* A part's frame stage (below) reads its group's media: its grid covers the group, its
 * cells sum their extinction. */
static uint32_t lbl_part_reads(const vsd_frame_ctx *ctx) { return ctx->part.group; }

/* The material volume: sigma_t of each cell as the mean of 3^3 samples inside it. */
static vsd_status lbl_prepare_frame(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    lbl_state *s = state;
    size_t n;
    vsd_status st;
    free_frame(s);
    if (!ctx->part.active) {
        if (ctx->kd.volume_count > 1) {
            int i;
            st = vsd_parts_prepare_frame(&s->parts, &vsd_method_lbl, &s->opt, lbl_part_reads, ctx, err, errlen);
            /* with light between groups a part reads the others' lighting too, so any
             * material edit re-lights every part (and the exchange after them) */
            s->parts.materials_of_all = 0;
            for (i = 0; i < s->parts.count && s->opt.exchange; i++)
                if (vsd_group_near_outside(&ctx->kd, s->parts.group[i])) s->parts.materials_of_all = 1;
            return st;
        }
        vsd_parts_free(&s->parts, &vsd_method_lbl);
    }
    if (ctx->part.active) {
        /* the grid covers the group: this volume's index space, grown over the others' */
        const vsd_kvolume *others[VSD_KMAX_VOLUMES];
        int i, k = 0;
        for (i = 0; i < ctx->kd.volume_count; i++)
            if (((ctx->part.group >> i) & 1u) && i != ctx->part.volume) others[k++] = &ctx->kd.volumes[i].density;
        st = vsd_record_grid_build_over(&ctx->kd.density, others, k, s->opt.cells, 2, &s->rg, err, errlen);
    } else {
        st = vsd_record_grid_build(&ctx->kd.density, s->opt.cells, 2, &s->rg, err, errlen);
    }
    if (st) return st;
    if ((st = vsd_refraction_for_frame(ctx, &s->refraction, err, errlen))) return st;
    n = cell_count(s);
    if (n == 0) return VSD_OK;
    if ((st = grid_to_world(s, err, errlen))) return st;
    s->sigma = malloc(n * sizeof *s->sigma);
    s->collide = malloc(n * sizeof *s->collide);
    if (!s->sigma || !s->collide) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for %zu cells", n);
    /* a part whose group holds other volumes: its lattice scatters their media with their
     * albedos, not its own (each cell the mixture over its 27 samples; mixed in the lighting
     * stage, where an albedo edit lands: mix_albedo_cells) */
    if (ctx->part.active && (ctx->part.group & ~(1u << ctx->part.volume)) &&
        !(s->albedo_cells = malloc(3 * n * sizeof *s->albedo_cells)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the albedos of %zu cells", n);
    if (!ctx->part.active) {
        /* one volume: the grid's own means, the density applied to them (apply_density) */
        vsd_frame_ctx unit = *ctx;
        cells_job job = {s, &unit, cell_field};
        unit.kd.density.scale = 1.0f;
        if (!(s->field = malloc(n * sizeof *s->field)))
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for %zu cells", n);
        if ((st = vsd_cpu_run_each(s->rg.res[2], ctx->threads, cell_slices, &job, "lbl cells")))
            return vsd_fail(st, err, errlen, "lbl: the cells' threads failed");
        apply_density(s, ctx->kd.density.scale);
    } else {
        cells_job job = {s, ctx, cell_sigma};
        if ((st = vsd_cpu_run_each(s->rg.res[2], ctx->threads, cell_slices, &job, "lbl cells")))
            return vsd_fail(st, err, errlen, "lbl: the cells' threads failed");
    }
    if (!(s->empty_d2 = malloc(n * sizeof *s->empty_d2)) ||
        !vsd_lbl_empty_distance(s->rg.res, s->sigma, s->rg.cell_record, ctx->threads, s->empty_d2))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the distance map of %zu cells", n);
    return VSD_OK;
}

/* The light each cell scatters out of the direct beams (and emits) per lattice step, in
 * watts: albedo * E_k T_k * (1 - e^{-sigma lambda}) lambda^2 summed over the lights (a beam
 * of irradiance E T_k through a cell of cross-section lambda^2, T_k at the centre), plus
 * the emission, 4pi L_e lambda^3 (L_e per unit length and steradian). */
/* Floats of the source: [3][cells], or [6][3][cells] per direction. */
static size_t source_floats(const lbl_state *s) { return (s->source_dirs ? 18 : 3) * cell_count(s); }

/* source += the emission (source_e), a sixth per direction on a lattice with directions */
static void add_emission(lbl_state *s)
{
    const size_t n3 = 3 * cell_count(s);
    size_t c;
    int i;
    if (!s->source_dirs) {
        for (c = 0; c < n3; c++) s->source[c] += s->source_e[c];
        return;
    }
    for (i = 0; i < 6; i++)
        for (c = 0; c < n3; c++) s->source[(size_t)i * n3 + c] += s->source_e[c] * (1.0f / 6.0f);
}

static void emission_source(lbl_state *s, const vsd_frame_ctx *ctx)
{
    const size_t n = cell_count(s);
    const double vol = s->cell_world * s->cell_world * s->cell_world;
    const vsd_kmedium *m = &ctx->kd.medium;
    size_t c;
    int32_t x, y, z;
    for (z = 0, c = 0; z < s->rg.res[2]; z++)
        for (y = 0; y < s->rg.res[1]; y++)
            for (x = 0; x < s->rg.res[0]; x++, c++) {
                vsd_f3 p = grid_point(s, x + 0.5, y + 0.5, z + 0.5);
                if (ctx->part.active) {
                    /* the group's emission, each volume's colour times its grid */
                    vsd_f3 e = vsd_group_emission(&ctx->kd, ctx->part.group, p);
                    s->source_e[c] = (float)(e.x * 4.0 * PI_D * vol);
                    s->source_e[n + c] = (float)(e.y * 4.0 * PI_D * vol);
                    s->source_e[2 * n + c] = (float)(e.z * 4.0 * PI_D * vol);
                } else {
                    double le = vsd_kvolume_at(&ctx->kd.emission, p) * 4.0 * PI_D * vol;
                    s->source_e[c] = (float)(le * m->emission.x);
                    s->source_e[n + c] = (float)(le * m->emission.y);
                    s->source_e[2 * n + c] = (float)(le * m->emission.z);
                }
            }
}

/* The share of light k's first scattering that goes into each lattice direction: 1/6 each
 * on an isotropic lattice; else the phase's cone shares around the light's direction of
 * travel (lbl_readout.h; a point light's from the record's position). */
static void light_shares(const lbl_state *s, int light, int32_t rec, float q[6])
{
    vsd_f3 w;
    int i;
    if (!s->source_dirs) {
        for (i = 0; i < 6; i++) q[i] = 1.0f / 6.0f;
        return;
    }
    if (light < s->dir_count) {
        memcpy(q, s->dir_shares[light], 6 * sizeof(float));
        return;
    }
    {
        /* toward the light from the record: the table's d (the light travels along -d) */
        const float *l = s->local_lights + (size_t)VSD_KLIGHT_FLOATS * (light - s->dir_count), *x = s->rg.record_pos + 4 * (size_t)rec;
        w = f3(l[0] - x[0], l[1] - x[1], l[2] - x[2]);
    }
    vsd_lbl_readout_weights(&s->readout, vsd_affine_vector(&s->rg.world_to_grid, w), q);
}

/* What turns a light's T (times albedo E) at cell c into the watts the cell scatters,
 * p lambda^2 — or, for the lost power (light_deposit "lost"), lambda^3. */
static double deposit_scale(const lbl_state *s, size_t c, int lost)
{
    return lost ? s->cell_world * s->cell_world * s->cell_world : s->lat_collide[c] * s->cell_world * s->cell_world;
}

/* Adds light k's first scattering at record rec (cell c), t its transmittance (times the
 * falloff for a point light), to the source: albedo E T p lambda^2, or with lost power
 * (light_deposit "lost", directional lights) albedo E lost lambda^3, per direction or all
 * directions alike. */
static void add_deposit(lbl_state *s, const float albedo[3], int light, size_t c, int32_t rec, double t, double lost)
{
    const size_t n = cell_count(s);
    const float *e = light < s->dir_count ? s->dir_lights + 8 * light + 4
                                          : s->local_lights + (size_t)VSD_KLIGHT_FLOATS * (light - s->dir_count) + 4;
    const int use_lost = s->light_lost && isfinite(lost);
    const double w = (use_lost ? lost : t) * deposit_scale(s, c, use_lost);
    int ch, i;
    if (!(w != 0.0)) return;
    if (!s->source_dirs) {
        for (ch = 0; ch < 3; ch++) s->source[(size_t)ch * n + c] += (float)(albedo[ch] * e[ch] * w);
        return;
    }
    {
        float q[6];
        light_shares(s, light, rec, q);
        for (i = 0; i < 6; i++)
            for (ch = 0; ch < 3; ch++) s->source[((size_t)i * 3 + ch) * n + c] += (float)(albedo[ch] * e[ch] * w * q[i]);
    }
}

/* deposit's cells of slices [z0, z1) (items), each on its own: the source's arrays there
 * cleared, then every light's first scattering at each record (0.07-0.11 s on one thread
 * at 64^3 with 64 lights). */
typedef struct deposit_job {
    lbl_state *s;
    const float *trans, *lost, *local;
    float albedo[3];
    const float *qe; /* albedo E_k times each direction's share: [light][direction][channel] */
    int m3;          /* directions times channels */
} deposit_job;

static void deposit_slices(void *user, int z0, int y0, int z1, int y1)
{
    const deposit_job *j = user;
    lbl_state *s = j->s;
    const size_t n = cell_count(s), slice = (size_t)s->rg.res[0] * s->rg.res[1], c0 = (size_t)z0 * slice,
                 c1 = (size_t)z1 * slice;
    const int m3 = j->m3;
    size_t c;
    int q, k;
    (void)y0, (void)y1;
    for (q = 0; q < (s->source_dirs ? 18 : 3); q++) memset(s->source + (size_t)q * n + c0, 0, (c1 - c0) * sizeof *s->source);
    for (c = c0; c < c1; c++) {
        int32_t rec = s->rg.cell_record[c];
        float acc[18] = {0};
        const float *t;
        if (rec < 0) continue;
        /* with the lost power (light_deposit "lost") the rays' loss in the cell, else their
         * T at its centre times the cell's collision probability */
        t = (j->lost ? j->lost : j->trans) + (size_t)rec * s->dir_count;
        for (k = 0; k < s->dir_count; k++)
            for (q = 0; q < m3; q++) acc[q] += t[k] * j->qe[(size_t)k * m3 + q];
        if (s->lat_albedo_cells)
            for (q = 0; q < m3; q++) acc[q] *= s->lat_albedo_cells[(size_t)(q % 3) * n + c];
        for (q = 0; q < m3; q++) s->source[(size_t)q * n + c] += (float)(acc[q] * deposit_scale(s, c, j->lost != NULL));
        /* point and spot lights: their falloff is in local_trans */
        for (k = 0; k < s->local_count; k++) {
            float a3[3];
            for (q = 0; q < 3; q++) a3[q] = s->lat_albedo_cells ? s->lat_albedo_cells[(size_t)q * n + c] : j->albedo[q];
            add_deposit(s, a3, s->dir_count + k, c, rec, j->local[(size_t)rec * s->local_count + k], NAN);
        }
    }
}

/* The source from scratch: every light's first scattering at every record (the light
 * each cell scatters out of the direct beams per lattice step, in watts: albedo E_k T_k
 * (1 - e^{-sigma lambda}) lambda^2, a beam of irradiance E T_k through a cell of
 * cross-section lambda^2, T_k at the centre), plus the emission, 4pi L_e lambda^3, a
 * sixth per direction.
 * T_k is the transmittance at the cell's centre (light_deposit "centre", the paper's): a
 * beam entering the cell brings T_k e^{x/2} (x = sigma lambda) and loses (1 - e^-x) of
 * that, so this is low by about x/2. With light_deposit "lost" (default) the march's exact
 * loss in the cell replaces T_k (1 - e^-x) lambda^2 (docs/methods/lbl.md, "What a cell
 * scatters out of the rays"). */
static void deposit(lbl_state *s, const vsd_frame_ctx *ctx, const float *trans, const float *lost, const float *local)
{
    /* with each cell's own albedo (a part's group), E_k's share here and the cell's albedo
     * per record below; the lattice's medium (delta-M's scaled one where it runs) */
    deposit_job j = {s, trans, lost, local, {s->lat_albedo_cells ? 1.0f : s->lat_albedo[0],
                                              s->lat_albedo_cells ? 1.0f : s->lat_albedo[1],
                                              s->lat_albedo_cells ? 1.0f : s->lat_albedo[2]},
                     NULL, 3 * (s->source_dirs ? 6 : 1)};
    const int nd = j.m3 / 3;
    /* the directional lights, the bulk: albedo E_k times each direction's share, once per
     * light, then one multiply-add per light, direction and channel at each record */
    float qe[VSD_RECORDS_MAX_LIGHTS * 18];
    int k, i, ch;
    for (k = 0; k < s->dir_count; k++) {
        float q[6];
        light_shares(s, k, -1, q);
        for (i = 0; i < nd; i++)
            for (ch = 0; ch < 3; ch++)
                qe[(size_t)k * j.m3 + 3 * i + ch] = j.albedo[ch] * s->dir_lights[8 * k + 4 + ch] * (nd > 1 ? q[i] : 1.0f);
    }
    j.qe = qe;
    /* (the pool fails only when cancelled, which this stage is not) */
    (void)vsd_cpu_run_each(s->rg.res[2], ctx->threads, deposit_slices, &j, "lbl deposit");
    if (vsd_group_emits(&ctx->kd, vsd_ctx_group(ctx))) {
        emission_source(s, ctx);
        add_emission(s);
    }
}

/* Marching and diffusion overlapped (option `history`): the lattice steps on the source
 * deposited so far while the rays march; each record's T, once final, adds its light to
 * the source. deposit() rebuilds the whole source after the march, so the steady state is
 * the sequential one's; only the warm state the rest of the solve starts from differs. */
#define LBL_STEPS_PER_ROUND 8   /* the paper's */
typedef struct overlap_ctx {
    lbl_state *s;
    const vsd_frame_ctx *ctx;
    float albedo[3];              /* the medium's: the source */
    vsd_lbl_stepper *stepper;     /* the lattice prepared once for the rounds' steps */
    int steps;
} overlap_ctx;

static void diffuse_during_march(void *user)
{
    overlap_ctx *o = user;
    vsd_lbl_stepper_run(o->stepper, LBL_STEPS_PER_ROUND, 1);
    o->steps += LBL_STEPS_PER_ROUND;
}

static void deposit_record(void *user, int light, size_t c, int32_t rec, float t, float lost)
{
    overlap_ctx *o = user;
    lbl_state *s = o->s;
    double w = t;
    if (light >= s->dir_count) {
        const float *l = s->local_lights + (size_t)VSD_KLIGHT_FLOATS * (light - s->dir_count), *x = s->rg.record_pos + 4 * (size_t)rec;
        w *= vsd_light_falloff(l, f3(x[0], x[1], x[2]));
    }
    add_deposit(s, o->albedo, light, c, rec, w, lost);
}

/* The scene's point and spot lights into s->local_lights; *suns = how many suns it has (they
 * join the directional lights). */
static vsd_status split_scene_lights(lbl_state *s, const vsd_kernel_data *kd, int *suns)
{
    int k;
    s->local_count = 0;
    *suns = 0;
    for (k = 0; k < kd->scene_light_count; k++) {
        const float *l = kd->scene_lights + (size_t)VSD_KLIGHT_FLOATS * k;
        if ((int)l[3] == VSD_LIGHT_SUN) {
            ++*suns;
        } else {
            if (s->local_count >= VSD_MAX_LIGHTS) return VSD_ERR_INTERNAL;
            memcpy(s->local_lights + (size_t)VSD_KLIGHT_FLOATS * s->local_count++, l, VSD_KLIGHT_FLOATS * sizeof(float));
        }
    }
    return *suns < VSD_RECORDS_MAX_LIGHTS ? VSD_OK : VSD_ERR_INTERNAL;
}

/* A cell's record's six populations for readout_populations (ms6), each on its own (the
 * means of a node solve its cell's births: 0.06-0.08 s on one thread at 64^3). */
static void cell_populations(const cells_job *j, int32_t x, int32_t y, int32_t z, size_t c)
{
    lbl_state *s = j->s;
    const size_t n = cell_count(s);
    const double k = 6.0 / (s->cell_world * s->cell_world) / (4.0 * PI_D);
    const int32_t rec = s->rg.cell_record[c];
    int i, a;
    (void)x, (void)y, (void)z;
    if (rec < 0) return;
    for (a = 0; a < 3; a++) {
        float m[6], me[6] = {0};
        vsd_lbl_lattice_node_means(&s->lattice, s->lat_collide, s->lat_albedo, s->source, a, c, m);
        if (s->fluence_e && s->ff_paths_e)
            for (i = 0; i < 6; i++) me[i] = s->ff_paths_e[((size_t)i * 3 + a) * n + c];
        else if (s->fluence_e && s->lattice_e.f)
            vsd_lbl_lattice_node_means(&s->lattice_e, s->collide, no_scattering, s->source_e, a, c, me);
        if (s->ff_paths)
            for (i = 0; i < 6; i++) m[i] += s->ff_paths[((size_t)i * 3 + a) * n + c];
        for (i = 0; i < 6; i++) {
            double f = (double)m[i] - me[i];
            s->ms6[18 * (size_t)rec + 3 * i + a] = (float)(f > 0.0 ? f * k : 0.0);
        }
    }
}

/* With readout "phase" on the global D3Q6 lattice: each record's six populations (less the
 * emission's unscattered part) as the cone radiances of lbl_readout.h, per unit sigma_s
 * and before the cone weights: ms6[rec][i][ch] = 6 f_i / (4 pi lambda^2). */
static vsd_status readout_populations(lbl_state *s, const vsd_frame_ctx *ctx, const vsd_lbl_layout *layout, char *err,
                                      size_t errlen)
{
    const size_t recs = (size_t)s->rg.count;
    /* (g = 0: every cone weighs 1/6, the isotropic readout exactly: none needed) */
    if (s->opt.readout != LBL_READOUT_PHASE || layout->block_steps > 0 || layout->d3q18 || !s->lattice.f || recs == 0 ||
        ctx->kd.medium.anisotropy == 0.0f)
        return VSD_OK;
    if (!(s->ms6 = malloc(18 * recs * sizeof *s->ms6)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the populations of %zu records", recs);
    {
        cells_job job = {s, ctx, cell_populations};
        vsd_status st = vsd_cpu_run_each(s->rg.res[2], ctx->threads, cell_slices, &job, "lbl readout");
        return st ? vsd_fail(st, err, errlen, "lbl: the readout's threads failed") : VSD_OK;
    }
}

/* The part's records as a record grid for any direction: the lights' term per ray, the
 * diffused light as its isotropic fluence / 4 pi (view_grid bakes both toward an eye). */
static void records_grid(const lbl_state *s, const vsd_kernel_data *kd, vsd_krecord_grid *out)
{
    vsd_krecord_grid g;
    memset(&g, 0, sizeof g);
    g.kd = kd;
    g.cell_record = s->rg.cell_record;
    g.world_to_grid = s->rg.world_to_grid;
    memcpy(g.res, s->rg.res, sizeof g.res);
    g.record_count = s->rg.count;
    g.interp = s->opt.interp;
    g.kind = VSD_RECORDS_LIGHTS;
    g.lights = s->dir_lights;
    g.light_trans = s->light_trans;
    g.light_count = s->light_trans ? s->dir_count : 0;
    g.sub_count = s->light_trans ? s->sub_count : 0;
    g.local_lights = s->local_lights;
    g.local_trans = s->local_trans;
    g.local_count = s->local_trans ? s->local_count : 0;
    g.record_pos = s->rg.record_pos;
    g.records_ms = s->ms;
    g.records_emission_once = s->emission_once;
    *out = g;
}

/* The diffused light toward this view's eye per record (readout "phase"), into ms_view:
 * the lattice's populations, the light other groups send (lbl_exchange.h) and delta-M's
 * forward light (lbl_delta_m.h), each at the volume's true phase. */
static vsd_status readout_view(lbl_state *s, const vsd_frame_ctx *ctx, int with_forward, char *err, size_t errlen)
{
    const vsd_kcamera *cam = &ctx->kd.camera;
    const float *m = cam->cam_to_world.m;
    const vsd_f3 eye = f3(m[3], m[7], m[11]), forward = f3_scale(f3(m[2], m[6], m[10]), -1.0f);
    size_t r, recs = (size_t)s->rg.count;
    if (!s->ms_view && !(s->ms_view = malloc(3 * (recs ? recs : 1) * sizeof *s->ms_view)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for %zu view records", recs);
    for (r = 0; r < recs; r++) {
        const float *p = s->rg.record_pos + 4 * r, *f = s->ms6 + 18 * r;
        vsd_f3 d = cam->orthographic ? forward : f3_sub(f3(p[0], p[1], p[2]), eye);
        float w[6];
        int i, a;
        vsd_lbl_readout_weights(&s->readout, vsd_affine_vector(&s->rg.world_to_grid, d), w);
        for (a = 0; a < 3; a++) {
            float v = 0.0f;
            for (i = 0; i < 6; i++) v += w[i] * f[3 * i + a];
            s->ms_view[3 * r + a] = v;
        }
        if (s->exchange_irr) {
            /* the other groups' light, scattered once here toward the eye (lbl_exchange.h) */
            const float *e = s->exchange_irr + 3 * (size_t)s->exchange.count * r;
            d = f3_normalize(d);
            for (i = 0; i < s->exchange.count; i++) {
                float ph = vsd_hg_eval(f3_dot(d, s->exchange.light[i].w), ctx->kd.medium.anisotropy);
                for (a = 0; a < 3; a++) s->ms_view[3 * r + a] += ph * e[3 * i + a];
            }
        }
    }
    if (s->fwd_trans && with_forward) {
        /* delta-M's forward light, E (T' - T) per light, at the true phase toward the eye:
         * the lights' bake with T' - T for T (view_grid's own bake does it alongside, with
         * the same phase weights, where the view bakes the lights on the CPU) */
        vsd_krecord_grid g;
        float *fwd = malloc(3 * (recs ? recs : 1) * sizeof *fwd);
        if (!fwd) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for %zu view records", recs);
        records_grid(s, &ctx->kd, &g);
        vsd_record_grid_bake_view_lights(&g, s->rg.record_pos, ctx->threads, s->fwd_trans, s->fwd_local, fwd);
        for (r = 0; r < 3 * recs; r++) s->ms_view[r] += fwd[r];
        free(fwd);
    }
    return VSD_OK;
}

/* A part's cells scatter with their group's mixed albedo, sigma_s / sigma_t over the same
 * 27 samples as the cells' extinction (the medium's own where no volume has density). The
 * albedos are lighting-stage inputs: an edit of one volume's albedo reaches this, not the
 * frame stage. */
static void cell_albedo(const cells_job *j, int32_t x, int32_t y, int32_t z, size_t c)
{
    lbl_state *s = j->s;
    const size_t n = cell_count(s);
    const vsd_f3 own = j->ctx->kd.medium.albedo;
    double sum = 0.0, scatter[3] = {0.0, 0.0, 0.0};
    int k;
    for (k = 0; k < 27; k++)
        sum += vsd_group_scattering(&j->ctx->kd, j->ctx->part.group, cell_sample(s, x, y, z, k), scatter);
    s->albedo_cells[c] = (float)(sum > 0.0 ? scatter[0] / sum : own.x);
    s->albedo_cells[n + c] = (float)(sum > 0.0 ? scatter[1] / sum : own.y);
    s->albedo_cells[2 * n + c] = (float)(sum > 0.0 ? scatter[2] / sum : own.z);
}

static vsd_status mix_albedo_cells(lbl_state *s, const vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    cells_job job = {s, ctx, cell_albedo};
    vsd_status st = vsd_cpu_run_each(s->rg.res[2], ctx->threads, cell_slices, &job, "lbl cells");
    return st ? vsd_fail(st, err, errlen, "lbl: the cells' threads failed") : VSD_OK;
}

/* The first flight's photons summed over the cones (0 without it). */
static double first_flight_fluence(const float *paths, size_t n, int a, size_t c)
{
    double sum = 0.0;
    int i;
    for (i = 0; paths && i < 6; i++) sum += paths[((size_t)i * 3 + a) * n + c];
    return sum;
}

/* The records' diffused light from the lattice's steady state: VolumeInd's source per unit
 * sigma_s, phi / 4pi, phi = the cell's photons / lambda^2 (less the emission's unscattered
 * fluence, VolumeDir's emission_once), and with readout "phase" the populations (ms6). */
static vsd_status records_from_fluence(lbl_state *s, const vsd_frame_ctx *ctx, const vsd_lbl_layout *layout, char *err,
                                       size_t errlen)
{
    const size_t n = cell_count(s);
    size_t c;
    int a;
    for (c = 0; c < n; c++) {
        int32_t rec = s->rg.cell_record[c];
        if (rec < 0) continue;
        for (a = 0; a < 3; a++) {
            double k = 1.0 / (s->cell_world * s->cell_world) / (4.0 * PI_D), phi = s->fluence[(size_t)a * n + c];
            phi += first_flight_fluence(s->ff_paths, n, a, c);
            if (s->fluence_e) {
                double phi_e = s->fluence_e[(size_t)a * n + c];
                s->emission_once[3 * (size_t)rec + a] = (float)(phi_e * k);
                phi = phi > phi_e ? phi - phi_e : 0.0;
            }
            s->ms[3 * (size_t)rec + a] = (float)(phi * k);
        }
    }
    free(s->ms6);
    s->ms6 = NULL;
    return readout_populations(s, ctx, layout, err, errlen);
}

static vsd_status exchange_between_groups(lbl_state *s, vsd_frame_ctx *ctx, char *err, size_t errlen);

/* Whether every volume of the lattice's medium (the part's group) that scatters has the
 * part's phase: delta-M scales the whole medium with one g (a pure absorber's lobe scatters
 * nothing, so it does not count). */
static int one_phase(const vsd_frame_ctx *ctx)
{
    int j;
    for (j = 0; ctx->part.active && j < ctx->kd.volume_count; j++) {
        const vsd_kmedium *m = &ctx->kd.volumes[j].medium;
        if (!((ctx->part.group >> j) & 1u) || m->anisotropy == ctx->kd.medium.anisotropy) continue;
        if (m->albedo.x > 0.0f || m->albedo.y > 0.0f || m->albedo.z > 0.0f) return 0;
    }
    return 1;
}

/* The cells' shape the lattice and the escape take: the boxes they are, or NULL = cubes. */
static const double *lattice_cell_shape(const lbl_state *s)
{
    return s->opt.cell_shape == LBL_SHAPE_BOXES ? s->cell_shape : NULL;
}

/* *keep (allocated on first use) = the surface escape's keep through sigma (lbl_escape.h). */
static vsd_status escape_keep(const lbl_state *s, const float *sigma, int threads, float **keep, char *err, size_t errlen)
{
    const size_t n = cell_count(s);
    if ((!*keep && !(*keep = malloc(n * sizeof **keep))) ||
        !vsd_lbl_escape_keep(s->rg.res, sigma, s->cell_world, lattice_cell_shape(s), threads, *keep)) {
        free(*keep), *keep = NULL;
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the surface escape of %zu cells", n);
    }
    return VSD_OK;
}

/* s->keep, the escape through the cells' own medium, made when first read (surface_escape on). */
static vsd_status own_keep(lbl_state *s, int threads, char *err, size_t errlen)
{
    return s->opt.escape && !s->keep ? escape_keep(s, s->sigma, threads, &s->keep, err, errlen) : VSD_OK;
}

/* The medium the lattice solves: the cells' own, or with delta-M (lbl_delta_m.h) the scaled
 * problem's, with the forward light's arrays. */
static vsd_status lattice_medium(lbl_state *s, const vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    const size_t n = cell_count(s), recs = (size_t)s->rg.count;
    const float g = ctx->kd.medium.anisotropy;
    const float albedo[3] = {ctx->kd.medium.albedo.x, ctx->kd.medium.albedo.y, ctx->kd.medium.albedo.z};
    s->lat_sigma = s->sigma;
    s->lat_collide = s->collide;
    s->lat_albedo_cells = s->albedo_cells;
    memcpy(s->lat_albedo, albedo, sizeof albedo);
    if (!s->opt.delta_m || s->opt.lattice_phase != LBL_PHASE_HG || s->opt.readout != LBL_READOUT_PHASE ||
        !s->source_dirs || !(g > 0.0f) || s->opt.history > 0 || !one_phase(ctx)) {
        vsd_status st = own_keep(s, ctx->threads, err, errlen);
        s->lat_keep = s->keep;
        return st;
    }
    s->dm_sigma = malloc(n * sizeof *s->dm_sigma);
    s->dm_collide = malloc(n * sizeof *s->dm_collide);
    s->dm_albedo_cells = s->albedo_cells ? malloc(3 * n * sizeof *s->dm_albedo_cells) : NULL;
    s->fwd_trans = calloc(recs * (size_t)(s->dir_count > 0 ? s->dir_count : 1), sizeof *s->fwd_trans);
    s->fwd_local = calloc(recs * (size_t)(s->local_count > 0 ? s->local_count : 1), sizeof *s->fwd_local);
    if (!s->dm_sigma || !s->dm_collide || (s->albedo_cells && !s->dm_albedo_cells) || !s->fwd_trans || !s->fwd_local)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for delta-M's medium of %zu cells", n);
    vsd_lbl_delta_m_cells(n, s->sigma, s->cell_world, s->albedo_cells, albedo, (double)g * g, s->dm_sigma,
                          s->dm_collide, s->dm_albedo_cells, s->lat_albedo);
    s->lat_sigma = s->dm_sigma;
    s->lat_collide = s->dm_collide;
    s->lat_albedo_cells = s->dm_albedo_cells;
    if (s->opt.escape) {
        /* A birth near the surface escapes through the medium the lattice solves: the
         * scaled one, about half as thick at g 0.7 (the forward peak goes on unscattered).
         * With the true medium's escape the lattice kept too much of it: cloud256's rims
         * were bright (docs/methods/lbl.md, "The escape through the scaled medium"). */
        if (!s->dm_keep || memcmp(s->dm_keep_sigma, s->dm_sigma, n * sizeof *s->dm_sigma)) {
            vsd_status st = escape_keep(s, s->dm_sigma, ctx->threads, &s->dm_keep, err, errlen);
            if (!st && !s->dm_keep_sigma && !(s->dm_keep_sigma = malloc(n * sizeof *s->dm_keep_sigma)))
                st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for delta-M's medium of %zu cells", n);
            if (st) {
                free(s->dm_keep), s->dm_keep = NULL;
                return st;
            }
            memcpy(s->dm_keep_sigma, s->dm_sigma, n * sizeof *s->dm_sigma);
        }
        s->lat_keep = s->dm_keep;
    }
    vsd_lbl_readout_build(&s->readout_dm, g / (1.0f + g));
    return VSD_OK;
}

/* The point and spot lights' falloff (1/d^2, the sphere, the spot's mask) at each record. */
static void local_falloff(const lbl_state *s, float *local_trans)
{
    size_t c;
    int q;
    for (c = 0; c < (size_t)s->rg.count; c++)
        for (q = 0; q < s->local_count; q++) {
            const float *x = s->rg.record_pos + 4 * c;
            local_trans[c * s->local_count + q] *=
                vsd_light_falloff(s->local_lights + (size_t)VSD_KLIGHT_FLOATS * q, f3(x[0], x[1], x[2]));
        }
}

/* The lights through the cells of `grid` (lbl_march.h's contract): the directional ones by
 * sweeps of the cells (light_march "sweep", lbl_sweep.h) where no refraction bends them and
 * no ray history overlaps them with the diffusion, the rest by the paper's rays. */
static vsd_status march_rays_or_sweep(const lbl_state *s, const vsd_lbl_grid *grid, const float *lights, int count,
                                      const float *points, int point_count, int threads, const vsd_lbl_march_out *out,
                                      vsd_lbl_overlap *overlap, char *err, size_t errlen)
{
    const int sweep = s->opt.light_march == LBL_MARCH_SWEEP && !grid->refract && !overlap;
    vsd_status st =
        sweep ? vsd_lbl_sweep_lights(grid, lights, count, s->rg.cell_record, s->rg.count, threads, out, err, errlen) : VSD_OK;
    return st ? st
              : vsd_lbl_march_lights(grid, lights, sweep ? 0 : count, points, point_count, (float)s->opt.ray_spacing,
                                     (float)s->opt.light_step, s->rg.cell_record, threads, out, overlap, err, errlen);
}

/* Every light marched through the cells of `grid` into the records, for each of its media
 * (out[0]: grid->sigma's, out[1]: grid->sigma2's): T into trans and point_trans (the point
 * and spot lights' falloff applied), the power the rays lost into lost (or NULL), then the
 * shadows of the volumes outside the group (light reaching the grid's box has crossed
 * them). The true extinction for the records, and with delta-M the scaled one for its
 * lattice (T' into fwd_trans and fwd_local) along the same rays. overlap: the ray
 * history's, or NULL. */
static vsd_status march_lights(lbl_state *s, const vsd_frame_ctx *ctx, const vsd_lbl_grid *grid,
                               const vsd_lbl_march_out *out, vsd_lbl_overlap *overlap, char *err, size_t errlen)
{
    vsd_status st = march_rays_or_sweep(s, grid, s->dir_lights, s->dir_count, s->local_lights, s->local_count,
                                        ctx->threads, out, overlap, err, errlen);
    int m;
    if (st) return st;
    for (m = 0; m < (grid->sigma2 ? 2 : 1); m++) {
        local_falloff(s, out[m].point_trans);
        if (ctx->part.active)
            vsd_group_shadow_records(&ctx->kd, ctx->part.group, s->rg.record_pos, s->rg.count, s->dir_lights,
                                     s->dir_count, s->local_lights, s->local_count, out[m].trans, out[m].lost,
                                     out[m].point_trans, ctx->threads);
    }
    return VSD_OK;
}

/* T' - T: what the true problem scattered forward (VolumeInd, read per view), for records
 * [4096 x0, 4096 x1) (items). */
static void forward_items(void *user, int x0, int y0, int x1, int y1)
{
    lbl_state *s = user;
    const size_t recs = (size_t)s->rg.count, r0 = (size_t)x0 * 4096, r1 = (size_t)x1 * 4096 < recs ? (size_t)x1 * 4096 : recs;
    size_t i;
    (void)y0, (void)y1;
    for (i = r0 * s->dir_count; i < r1 * s->dir_count; i++) s->fwd_trans[i] = fmaxf(s->fwd_trans[i] - s->light_trans[i], 0.0f);
    for (i = r0 * s->local_count; i < r1 * s->local_count; i++)
        s->fwd_local[i] = fmaxf(s->fwd_local[i] - s->local_trans[i], 0.0f);
}

static void forward_light(lbl_state *s, int threads)
{
    /* (the pool fails only when cancelled, which this stage is not) */
    (void)vsd_cpu_run_each((s->rg.count + 4095) / 4096, threads, forward_items, s, "lbl forward light");
}

/* The cells as the light march reads them (lbl_march.h). */
static void march_grid(const lbl_state *s, vsd_lbl_grid *grid)
{
    int a, q;
    memset(grid, 0, sizeof *grid);
    memcpy(grid->res, s->rg.res, sizeof grid->res);
    grid->sigma = s->sigma;
    for (a = 0; a < 3; a++)
        for (q = 0; q < 3; q++) grid->to_grid[3 * a + q] = s->rg.world_to_grid.m[4 * a + q];
    grid->refract = s->refraction.k.ng ? &s->refraction.k : NULL;
    grid->empty_d2 = s->opt.leaps ? s->empty_d2 : NULL;
    grid->world_to_grid = s->rg.world_to_grid;
    for (a = 0; a < 12; a++) grid->grid_to_world.m[a] = (float)s->g2w[a];
}

/* first_flight where its rows' `when` holds: the global D3Q6 lattice, the path in the cell. */
static int first_flight_on(const lbl_state *s, const vsd_lbl_layout *layout)
{
    return s->opt.first_flight && layout->block_steps == 0 && !layout->d3q18 && s->opt.cell_light == VSD_LBL_CELL_PATH;
}

/* The first flight of source (lbl_first_flight.h) through sigma: *paths (allocated), and
 * the collisions after it born again into births (NULL = not wanted; may be the source). */
static vsd_status fly(const lbl_state *s, const float *sigma, const float *source, int per_direction,
                      const float *albedo_cells, const float albedo[3], float **paths, float *births,
                      const vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    const size_t n = cell_count(s);
    vsd_lbl_first_flight in;
    if (!(*paths = malloc(18 * n * sizeof **paths)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the first flight of %zu cells", n);
    memset(&in, 0, sizeof in);
    memcpy(in.res, s->rg.res, sizeof in.res);
    in.sigma = sigma;
    in.cell_world = s->cell_world;
    in.shape = lattice_cell_shape(s);
    in.source = source;
    in.per_direction = per_direction;
    in.albedo_cells = albedo_cells;
    memcpy(in.albedo, albedo, sizeof in.albedo);
    in.forward = s->lattice.forward, in.backward = s->lattice.backward, in.side = s->lattice.side;
    return vsd_lbl_first_flight_run(&in, ctx->threads, births, *paths, err, errlen);
}

/* The lattice's births (the deposit and the emission) flown to their next collision: the
 * lattice's source becomes, in place, those collisions born again. */
static vsd_status fly_births(lbl_state *s, const vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    return fly(s, s->lat_sigma, s->source, s->source_dirs, s->lat_albedo_cells, s->lat_albedo, &s->ff_paths, s->source,
               ctx, err, errlen);
}

/* The emission's light before any scattering, through the true medium: its first flight
 * (in place of the albedo-0 lattice). */
static vsd_status fly_emission(lbl_state *s, const vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    const size_t n = cell_count(s);
    size_t c;
    int a;
    vsd_status st = fly(s, s->sigma, s->source_e, 0, NULL, no_scattering, &s->ff_paths_e, NULL, ctx, err, errlen);
    for (a = 0; a < 3 && !st; a++)
        for (c = 0; c < n; c++) s->fluence_e[(size_t)a * n + c] = (float)first_flight_fluence(s->ff_paths_e, n, a, c);
    return st;
}

static vsd_status lbl_prepare_lighting(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    lbl_state *s = state;
    const vsd_scene *sc = ctx->scene;
    const size_t n = cell_count(s), recs = (size_t)s->rg.count;
    vsd_lbl_grid grid;
    float albedo[3];
    const vsd_lbl_layout layout = {s->opt.block_steps, s->opt.lattice == 1};
    double t0;
    vsd_status st;
    int a, q;
    int suns;
    free_lighting(s);
    if (s->parts.count) {
        if ((st = vsd_parts_prepare_lighting(&s->parts, &vsd_method_lbl, ctx, err, errlen)) || !s->parts.relit)
            return st;
        return exchange_between_groups(s, ctx, err, errlen);
    }
    if (s->field && ctx->kd.density.scale != s->sigma_density) {
        /* a density edit (density_in_lighting): the cells' medium for the new density, and
           what the escape kept through the old one made again when read (dm_keep follows
           delta-M's medium by itself) */
        apply_density(s, ctx->kd.density.scale);
        free(s->keep);
        s->keep = NULL;
    }
    if (s->albedo_cells && (st = mix_albedo_cells(s, ctx, err, errlen))) return st;
    if ((st = split_scene_lights(s, &ctx->kd, &suns))) return vsd_fail(st, err, errlen, "lbl: internal: too many lights");
    /* the record grid's per-ray weights hold VSD_RECORDS_MAX_LIGHTS directional lights,
     * the scene's suns among them */
    if ((st = vsd_constellation_cache_update_grouped(
             &s->cc, ctx->env, s->opt.lights + suns > VSD_RECORDS_MAX_LIGHTS ? VSD_RECORDS_MAX_LIGHTS - suns : s->opt.lights,
             s->opt.sub_lights, VSD_LIGHTS_MEDIAN_CUT, sc->environment.strength, sc->environment.rotation_z, err, errlen)))
        return st;
    s->dir_count = 0;
    for (a = 0; a < s->cc.count && s->dir_count < VSD_RECORDS_MAX_LIGHTS; a++)
        memcpy(s->dir_lights + 8 * s->dir_count++, s->cc.lights + 8 * a, 8 * sizeof(float));
    for (a = 0; a < ctx->kd.scene_light_count && s->dir_count < VSD_RECORDS_MAX_LIGHTS; a++) {
        const float *l = ctx->kd.scene_lights + (size_t)VSD_KLIGHT_FLOATS * a;
        float *d = s->dir_lights + 8 * s->dir_count;
        if ((int)l[3] != VSD_LIGHT_SUN) continue;
        /* a sun as a directional light of irradiance S (its angle is left out: a real sun's
         * half degree blurs nothing at the cells' scale) */
        d[0] = l[0], d[1] = l[1], d[2] = l[2], d[3] = 0.0f;
        d[4] = l[4], d[5] = l[5], d[6] = l[6], d[7] = 0.0f;
        s->dir_count++;
    }
    /* the sub-lights: the map's, each naming its light, and every sun as its own */
    s->sub_count = 0;
    if (s->cc.sub_count > 0) {
        float *sub = s->dir_lights + 8 * (size_t)s->dir_count;
        memcpy(sub, s->cc.lights + 8 * (size_t)s->cc.count, 8 * sizeof(float) * (size_t)s->cc.sub_count);
        s->sub_count = s->cc.sub_count;
        for (a = s->cc.count; a < s->dir_count; a++, s->sub_count++) {
            memcpy(sub + 8 * (size_t)s->sub_count, s->dir_lights + 8 * (size_t)a, 8 * sizeof(float));
            sub[8 * (size_t)s->sub_count + 7] = (float)a;
        }
    }
    if (n == 0 || recs == 0) return VSD_OK;
    s->light_trans = calloc(recs * (size_t)(s->dir_count > 0 ? s->dir_count : 1), sizeof *s->light_trans);
    s->local_trans = calloc(recs * (size_t)(s->local_count > 0 ? s->local_count : 1), sizeof *s->local_trans);
    if (s->opt.light_deposit == LBL_DEPOSIT_LOST &&
        !(s->light_lost = calloc(recs * (size_t)(s->dir_count > 0 ? s->dir_count : 1), sizeof *s->light_lost)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the lost power of %zu records", recs);
    /* the lattice's phase: with directions the source is per direction; so too where light
     * from near volumes outside the group comes in at the faces */
    s->receives = s->opt.exchange && ctx->part.active && layout.block_steps == 0 && !layout.d3q18 &&
                  vsd_group_near_outside(&ctx->kd, ctx->part.group);
    s->source_dirs = ((s->opt.lattice_phase == LBL_PHASE_HG && ctx->kd.medium.anisotropy != 0.0f) || s->receives) &&
                     layout.block_steps == 0 && !layout.d3q18;
    vsd_lbl_readout_build(&s->readout, ctx->kd.medium.anisotropy);
    s->source = malloc(source_floats(s) * sizeof *s->source);
    s->fluence = malloc(3 * n * sizeof *s->fluence);
    s->ms = malloc(3 * recs * sizeof *s->ms);
    if (vsd_group_emits(&ctx->kd, vsd_ctx_group(ctx))) {
        s->source_e = malloc(3 * n * sizeof *s->source_e);
        s->fluence_e = malloc(3 * n * sizeof *s->fluence_e);
        s->emission_once = malloc(3 * recs * sizeof *s->emission_once);
    }
    if (!s->light_trans || !s->local_trans || !s->source || !s->fluence || !s->ms ||
        (vsd_group_emits(&ctx->kd, vsd_ctx_group(ctx)) && (!s->source_e || !s->fluence_e || !s->emission_once)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the lighting of %zu cells", n);
    /* marching pass */
    march_grid(s, &grid);
    /* the lattice first: with a ray history it steps while the rays march */
    if ((st = vsd_lbl_lattice_init(&s->lattice, s->rg.res, &layout, err, errlen))) return st;
    vsd_lbl_lattice_set_cell_light(&s->lattice, s->opt.cell_light);
    vsd_lbl_lattice_set_order(&s->lattice, s->opt.lattice_order);
    vsd_lbl_lattice_set_cell_shape(&s->lattice, lattice_cell_shape(s));
    if ((st = lattice_medium(s, ctx, err, errlen))) return st;
    vsd_lbl_lattice_set_keep(&s->lattice, s->lat_keep);
    vsd_lbl_lattice_set_albedo_cells(&s->lattice, s->lat_albedo_cells);
    if (s->opt.lattice_phase == LBL_PHASE_HG && s->source_dirs) {
        /* the lattice's phase and the first scattering's cone shares: delta-M's g / (1 + g) */
        const vsd_lbl_readout *shares = s->dm_sigma ? &s->readout_dm : &s->readout;
        float f, b, sd;
        vsd_lbl_readout_lattice_phase(shares->g, &f, &b, &sd);
        vsd_lbl_lattice_set_phase(&s->lattice, f, b, sd);
        for (a = 0; a < s->dir_count; a++) {
            const float *l = s->dir_lights + 8 * (size_t)a;
            vsd_lbl_readout_weights(shares, vsd_affine_vector(&s->rg.world_to_grid, f3(l[0], l[1], l[2])),
                                    s->dir_shares[a]);
        }
    } else {
        vsd_lbl_lattice_set_phase(&s->lattice, 1.0f / 6.0f, 1.0f / 6.0f, 1.0f / 6.0f);
        for (a = 0; a < s->dir_count; a++)
            for (q = 0; q < 6; q++) s->dir_shares[a][q] = 1.0f / 6.0f;
    }
    if (s->source_dirs) vsd_lbl_lattice_set_source_per_direction(&s->lattice);
    memcpy(albedo, s->lat_albedo, sizeof albedo);
    t0 = vsd_clock_seconds();
    {
        overlap_ctx oc;
        vsd_lbl_overlap ov = {s->opt.history, diffuse_during_march, deposit_record, &oc, 0};
        oc.s = s;
        oc.ctx = ctx;
        memcpy(oc.albedo, albedo, sizeof albedo);
        oc.steps = 0;
        oc.stepper = NULL;
        if (s->opt.history > 0) {
            memset(s->source, 0, source_floats(s) * sizeof *s->source);
            if (s->source_e) {
                emission_source(s, ctx);
                add_emission(s);
            }
            if ((st = vsd_lbl_stepper_new(&s->lattice, s->lat_collide, albedo, s->source, &oc.stepper, err, errlen)))
                return st;
        }
        /* with delta-M, the scaled extinction too (what feeds its lattice, the power lost
           into lost_dm when the deposit takes it), along the same rays */
        vsd_lbl_march_out out[2] = {{s->light_trans, s->light_lost, s->local_trans}, {s->fwd_trans, NULL, s->fwd_local}};
        if (s->dm_sigma) {
            grid.sigma2 = s->dm_sigma;
            if (s->light_lost && !(out[1].lost = calloc(recs * (size_t)(s->dir_count > 0 ? s->dir_count : 1),
                                                        sizeof *out[1].lost))) {
                vsd_lbl_stepper_free(oc.stepper);
                return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the lost power of %zu records", recs);
            }
        }
        st = march_lights(s, ctx, &grid, out, s->opt.history > 0 ? &ov : NULL, err, errlen);
        vsd_lbl_stepper_free(oc.stepper);
        if (!st && s->dm_sigma) {
            deposit(s, ctx, s->fwd_trans, out[1].lost, s->fwd_local);
            forward_light(s, ctx->threads);
        } else if (!st) {
            deposit(s, ctx, s->light_trans, s->light_lost, s->local_trans);
        }
        free(out[1].lost);
        if (st) return st;
        s->history_rounds = s->opt.history > 0 ? ov.rounds : 0;
        s->history_steps = oc.steps;
    }
    s->march_seconds = vsd_clock_seconds() - t0;
    t0 = vsd_clock_seconds();
    if (first_flight_on(s, &layout) && (st = fly_births(s, ctx, err, errlen))) return st;
    s->flight_seconds = vsd_clock_seconds() - t0;
    /* diffusion pass to the steady state, from the last solve's state (or the overlap's) */
    if ((st = vsd_lbl_diffuse(&s->lattice, s->lat_collide, albedo, s->source, s->opt.tolerance,
                              s->opt.max_steps - s->history_steps > 8 ? s->opt.max_steps - s->history_steps : 8,
                              ctx->threads, s->fluence, &s->diffusion, err, errlen)))
        return st;
    s->diffusion.steps += s->history_steps;   /* all the lattice's steps of this solve */
    if (s->source_e && first_flight_on(s, &layout)) {
        t0 = vsd_clock_seconds();
        if ((st = fly_emission(s, ctx, err, errlen))) return st;
        s->flight_seconds += vsd_clock_seconds() - t0;
    } else if (s->source_e) {
        /* The emission's fluence before any scattering: the same lattice without scattering
         * (albedo 0), fed by the emission alone. Scattered toward the camera it is light
         * that scattered once: VolumeDir, as Cycles counts it (docs/design-notes.md,
         * "Passes"); the rest of the fluence scatters again before it gets there. */
        vsd_lbl_diffusion_stats stats_e;
        if ((st = vsd_lbl_lattice_init(&s->lattice_e, s->rg.res, &layout, err, errlen))) return st;
        vsd_lbl_lattice_set_cell_light(&s->lattice_e, s->opt.cell_light);
        vsd_lbl_lattice_set_order(&s->lattice_e, s->opt.lattice_order);
        vsd_lbl_lattice_set_cell_shape(&s->lattice_e, lattice_cell_shape(s));
        if ((st = own_keep(s, ctx->threads, err, errlen))) return st;
        vsd_lbl_lattice_set_keep(&s->lattice_e, s->keep);
        if ((st = vsd_lbl_diffuse(&s->lattice_e, s->collide, no_scattering, s->source_e, s->opt.tolerance,
                                  s->opt.max_steps, ctx->threads, s->fluence_e, &stats_e, err, errlen)))
            return st;
        s->diffusion.seconds += stats_e.seconds;
        s->emission_steps = stats_e.steps;
    }
    return records_from_fluence(s, ctx, &layout, err, errlen);
}

static vsd_sample_result bent_sample(const void *m, int x, int y, int s, int n)
{
    return vsd_lbl_bent_sample((const vsd_klbl_bent *)m, x, y, s, n);
}

/* bent view rays have no device entry yet: the CPU threads run them */
static const vsd_device_pass bent_view_pass = {
    "ray marching (refracted)", 1, 256, sizeof(vsd_klbl_bent), offsetof(vsd_klbl_bent, g.kd), bent_sample, NULL, NULL,
    NULL,
};

/* The view through a refracting medium (lbl_kernel.h), with the records baked for this view. */
static vsd_status render_bent(lbl_state *s, vsd_frame_ctx *ctx, vsd_framebuffer *fb, const vsd_krecord_grid *g,
                              int *samples, char *err, size_t errlen)
{
    vsd_klbl_bent b;
    b.g = *g;
    b.r = s->refraction.k;
    ctx->kd.march_stop = (float)s->opt.early_termination;
    /* no device entry: the CPU threads (vsd_method_render_view) */
    return vsd_method_render_view(ctx, fb, s->opt.pixel_samples, &s->opt.view, &bent_view_pass, NULL, &b, samples, err,
                                  errlen);
}

/* The record grid the view reads, *g, with the lights' term baked for this view where the
 * CPU renders it; also a part's (vsd_part_view_fn, src/method/method_parts.h). */
static vsd_status view_grid(void *state, vsd_frame_ctx *ctx, vsd_krecord_grid *g_out, char *err, size_t errlen)
{
    lbl_state *s = state;
    vsd_krecord_grid g;
    /* on the CPU the lights' term is baked per view; the device keeps its arrays per
     * lighting generation, so there the march sums the lights per ray (exact phase) */
    /* (bent view rays always read baked records: they run on the CPU) */
    const int bake = (!ctx->cuda || s->refraction.k.ng) && (s->opt.view_bake || s->refraction.k.ng) && s->light_trans;
    records_grid(s, &ctx->kd, &g);
    if (s->ms6) {
        vsd_status st = readout_view(s, ctx, !bake, err, errlen);
        if (st) return st;
        g.records_ms = s->ms_view;
        g.records_ms_per_view = 1;
    }
    if (bake) {
        if (!s->view_baked && !(s->view_baked = malloc(3 * (size_t)s->rg.count * sizeof *s->view_baked)))
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for %d view records", (int)s->rg.count);
        if (s->fwd_trans && s->ms_view) {
            /* delta-M's forward light with the lights' own phase weights (readout_view) */
            const size_t n3 = 3 * (size_t)s->rg.count;
            float *fwd = malloc((n3 ? n3 : 1) * sizeof *fwd);
            size_t r;
            if (!fwd) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for %d view records", (int)s->rg.count);
            vsd_record_grid_bake_view_pair(&g, s->rg.record_pos, ctx->threads, s->view_baked, s->fwd_trans, s->fwd_local,
                                           fwd);
            for (r = 0; r < n3; r++) s->ms_view[r] += fwd[r];
            free(fwd);
        } else {
            vsd_record_grid_bake_view(&g, s->rg.record_pos, ctx->threads, s->view_baked);
        }
        vsd_record_grid_use_baked(&g, s->view_baked);
    }
    *g_out = g;
    return VSD_OK;
}

typedef struct receive_job {
    lbl_state *p;
    const float *albedo;          /* the lattice's (delta-M's scaled one where it runs) */
    const float *trans, *lost;
    /* the true T where delta-M's T' is `trans` and some light is emitted (the emission
     * scattered once is VolumeDir, T' - T of it VolumeInd), else trans */
    const float *trans_true;
    const float (*shares)[6];
    float *once_s, *once_e;
    int per_view;
} receive_job;

/* receive_exchange's records in the cells of slices [z0, z1) */
static void receive_slices(void *arg, int z0, int y0, int z1, int y1)
{
    const receive_job *j = arg;
    lbl_state *p = j->p;
    const size_t n = cell_count(p);
    const int k_count = p->exchange.count;
    const double lambda2 = p->cell_world * p->cell_world, lambda3 = lambda2 * p->cell_world, k4pi = 1.0 / (4.0 * PI_D);
    const double dw = p->exchange.domega;
    int32_t x, y, z;
    int k, i, ch;
    (void)y0;
    (void)y1;
    for (z = z0; z < z1; z++)
        for (y = 0; y < p->rg.res[1]; y++)
            for (x = 0; x < p->rg.res[0]; x++) {
                const size_t c = (size_t)x + (size_t)p->rg.res[0] * ((size_t)y + (size_t)p->rg.res[1] * z);
                const int32_t rec = p->rg.cell_record[c];
                const vsd_f3 q = f3(x + 0.5f, y + 0.5f, z + 0.5f);
                double a3[3];
                if (rec < 0) continue;
                for (ch = 0; ch < 3; ch++)
                    a3[ch] = p->lat_albedo_cells ? p->lat_albedo_cells[(size_t)ch * n + c] : j->albedo[ch];
                for (k = 0; k < k_count; k++) {
                    const size_t at = (size_t)rec * k_count + k;
                    const double t = j->trans[at], w = j->lost ? j->lost[at] * lambda3 : t * p->lat_collide[c] * lambda2;
                    const double t1 = j->trans_true[at];
                    vsd_f3 ls, le;
                    double es[3], ee[3];
                    if (!(t > 0.0) && !(w > 0.0)) continue;
                    vsd_lbl_exchange_radiance(&p->exchange, k, q, &ls, &le);
                    es[0] = ls.x * dw, es[1] = ls.y * dw, es[2] = ls.z * dw;
                    ee[0] = le.x * dw, ee[1] = le.y * dw, ee[2] = le.z * dw;
                    for (ch = 0; ch < 3; ch++) {
                        /* the first scattering here, toward the eye */
                        const double ind = es[ch] * t + ee[ch] * (t - t1);
                        j->once_e[3 * (size_t)rec + ch] += (float)(ee[ch] * t1 * k4pi);
                        if (j->per_view) p->exchange_irr[3 * at + ch] = (float)ind;
                        else j->once_s[3 * (size_t)rec + ch] += (float)(ind * k4pi);
                        /* what it loses in the cell, scattered into the lattice */
                        for (i = 0; i < 6; i++)
                            p->source[((size_t)i * 3 + ch) * n + c] +=
                                (float)(a3[ch] * (es[ch] + ee[ch]) * w * j->shares[k][i]);
                    }
                }
            }
}

/* Part p's light from the other groups (lbl_exchange.h), gathered into p->exchange: each
 * kept direction's rays march through the cells as the lights' do; its light at each record
 * goes into the lattice's source (the power lost in the cell, the phase's cone shares) and,
 * scattered once toward the eye, into exchange_irr (VolumeInd, read per view) or, for the
 * emitted part and the isotropic readout, into the records' isotropic terms (*once_e:
 * VolumeDir's emission scattered once; *once_s: VolumeInd), per unit sigma_s. */
static vsd_status receive_exchange(lbl_state *p, const vsd_frame_ctx *pc, float *once_s, float *once_e, char *err,
                                   size_t errlen)
{
    const size_t recs = (size_t)p->rg.count;
    const int k_count = p->exchange.count;
    float *lights = calloc(8 * (size_t)k_count, sizeof *lights), *trans = malloc(recs * k_count * sizeof *trans),
          *lost = p->light_lost ? malloc(recs * k_count * sizeof *lost) : NULL, points_trans = 0.0f,
          *trans_true = p->dm_sigma && p->exchange.emits ? malloc(recs * k_count * sizeof *trans_true) : NULL;
    float (*shares)[6] = malloc((size_t)k_count * sizeof *shares);
    const int per_view = p->ms6 != NULL;
    vsd_lbl_grid grid;
    vsd_status st = VSD_OK;
    int k, i;
    if (per_view && !(p->exchange_irr = calloc(3 * recs * k_count, sizeof *p->exchange_irr))) st = VSD_ERR_NOMEM;
    if (st || !lights || !trans || !shares || (p->light_lost && !lost) ||
        (p->dm_sigma && p->exchange.emits && !trans_true)) {
        free(lights), free(trans), free(lost), free(shares), free(trans_true);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the light between groups at %zu records", recs);
    }
    for (k = 0; k < k_count; k++) {
        const vsd_f3 w = p->exchange.light[k].w;
        lights[8 * k] = w.x, lights[8 * k + 1] = w.y, lights[8 * k + 2] = w.z;
        lights[8 * k + 4] = lights[8 * k + 5] = lights[8 * k + 6] = 1.0f;
        if (p->opt.lattice_phase == LBL_PHASE_HG)
            vsd_lbl_readout_weights(p->dm_sigma ? &p->readout_dm : &p->readout,
                                    vsd_affine_vector(&p->rg.world_to_grid, w), shares[k]);
        else
            for (i = 0; i < 6; i++) shares[k][i] = 1.0f / 6.0f;
    }
    march_grid(p, &grid);
    /* with delta-M the light scattered forward goes on with it; the emission's once-scattered
       light needs the true T too, along the same rays */
    grid.sigma = p->lat_sigma;
    grid.sigma2 = trans_true ? p->sigma : NULL;
    {
        const vsd_lbl_march_out out[2] = {{trans, lost, &points_trans}, {trans_true, NULL, &points_trans}};
        st = march_rays_or_sweep(p, &grid, lights, k_count, NULL, 0, pc->threads, out, NULL, err, errlen);
    }
    if (st == VSD_OK) {
        receive_job j = {p,      p->lat_albedo, trans, lost, trans_true ? trans_true : trans, (const float(*)[6])shares,
                         once_s, once_e, per_view};
        /* (the pool fails only when cancelled, which this stage is not) */
        if (vsd_cpu_run_each(p->rg.res[2], pc->threads, receive_slices, &j, "light between groups") != VSD_OK)
            receive_slices(&j, 0, 0, p->rg.res[2], 1);
    }
    free(lights), free(trans), free(lost), free(shares), free(trans_true);
    return st;
}

/* Light between groups (lbl_exchange.h): once every part is lit, each part with near
 * volumes outside its group gathers the light they send it (all gathers first, from the
 * lighting without this exchange), takes it into its records and lattice, and solves the
 * lattice again from its steady state. */
static vsd_status exchange_between_groups(lbl_state *s, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    vsd_krecord_grid grids[VSD_KMAX_VOLUMES];
    const vsd_krecord_grids gs = {&ctx->kd, grids, s->parts.count, {0, 0, 0}};
    const uint32_t all = s->parts.count >= 32 ? ~0u : (1u << s->parts.count) - 1u;
    /* a sender with delta-M: its lights' term through T' = T + (T' - T), the light it
     * scattered forward included (its lattice holds only the scaled problem's) */
    float *forward[VSD_KMAX_VOLUMES][2] = {{NULL}};
    float step = 0.0f;
    vsd_status st = VSD_OK;
    int i, a;
    for (i = 0; i < s->parts.count && st == VSD_OK; i++) {
        const lbl_state *p = s->parts.state[i];
        records_grid(p, &ctx->kd, &grids[i]);
        /* the march's step: the finest part's cell */
        if (p->rg.count > 0 && (step == 0.0f || p->cell_world < step)) step = (float)p->cell_world;
        if (p->fwd_trans) {
            const size_t nd = (size_t)p->rg.count * p->dir_count, nl = (size_t)p->rg.count * p->local_count;
            size_t k;
            forward[i][0] = malloc((nd ? nd : 1) * sizeof(float));
            forward[i][1] = malloc((nl ? nl : 1) * sizeof(float));
            if (!forward[i][0] || !forward[i][1]) {
                st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the light between groups");
                break;
            }
            for (k = 0; k < nd; k++) forward[i][0][k] = p->light_trans[k] + p->fwd_trans[k];
            for (k = 0; k < nl; k++) forward[i][1][k] = p->local_trans[k] + p->fwd_local[k];
            grids[i].light_trans = forward[i][0];
            grids[i].local_trans = forward[i][1];
        }
    }
    for (i = 0; i < s->parts.count && st == VSD_OK; i++) {
        lbl_state *p = s->parts.state[i];
        vsd_lbl_exchange_grid eg;
        if (!p->receives || !p->source || p->rg.count == 0) continue;
        memcpy(eg.res, p->rg.res, sizeof eg.res);
        eg.world_to_grid = p->rg.world_to_grid;
        for (a = 0; a < 12; a++) eg.grid_to_world.m[a] = (float)p->g2w[a];
        st = vsd_lbl_exchange_gather(&gs, all & ~s->parts.group[i], &eg, step, ctx->threads, &p->exchange, err, errlen);
    }
    for (i = 0; i < s->parts.count; i++) free(forward[i][0]), free(forward[i][1]);
    if (st) return st;
    for (i = 0; i < s->parts.count; i++) {
        lbl_state *p = s->parts.state[i];
        const size_t recs = (size_t)p->rg.count;
        const vsd_lbl_layout layout = {p->opt.block_steps, p->opt.lattice == 1};
        vsd_lbl_diffusion_stats stats;
        vsd_frame_ctx pc;
        float *once;
        size_t r;
        if (!p->exchange.count) continue;
        vsd_part_ctx(ctx, &s->parts, i, &pc);
        if (!(once = calloc(6 * recs, sizeof *once)) ||
            (p->exchange.emits && !p->emission_once && !(p->emission_once = calloc(3 * recs, sizeof *p->emission_once)))) {
            free(once);
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the light between groups");
        }
        if ((st = receive_exchange(p, &pc, once, once + 3 * recs, err, errlen)) ||
            (st = vsd_lbl_diffuse(&p->lattice, p->lat_collide, p->lat_albedo, p->source, p->opt.tolerance, p->opt.max_steps,
                                  ctx->threads, p->fluence, &stats, err, errlen)) ||
            (st = records_from_fluence(p, &pc, &layout, err, errlen))) {
            free(once);
            return st;
        }
        for (r = 0; r < 3 * recs; r++) {
            p->ms[r] += once[r];
            if (p->emission_once) p->emission_once[r] += once[3 * recs + r];
        }
        free(once);
        p->diffusion.steps += stats.steps;
        p->diffusion.seconds += stats.seconds;
    }
    return VSD_OK;
}

static vsd_status lbl_render(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples, char *err,
                             size_t errlen)
{
    lbl_state *s = state;
    vsd_krecord_grid g;
    vsd_status st;
    if (s->parts.count)
        return vsd_parts_render(&s->parts, view_grid, ctx, fb, s->opt.pixel_samples, s->opt.slice,
                                s->opt.early_termination, &s->opt.view, samples, err, errlen);
    ctx->kd.lights = s->dir_lights;
    ctx->kd.light_count = s->dir_count;
    if ((st = view_grid(s, ctx, &g, err, errlen))) return st;
    if (ctx->info && ctx->info_len)
        snprintf(ctx->info, ctx->info_len,
                 "cells=%dx%dx%d records=%d lights=%d march_seconds=%.3f first_flight_seconds=%.3f diffusion_steps=%d diffusion_converged=%d "
                 "diffusion_change=%.3g diffusion_seconds=%.3f emission_steps=%d history_rounds=%d history_steps=%d",
                 s->rg.res[0], s->rg.res[1], s->rg.res[2], (int)s->rg.count, s->dir_count + s->local_count, s->march_seconds,
                 s->flight_seconds, s->diffusion.steps, s->diffusion.converged, s->diffusion.change, s->diffusion.seconds,
                 s->emission_steps, s->history_rounds, s->history_steps);
    if (s->refraction.k.ng) return render_bent(s, ctx, fb, &g, samples, err, errlen);
    return vsd_record_grid_render(ctx, fb, &g, s->opt.pixel_samples, s->opt.slice, s->opt.early_termination, &s->opt.view, samples,
                                  err, errlen);
}

static void lbl_destroy(void *state)
{
    lbl_state *s = state;
    if (!s) return;
    vsd_parts_free(&s->parts, &vsd_method_lbl);
    free_frame(s);
    vsd_lbl_lattice_free(&s->lattice);
    vsd_lbl_lattice_free(&s->lattice_e);
    vsd_constellation_cache_free(&s->cc);
    free(s);
}

/* reference's cache (render.options.cache "lbl"): the lattice's diffused light as cone
 * radiances where the readout keeps them (ms6), else its isotropic fluence / 4pi. With
 * delta-M these are the scaled problem's: what the lattice carries without HG's forward
 * peak (the cache need only be near the truth: reference's estimate is unbiased with any). */
static vsd_status lbl_radiance_cache(void *state, const vsd_frame_ctx *ctx, vsd_radiance_cache *out, char *err,
                                     size_t errlen)
{
    const lbl_state *s = state;
    (void)ctx;   /* its record grid has the cells' place in the world */
    if (s->parts.count > 0)
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                        "render.options.cache: lbl's cache covers one volume so far (the scene has %d)", s->parts.count);
    if (!s->ms) return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "lbl: the cache was asked for before the lighting");
    return vsd_radiance_cache_from_records(&s->rg, s->ms6, s->ms, out, err, errlen);
}

/* The rendered viewport's default: it scatters more than once, so the viewport shows what a
 * final render with `reference` shows (shgrid, the default before issue 28, scatters once:
 * its smoke is about half as bright). Measured for issue 28 at 264x166, lbl / crm: Combined
 * against 4096-spp `reference` (relative RMSE, 4x4 blocks) 7.7% / 13.1% on smoke64 frame 20
 * (the viewport test's scene), 4.4% / 7.2% on smoke128 frame 45; mean brightness 1.005 /
 * 1.007; seconds from a view change to the new image in Blender 3.4 under Xvfb
 * (test_viewport's benchmark, 2-core VM, three runs) 0.29-0.50 / 0.15-0.27 (shgrid
 * 0.16-0.25). crm is the faster, but not within 10% of the reference on the add-on's own
 * smoke: lbl. */
const vsd_method vsd_method_lbl = {
    .name = "lbl",
    .label = "LBL",
    .summary = "Bernabei 2012: light marching, lattice-Boltzmann multiple scattering",
    .caps = VSD_METHOD_CAP_MULTIPLE_SCATTERING | VSD_METHOD_CAP_REFRACTION | VSD_METHOD_CAP_SCENE_LIGHTS |
            VSD_METHOD_CAP_EMISSION_SCATTERING | VSD_METHOD_CAP_CUDA_VIEW | VSD_METHOD_CAP_SEVERAL_VOLUMES,
    .roles = VSD_METHOD_ROLE_VIEWPORT_DEFAULT,
    /* half the cells per axis: an eighth of the march, the first flight and the lattice;
     * a density edit on smoke128 at 264x166 1.6 -> 0.37 s, Combined 2.9 -> 3.0% (smoke128),
     * 9.3 -> 10.2% (cloud256), 3.5 -> 5.9% (rot_lowalb) at 160x90 (docs/methods/lbl.md) */
    .preview_options = "{\"cells\": 32}",
    .density_in_lighting = 1,   /* the cells' field kept, the density applied per lighting */
    .options = VSD_OPTION_TABLE(lbl_option_rows, lbl_options),
    .create = lbl_create,
    .prepare_frame = lbl_prepare_frame,
    .prepare_lighting = lbl_prepare_lighting,
    .render = lbl_render,
    .destroy = lbl_destroy,
    .radiance_cache = lbl_radiance_cache,
};
