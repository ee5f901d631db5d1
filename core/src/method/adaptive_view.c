/* Adaptive view sampling for the deterministic view passes on the CPU (stratified.c):
 * rays through every s-th pixel in x and y first (the anchors, and the last row and
 * column), then each s x s block of pixels between four anchors is either interpolated
 * bilinearly from them or traced pixel by pixel, when the anchors differ by more than the
 * threshold:
 *   any radiance channel (VolumeDir, VolumeInd, Emit; the background too on an opaque
 *   film): max - min > threshold * max(largest |value| of the four, 5% of the image's
 *   brightest anchor) — relative where the volume is bright, and not chasing differences
 *   that are small beside the whole picture;
 *   Transmittance: max - min > threshold;
 *   Depth: some strata of one anchor hit the medium where another's do not (a silhouette).
 * Why it is sound here: these methods are deterministic (no noise to mistake for detail),
 * and at film resolutions above the volume's the image is smooth between pixels — at
 * 1280x720 a 128^3 smoke's voxel covers about 5 pixels, so a trilinear field cannot put a
 * feature between anchors 2 pixels apart that the anchors do not see. Where it is not (a
 * wisp thinner than s pixels, the background map's texture) the threshold decides, and
 * docs/methods/lbl.md measures the image against the traced one. The automatic spacing
 * (vsd_view_auto_spacing) follows the same argument: the anchors at most 2/3 of a voxel's
 * footprint on the film apart (at the volume's centre), so low resolutions trace every
 * pixel. */
#include "method.h"
#include "src/render/accum.h"
#include "device/cpu/cpu_tiles.h"
#include "device/device_pass.h"
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

typedef struct adaptive_view {
    const vsd_device_pass *pass;
    const void *kernel;
    vsd_accum *acc;            /* sums of the traced pixels only (read back only where traced[] says) */
    vsd_framebuffer *fb;       /* every pixel resolved here, traced or interpolated */
    double inv;                /* 1 / the strata per pixel */
    int n, s, transparent;
    int nxa, nya;              /* anchors per row and column */
    int bx, by, tiles_x;       /* blocks per row and column (at least 1); tiles of blocks per row */
    double *anchors;           /* [nya * nxa * VSD_ACC_N] sums over the n x n strata */
    double floor;              /* 5% of the brightest anchor's per-sample radiance */
    double threshold;
    unsigned char *traced;     /* [width * height]: 1 where the film's pixel was traced (fill_blocks) */
    atomic_int rays;          /* pixels traced between the anchors */
} adaptive_view;

/* pixel coordinate of anchor i along an axis of `len` pixels */
static int anchor_pos(int i, int s, int len) { return i * s < len - 1 ? i * s : len - 1; }

static void trace_pixel(const adaptive_view *a, int x, int y, double *sums)
{
    int k;
    for (k = 0; k < a->n * a->n; k++) {
        vsd_sample_result r = a->pass->sample(a->kernel, x, y, k, a->n);
        vsd_accum_sample(sums, &r);
    }
}

static void anchor_fn(void *user, int i0, int j0, int i1, int j1)
{
    adaptive_view *a = user;
    int i, j;
    for (j = j0; j < j1; j++)
        for (i = i0; i < i1; i++)
            trace_pixel(a, anchor_pos(i, a->s, a->acc->width), anchor_pos(j, a->s, a->acc->height),
                        a->anchors + ((size_t)j * a->nxa + i) * VSD_ACC_N);
}

/* The lowest and highest of sum q over the four corners. */
static void corner_range(const double *const c[4], int q, double *lo, double *hi)
{
    int k;
    *lo = *hi = c[0][q];
    for (k = 1; k < 4; k++) {
        *lo = fmin(*lo, c[k][q]);
        *hi = fmax(*hi, c[k][q]);
    }
}

/* Whether the four anchor sums c[4] differ by more than the threshold (see the top). */
static int needs_tracing(const adaptive_view *a, const double *const c[4])
{
    const double inv = 1.0 / (double)(a->n * a->n);
    double lo, hi;
    int q, last = a->transparent ? VSD_ACC_BG : VSD_ACC_T;
    for (q = VSD_ACC_DIR; q < last; q++) {
        corner_range(c, q, &lo, &hi);
        if ((hi - lo) * inv > a->threshold * fmax(fmax(fabs(lo), fabs(hi)) * inv, a->floor)) return 1;
    }
    corner_range(c, VSD_ACC_DEPTH_N, &lo, &hi);
    if (lo != hi) return 1;   /* a silhouette */
    corner_range(c, VSD_ACC_T, &lo, &hi);
    return (hi - lo) * inv > a->threshold;
}

/* The bilinear mix at (u, v) of the four corners' sums c[4] (c[1] along u, c[2] along v). */
static void bilinear(const double *const c[4], double u, double v, double *out)
{
    int q;
    for (q = 0; q < VSD_ACC_N; q++)
        out[q] = (1 - v) * ((1 - u) * c[0][q] + u * c[1][q]) + v * ((1 - u) * c[2][q] + u * c[3][q]);
}

/* A block's lattice of pixels, (s + 1)^2 at most, while it is refined: a flagged block is
 * not traced whole at once but halved: the midpoints of its edges and its centre are
 * traced, and each part is decided again on its own four corners, down to single pixels
 * (4 -> 2 -> 1; 3 -> 1 and 2; the last block of a row or column is as long as the film
 * leaves it). Along a silhouette or a shadow's edge only the parts the edge crosses are
 * traced pixel by pixel; the others interpolate over half the spacing, which is no coarser
 * than the block's own interpolation they would have had with agreeing anchors. Points on
 * the block's far edges belong to the next blocks, which a tile fills first (it goes from
 * its last block back to its first): what they traced is read from the film, and only what
 * they interpolated (or what lies in another tile) is traced here, for this block's parts
 * alone. */
#define SIDE_MAX (VSD_VIEW_SPACING_MAX + 1)
enum { POINT_UNKNOWN, POINT_INTERPOLATED, POINT_TRACED };
typedef struct block_lattice {
    int x0, y0, side;   /* film pixel of point (0, 0); points per row */
    int reuse_x, reuse_y;   /* the far column (x = x0 + side - 1) / row is the next block's, done already */
    int far_y;              /* the far row's j */
    double v[SIDE_MAX * SIDE_MAX][VSD_ACC_N];
    unsigned char state[SIDE_MAX * SIDE_MAX];
    int rays;           /* pixels traced here */
} block_lattice;

static double *lattice_point(block_lattice *b, int i, int j) { return b->v[j * b->side + i]; }

static void trace_point(const adaptive_view *a, block_lattice *b, int i, int j)
{
    const int k = j * b->side + i, w = a->acc->width;
    const size_t film = (size_t)(b->y0 + j) * w + (b->x0 + i);
    if (b->state[k] == POINT_TRACED) return;
    b->state[k] = POINT_TRACED;
    if (((b->reuse_x && i == b->side - 1) || (b->reuse_y && j == b->far_y)) && a->traced[film]) {
        memcpy(b->v[k], a->acc->v + film * VSD_ACC_N, sizeof b->v[k]);
        return;
    }
    memset(b->v[k], 0, sizeof b->v[k]);
    trace_pixel(a, b->x0 + i, b->y0 + j, b->v[k]);
    b->rays++;
}

/* The w x h rectangle of points from (i0, j0), its four corners traced. */
static void refine(const adaptive_view *a, block_lattice *b, int i0, int j0, int w, int h)
{
    const double *c[4] = {lattice_point(b, i0, j0), lattice_point(b, i0 + w, j0), lattice_point(b, i0, j0 + h),
                          lattice_point(b, i0 + w, j0 + h)};
    const int hx = w / 2, hy = h / 2;   /* where the halves meet (0: not split along that axis) */
    int i, j;
    if (w < 2 && h < 2) return;   /* no points between the corners */
    if (!needs_tracing(a, c)) {
        for (j = j0; j <= j0 + h; j++)
            for (i = i0; i <= i0 + w; i++) {
                const int k = j * b->side + i;
                if (b->state[k] != POINT_UNKNOWN) continue;
                bilinear(c, w ? (double)(i - i0) / w : 0.0, h ? (double)(j - j0) / h : 0.0, b->v[k]);
                b->state[k] = POINT_INTERPOLATED;
            }
        return;
    }
    if (w >= 2) {
        trace_point(a, b, i0 + hx, j0);
        trace_point(a, b, i0 + hx, j0 + h);
    }
    if (h >= 2) {
        trace_point(a, b, i0, j0 + hy);
        trace_point(a, b, i0 + w, j0 + hy);
    }
    if (w >= 2 && h >= 2) {
        trace_point(a, b, i0 + hx, j0 + hy);
        refine(a, b, i0, j0, hx, hy);
        refine(a, b, i0 + hx, j0, w - hx, hy);
        refine(a, b, i0, j0 + hy, hx, h - hy);
        refine(a, b, i0 + hx, j0 + hy, w - hx, h - hy);
    } else if (w >= 2) {
        refine(a, b, i0, j0, hx, h);
        refine(a, b, i0 + hx, j0, w - hx, h);
    } else {
        refine(a, b, i0, j0, w, hy);
        refine(a, b, i0, j0 + hy, w, h - hy);
    }
}

/* Blocks [bi0, bi1) x [bj0, bj1), one thread's. Block (bi, bj): the pixels from anchor
 * (bi, bj) up to, not including, the next anchors, except on the last block of a row or
 * column, which ends on the image's last pixel. */
static void fill_blocks(adaptive_view *a, int bi0, int bj0, int bi1, int bj1)
{
    const int w = a->acc->width, h = a->acc->height;
    block_lattice b;
    int bi, bj, rays = 0;
    /* from the tile's last block back, so the blocks that own this one's far edges are done */
    for (bj = bj1 - 1; bj >= bj0; bj--)
        for (bi = bi1 - 1; bi >= bi0; bi--) {
            int i1 = bi + 1 < a->nxa ? bi + 1 : bi, j1 = bj + 1 < a->nya ? bj + 1 : bj;
            int xa = anchor_pos(bi, a->s, w), xb = anchor_pos(i1, a->s, w);
            int ya = anchor_pos(bj, a->s, h), yb = anchor_pos(j1, a->s, h);
            int xe = i1 == a->nxa - 1 ? xb + 1 : xb, ye = j1 == a->nya - 1 ? yb + 1 : yb;
            const int bw = xb - xa, bh = yb - ya;
            int x, y;
            const double *c[4] = {a->anchors + ((size_t)bj * a->nxa + bi) * VSD_ACC_N,
                                  a->anchors + ((size_t)bj * a->nxa + i1) * VSD_ACC_N,
                                  a->anchors + ((size_t)j1 * a->nxa + bi) * VSD_ACC_N,
                                  a->anchors + ((size_t)j1 * a->nxa + i1) * VSD_ACC_N};
            if (xe == xa) xe = xa + 1;   /* a one-pixel-wide image */
            if (ye == ya) ye = ya + 1;
            if (!needs_tracing(a, c)) {
                /* most blocks: straight into the film, as refine() would interpolate them */
                for (y = ya; y < ye; y++)
                    for (x = xa; x < xe; x++) {
                        const size_t film = (size_t)y * w + x;
                        const int corner = (x == xa || x == xb) && (y == ya || y == yb);
                        double mix[VSD_ACC_N];
                        const double *p = mix;
                        a->traced[film] = (unsigned char)corner;
                        if (corner) {
                            p = c[(x == xb && xb != xa) + 2 * (y == yb && yb != ya)];
                            memcpy(a->acc->v + film * VSD_ACC_N, p, VSD_ACC_N * sizeof *p);
                        } else {
                            bilinear(c, bw ? (double)(x - xa) / bw : 0.0, bh ? (double)(y - ya) / bh : 0.0, mix);
                        }
                        vsd_accum_resolve_pixel(p, a->inv, a->transparent, a->fb, film);
                    }
                continue;
            }
            b.x0 = xa, b.y0 = ya, b.side = bw + 1, b.rays = 0, b.far_y = bh;
            b.reuse_x = xe == xb && bi + 1 < bi1;
            b.reuse_y = ye == yb && bj + 1 < bj1;
            memset(b.state, POINT_UNKNOWN, (size_t)(bw + 1) * (bh + 1));
            /* the corners: the anchors' own rays */
            memcpy(lattice_point(&b, 0, 0), c[0], sizeof b.v[0]);
            memcpy(lattice_point(&b, bw, 0), c[1], sizeof b.v[0]);
            memcpy(lattice_point(&b, 0, bh), c[2], sizeof b.v[0]);
            memcpy(lattice_point(&b, bw, bh), c[3], sizeof b.v[0]);
            b.state[0] = b.state[bw] = b.state[bh * b.side] = b.state[bh * b.side + bw] = POINT_TRACED;
            refine(a, &b, 0, 0, bw, bh);
            rays += b.rays;
            for (y = ya; y < ye; y++)
                for (x = xa; x < xe; x++) {
                    const size_t film = (size_t)y * w + x;
                    const double *p = lattice_point(&b, x - xa, y - ya);
                    const int traced = b.state[(y - ya) * b.side + (x - xa)] == POINT_TRACED;
                    /* the sums kept only where a later block may read them back (trace_point) */
                    if (traced) memcpy(a->acc->v + film * VSD_ACC_N, p, sizeof b.v[0]);
                    a->traced[film] = (unsigned char)traced;
                    vsd_accum_resolve_pixel(p, a->inv, a->transparent, a->fb, film);
                }
        }
    atomic_fetch_add(&a->rays, rays);
}

/* Tiles of BLOCK_TILE x BLOCK_TILE blocks, items [t0, t1) of a list, each on one thread:
 * within a tile the blocks that own a block's far edges are filled before it. */
#define BLOCK_TILE 16
static void block_tiles_fn(void *user, int t0, int unused0, int t1, int unused1)
{
    adaptive_view *a = user;
    int t;
    (void)unused0, (void)unused1;
    for (t = t0; t < t1; t++) {
        const int bi0 = (t % a->tiles_x) * BLOCK_TILE, bj0 = (t / a->tiles_x) * BLOCK_TILE;
        fill_blocks(a, bi0, bj0, bi0 + BLOCK_TILE < a->bx ? bi0 + BLOCK_TILE : a->bx,
                    bj0 + BLOCK_TILE < a->by ? bj0 + BLOCK_TILE : a->by);
    }
}

int vsd_view_auto_spacing(const vsd_frame_ctx *ctx)
{
    const vsd_kvolume *v = ctx->kd.density.dims[0] ? &ctx->kd.density : &ctx->kd.emission;
    const vsd_kcamera *c = &ctx->kd.camera;
    const float *m = c->cam_to_world.m;
    int maxdim = c->width > c->height ? c->width : c->height;
    double px, s;
    if (!v->dims[0] || maxdim <= 0) return 1;
    if (c->orthographic) {
        /* v->step is about half a voxel's world length */
        px = 2.0 * v->step / (2.0 * c->ortho_half_width / maxdim);
    } else {
        vsd_f3 q = vsd_affine_point(&v->world_to_index, f3(m[3], m[7], m[11]));
        double dx = q.x - (v->origin[0] + 4.0 * v->dims[0]), dy = q.y - (v->origin[1] + 4.0 * v->dims[1]);
        double dz = q.z - (v->origin[2] + 4.0 * v->dims[2]), d = sqrt(dx * dx + dy * dy + dz * dz);
        if (!(d > 1.0)) return 1;   /* the camera inside the volume */
        px = (1.0 / d) / (2.0 * c->tan_half_fov / maxdim);
    }
    /* anchors at most 2/3 of a voxel's footprint apart, so any voxel-sized feature of the
     * trilinear field spans more than one anchor interval */
    s = floor(px / 1.5);
    return s < 1.0 ? 1 : s > 4.0 ? 4 : (int)s;
}

vsd_status vsd_adaptive_view(vsd_frame_ctx *ctx, vsd_accum *acc, vsd_framebuffer *fb, int n, const vsd_view_sampling *vs,
                             const vsd_device_pass *pass, const void *kernel, int *traced_permille, char *err,
                             size_t errlen)
{
    adaptive_view a;
    vsd_tile_job job;
    vsd_status st;
    size_t k, count;
    double top = 0.0;
    memset(&a, 0, sizeof a);
    a.pass = pass;
    a.kernel = kernel;
    a.acc = acc;
    a.fb = fb;
    a.n = n;
    a.inv = 1.0 / (double)(n * n);
    a.s = vs->spacing;
    a.threshold = vs->threshold;
    a.transparent = ctx->scene->film.transparent;
    a.nxa = (acc->width - 1 + a.s - 1) / a.s + 1;
    a.nya = (acc->height - 1 + a.s - 1) / a.s + 1;
    a.bx = a.nxa > 1 ? a.nxa - 1 : 1;
    a.by = a.nya > 1 ? a.nya - 1 : 1;
    a.tiles_x = (a.bx + BLOCK_TILE - 1) / BLOCK_TILE;
    count = (size_t)a.nxa * a.nya;
    a.anchors = calloc(count * VSD_ACC_N, sizeof *a.anchors);
    a.traced = calloc((size_t)acc->width * acc->height, 1);
    if (!a.anchors || !a.traced) {
        free(a.anchors);
        free(a.traced);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %zu view anchors and a %dx%d traced map", count,
                        acc->width, acc->height);
    }
    vsd_method_item_job(&job, ctx, a.nxa, anchor_fn, &a, pass->stage);
    job.width = a.nxa;
    job.height = a.nya;
    job.progress_span = 0.3f;
    if ((st = vsd_cpu_run_tiles(&job))) goto done;
    for (k = 0; k < count; k++) {
        const double *p = a.anchors + k * VSD_ACC_N;
        int q;
        for (q = 0; q < 3; q++)
            top = fmax(top, p[VSD_ACC_DIR + q] + p[VSD_ACC_IND + q] + p[VSD_ACC_EMIT + q] +
                                (a.transparent ? 0.0 : p[VSD_ACC_BG + q]));
    }
    a.floor = 0.05 * top / (double)(n * n);
    vsd_method_item_job(&job, ctx, a.tiles_x * ((a.by + BLOCK_TILE - 1) / BLOCK_TILE), block_tiles_fn, &a,
                        pass->stage);
    job.item_range = 1;
    job.progress_base = 0.3f;
    job.progress_span = 0.7f;
    st = vsd_cpu_run_tiles(&job);
    if (traced_permille)
        *traced_permille = (int)(1000.0 * ((double)count + a.rays) / ((double)acc->width * acc->height) + 0.5);
done:
    free(a.anchors);
    free(a.traced);
    if (st == VSD_ERR_CANCELLED) vsd_fail(st, err, errlen, "render cancelled");
    return st;
}
