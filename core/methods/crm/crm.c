/* Method `crm`: Zhou, Ren, Lin, Bao, Guo, Shum 2008, "Real-time smoke rendering using
 * compensated ray marching" — single and multiple scattering from an RBF model of the
 * density, with the residual put back in the view march.
 *
 * Stages and caches (the paper's split, §4; issue 13 part 6):
 *   prepare_frame     only when the density grid's *content* changed (a change of medium
 *                     density re-runs the renderer's frame stage but not this): the node
 *                     grid's cell-mean density; and §5.1-5.2 only where something reads
 *                     them (`needs_fit`: view_density "compensated" or "eq8", single "sh",
 *                     multiple "rbf"): the RBF fit (crm_fit.c; from/to the disk cache in
 *                     ctx->cache_dir; frame k+1 starts from frame k's RBFs), D~ rasterised on
 *                     the voxels, the residual R = D - D~ quantised into a perfect hash
 *                     (crm_residual_hash.c) and decoded into D~ + R for the view. The
 *                     default path (voxels, grid, orders) fits nothing: its view marches the
 *                     density grid, which D~ + R only reproduced (issue 31).
 *   prepare_lighting  for the environment, sigma_t, albedo and phase: the SH projection of
 *                     the map; single scattering on the nodes (crm_node_single.c) or the
 *                     paper's at the RBF centres (crm_single.c); multiple scattering by
 *                     successive orders on the nodes (crm_orders.c) or the paper's diffusion
 *                     at the centres (crm_diffusion.c), J~ on the nodes (crm_source_grid.c).
 *   render            §5.5, the march (crm_kernel.h) on CPU tiles or CUDA.
 * Several volumes: a part per volume (crm_parts.h), the default path only.
 * Options: the table below (`vsd methods`). */
#include "src/method/method.h"
#include "src/lighting/env_healpix.h"
#include "vsd/sh.h"
#include "crm_fit.h"
#include "crm_fit_cache.h"
#include "crm_residual_hash.h"
#include "crm_single.h"
#include "crm_diffusion.h"
#include "crm_source_grid.h"
#include "crm_orders.h"
#include "src/lighting/radiance_cache.h"
#include "crm_sky.h"
#include "crm_phase.h"
#include "crm_node_single.h"
#include "crm_kernel.h"
#include "crm_device.h"
#include "crm_hash_kernel.h"
#include "crm_parts.h"
#include "crm_lights.h"
#include "src/method/method_parts.h"
#include "src/grids/volume_groups.h"
#include "src/common/clock.h"
#include "kernel/kernel_volume.h"
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* extracted lights (crm_lights.h): shgrid's defaults, as many as the view's node pass
 * affords */
#define CRM_DEFAULT_LIGHTS 32
#define CRM_DEFAULT_LIGHT_THRESHOLD 3.0

/* rbf_count 0: one RBF per this many non-zero voxels, within [MIN, MAX] (800 at 128^3 smoke;
 * a 22^3 puff gets 35 instead of 800 RBFs crowding its 3456 voxels, which cost a minute of
 * fitting and left nothing for the residual to do) */
#define CRM_AUTO_VOXELS_PER_RBF 100
#define CRM_AUTO_RBFS_MIN 16
#define CRM_AUTO_RBFS_MAX 800

typedef struct crm_options {
    int rbf_count, fit_iterations, sh_order, cg_iterations, view_density, pixel_samples, delete_per_frame, insert_max;
    int coherent, multiple, single, directions, orders, order_directions, order_cell, order_fine, sky, sky_view, lights, delta_m;
    int ms_bands, gather;
    double node_spacing, step, early_termination, error_ratio, light_threshold;
    vsd_view_sampling view;
} crm_options;

/* Beside the defaults only the paper's own forms remain; the variants that were neither
 * and lost to the defaults (single "direct", multiple "grid", residual "none", decode
 * "view", orders_phase "isotropic") are measured in docs/methods/crm.md and in the history. */
static const char *const view_density_names[] = {"voxels", "compensated", "eq8", NULL}; /* CRM_VIEW_* */
static const char *const sky_names[] = {"pixels", "sh", NULL};
enum { SKY_PIXELS, SKY_SH };
static const char *const sky_view_names[] = {"sh", "sum", NULL};
enum { SKY_VIEW_SH, SKY_VIEW_SUM };
enum { MULTIPLE_ORDERS, MULTIPLE_RBF };
enum { SINGLE_GRID, SINGLE_SH };
static const char *const single_names[] = {"grid", "sh", NULL};

static const char *healpix_count_problem(double v)
{
    return vsd_sh_healpix_nside((long)v) ? NULL : "is not a HEALPix pixel count 12 nside^2 (12, 48, 108, 192, 300, ...)";
}
static const char *const multiple_names[] = {"orders", "rbf", NULL};
enum { GATHER_MARCH, GATHER_SWEEP };
static const char *const gather_names[] = {"march", "sweep", NULL};

/* Options of one form of single or multiple scattering mean nothing under another. */
static const vsd_option_when crm_on_single_grid[] = {{"single", 0, 0, "grid"}, {NULL, 0, 0, NULL}};
static const vsd_option_when crm_on_lights[] = {{"single", 0, 0, "grid"}, {"lights", 1, 0, NULL}, {NULL, 0, 0, NULL}};
static const vsd_option_when crm_on_multiple_rbf[] = {{"multiple", 0, 0, "rbf"}, {NULL, 0, 0, NULL}};
static const vsd_option_when crm_on_multiple_orders[] = {{"multiple", 0, 0, "orders"}, {NULL, 0, 0, NULL}};
/* Deleting and inserting RBFs is how a coherent fit follows the frames. */
static const vsd_option_when crm_on_coherent[] = {{"coherent", 0, 1, NULL}, {NULL, 0, 0, NULL}};

static const vsd_option_spec crm_option_rows[] = {
    {"rbf_count", VSD_OPT_INT, 1, VSD_CRM_DIFFUSION_MAX_RBFS, 0, NULL,
     "RBFs fitted to the first frame (0 = one per 100 non-zero voxels, 16..800; the paper: 1000); the fit runs only "
     "for view_density compensated or eq8, single sh or multiple rbf",
     offsetof(crm_options, rbf_count), VSD_OPT_ZERO_AUTO, NULL, NULL},
    {"fit_iterations", VSD_OPT_INT, 10, 100000, 3000, NULL,
     "bound on the L-BFGS iterations of one frame's RBF fit", offsetof(crm_options, fit_iterations), 0, NULL, NULL},
    {"coherent", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "start each frame's fit from the previous frame's RBFs (delete, refit, insert; §5.1)",
     offsetof(crm_options, coherent), 0, NULL, NULL},
    {"delete_per_frame", VSD_OPT_INT, 0, 100, 3, NULL, "coherent frames: least significant RBFs deleted first",
     offsetof(crm_options, delete_per_frame), 0, NULL, .when = crm_on_coherent},
    {"insert_max", VSD_OPT_INT, 0, 100, 8, NULL, "coherent frames: most RBFs inserted at the error maximum",
     offsetof(crm_options, insert_max), 0, NULL, .when = crm_on_coherent},
    {"error_ratio", VSD_OPT_NUMBER, 1.0, 10.0, 1.1, NULL,
     "coherent frames: insert while the fit error exceeds the first frame's by this factor (paper 1.05-1.2)",
     offsetof(crm_options, error_ratio), 0, NULL, .when = crm_on_coherent},
    {"sh_order", VSD_OPT_INT, 1, 4, 4, NULL,
     "SH order of single scattering (bands; multiple scattering is order 2; not the scattering orders of "
     "multiple \"orders\")",
     offsetof(crm_options, sh_order), 0, NULL, NULL},
    {"single", VSD_OPT_CHOICE, 0, 0, SINGLE_GRID, single_names,
     "single scattering: grid (at every medium node, marched toward HEALPix directions) or sh (the paper's: at the RBF "
     "centres, ZH table + exp*)",
     offsetof(crm_options, single), 0, NULL, NULL},
    {"sky", VSD_OPT_CHOICE, 0, 0, SKY_SH, sky_names,
     "single grid: the light arriving from each direction in the nodes' SH single scattering (the orders' J_1, and "
     "the view's with sky_view \"sh\"), the map averaged per HEALPix pixel (a lamp or a small sun shadowed where it "
     "is) or the map's order-n SH (the paper's L_in)",
     offsetof(crm_options, sky), 0, NULL, .when = crm_on_single_grid},
    {"sky_view", VSD_OPT_CHOICE, 0, 0, SKY_VIEW_SUM, sky_view_names,
     "single grid: the sky's single scattering toward the eye from the nodes' order-4 SH convolved with HG (the "
     "paper's), or summed per view over the HEALPix pixels with HG averaged over each (crm_sky.h)",
     offsetof(crm_options, sky_view), 0, NULL, .when = crm_on_single_grid},
    {"lights", VSD_OPT_INT, 0, VSD_CRM_MAX_LIGHTS, CRM_DEFAULT_LIGHTS, NULL,
     "single grid: the map's bright texels taken out of the SH sky as this many exact directional lights, each "
     "with its own transmittance per node (0 = none: the whole map through the SH)",
     offsetof(crm_options, lights), 0, NULL, .when = crm_on_single_grid},
    {"light_threshold", VSD_OPT_NUMBER, 1, 1e30, CRM_DEFAULT_LIGHT_THRESHOLD, NULL,
     "single grid: texels brighter than this multiple of the map's mean luminance become lights",
     offsetof(crm_options, light_threshold), 0, NULL, .when = crm_on_lights},
    {"directions", VSD_OPT_INT, 12, 3072, 108, NULL, "single grid: HEALPix directions of the transmittance (12 nside^2)",
     offsetof(crm_options, directions), 0, healpix_count_problem, .when = crm_on_single_grid},
    {"multiple", VSD_OPT_CHOICE, 0, 0, MULTIPLE_ORDERS, multiple_names,
     "multiple scattering: orders (successive orders on a coarse grid, each scattered with the medium's phase) or rbf "
     "(the paper's diffusion, eq. 13, at the RBF centres)",
     offsetof(crm_options, multiple), 0, NULL, NULL},
    {"cg_iterations", VSD_OPT_INT, 0, 10000, VSD_CRM_DIFFUSION_MAX_ITER, NULL,
     "multiple rbf: CG iterations of eq. 13 (early stopping regularises it; the paper: 20-40)",
     offsetof(crm_options, cg_iterations), 0, NULL, .when = crm_on_multiple_rbf},
    {"orders", VSD_OPT_INT, 1, 64, 24, NULL,
     "multiple orders: most orders followed before the geometric tail closes the series",
     offsetof(crm_options, orders), 0, NULL, .when = crm_on_multiple_orders},
    {"order_directions", VSD_OPT_INT, 12, 768, 48, NULL, "multiple orders: HEALPix directions gathered per cell and order",
     offsetof(crm_options, order_directions), 0, healpix_count_problem, .when = crm_on_multiple_orders},
    {"order_cell", VSD_OPT_INT, 1, 8, 2, NULL, "multiple orders: source nodes per cell of the coarse grid",
     offsetof(crm_options, order_cell), 0, NULL, .when = crm_on_multiple_orders},
    {"order_fine", VSD_OPT_INT, 0, 64, 3, NULL,
     "multiple orders: how many of the first orders run on the nodes themselves before the rest go on to the coarse "
     "grid of order_cell (the first orders carry the medium's detail; the later ones are smooth)",
     offsetof(crm_options, order_fine), 0, NULL, .when = crm_on_multiple_orders},
    {"gather", VSD_OPT_CHOICE, 0, 0, GATHER_SWEEP, gather_names,
     "multiple orders: how each order gathers the light toward every cell: sweep (one pass over the cells per "
     "direction, each cell's light from its upstream neighbours) or march (from every cell toward every direction)",
     offsetof(crm_options, gather), 0, NULL, .when = crm_on_multiple_orders},
    {"delta_m", VSD_OPT_BOOL, 0, 1, 1, NULL,
     "multiple orders with single grid: delta-M scaling of the phase (g > 0): the orders, which carry HG's first "
     "ms_bands bands, take its forward peak as unscattered light (f = g^ms_bands: sigma_t (1 - a f), albedo a (1 - f) "
     "/ (1 - a f), band l of the phase (g^l - f) / (1 - f))",
     offsetof(crm_options, delta_m), 0, NULL, .when = crm_on_multiple_orders},
    {"ms_bands", VSD_OPT_INT, 2, 3, 3, NULL,
     "multiple orders (g != 0): SH bands the orders' source J carries and the view reads (2: bands 0-1, 3: bands 0-2; "
     "delta-M then takes f = g^bands)",
     offsetof(crm_options, ms_bands), 0, NULL, .when = crm_on_multiple_orders},
    {"view_density", VSD_OPT_CHOICE, 0, 0, CRM_VIEW_VOXELS, view_density_names,
     "density of the view march: voxels (the grid itself; nothing fitted), compensated (the paper's D~ + R: RBF fit "
     "plus 8-bit residual hash) or eq8 (the paper's eq. 8: transmittance from D~ alone, source from D~ + R)",
     offsetof(crm_options, view_density), 0, NULL, NULL},
    {"node_spacing", VSD_OPT_NUMBER, 0, 64, 0, NULL,
     "voxels between the source-radiance nodes (0 = automatic: about 48^3 nodes over the volume's box, whatever "
     "its shape: the cube root of its voxels / 48^3, at least 1)",
     offsetof(crm_options, node_spacing), VSD_OPT_ZERO_AUTO, NULL, NULL},
    {"step", VSD_OPT_NUMBER, 0, 1e30, 0, NULL, "view march step, world units (0 = one voxel)",
     offsetof(crm_options, step), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH, NULL, NULL},
    VSD_OPTION_PIXEL_SAMPLES(crm_options),
    VSD_OPTION_VIEW_SPACING(crm_options, view.spacing, view.threshold),
    VSD_OPTION_EARLY_TERMINATION(crm_options, "view ray"),
};

typedef struct crm_state {
    crm_options opt;
    vsd_crm_fit_options fit_opt;
    /* frame (§5.1-5.2) */
    int32_t dims[3], origin[3];
    char fit_key[65];             /* content key of the fitted grid (fit options, no previous
                                     fit): same key, no refit */
    vsd_crm_rbfs rbfs;
    double first_rel_error;       /* the sequence's first fit error (coherent insertion rule) */
    vsd_crm_fit_stats fit;
    int fit_cached;
    long long fits_run;           /* fits actually computed (not from memory or disk) */
    uint64_t volume_gen;          /* of the grid the nodes were built from (no fit) */
    float *dtilde;                /* D~ (view_density eq8 only) */
    float *dfull;                 /* D~ + R decoded from the hash (compensated, eq8) */
    vsd_crm_hash *hash;
    double voxel_world;           /* world length of a voxel (mean of the three axes) */
    float spacing;                /* voxels between source nodes */
    int32_t node_res[3];
    float *node_density;          /* [nodes] mean density of each node's cell (a part: every
                                     volume's extinction over its own scale, crm_parts.h) */
    float *node_albedo;           /* [3 * nodes] a part's mixture albedo, else NULL */
    vsd_crm_node_depths depths;   /* the nodes' transmittance toward the sky, kept across
                                     lighting and medium edits (crm_node_single.h) */
    vsd_crm_lights lights;        /* the bright texels as lights, their transmittance per node */
    float *view_lights;           /* [8 * lights.count] for the view (crm_kernel.h) */
    vsd_crm_sky sky;              /* sky_view "sum": the sky's pixels and transmittance for the view */
    double *sky_dirs;             /* [3 * opt.directions] the sky's HEALPix directions */
    float light_g;
    /* lighting (§5.3-5.4) */
    vsd_crm_od_table *table;
    double *j_ss, *j_ms, *l_m0;   /* per centre; l_m0 warm-starts the next solve */
    int l_m0_count;
    vsd_crm_diffusion_stats diffusion;
    double single_seconds;
    double transmittance_seconds; /* of single_seconds: the marches (0 when reused) */
    long long transmittance_marches; /* times the node transmittance was marched, not reused */
    vsd_crm_source_grid nodes;
    float *view_nodes;            /* [nodes * CRM_VIEW_FLOATS] the CPU's per-view node pass */
    size_t view_count;
    vsd_crm_orders_stats orders;
    vsd_method_parts parts;       /* several volumes: a crm state per volume */
} crm_state;

extern const vsd_method vsd_method_crm;

/* Whether anything this configuration runs reads the RBF fit (and so the dense copy the
 * fit is made from): the paper's lighting at the centres, or its D~ + R in the view. */
static int needs_fit(const crm_options *o)
{
    return o->view_density != CRM_VIEW_VOXELS || o->single == SINGLE_SH || o->multiple == MULTIPLE_RBF;
}

/* The fit is one volume's: the paper's forms render one volume. */
static const char *several_volumes_refusal(int volumes, char *buf, size_t len)
{
    snprintf(buf, len,
             "volumes: the scene has %d volumes; crm's fitted forms (view_density \"compensated\" or \"eq8\", single "
             "\"sh\", multiple \"rbf\") render one volume; its default path renders several",
             volumes);
    return buf;
}

static vsd_status crm_create(void **state, const vsd_scene *scene, const void *options, char *err, size_t errlen)
{
    crm_state *s = calloc(1, sizeof *s);
    vsd_status st;
    char buf[512];
    if (!s) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    s->opt = *(const crm_options *)options;
    vsd_crm_fit_defaults(&s->fit_opt);
    s->fit_opt.rbf_count = s->opt.rbf_count > 0 ? s->opt.rbf_count : CRM_AUTO_RBFS_MAX;
    s->fit_opt.max_iterations = s->opt.fit_iterations;
    s->fit_opt.delete_per_frame = s->opt.delete_per_frame;
    s->fit_opt.insert_max = s->opt.insert_max;
    s->fit_opt.error_ratio = (float)s->opt.error_ratio;
    if (scene && scene->volume_count > 1 && needs_fit(&s->opt)) {
        free(s);
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen, "%s", several_volumes_refusal(scene->volume_count, buf, sizeof buf));
    }
    if ((st = vsd_crm_fit_options_check(&s->fit_opt, err, errlen)) ||
        (st = vsd_crm_od_table_create(s->opt.sh_order, 256, &s->table, err, errlen))) {
        free(s);
        return st;
    }
    if (!(s->sky_dirs = vsd_crm_healpix_directions(s->opt.directions))) {
        int directions = s->opt.directions;
        vsd_crm_od_table_destroy(s->table);
        free(s);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for %d sky directions", directions);
    }
    *state = s;
    return VSD_OK;
}

static void free_frame(crm_state *s)
{
    free(s->dtilde);
    s->dtilde = NULL;
    free(s->dfull);
    s->dfull = NULL;
    free(s->node_density);
    s->node_density = NULL;
    free(s->node_albedo);
    s->node_albedo = NULL;
    vsd_crm_node_depths_free(&s->depths);
    vsd_crm_node_depths_free(&s->lights.depths);
    vsd_crm_hash_destroy(s->hash);
    s->hash = NULL;
}

/* The density as a dense grid over its bricks (crm space: voxel (i,j,k) = index origin + (i,j,k)). */
static vsd_status dense_copy(const vsd_volume *vol, int32_t dims[3], int32_t origin[3], float **out, char *err,
                             size_t errlen)
{
    size_t n;
    int32_t i, j, k, a;
    float *d;
    *out = NULL;
    for (a = 0; a < 3; a++) {
        dims[a] = 8 * vol->brick_dims[a];
        origin[a] = vol->origin[a];
    }
    n = (size_t)dims[0] * dims[1] * dims[2];
    if (n == 0) return VSD_OK;
    if (n > ((size_t)1 << 28))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: a %dx%dx%d density grid is beyond the method's limit of 2^28 voxels",
                        dims[0], dims[1], dims[2]);
    if (!(d = malloc(n * sizeof *d)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for a %dx%dx%d density copy", dims[0], dims[1], dims[2]);
    for (k = 0; k < dims[2]; k++)
        for (j = 0; j < dims[1]; j++)
            for (i = 0; i < dims[0]; i++)
                d[((size_t)k * dims[1] + j) * dims[0] + i] = vsd_volume_voxel(vol, origin[0] + i, origin[1] + j, origin[2] + k);
    *out = d;
    return VSD_OK;
}

/* The node grid's spacing for a box of `dims` voxels (option, else the cube root of the
 * box's voxels over 48^3, at least 1 voxel: about 48^3 nodes whatever the box's shape —
 * largest dimension / 48 left the short axes of a tall smoke 25 nodes, docs/methods/crm.md). */
static float auto_spacing(const crm_state *s, const int32_t dims[3])
{
    if (s->opt.node_spacing > 0) return (float)s->opt.node_spacing;
    return fmaxf(1.0f, cbrtf((float)dims[0] * (float)dims[1] * (float)dims[2] / (48.0f * 48.0f * 48.0f)));
}

/* The nodes over s->dims at s->spacing and the mean density of each node's cell: 3 x 3 x 3
 * trilinear samples of the density grid over the cube of side `spacing` around the node (a
 * box filter that neither aliases at spacing 1, where nodes sit between voxel centres, nor
 * blurs much at larger spacings). Node (i,j,k) sits at crm-space spacing * (i,j,k), index
 * origin - 0.5 + that. */
static vsd_status node_density(crm_state *s, const vsd_kvolume *density /* NULL: allocate only */, char *err,
                               size_t errlen)
{
    int32_t a, i, j, k, u, v, w;
    size_t count, n;
    for (a = 0; a < 3; a++) s->node_res[a] = (int32_t)ceilf((float)s->dims[a] / s->spacing) + 1;
    count = (size_t)s->node_res[0] * s->node_res[1] * s->node_res[2];
    if (!(s->node_density = calloc(count, sizeof *s->node_density)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for %zu source nodes", count);
    if (!density) return VSD_OK;   /* a part: its lighting stage puts every volume's medium there */
    for (n = 0, k = 0; k < s->node_res[2]; k++)
        for (j = 0; j < s->node_res[1]; j++)
            for (i = 0; i < s->node_res[0]; i++, n++) {
                float sum = 0.0f, third = s->spacing / 3.0f;
                for (w = -1; w <= 1; w++)
                    for (v = -1; v <= 1; v++)
                        for (u = -1; u <= 1; u++)
                            sum += vsd_kvolume_field(
                                density, f3((float)s->origin[0] - 0.5f + (float)i * s->spacing + (float)u * third,
                                            (float)s->origin[1] - 0.5f + (float)j * s->spacing + (float)v * third,
                                            (float)s->origin[2] - 0.5f + (float)k * s->spacing + (float)w * third));
                s->node_density[n] = sum > 0.0f ? sum / 27.0f : 0.0f;
            }
    return VSD_OK;
}

/* The paper's §5.1-5.2 for the frame's grid: the fit (from the disk cache when it has it),
 * D~ on the voxels, the residual hash, and D~ + R decoded for the view where it reads it.
 * Returns with s->dims/origin set and, on the same grid as last time, without refitting. */
static vsd_status fit_frame(crm_state *s, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    vsd_crm_dense dense;
    vsd_crm_rbfs fitted = {NULL, 0};
    const vsd_crm_rbfs *previous;
    char key[65];
    float *d = NULL, *residual = NULL;
    size_t n, i;
    vsd_status st;
    int32_t dims[3], origin[3];
    if ((st = dense_copy(ctx->density, dims, origin, &d, err, errlen))) return st;
    dense.nx = dims[0];
    dense.ny = dims[1];
    dense.nz = dims[2];
    dense.d = d;
    n = (size_t)dims[0] * dims[1] * dims[2];
    /* coherence needs the same grid; a sequence whose bounding box changes starts over */
    previous = s->opt.coherent && s->rbfs.count > 0 && memcmp(dims, s->dims, sizeof dims) == 0 &&
                       memcmp(origin, s->origin, sizeof origin) == 0
                   ? &s->rbfs
                   : NULL;
    if (s->opt.rbf_count == 0 && n > 0) {
        size_t nonzero = 0, auto_n;
        for (i = 0; i < n; i++) nonzero += d[i] != 0.0f;
        auto_n = nonzero / CRM_AUTO_VOXELS_PER_RBF;
        s->fit_opt.rbf_count = (int)(auto_n < CRM_AUTO_RBFS_MIN ? CRM_AUTO_RBFS_MIN
                                     : auto_n > CRM_AUTO_RBFS_MAX ? CRM_AUTO_RBFS_MAX : auto_n);
    }
    /* the grid's content alone (no previous fit): a medium edit re-runs this stage with the
     * same grid, and must find it already fitted whatever the coherence chain says */
    if (n > 0 && (st = vsd_crm_fit_cache_key(&dense, &s->fit_opt, NULL, 0.0, key))) goto done;
    if (n > 0 && s->fit_key[0] && strcmp(key, s->fit_key) == 0 && s->node_density) {
        /* the same grid as last time (a medium change): §5.1-5.2 stand */
        free(d);
        return VSD_OK;
    }
    free_frame(s);
    if (n > 0) {
        int was_cached = 0;
        st = vsd_crm_fit_cached(ctx->cache_dir, &dense, &s->fit_opt, previous, s->first_rel_error, &fitted, &s->fit,
                                err, errlen, &was_cached);
        if (st == VSD_ERR_IO) {
            /* fitted, but the cache could not be written: render anyway */
            fprintf(stderr, "vsd: crm: %s\n", err);
            st = VSD_OK;
        }
        if (st) goto done;
        s->fit_cached = was_cached;
        if (!was_cached) s->fits_run++;
        if (!previous) s->first_rel_error = s->fit.rel_error;
        snprintf(s->fit_key, sizeof s->fit_key, "%s", key);
    }
    vsd_crm_rbfs_free(&s->rbfs);
    s->rbfs = fitted;
    memcpy(s->dims, dims, sizeof dims);
    memcpy(s->origin, origin, sizeof origin);
    if (n == 0 || s->opt.view_density == CRM_VIEW_VOXELS) goto done;
    /* the view's D~ + R: rasterise, hash the residual, decode it once per frame (the
     * paper's volume pass reconstructs D the same way) */
    if (!(s->dtilde = malloc(n * sizeof(float))) || !(residual = malloc(n * sizeof(float))) ||
        !(s->dfull = malloc(n * sizeof(float)))) {
        st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the %zu-voxel residual", n);
        goto done;
    }
    vsd_crm_rasterise(&s->rbfs, dims[0], dims[1], dims[2], s->dtilde);
    for (i = 0; i < n; i++) residual[i] = d[i] - s->dtilde[i];
    if ((st = vsd_crm_hash_build(dims[0], dims[1], dims[2], residual, 0.0f, &s->hash, err, errlen))) goto done;
    {
        vsd_crm_hash_view hv = vsd_crm_hash_get_view(s->hash);
        int32_t x, y, z;
        for (i = 0, z = 0; z < dims[2]; z++)
            for (y = 0; y < dims[1]; y++)
                for (x = 0; x < dims[0]; x++, i++) s->dfull[i] = s->dtilde[i] + vsd_crm_residual(&hv, x, y, z);
    }
    if (s->opt.view_density != CRM_VIEW_EQ8) {
        /* only eq. 8 attenuates with D~ alone */
        free(s->dtilde);
        s->dtilde = NULL;
    }
done:
    if (st) {
        free_frame(s);
        s->fit_key[0] = '\0';
    }
    free(residual);
    free(d);
    return st;
}

static vsd_status crm_prepare_frame(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    crm_state *s = state;
    const double *vs;
    vsd_status st;
    int a;
    if (!ctx->part.active) {
        if (ctx->volume_count > 1) {
            char buf[512];
            if (needs_fit(&s->opt))
                return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen, "%s",
                                several_volumes_refusal(ctx->volume_count, buf, sizeof buf));
            /* every volume: a part's box grows over the volumes near it (its frame stage is
             * that box alone; the nodes' media are the lighting stage's) */
            st = vsd_parts_prepare_frame(&s->parts, &vsd_method_crm, &s->opt, NULL, ctx, err, errlen);
            /* a part's nodes mix every volume in its box, so any material edit re-lights it */
            s->parts.materials_of_all = 1;
            return st;
        }
        vsd_parts_free(&s->parts, &vsd_method_crm);
    }
    vs = ctx->density->voxel_size;
    s->voxel_world = (vs[0] + vs[1] + vs[2]) / 3.0;
    if (needs_fit(&s->opt)) {
        /* the same fitted grid keeps its nodes; a new one was freed with its fit */
        if ((st = fit_frame(s, ctx, err, errlen))) return st;
        if (s->node_density) return VSD_OK;
    } else {
        /* the same grid as last time (a medium change re-runs this stage): the nodes and
         * their transmittance stand; a part's nodes hold the other volumes too, which may
         * have moved or changed: built again */
        if (!ctx->part.active && s->node_density && s->volume_gen == ctx->volume_gen) return VSD_OK;
        free_frame(s);
        for (a = 0; a < 3; a++) {
            s->dims[a] = 8 * ctx->density->brick_dims[a];
            s->origin[a] = ctx->density->origin[a];
        }
    }
    if ((size_t)s->dims[0] * s->dims[1] * s->dims[2] == 0) return VSD_OK;
    s->spacing = auto_spacing(s, s->dims);
    if (ctx->part.active) {
        /* the box of its group and the volumes near it (crm_parts.h) at the volume's own
         * spacing, up to 2x its nodes (a small fire in a large smoke: the smoke's size then
         * sets the spacing; 4x cost the issue-30 scene twice the time for 0.5 points) */
        vsd_crm_part_box(ctx, s->origin, s->dims);
        if (!(s->opt.node_spacing > 0))
            s->spacing = fmaxf(s->spacing, cbrtf((float)s->dims[0] * (float)s->dims[1] * (float)s->dims[2] /
                                                 (2.0f * 48.0f * 48.0f * 48.0f)));
    }
    free(s->node_density);
    s->node_density = NULL;
    if ((st = node_density(s, ctx->part.active ? NULL : &ctx->kd.density, err, errlen))) {
        free_frame(s);
        s->fit_key[0] = '\0';
        return st;
    }
    s->volume_gen = ctx->volume_gen;
    return VSD_OK;
}

/* The emitted radiance per unit length (world units, RGB) at every node: the emission
 * grid, box-filtered like the density (3 x 3 x 3 samples over the node's cell) and scaled
 * by the medium's emission colour and strength. Nodes are in the density's index space,
 * so each sample goes to world space (the inverse of the density's world-to-index map)
 * and from there into the emission grid, which may have a transform of its own. */
/* Node coordinates to world: node (a,b,c) sits at crm-space spacing * (a,b,c), i.e. density
 * index spacing * (a,b,c) - 0.5 + origin, taken to world by the inverse of the density's
 * world-to-index map. */
static vsd_status node_to_world(const crm_state *s, const vsd_frame_ctx *ctx, vsd_affine *out, char *err, size_t errlen)
{
    const float *m = ctx->kd.density.world_to_index.m;
    double a[9], inv[9], det, t[3];
    int r, c;
    for (r = 0; r < 3; r++)
        for (c = 0; c < 3; c++) a[3 * r + c] = m[4 * r + c];
    det = a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) + a[2] * (a[3] * a[7] - a[4] * a[6]);
    if (!(fabs(det) > 0.0)) return vsd_fail(VSD_ERR_INVALID, err, errlen, "crm: the density's transform is singular");
    inv[0] = (a[4] * a[8] - a[5] * a[7]) / det; inv[1] = (a[2] * a[7] - a[1] * a[8]) / det; inv[2] = (a[1] * a[5] - a[2] * a[4]) / det;
    inv[3] = (a[5] * a[6] - a[3] * a[8]) / det; inv[4] = (a[0] * a[8] - a[2] * a[6]) / det; inv[5] = (a[2] * a[3] - a[0] * a[5]) / det;
    inv[6] = (a[3] * a[7] - a[4] * a[6]) / det; inv[7] = (a[1] * a[6] - a[0] * a[7]) / det; inv[8] = (a[0] * a[4] - a[1] * a[3]) / det;
    for (r = 0; r < 3; r++) t[r] = (double)s->origin[r] - 0.5 - m[4 * r + 3];
    for (r = 0; r < 3; r++) {
        for (c = 0; c < 3; c++) out->m[4 * r + c] = (float)(inv[3 * r + c] * s->spacing);
        out->m[4 * r + 3] = (float)(inv[3 * r] * t[0] + inv[3 * r + 1] * t[1] + inv[3 * r + 2] * t[2]);
    }
    return VSD_OK;
}

/* The emitted radiance per unit length (world units, RGB) at every node: the emission
 * grid, box-filtered like the density (3 x 3 x 3 samples over the node's cell) and scaled
 * by the medium's emission colour and strength; the samples go to world space and from
 * there into the emission grid, which may have a transform of its own. */
static vsd_status node_emission(const crm_state *s, const vsd_frame_ctx *ctx, float **out, char *err, size_t errlen)
{
    vsd_affine n2w;
    size_t count = (size_t)s->node_res[0] * s->node_res[1] * s->node_res[2], n;
    float *e;
    int32_t i, j, k, u, v, w;
    vsd_status st;
    *out = NULL;
    if ((st = node_to_world(s, ctx, &n2w, err, errlen))) return st;
    if (!(e = calloc(count * 3, sizeof *e)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the emission of %zu nodes", count);
    for (n = 0, k = 0; k < s->node_res[2]; k++)
        for (j = 0; j < s->node_res[1]; j++)
            for (i = 0; i < s->node_res[0]; i++, n++) {
                float sum = 0.0f;
                for (w = -1; w <= 1; w++)
                    for (v = -1; v <= 1; v++)
                        for (u = -1; u <= 1; u++) {
                            vsd_f3 p = vsd_affine_point(&n2w, f3((float)i + (float)u / 3.0f, (float)j + (float)v / 3.0f,
                                                                  (float)k + (float)w / 3.0f));
                            sum += vsd_kvolume_at(&ctx->kd.emission, p);
                        }
                sum = sum > 0.0f ? sum / 27.0f : 0.0f;
                e[3 * n] = ctx->kd.medium.emission.x * sum;
                e[3 * n + 1] = ctx->kd.medium.emission.y * sum;
                e[3 * n + 2] = ctx->kd.medium.emission.z * sum;
            }
    *out = e;
    return VSD_OK;
}

/* The mean of the medium's albedo channels: delta-M's extinction scale 1 - a f is one
 * number per medium (the depths are scalars), for a part its own volume's (the orders scale
 * each cell by its mixture's: equal where the volumes coincide). */
static double mean_albedo(const vsd_frame_ctx *ctx)
{
    return ((double)ctx->kd.medium.albedo.x + ctx->kd.medium.albedo.y + ctx->kd.medium.albedo.z) / 3.0;
}

/* The orders' source J: SH coefficients per channel (bands 0-1 or 0-2, `ms_bands`) */
static int ms_coefficients(const crm_state *s)
{
    return s->opt.ms_bands * s->opt.ms_bands;
}

/* J_1 of the delta-M scaled problem for the orders (crm_orders.h): the nodes' single
 * scattering, sky and lights, with sigma_t (1 - a f), albedo (1 - f) / (1 - a f) times
 * `albedo` (the one the single scattering was lit with: the medium's, or a part's unit
 * albedo, which the orders turn into each node's) and the scaled phase (crm_phase.h), f =
 * g^ms_bands, a = mean_albedo, into *out (a copy of the nodes). */
static vsd_status delta_m_single(crm_state *s, vsd_frame_ctx *ctx, const double albedo[3], double g, int order,
                                 const double *grid_sh, const float *sky, float **out, char *err, size_t errlen)
{
    size_t count = (size_t)s->node_res[0] * s->node_res[1] * s->node_res[2] * CRM_NODE_FLOATS;
    double f = vsd_crm_delta_m_fraction(g, s->opt.ms_bands), shrink = 1.0 - mean_albedo(ctx) * f, scaled[3];
    const vsd_crm_phase phase = vsd_crm_phase_delta_m(g, s->opt.ms_bands);
    float scale = ctx->kd.density.scale;
    vsd_status st;
    int c;
    for (c = 0; c < 3; c++) scaled[c] = albedo[c] * (1.0 - f) / shrink;
    if (!(*out = malloc(count * sizeof **out)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the delta-M source of %zu nodes",
                        count / CRM_NODE_FLOATS);
    memcpy(*out, s->nodes.nodes, count * sizeof **out);
    st = vsd_crm_node_single(&s->depths, scale * (float)shrink, scaled, &phase, order, grid_sh, sky, ctx->threads, *out,
                             s->nodes.valid, err, errlen);
    if (!st && s->lights.count > 0) {
        /* the lights' transmittance through the scaled medium for this, then back */
        st = vsd_crm_lights_transmittance(&s->lights, scale * (float)shrink, err, errlen);
        if (!st) vsd_crm_lights_bands(&s->lights, scaled, &phase, ms_coefficients(s), 1.0f, *out);
        if (!st) st = vsd_crm_lights_transmittance(&s->lights, scale, err, errlen);
    }
    return st;
}

/* What delta-M's orders leave out of J_ms (crm_orders.h): the scaled problem counts the
 * light its forward peak passes on as unscattered (J_1 of j1, through sigma_t'), where the
 * view's single scattering (J_1, through sigma_t) does not, so that light's next scattering
 * is J_ms's: the true phase on j1's light less J_1, in J_ms's bands (`ms_bands`) per node
 * into diff (3 x CRM_MS_N floats per node, 0 past those bands; a part's, lit with unit
 * albedo, times its node's). nodes: J_1 with the lights' bands. */
static void delta_m_forward(const crm_state *s, const vsd_frame_ctx *ctx, const float *j1, double g, float *diff)
{
    size_t count = (size_t)s->node_res[0] * s->node_res[1] * s->node_res[2], i;
    const vsd_crm_phase hg = vsd_crm_phase_hg(g), scaled_phase = vsd_crm_phase_delta_m(g, s->opt.ms_bands);
    double f = vsd_crm_delta_m_fraction(g, s->opt.ms_bands), back = (1.0 - mean_albedo(ctx) * f) / (1.0 - f),
           to_true[CRM_MS_N];
    int c, l, n2 = ms_coefficients(s);
    /* per coefficient: the scaled phase's band back to the true one (back: the albedo's) */
    for (l = 0; l < CRM_MS_N; l++) {
        int band = vsd_crm_sh_band(l);
        /* (bands 0-1: chi_1 / chi'_1 = 1 + g, in the form it always had) */
        to_true[l] = band == 0 ? 1.0 : s->opt.ms_bands == 2 ? 1.0 + g : hg.chi[band] / scaled_phase.chi[band];
    }
    for (i = 0; i < count; i++)
        for (c = 0; c < 3; c++)
            for (l = 0; l < CRM_MS_N; l++) {
                const float *now = s->nodes.nodes + i * CRM_NODE_FLOATS + c * CRM_SS_N,
                            *scaled = j1 + i * CRM_NODE_FLOATS + c * CRM_SS_N;
                double a = s->node_albedo ? s->node_albedo[3 * i + c] : 1.0, d = scaled[l] * back * to_true[l] - now[l];
                diff[(3 * i + c) * CRM_MS_N + l] =
                    l < n2 && (s->nodes.valid[i] & CRM_NODE_SINGLE) ? (float)(a * d) : 0.0f;
            }
}

/* The paper's diffusion at the RBF centres (multiple "rbf"), driven by the order-2 part of
 * J_ss (its first four coefficients), warm-started from the last solve. */
static vsd_status rbf_diffusion(crm_state *s, double sigma, const double albedo[3], double g, char *err,
                                size_t errlen)
{
    int count = s->rbfs.count, n2 = s->opt.sh_order * s->opt.sh_order, l, c, q;
    double ms_albedo[3], *j_ss2;
    vsd_status st;
    /* the system has no vacuum boundary and is singular without absorption
     * (crm_diffusion.h): albedo 1 is solved as 0.999 */
    for (c = 0; c < 3; c++) ms_albedo[c] = albedo[c] < 0.999 ? albedo[c] : 0.999;
    if (s->l_m0_count != count) {
        free(s->l_m0);
        s->l_m0 = calloc((size_t)count * 3, sizeof(double));
        s->l_m0_count = s->l_m0 ? count : 0;
    }
    if (!s->l_m0 || !(j_ss2 = malloc(sizeof(double) * (size_t)count * 12)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the diffusion of %d RBFs", count);
    for (l = 0; l < count; l++)
        for (c = 0; c < 3; c++)
            for (q = 0; q < 4; q++) j_ss2[((size_t)l * 3 + c) * 4 + q] = q < n2 ? s->j_ss[((size_t)l * 3 + c) * n2 + q] : 0.0;
    st = vsd_crm_diffusion_solve_ex(&s->rbfs, sigma, ms_albedo, g, j_ss2, s->l_m0, s->j_ms, 1e-4, s->opt.cg_iterations,
                                    &s->diffusion, err, errlen);
    free(j_ss2);
    return st;
}

/* A part's single scattering was lit with albedo 1 (unit: its bands per node, saved before
 * the orders added the emission scattered once, which has the mixture's albedo already):
 * the view's takes the volume's own albedo. */
static void own_albedo_single(crm_state *s, const float *unit, const double albedo[3])
{
    size_t nodes = (size_t)s->node_res[0] * s->node_res[1] * s->node_res[2], i;
    int c, l;
    for (i = 0; i < nodes; i++)
        for (c = 0; c < 3; c++)
            for (l = 0; l < CRM_SS_N; l++)
                s->nodes.nodes[i * CRM_NODE_FLOATS + c * CRM_SS_N + l] +=
                    (float)(albedo[c] - 1.0) * unit[(i * 3 + c) * CRM_SS_N + l];
}

static vsd_status crm_prepare_lighting(void *state, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    crm_state *s = state;
    const vsd_scene *sc = ctx->scene;
    int order = s->opt.sh_order, n2 = order * order, count = s->rbfs.count, c, q;
    double grid_sh[3 * 16], albedo[3], sigma = ctx->kd.density.scale * s->voxel_world, t0, w2i[9], to_node[9];
    double g = ctx->kd.medium.anisotropy;
    const vsd_crm_phase hg = vsd_crm_phase_hg(g);
    /* lighting at the RBF centres: the paper's forms (its diffusion reads its single
     * scattering there whatever lights the nodes) */
    int centres = s->opt.single == SINGLE_SH || s->opt.multiple == MULTIPLE_RBF;
    const vsd_crm_rbfs no_rbfs = {NULL, 0};
    const vsd_env *grid_env = ctx->env;
    vsd_status st;
    if (s->parts.count) return vsd_parts_prepare_lighting(&s->parts, &vsd_method_crm, ctx, err, errlen);
    free(s->j_ss);
    free(s->j_ms);
    s->j_ss = s->j_ms = NULL;
    vsd_crm_source_grid_free(&s->nodes);
    if (!s->node_density || (centres && count == 0)) { /* an empty grid */
        vsd_crm_sky_free(&s->sky);
        return VSD_OK;
    }
    /* world directions into index space (the volume's transform), and into the node grid */
    for (c = 0; c < 3; c++)
        for (q = 0; q < 3; q++) {
            w2i[3 * c + q] = ctx->kd.density.world_to_index.m[4 * c + q];
            to_node[3 * c + q] = w2i[3 * c + q] / s->spacing;
        }
    albedo[0] = ctx->kd.medium.albedo.x;
    albedo[1] = ctx->kd.medium.albedo.y;
    albedo[2] = ctx->kd.medium.albedo.z;
    /* the sky the node grid's SH carries: the map less its bright texels, which become
     * exact lights (crm_lights.h); the paper's forms at the centres see the whole map */
    if (s->opt.single == SINGLE_GRID &&
        (st = vsd_crm_lights_update(&s->lights, ctx->env, s->opt.lights, s->opt.light_threshold,
                                    sc->environment.strength, sc->environment.rotation_z, &grid_env, err, errlen)))
        return st;
    if ((st = vsd_sh_project_env(order, grid_env, sc->environment.strength, sc->environment.rotation_z, grid_sh, err,
                                 errlen)))
        return st;
    if (centres) {
        /* the whole map, where the lights took texels from the grid's sky */
        const double *env_sh = grid_sh;
        double whole_sh[3 * 16];
        if (grid_env != ctx->env) {
            if ((st = vsd_sh_project_env(order, ctx->env, sc->environment.strength, sc->environment.rotation_z, whole_sh,
                                         err, errlen)))
                return st;
            env_sh = whole_sh;
        }
        s->j_ss = malloc(sizeof(double) * (size_t)count * 3 * n2);
        s->j_ms = calloc((size_t)count * 12, sizeof(double));
        if (!s->j_ss || !s->j_ms)
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the source radiances of %d RBFs", count);
        t0 = vsd_clock_seconds();
        st = vsd_crm_single_scatter(&s->rbfs, sigma, albedo, g, order, env_sh, s->table, s->j_ss, NULL, err, errlen);
        s->single_seconds = vsd_clock_seconds() - t0;
        if (!st && s->opt.multiple == MULTIPLE_RBF) st = rbf_diffusion(s, sigma, albedo, g, err, errlen);
        if (st) return st;
    }
    /* eq. 7 from the centres when they were lit; else empty nodes for the grid stages */
    if ((st = vsd_crm_source_grid_build(centres ? &s->rbfs : &no_rbfs, s->j_ss, n2, s->j_ms, s->dims, s->spacing,
                                        &s->nodes, err, errlen)))
        return st;
    if (s->opt.multiple == MULTIPLE_ORDERS || s->opt.single == SINGLE_GRID) {
        size_t nodes = (size_t)s->node_res[0] * s->node_res[1] * s->node_res[2], i;
        float *sigma_t, *part_emission = NULL, *lit_single = NULL, *j1 = NULL, *forward = NULL, *pixel_sky = NULL;
        /* the view sums the sky's remainder over its pixels (crm_sky.h) */
        int sum_sky = s->opt.single == SINGLE_GRID && s->opt.sky_view == SKY_VIEW_SUM;
        /* delta-M for the orders (crm_orders.h) needs the scaled problem's single
         * scattering, which only the node grid's marches give */
        int delta = s->opt.delta_m && g > 0.0 && s->opt.multiple == MULTIPLE_ORDERS && s->opt.single == SINGLE_GRID &&
                    (!ctx->part.active || vsd_crm_part_one_phase(ctx, s->origin, s->dims));
        /* a part lights its nodes with albedo 1 first: the orders scatter the mixture's
         * albedo from there, and the view's single scattering takes the volume's own after */
        const double unit[3] = {1.0, 1.0, 1.0};
        vsd_affine n2w;
        if (ctx->part.active && ctx->kd.density.scale > 0.0f) {
            /* a part: every volume's medium on the nodes, and the transmittance marched
             * for it again (crm_parts.h) */
            int emits = vsd_group_emits(&ctx->kd, ~0u);
            if (!s->node_albedo && !(s->node_albedo = malloc(3 * nodes * sizeof *s->node_albedo)))
                return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the albedo of %zu nodes", nodes);
            if (emits && !(part_emission = malloc(3 * nodes * sizeof *part_emission)))
                return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the emission of %zu nodes", nodes);
            if ((st = node_to_world(s, ctx, &n2w, err, errlen))) {
                free(part_emission);
                return st;
            }
            vsd_crm_part_medium(ctx, s->node_res, &n2w, ctx->kd.density.scale, s->node_density, s->node_albedo,
                                part_emission);
            vsd_crm_node_depths_free(&s->depths);
            vsd_crm_node_depths_free(&s->lights.depths);
        }
        if (!(sigma_t = malloc(nodes * sizeof *sigma_t))) {
            free(part_emission);
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the extinction of %zu nodes", nodes);
        }
        for (i = 0; i < nodes; i++) sigma_t[i] = ctx->kd.density.scale * s->node_density[i];
        if (s->opt.single == SINGLE_GRID) {
            int marched;
            t0 = vsd_clock_seconds();
            st = vsd_crm_node_depths_update(&s->depths, s->node_res, to_node, s->node_density, ctx->kd.density.scale,
                                            s->sky_dirs, s->opt.directions, ctx->threads, &marched, err, errlen);
            if (!st && marched && s->node_albedo)
                st = vsd_crm_part_shadows(ctx, &s->depths, &n2w, s->origin, s->dims, ctx->kd.density.scale,
                                          s->spacing * (float)s->voxel_world, ctx->threads, err, errlen);
            s->transmittance_marches += marched;
            if (!st) {
                /* toward the extracted lights: marched again when they turn with the map */
                int lights_marched;
                st = vsd_crm_lights_march(&s->lights, s->node_res, to_node, s->node_density, ctx->kd.density.scale,
                                          ctx->threads, &lights_marched, err, errlen);
                if (!st && lights_marched && s->node_albedo)
                    st = vsd_crm_part_shadows(ctx, &s->lights.depths, &n2w, s->origin, s->dims,
                                              ctx->kd.density.scale, s->spacing * (float)s->voxel_world,
                                              ctx->threads, err, errlen);
                if (!st) st = vsd_crm_lights_transmittance(&s->lights, ctx->kd.density.scale, err, errlen);
                marched |= lights_marched;
            }
            s->transmittance_seconds = marched ? vsd_clock_seconds() - t0 : 0.0;
            if (!st && (s->opt.sky == SKY_PIXELS || sum_sky)) {
                /* the map per HEALPix pixel of the transmittance's directions: the SH single
                 * scattering's L_in with `sky: "pixels"`, the view's sum with `sky_view: "sum"` */
                pixel_sky = malloc(4 * (size_t)s->opt.directions * sizeof *pixel_sky);
                if (!pixel_sky ||
                    !vsd_env_healpix_radiance(grid_env, &ctx->kd.env, vsd_sh_healpix_nside(s->opt.directions), pixel_sky))
                    st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the sky of %d directions",
                                  s->opt.directions);
            }
            {
                const float *sky = s->opt.sky == SKY_PIXELS ? pixel_sky : NULL;
                if (!st)
                    st = vsd_crm_node_single(&s->depths, ctx->kd.density.scale, s->node_albedo ? unit : albedo, &hg,
                                             order, grid_sh, sky, ctx->threads, s->nodes.nodes, s->nodes.valid, err,
                                             errlen);
                if (!st && delta)
                    st = delta_m_single(s, ctx, s->node_albedo ? unit : albedo, g, order, grid_sh, sky, &j1, err,
                                        errlen);
            }
            if (!st && (s->node_albedo || sum_sky)) {
                /* the nodes' SH single scattering as the map lit it, kept for after the orders
                 * (which read it as J_1): a part's unit-albedo light, which its own albedo
                 * scales then (own_albedo_single), or the sky the view sums itself, taken
                 * out of the nodes then */
                if (!(lit_single = malloc(nodes * 3 * CRM_SS_N * sizeof *lit_single)))
                    st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the single scattering of %zu nodes",
                                  nodes);
                for (i = 0; !st && i < nodes; i++)
                    memcpy(lit_single + i * 3 * CRM_SS_N, s->nodes.nodes + i * CRM_NODE_FLOATS,
                           3 * CRM_SS_N * sizeof *lit_single);
            }
            s->single_seconds = vsd_clock_seconds() - t0;
        }
        if (!st && s->opt.multiple == MULTIPLE_ORDERS) {
            float *emission = part_emission;
            if (!s->node_albedo && ctx->kd.medium.has_emission) st = node_emission(s, ctx, &emission, err, errlen);
            /* the lights' single scattering is J_1 too: in its bands for the orders only (in
             * j1's already, scaled, with delta-M) */
            if (!st && !j1) vsd_crm_lights_bands(&s->lights, s->node_albedo ? unit : albedo, &hg, ms_coefficients(s), 1.0f, s->nodes.nodes);
            if (!st && j1) {
                if (!(forward = malloc(3 * CRM_MS_N * nodes * sizeof *forward))) {
                    st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the delta-M source of %zu nodes",
                                  nodes);
                } else {
                    vsd_crm_lights_bands(&s->lights, s->node_albedo ? unit : albedo, &hg, ms_coefficients(s), 1.0f, s->nodes.nodes);
                    delta_m_forward(s, ctx, j1, g, forward);
                    vsd_crm_lights_bands(&s->lights, s->node_albedo ? unit : albedo, &hg, ms_coefficients(s), -1.0f, s->nodes.nodes);
                }
            }
            if (!st)
                st = vsd_crm_orders(s->node_res, to_node, sigma_t, emission, s->node_albedo ? unit : albedo,
                                    s->node_albedo, g, s->opt.ms_bands, j1, j1 != NULL, s->nodes.nodes, s->nodes.valid,
                                    s->opt.order_cell, s->opt.order_fine, s->opt.gather == GATHER_SWEEP,
                                    s->opt.order_directions, s->opt.orders, 0.01, ctx->threads, &s->orders, err, errlen);
            if (!j1) vsd_crm_lights_bands(&s->lights, s->node_albedo ? unit : albedo, &hg, ms_coefficients(s), -1.0f, s->nodes.nodes);
            for (i = 0; !st && forward && i < nodes; i++) {
                float *ms = s->nodes.nodes + i * CRM_NODE_FLOATS + 3 * CRM_SS_N;
                int c, l;
                if (!(s->nodes.valid[i] & CRM_NODE_MULTIPLE)) continue;
                for (c = 0; c < 3; c++)
                    for (l = 0; l < CRM_MS_N; l++) ms[c * CRM_MS_N + l] += forward[(3 * i + c) * CRM_MS_N + l];
            }
            free(forward);
            if (emission != part_emission) free(emission);
        }
        if (!st && lit_single && sum_sky) {
            /* the sky's remainder out of the nodes' SH (a part's at unit albedo: its own
             * albedo would scale it only for this to take it out), its sum over the pixels in */
            for (i = 0; i < nodes; i++)
                for (q = 0; q < 3 * CRM_SS_N; q++)
                    s->nodes.nodes[i * CRM_NODE_FLOATS + q] -= lit_single[i * 3 * CRM_SS_N + q];
            st = vsd_crm_sky_update(&s->sky, &s->depths, s->transmittance_marches, ctx->kd.density.scale, pixel_sky,
                                    albedo, g, err, errlen);
        } else if (!st && lit_single) {
            own_albedo_single(s, lit_single, albedo);
        }
        /* the SH carries the sky (sky_view "sh", or the paper's single scattering) */
        if (!sum_sky || st) vsd_crm_sky_free(&s->sky);
        /* the view's lights carry the volume's own albedo and phase, as its single
         * scattering does */
        free(s->view_lights);
        s->view_lights = NULL;
        s->light_g = (float)g;
        if (!st && s->lights.count > 0) {
            if (!(s->view_lights = malloc(sizeof *s->view_lights * 8 * (size_t)s->lights.count)))
                st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for %d lights", s->lights.count);
            else
                vsd_crm_lights_view(&s->lights, albedo, s->view_lights);
        }
        free(part_emission);
        free(lit_single);
        free(pixel_sky);
        free(sigma_t);
        free(j1);
    }
    return st;
}

static void crm_info(const crm_state *s, vsd_frame_ctx *ctx)
{
    vsd_crm_hash_stats hs;
    if (!ctx->info || !ctx->info_len) return;
    memset(&hs, 0, sizeof hs);
    if (s->hash) hs = vsd_crm_hash_get_stats(s->hash);
    snprintf(ctx->info, ctx->info_len,
             "rbfs=%d fit_rel_error=%.5g fit_seconds=%.3f fit_evaluations=%d fit_cached=%d fits_run=%lld "
             "hash_stored=%zu hash_bytes=%zu hash_seconds=%.3f single_seconds=%.3f transmittance_seconds=%.3f transmittance_marches=%lld cg_iterations=%d "
             "diffusion_seconds=%.3f orders=%d orders_fine=%d orders_tail=%.3f orders_seconds=%.3f nodes=%dx%dx%d node_seconds=%.3f "
             "lights=%d light_fraction=%.3f light_marches=%lld",
             s->rbfs.count, s->fit.rel_error, s->fit.seconds, s->fit.evaluations, s->fit_cached, s->fits_run,
             hs.stored, hs.bytes, hs.build_seconds, s->single_seconds, s->transmittance_seconds, s->transmittance_marches, s->diffusion.iterations, s->diffusion.seconds,
             s->orders.orders, s->orders.fine_orders, s->orders.tail, s->orders.seconds, s->nodes.res[0], s->nodes.res[1], s->nodes.res[2], s->nodes.seconds,
             s->lights.count, s->lights.fraction, s->lights.marches);
}

/* The view's kernel struct for this state, its per-view node pass done on the CPU threads
 * (on the device it runs with the view, crm_device.c, unless `cpu_nodes`). */
static vsd_status view_struct(crm_state *s, vsd_frame_ctx *ctx, vsd_kcrm *kc, int cpu_nodes, char *err, size_t errlen)
{
    memset(kc, 0, sizeof *kc);
    kc->kd = &ctx->kd;
    kc->dtilde = s->dtilde;
    kc->dfull = s->dfull;
    kc->nodes = s->nodes.nodes;
    kc->node_valid = s->nodes.valid;
    memcpy(kc->dims, s->dims, sizeof kc->dims);
    memcpy(kc->origin, s->origin, sizeof kc->origin);
    memcpy(kc->node_res, s->nodes.res, sizeof kc->node_res);
    kc->node_spacing = s->nodes.spacing > 0 ? s->nodes.spacing : 1.0f;
    kc->view_density = s->opt.view_density;
    kc->order = s->opt.sh_order;
    if (s->view_lights && s->lights.tr) {
        kc->light_count = s->lights.count;
        kc->light_tr = s->lights.tr;
        kc->lights = s->view_lights;
        kc->light_g = s->light_g;
    }
    if (s->sky.count > 0 && s->sky.tr) {
        kc->sky_count = s->sky.count;
        kc->sky_rows = (int32_t)s->sky.rows;
        kc->sky_tr = s->sky.tr;
        kc->sky_row = s->sky.row;
        kc->sky = s->sky.pixels;
        kc->sky_phase = s->sky.phase;
    }
    if (s->nodes.nodes) {
        size_t count = (size_t)kc->node_res[0] * kc->node_res[1] * kc->node_res[2];
        vsd_status st = node_to_world(s, ctx, &kc->node_to_world, err, errlen);
        if (st) return st;
        if (cpu_nodes || !ctx->cuda) {
            /* the per-view node pass (the paper's volume pass) */
            if (s->view_count != count) {
                free(s->view_nodes);
                s->view_nodes = malloc(count * CRM_VIEW_FLOATS * sizeof(float));
                s->view_count = s->view_nodes ? count : 0;
                if (!s->view_nodes) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for %zu view nodes", count);
            }
            kc->view_nodes = s->view_nodes;
            if ((st = vsd_crm_view_nodes_cpu(ctx, kc)))
                return st == VSD_ERR_CANCELLED ? vsd_fail(st, err, errlen, "render cancelled") : st;
        }
    }
    return VSD_OK;
}

/* Several volumes: every part's nodes toward this view, then one march over all volumes. */
static vsd_status parts_render(crm_state *s, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples, char *err,
                               size_t errlen)
{
    int n = s->parts.count, i;
    vsd_frame_ctx *pc = calloc((size_t)n, sizeof *pc);
    vsd_kcrm *kc = calloc((size_t)n, sizeof *kc);
    size_t nodes = 0;
    vsd_status st = VSD_OK;
    if (!pc || !kc) st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for %d volumes", n);
    /* on the device every part's node pass runs there, and the view reads device structs */
    int device = ctx->cuda && vsd_crm_volumes_view_pass.cuda;
    for (i = 0; i < n && st == VSD_OK; i++) {
        crm_state *part = s->parts.state[i];
        vsd_part_ctx(ctx, &s->parts, i, &pc[i]);
        if ((st = view_struct(part, &pc[i], &kc[i], !device, err, errlen))) break;
        nodes += (size_t)kc[i].node_res[0] * kc[i].node_res[1] * kc[i].node_res[2];
        if (device) {
            vsd_kcrm on_device;
            if ((st = vsd_crm_part_device(&pc[i], &kc[i], i, &on_device, err, errlen))) break;
            kc[i] = on_device;
        }
    }
    if (st == VSD_OK && ctx->info && ctx->info_len) snprintf(ctx->info, ctx->info_len, "volumes=%d nodes=%zu", n, nodes);
    ctx->kd.march_step = s->opt.step > 0 ? (float)s->opt.step : 2.0f * vsd_method_march_step(ctx, 0.0);
    ctx->kd.march_stop = (float)s->opt.early_termination;
    if (st == VSD_OK) st = vsd_crm_parts_view(ctx, fb, kc, n, s->opt.pixel_samples, &s->opt.view, samples, err, errlen);
    free(pc);
    free(kc);
    return st;
}

static vsd_status crm_render(void *state, vsd_frame_ctx *ctx, vsd_framebuffer *fb, int *samples, char *err,
                             size_t errlen)
{
    crm_state *s = state;
    vsd_kcrm kc;
    vsd_status st;
    if (s->parts.count) return parts_render(s, ctx, fb, samples, err, errlen);
    ctx->kd.march_step = s->opt.step > 0 ? (float)s->opt.step : 2.0f * vsd_method_march_step(ctx, 0.0);
    ctx->kd.march_stop = (float)s->opt.early_termination;
    crm_info(s, ctx);
    if ((st = view_struct(s, ctx, &kc, 0, err, errlen))) return st;
    if (!s->nodes.nodes) {
        /* an empty grid: the march still draws emission and background */
        static const float zero = 0.0f;
        static const uint8_t none = 0;
        static float no_view[CRM_VIEW_FLOATS];
        int32_t one[3] = {1, 1, 1};
        kc.dtilde = kc.dfull = NULL;
        kc.view_density = CRM_VIEW_VOXELS; /* the grid's own zeros */
        kc.nodes = &zero;
        kc.node_valid = &none;
        kc.view_nodes = no_view;
        memcpy(kc.dims, one, sizeof one);
        memcpy(kc.node_res, one, sizeof one);
    }
    return vsd_method_render_view(ctx, fb, s->opt.pixel_samples, &s->opt.view, &vsd_crm_view_pass, vsd_crm_view_struct,
                                  &kc, samples, err, errlen);
}

static void crm_destroy(void *state)
{
    crm_state *s = state;
    if (!s) return;
    free_frame(s);
    vsd_crm_rbfs_free(&s->rbfs);
    vsd_crm_od_table_destroy(s->table);
    free(s->j_ss);
    free(s->j_ms);
    free(s->l_m0);
    free(s->view_nodes);
    free(s->view_lights);
    free(s->sky_dirs);
    vsd_crm_lights_free(&s->lights);
    vsd_crm_sky_free(&s->sky);
    vsd_crm_source_grid_free(&s->nodes);
    vsd_parts_free(&s->parts, &vsd_method_crm);
    free(s);
}

/* reference's cache (render.options.cache "crm"): the light crm's orders scattered more
 * than once, as radiance in SH bands 0-1 on its nodes. The nodes keep the in-scattered
 * source J_ms = albedo x the integral of HG times the radiance, whose band l is albedo g^l
 * times the radiance's (Funk-Hecke), so the radiance is J's band 0 over the albedo and its
 * band 1 over albedo g; where |g| < 1e-3 J holds nothing of the light's direction (the
 * orders keep band 0 alone at g = 0) and the cache is isotropic. The cache need only be
 * near the truth: reference's estimate is unbiased with any. */
static vsd_status crm_radiance_cache(void *state, const vsd_frame_ctx *ctx, vsd_radiance_cache *out, char *err,
                                     size_t errlen)
{
    const crm_state *s = state;
    const size_t nodes = (size_t)s->nodes.res[0] * s->nodes.res[1] * s->nodes.res[2];
    const double g = ctx->kd.medium.anisotropy,
                 albedo[3] = {ctx->kd.medium.albedo.x, ctx->kd.medium.albedo.y, ctx->kd.medium.albedo.z};
    vsd_affine n2w;
    size_t i;
    float *sh;
    vsd_status st;
    if (s->parts.count > 0)
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                        "render.options.cache: crm's cache covers one volume so far (the scene has %d)", s->parts.count);
    memset(out, 0, sizeof *out);
    if (!s->nodes.nodes || nodes == 0) return VSD_OK;   /* an empty volume: a cache of nothing */
    if ((st = node_to_world(s, ctx, &n2w, err, errlen))) return st;
    if (!(sh = malloc(nodes * 12 * sizeof *sh)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "crm: no memory for the cache of %zu nodes", nodes);
    for (i = 0; i < nodes; i++) {
        int c, l;
        for (c = 0; c < 3; c++) {
            const float *j = s->nodes.nodes + i * CRM_NODE_FLOATS + 3 * CRM_SS_N + c * CRM_MS_N;
            const double a = albedo[c];
            float *L = sh + (i * 3 + (size_t)c) * 4;
            const int lit = (s->nodes.valid[i] & CRM_NODE_MULTIPLE) && a > 0.0;
            L[0] = lit ? (float)(j[0] / a) : 0.0f;
            for (l = 1; l < 4; l++) L[l] = lit && fabs(g) >= 1e-3 ? (float)(j[l] / (a * g)) : 0.0f;
        }
    }
    st = vsd_radiance_cache_from_sh(s->nodes.res, &n2w, sh, out, err, errlen);
    free(sh);
    return st;
}

const vsd_method vsd_method_crm = {
    .name = "crm",
    .label = "CRM",
    .summary = "Zhou 2008, compensated ray marching: node-grid lighting with multiple scattering (the paper's RBF form as options)",
    .caps = VSD_METHOD_CAP_MULTIPLE_SCATTERING | VSD_METHOD_CAP_EMISSION_SCATTERING | VSD_METHOD_CAP_CUDA_VIEW |
            VSD_METHOD_CAP_SEVERAL_VOLUMES,
    .roles = 0,
    .options = VSD_OPTION_TABLE(crm_option_rows, crm_options),
    .create = crm_create,
    .prepare_frame = crm_prepare_frame,
    .prepare_lighting = crm_prepare_lighting,
    .render = crm_render,
    .destroy = crm_destroy,
    .radiance_cache = crm_radiance_cache,
};
