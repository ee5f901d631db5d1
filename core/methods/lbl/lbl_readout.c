#include "lbl_readout.h"
#include "kernel/kernel_phase.h"
#include "src/common/fibonacci_sphere.h"
#include <math.h>
#include <string.h>

#define FIB 4096

/* the cube-map cell of direction d: face = 2 axis + (component < 0), (u, v) the other two
 * components over the largest, in [-1, 1] */
static void cell_of(vsd_f3 d, int *face, int *iu, int *iv)
{
    float a[3] = {d.x, d.y, d.z}, m;
    int ax = fabsf(a[0]) >= fabsf(a[1]) ? (fabsf(a[0]) >= fabsf(a[2]) ? 0 : 2) : (fabsf(a[1]) >= fabsf(a[2]) ? 1 : 2);
    float u, v;
    m = fabsf(a[ax]);
    if (!(m > 0.0f)) {
        *face = 4, *iu = *iv = VSD_LBL_READOUT_FACE / 2;
        return;
    }
    u = a[(ax + 1) % 3] / m;
    v = a[(ax + 2) % 3] / m;
    *face = 2 * ax + (a[ax] < 0.0f);
    *iu = (int)fminf(fmaxf((u + 1.0f) * 0.5f * VSD_LBL_READOUT_FACE, 0.0f), VSD_LBL_READOUT_FACE - 1);
    *iv = (int)fminf(fmaxf((v + 1.0f) * 0.5f * VSD_LBL_READOUT_FACE, 0.0f), VSD_LBL_READOUT_FACE - 1);
}

/* A fixed Fibonacci sphere, and the cone (dominant axis and sign) of each point. */
static float fib_dirs[FIB][3];
static int fib_cone[FIB], fib_ready;

static void fib_init(void)
{
    int k, iu, iv;
    if (fib_ready) return;
    for (k = 0; k < FIB; k++) {
        double p[3];
        vsd_f3 d;
        vsd_fibonacci_point(k, FIB, p);
        d = f3((float)p[0], (float)p[1], (float)p[2]);
        fib_dirs[k][0] = d.x, fib_dirs[k][1] = d.y, fib_dirs[k][2] = d.z;
        cell_of(d, &fib_cone[k], &iu, &iv);
    }
    fib_ready = 1;
}

/* w[i] = integral over cone i of HG(w . u): each cone's mean phase times its exact solid
 * angle (4pi/6), normalised to sum to 1, so isotropic scattering gives 1/6 each whatever
 * the points per cone. */
static void cone_shares(vsd_f3 u, float g, float w[6])
{
    double sum[6] = {0, 0, 0, 0, 0, 0}, total = 0.0;
    int count[6] = {0, 0, 0, 0, 0, 0}, k, i;
    fib_init();
    for (k = 0; k < FIB; k++) {
        sum[fib_cone[k]] += vsd_hg_eval(fib_dirs[k][0] * u.x + fib_dirs[k][1] * u.y + fib_dirs[k][2] * u.z, g);
        count[fib_cone[k]]++;
    }
    for (i = 0; i < 6; i++) total += count[i] ? sum[i] / count[i] : 0.0;
    for (i = 0; i < 6; i++) w[i] = (float)(count[i] ? sum[i] / count[i] / total : 0.0);
}

void vsd_lbl_readout_build(vsd_lbl_readout *t, float g)
{
    int face, iu, iv;
    if (t->g == g) return;
    for (face = 0; face < 6; face++)
        for (iu = 0; iu < VSD_LBL_READOUT_FACE; iu++)
            for (iv = 0; iv < VSD_LBL_READOUT_FACE; iv++) {
                /* the cell's centre direction d; the eye receives what scatters into -d */
                float c[3], u = ((float)iu + 0.5f) / VSD_LBL_READOUT_FACE * 2.0f - 1.0f,
                            v = ((float)iv + 0.5f) / VSD_LBL_READOUT_FACE * 2.0f - 1.0f;
                int ax = face >> 1;
                c[ax] = (face & 1) ? -1.0f : 1.0f;
                c[(ax + 1) % 3] = u;
                c[(ax + 2) % 3] = v;
                cone_shares(f3_scale(f3_normalize(f3(c[0], c[1], c[2])), -1.0f), g, t->w[face][iu][iv]);
            }
    t->g = g;
}

void vsd_lbl_readout_lattice_phase(float g, float *forward, float *backward, float *side)
{
    float w[6];
    cone_shares(f3(0.0f, 0.0f, 1.0f), g, w);
    *forward = w[4];
    *backward = w[5];
    *side = 0.25f * (w[0] + w[1] + w[2] + w[3]);
}

void vsd_lbl_readout_weights(const vsd_lbl_readout *t, vsd_f3 d, float w[6])
{
    int face, iu, iv;
    cell_of(d, &face, &iu, &iv);
    memcpy(w, t->w[face][iu][iv], 6 * sizeof(float));
}
