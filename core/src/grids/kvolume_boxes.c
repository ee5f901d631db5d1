/* A kernel volume's boxes and maps (kvolume_boxes.h). */
#include "kvolume_boxes.h"
#include "vsd/volume.h"

void vsd_kvolume_brick_extent(const vsd_kvolume *v, int *longest, int *shortest)
{
    int a;
    *longest = *shortest = 8 * v->dims[0];
    for (a = 1; a < 3; a++) {
        int n = 8 * v->dims[a];
        if (n > *longest) *longest = n;
        if (n < *shortest) *shortest = n;
    }
}

int vsd_kvolume_active_index_box(const vsd_kvolume *v, double lo[3], double hi[3])
{
    int a, x, y, z, any = 0;
    if (v->dims[0] == 0 || !v->brick_max) return 0;
    for (z = 0; z < v->dims[2]; z++)
        for (y = 0; y < v->dims[1]; y++)
            for (x = 0; x < v->dims[0]; x++) {
                int b[3] = {x, y, z};
                if (!(v->brick_max[((size_t)z * v->dims[1] + y) * v->dims[0] + x] > 0.0f)) continue;
                for (a = 0; a < 3; a++) {
                    double l = v->origin[a] + 8.0 * b[a], h = l + 8.0;
                    if (!any || l < lo[a]) lo[a] = l;
                    if (!any || h > hi[a]) hi[a] = h;
                }
                any = 1;
            }
    return any;
}

void vsd_kvolume_world_to_index_d(const vsd_kvolume *v, double w2i[16])
{
    int a;
    for (a = 0; a < 12; a++) w2i[a] = v->world_to_index.m[a];
    w2i[12] = w2i[13] = w2i[14] = 0;
    w2i[15] = 1;
}

int vsd_kvolume_index_to_world(const vsd_kvolume *v, double i2w[16])
{
    double w2i[16];
    vsd_kvolume_world_to_index_d(v, w2i);
    return vsd_mat4_invert(w2i, i2w);
}

void vsd_affine_apply_d(const double m[16], const double p[3], double out[3])
{
    int a;
    for (a = 0; a < 3; a++) out[a] = m[4 * a] * p[0] + m[4 * a + 1] * p[1] + m[4 * a + 2] * p[2] + m[4 * a + 3];
}

vsd_f3 vsd_box_probe(const double lo[3], const double hi[3], int k, int i)
{
    const int x = i % k, y = (i / k) % k, z = i / (k * k);
    return f3((float)(lo[0] + (hi[0] - lo[0]) * (x + 0.5) / k), (float)(lo[1] + (hi[1] - lo[1]) * (y + 0.5) / k),
              (float)(lo[2] + (hi[2] - lo[2]) * (z + 0.5) / k));
}

void vsd_affine_box(const double m[16], const double lo[3], const double hi[3], double out_lo[3], double out_hi[3])
{
    int a, c;
    for (c = 0; c < 8; c++) {
        double p[3] = {(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]}, q[3];
        vsd_affine_apply_d(m, p, q);
        for (a = 0; a < 3; a++) {
            if (c == 0 || q[a] < out_lo[a]) out_lo[a] = q[a];
            if (c == 0 || q[a] > out_hi[a]) out_hi[a] = q[a];
        }
    }
}
