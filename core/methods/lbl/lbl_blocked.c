#include "lbl_blocked.h"
#include "device/cpu/cpu_tiles.h"
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

enum { DIRS = 6, CH = 3, B = VSD_LBL_BLOCK, NODES = B * B * B, FACE = B * B };

/* the six lattice directions, in lbl_lattice.c's order: +x, -x, +y, -y, +z, -z */
static const int dir_axis[DIRS] = {0, 0, 1, 1, 2, 2};
static const int dir_sign[DIRS] = {1, -1, 1, -1, 1, -1};

static size_t block_index(const vsd_lbl_blocked *b, int bx, int by, int bz)
{
    return ((size_t)bz * b->nb[1] + by) * b->nb[0] + bx;
}

/* The node's place on the face it crosses along axis `axis`: the other two coordinates. */
static int face_of(int axis, int x, int y, int z)
{
    return axis == 0 ? z * B + y : axis == 1 ? z * B + x : y * B + x;
}

vsd_status vsd_lbl_blocked_init(vsd_lbl_blocked *b, const int32_t res[3], int block_steps, char *err, size_t errlen)
{
    int a;
    if (b->f && memcmp(b->res, res, sizeof b->res) == 0 && b->block_steps == block_steps) return VSD_OK;
    vsd_lbl_blocked_free(b);
    for (a = 0; a < 3; a++) b->nb[a] = (res[a] + B - 1) / B;
    b->blocks = (size_t)b->nb[0] * b->nb[1] * b->nb[2];
    if (b->blocks == 0) return VSD_OK;
    b->f = calloc(b->blocks * DIRS * CH * NODES, sizeof *b->f);
    b->iface[0] = calloc(b->blocks * DIRS * CH * FACE, sizeof *b->iface[0]);
    b->iface[1] = calloc(b->blocks * DIRS * CH * FACE, sizeof *b->iface[1]);
    b->collide_b = calloc(b->blocks * NODES, sizeof *b->collide_b);
    b->fluence_b = calloc(b->blocks * CH * NODES, sizeof *b->fluence_b);
    if (!b->f || !b->iface[0] || !b->iface[1] || !b->collide_b || !b->fluence_b) {
        vsd_lbl_blocked_free(b);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for a %dx%dx%d blocked lattice", res[0], res[1],
                        res[2]);
    }
    memcpy(b->res, res, sizeof b->res);
    b->block_steps = block_steps < 1 ? 1 : block_steps;
    return VSD_OK;
}

void vsd_lbl_blocked_free(vsd_lbl_blocked *b)
{
    free(b->f);
    free(b->iface[0]);
    free(b->iface[1]);
    free(b->collide_b);
    free(b->source_b);
    free(b->fluence_b);
    memset(b, 0, sizeof *b);
}

/* Node c of the caller's order (x fastest over res) as (block, node in block). */
static void locate(const vsd_lbl_blocked *b, size_t c, size_t *block, int *node)
{
    const int x = (int)(c % (size_t)b->res[0]), y = (int)(c / (size_t)b->res[0] % (size_t)b->res[1]);
    const int z = (int)(c / ((size_t)b->res[0] * b->res[1]));
    *block = block_index(b, x / B, y / B, z / B);
    *node = ((z % B) * B + y % B) * B + x % B;
}

vsd_status vsd_lbl_blocked_set_material(vsd_lbl_blocked *b, const float *collide, const float *source, char *err,
                                        size_t errlen)
{
    const size_t cells = (size_t)b->res[0] * b->res[1] * b->res[2];
    size_t c, blk;
    int node, ch;
    if (!b->f) return VSD_OK;
    free(b->source_b);
    b->source_b = NULL;
    if (source && !(b->source_b = calloc(b->blocks * CH * NODES, sizeof *b->source_b)))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for the blocked lattice's sources");
    /* nodes past the lattice's size keep p = 0 and no source: vacuum */
    memset(b->collide_b, 0, b->blocks * NODES * sizeof *b->collide_b);
    for (c = 0; c < cells; c++) {
        locate(b, c, &blk, &node);
        b->collide_b[blk * NODES + node] = collide[c];
        for (ch = 0; source && ch < CH; ch++)
            b->source_b[(blk * CH + ch) * NODES + node] = source[(size_t)ch * cells + c];
    }
    return VSD_OK;
}

typedef struct iterate_job {
    vsd_lbl_blocked *b;
    float albedo[3];
} iterate_job;

/* Per direction and node of a block: the node its population comes from (-1: across the
 * face, from the interface buffer), whether it leaves through the face, and its place on
 * that face. The same for every block: built once. */
static struct {
    int8_t from[DIRS][NODES];
    uint8_t leaves[DIRS][NODES];
    uint8_t face[DIRS][NODES];
} T;

static void build_tables(void)
{
    int i, x, y, z;
    for (i = 0; i < DIRS; i++)
        for (z = 0; z < B; z++)
            for (y = 0; y < B; y++)
                for (x = 0; x < B; x++) {
                    const int a = dir_axis[i], sg = dir_sign[i], n = (z * B + y) * B + x;
                    int q[3] = {x, y, z}, t[3] = {x, y, z};
                    q[a] -= sg;
                    t[a] += sg;
                    T.from[i][n] = (int8_t)(q[a] >= 0 && q[a] < B ? (q[2] * B + q[1]) * B + q[0] : -1);
                    T.leaves[i][n] = (uint8_t)(t[a] < 0 || t[a] >= B);
                    T.face[i][n] = (uint8_t)face_of(a, x, y, z);
                }
}

/* One iteration of block k: block_steps collide-and-stream steps on its own populations,
 * the populations arriving through its faces (iface[parity], from the neighbours' last
 * iteration) entering at the first step, what leaves through a face summed into
 * iface[1 - parity] for the neighbour. The node sums are averaged over the steps: the
 * fluence an iteration leaves (the paper's irradiance volume accumulates it), since right
 * after an exchange a face holds a whole iteration's inflow. */
static void iterate_block(const iterate_job *j, size_t k)
{
    vsd_lbl_blocked *b = j->b;
    const int bx = (int)(k % (size_t)b->nb[0]), by = (int)(k / (size_t)b->nb[0] % (size_t)b->nb[1]);
    const int bz = (int)(k / ((size_t)b->nb[0] * b->nb[1]));
    const float *p = b->collide_b + k * NODES;
    const float *in = b->iface[b->parity];
    float *out = b->iface[1 - b->parity] + k * DIRS * CH * FACE;
    float *f = b->f + k * DIRS * CH * NODES, *avg = b->fluence_b + k * CH * NODES;
    const float w = 1.0f / (float)b->block_steps;
    float post[DIRS][CH][NODES], gain[NODES], valid[NODES];
    const float *from_block[DIRS];
    int s, i, ch, n, x, y, z, sends[DIRS];
    for (i = 0; i < DIRS; i++) {
        /* populations in direction i arrive from the block on the -c_i side and leave to
         * the one on the +c_i side */
        int c[3] = {bx, by, bz}, t[3] = {bx, by, bz}, a = dir_axis[i];
        c[a] -= dir_sign[i];
        t[a] += dir_sign[i];
        from_block[i] = c[a] >= 0 && c[a] < b->nb[a]
                            ? in + (block_index(b, c[0], c[1], c[2]) * DIRS + (size_t)i) * CH * FACE
                            : NULL;
        sends[i] = t[a] >= 0 && t[a] < b->nb[a];
    }
    for (z = 0; z < B; z++)
        for (y = 0; y < B; y++)
            for (x = 0; x < B; x++)
                valid[(z * B + y) * B + x] =
                    bx * B + x < b->res[0] && by * B + y < b->res[1] && bz * B + z < b->res[2] ? 1.0f : 0.0f;
    memset(out, 0, sizeof(float) * DIRS * CH * FACE);
    memset(avg, 0, sizeof(float) * CH * NODES);
    for (s = 0; s < b->block_steps; s++) {
        /* collide: post = (1 - p) f + albedo p / 6 sum_j f_j + S / 6 (lbl_lattice.h) */
        for (ch = 0; ch < CH; ch++) {
            const float a6 = j->albedo[ch] / 6.0f;
            const float *src = b->source_b ? b->source_b + (k * CH + ch) * NODES : NULL;
            for (n = 0; n < NODES; n++) gain[n] = 0.0f;
            for (i = 0; i < DIRS; i++)
                for (n = 0; n < NODES; n++) gain[n] += f[(i * CH + ch) * NODES + n];
            for (n = 0; n < NODES; n++) gain[n] = a6 * p[n] * gain[n] + (src ? src[n] * (1.0f / 6.0f) : 0.0f);
            for (i = 0; i < DIRS; i++)
                for (n = 0; n < NODES; n++) post[i][ch][n] = (1.0f - p[n]) * f[(i * CH + ch) * NODES + n] + gain[n];
        }
        /* stream one node along c_i: inside the block directly, across a face through the
         * interface buffers; nodes past the lattice's size are vacuum */
        for (i = 0; i < DIRS; i++)
            for (ch = 0; ch < CH; ch++) {
                const float *face_in = s == 0 && from_block[i] ? from_block[i] + ch * FACE : NULL;
                float *fi = f + (i * CH + ch) * NODES, *o = out + (i * CH + ch) * FACE;
                for (n = 0; n < NODES; n++) {
                    const int q = T.from[i][n];
                    const float v = q >= 0 ? post[i][ch][q] : face_in ? face_in[T.face[i][n]] : 0.0f;
                    fi[n] = valid[n] * v;
                    if (T.leaves[i][n] && sends[i]) o[T.face[i][n]] += valid[n] * post[i][ch][n];
                }
            }
        for (ch = 0; ch < CH; ch++)
            for (i = 0; i < DIRS; i++)
                for (n = 0; n < NODES; n++) avg[ch * NODES + n] += w * f[(i * CH + ch) * NODES + n];
    }
}

static void iterate_blocks(void *arg, int k0, int y0, int k1, int y1)
{
    int k;
    (void)y0;
    (void)y1;
    for (k = k0; k < k1; k++) iterate_block(arg, (size_t)k);
}

vsd_status vsd_lbl_blocked_iterate(vsd_lbl_blocked *b, const float albedo[3], int threads)
{
    iterate_job j;
    vsd_status st;
    int ch;
    static pthread_once_t once = PTHREAD_ONCE_INIT;
    if (!b->f) return VSD_OK;
    pthread_once(&once, build_tables);
    j.b = b;
    for (ch = 0; ch < CH; ch++) j.albedo[ch] = albedo[ch];
    st = vsd_cpu_run_items((int)b->blocks, threads, iterate_blocks, &j, "lbl diffusion");
    if (!st) b->parity = 1 - b->parity;
    return st;
}

float vsd_lbl_blocked_node_sum(const vsd_lbl_blocked *b, int ch, size_t c)
{
    size_t blk;
    int node;
    locate(b, c, &blk, &node);
    return b->fluence_b[(blk * CH + ch) * NODES + node];
}

double vsd_lbl_blocked_total(const vsd_lbl_blocked *b, int ch)
{
    double s = 0.0;
    size_t k;
    int i, n;
    for (k = 0; k < b->blocks; k++)
        for (i = 0; i < DIRS; i++) {
            for (n = 0; n < NODES; n++) s += b->f[((k * DIRS + i) * CH + ch) * NODES + n];
            for (n = 0; n < FACE; n++) s += b->iface[b->parity][((k * DIRS + i) * CH + ch) * FACE + n];
        }
    return s;
}
