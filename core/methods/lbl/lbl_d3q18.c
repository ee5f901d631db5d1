#include "lbl_d3q18.h"
#include "device/cpu/cpu_tiles.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { DIRS = 18, AXES = 6, CH = 3 };

/* the 6 axis directions in lbl_lattice.c's order, then the 12 diagonals of the xy, xz, yz
 * planes */
static const int8_t dir[DIRS][3] = {
    {1, 0, 0},  {-1, 0, 0}, {0, 1, 0},  {0, -1, 0}, {0, 0, 1},  {0, 0, -1},
    {1, 1, 0},  {-1, -1, 0}, {1, -1, 0}, {-1, 1, 0}, {1, 0, 1},  {-1, 0, -1},
    {1, 0, -1}, {-1, 0, 1}, {0, 1, 1},  {0, -1, -1}, {0, 1, -1}, {0, -1, 1},
};
#define W_AXIS (1.0f / 12.0f)
#define W_DIAG (1.0f / 24.0f)
#define SQRT2 1.41421356237f

vsd_status vsd_lbl_q18_init(vsd_lbl_q18 *q, const int32_t res[3], char *err, size_t errlen)
{
    size_t cells = (size_t)res[0] * res[1] * res[2];
    if (q->f && memcmp(q->res, res, sizeof q->res) == 0) return VSD_OK;
    vsd_lbl_q18_free(q);
    if (cells == 0) return VSD_OK;
    q->f = calloc(cells * DIRS * CH, sizeof *q->f);
    q->post = malloc(cells * DIRS * CH * sizeof *q->post);
    q->pd = malloc(cells * sizeof *q->pd);
    if (!q->f || !q->post || !q->pd) {
        vsd_lbl_q18_free(q);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "lbl: no memory for a %dx%dx%d D3Q18 lattice (%.0f MB)", res[0],
                        res[1], res[2], (double)cells * DIRS * CH * 8 / 1e6);
    }
    memcpy(q->res, res, sizeof q->res);
    q->cells = cells;
    return VSD_OK;
}

void vsd_lbl_q18_free(vsd_lbl_q18 *q)
{
    free(q->f);
    free(q->post);
    free(q->pd);
    memset(q, 0, sizeof *q);
}

void vsd_lbl_q18_set_material(vsd_lbl_q18 *q, const float *collide, const float *source)
{
    size_t c;
    q->p = collide;
    q->source = source;
    /* the same medium over a link √2 as long */
    for (c = 0; q->pd && c < q->cells; c++)
        q->pd[c] = collide[c] < 1.0f ? 1.0f - powf(1.0f - collide[c], SQRT2) : 1.0f;
}

typedef struct q18_job {
    vsd_lbl_q18 *q;
    float albedo[3];
} q18_job;

/* collision of slices [z0, z1): post_i = (1 - p_i) f_i + w_i (albedo sum_j p_j f_j + S) */
static void collide_slices(void *arg, int z0, int y0, int z1, int y1)
{
    const q18_job *j = arg;
    const vsd_lbl_q18 *q = j->q;
    const size_t cells = q->cells, slice = (size_t)q->res[0] * q->res[1];
    const size_t c0 = (size_t)z0 * slice, n = (size_t)(z1 - z0) * slice;
    size_t c;
    int ch, i;
    (void)y0;
    (void)y1;
    for (ch = 0; ch < CH; ch++) {
        const float *src = q->source ? q->source + (size_t)ch * cells + c0 : NULL;
        for (c = 0; c < n; c++) {
            const float pa = q->p[c0 + c], pd = q->pd[c0 + c];
            float sa = 0.0f, sd = 0.0f, g;
            for (i = 0; i < AXES; i++) sa += q->f[((size_t)i * CH + ch) * cells + c0 + c];
            for (i = AXES; i < DIRS; i++) sd += q->f[((size_t)i * CH + ch) * cells + c0 + c];
            g = j->albedo[ch] * (pa * sa + pd * sd) + (src ? src[c] : 0.0f);
            for (i = 0; i < DIRS; i++) {
                const size_t o = ((size_t)i * CH + ch) * cells + c0 + c;
                q->post[o] = i < AXES ? (1.0f - pa) * q->f[o] + W_AXIS * g : (1.0f - pd) * q->f[o] + W_DIAG * g;
            }
        }
    }
}

/* streaming into slices [z0, z1): f_i(x) = post_i(x - c_i), 0 from outside the lattice */
static void stream_slices(void *arg, int z0, int y0, int z1, int y1)
{
    const q18_job *j = arg;
    const vsd_lbl_q18 *q = j->q;
    const int32_t nx = q->res[0], ny = q->res[1], nz = q->res[2];
    const size_t cells = q->cells;
    int i, ch, z, y;
    (void)y0;
    (void)y1;
    for (i = 0; i < DIRS; i++)
        for (ch = 0; ch < CH; ch++) {
            float *dst = q->f + ((size_t)i * CH + ch) * cells;
            const float *src = q->post + ((size_t)i * CH + ch) * cells;
            const int dx = dir[i][0], dy = dir[i][1], dz = dir[i][2];
            for (z = z0; z < z1; z++)
                for (y = 0; y < ny; y++) {
                    const size_t row = ((size_t)z * ny + y) * nx;
                    const int sy = y - dy, sz = z - dz;
                    if (sy < 0 || sy >= ny || sz < 0 || sz >= nz) {
                        memset(dst + row, 0, sizeof(float) * (size_t)nx);
                        continue;
                    }
                    {
                        const float *s = src + ((size_t)sz * ny + sy) * nx;
                        if (dx == 0) {
                            memcpy(dst + row, s, sizeof(float) * (size_t)nx);
                        } else if (dx > 0) {
                            dst[row] = 0.0f;
                            memcpy(dst + row + 1, s, sizeof(float) * (size_t)(nx - 1));
                        } else {
                            memcpy(dst + row, s + 1, sizeof(float) * (size_t)(nx - 1));
                            dst[row + nx - 1] = 0.0f;
                        }
                    }
                }
        }
}

vsd_status vsd_lbl_q18_step(vsd_lbl_q18 *q, const float albedo[3], int threads)
{
    q18_job j;
    vsd_status st;
    int ch;
    if (!q->f || !q->p) return VSD_OK;
    j.q = q;
    for (ch = 0; ch < CH; ch++) j.albedo[ch] = albedo[ch];
    st = vsd_cpu_run_items(q->res[2], threads, collide_slices, &j, "lbl diffusion");
    return st ? st : vsd_cpu_run_items(q->res[2], threads, stream_slices, &j, "lbl diffusion");
}

float vsd_lbl_q18_node_fluence(const vsd_lbl_q18 *q, int ch, size_t c)
{
    float a = 0.0f, d = 0.0f;
    int i;
    for (i = 0; i < AXES; i++) a += q->f[((size_t)i * CH + ch) * q->cells + c];
    for (i = AXES; i < DIRS; i++) d += q->f[((size_t)i * CH + ch) * q->cells + c];
    return a + SQRT2 * d;
}

double vsd_lbl_q18_total(const vsd_lbl_q18 *q, int ch)
{
    double s = 0.0;
    size_t c;
    int i;
    for (i = 0; i < DIRS; i++)
        for (c = 0; c < q->cells; c++) s += q->f[((size_t)i * CH + ch) * q->cells + c];
    return s;
}
