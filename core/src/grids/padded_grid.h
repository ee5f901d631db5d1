/* padded_grid.h — a scalar grid with a zero border (one cell below, two above per axis), so
 * a trilinear lookup anywhere in [-1, res] reads its eight corners without bounds tests.
 * The hot loops of the methods' lighting marches (crm's node transmittance, lbl's light
 * rays) sample it millions of times. Values sit at integer coordinates: node (i,j,k) at
 * (i,j,k); outside the grid the field falls linearly to 0 over one cell. */
#ifndef VSD_PADDED_GRID_H
#define VSD_PADDED_GRID_H
#include <math.h>
#include <stddef.h>
#include <stdint.h>

typedef struct vsd_padded_grid {
    float *v;
    size_t sx, sy;           /* strides of v */
    int32_t res[3];
} vsd_padded_grid;

/* 0 when out of memory. values: res x*y*z, x fastest. */
int vsd_padded_grid_build(vsd_padded_grid *p, const int32_t res[3], const float *values);
void vsd_padded_grid_free(vsd_padded_grid *p);

/* Trilinear value at (x, y, z) in [-1, res]. */
static inline float vsd_padded_at(const vsd_padded_grid *p, float x, float y, float z)
{
    float fx = floorf(x), fy = floorf(y), fz = floorf(z), tx = x - fx, ty = y - fy, tz = z - fz;
    const float *c = p->v + (size_t)((int32_t)fz + 1) * p->sy + (size_t)((int32_t)fy + 1) * p->sx + (size_t)((int32_t)fx + 1);
    float c00 = c[0] + (c[1] - c[0]) * tx, c10 = c[p->sx] + (c[p->sx + 1] - c[p->sx]) * tx;
    float c01 = c[p->sy] + (c[p->sy + 1] - c[p->sy]) * tx;
    float c11 = c[p->sy + p->sx] + (c[p->sy + p->sx + 1] - c[p->sy + p->sx]) * tx;
    float c0 = c00 + (c10 - c00) * ty, c1 = c01 + (c11 - c01) * ty;
    return c0 + (c1 - c0) * tz;
}

#endif
