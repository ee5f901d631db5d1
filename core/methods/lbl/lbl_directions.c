#include "lbl_directions.h"
#include "src/common/fibonacci_sphere.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { REACH = 2, FIB = 16384 };

static int gcd(int a, int b) { return b ? gcd(b, a % b) : a; }

static double edge(const double *shape, int a) { return shape ? shape[a] : 1.0; }

/* the vectors, their world lengths, and the cones they fall in */
static void lattice_vectors(const double *shape, vsd_lbl_directions *dirs)
{
    int k = 0, x, y, z;
    for (z = -REACH; z <= REACH; z++)
        for (y = -REACH; y <= REACH; y++)
            for (x = -REACH; x <= REACH; x++) {
                double w[3], top = 0.0;
                int a, ties = 0;
                if (gcd(gcd(abs(x), abs(y)), abs(z)) != 1) continue;
                dirs->d[k][0] = x, dirs->d[k][1] = y, dirs->d[k][2] = z;
                w[0] = x * edge(shape, 0), w[1] = y * edge(shape, 1), w[2] = z * edge(shape, 2);
                dirs->len[k] = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
                for (a = 0; a < 3; a++) top = fmax(top, fabs(w[a]));
                for (a = 0; a < 3; a++) ties += fabs(w[a]) > top * (1.0 - 1e-9);
                for (a = 0; a < 6; a++) dirs->cone[k][a] = 0.0;
                for (a = 0; a < 3; a++)
                    if (fabs(w[a]) > top * (1.0 - 1e-9)) dirs->cone[k][2 * a + (w[a] < 0.0)] = 1.0 / ties;
                k++;
            }
}

/* each vector's share of the sphere: the Fibonacci points nearest it in world directions */
static void solid_angles(vsd_lbl_directions *dirs, const double *shape)
{
    int k, v;
    memset(dirs->share, 0, sizeof dirs->share);
    for (k = 0; k < FIB; k++) {
        double p[3], best = -2.0;
        int arg = 0;
        vsd_fibonacci_point(k, FIB, p);
        for (v = 0; v < VSD_LBL_VECTORS; v++) {
            double c = 0.0;
            int a;
            for (a = 0; a < 3; a++) c += p[a] * dirs->d[v][a] * edge(shape, a);
            c /= dirs->len[v];
            if (c > best) best = c, arg = v;
        }
        dirs->share[arg] += 1.0 / FIB;
    }
}

/* The table depends on the cells' shape alone, and solid_angles' 16384 x 98 dot products
 * cost ~10 ms; the surface escape and the first flight each make it at every lighting
 * change, 5% of a density edit on 32^3 cells (perf, 2026-12-07). So each thread keeps the
 * last shape's table (a daemon's worker renders the same volume edit after edit); the
 * table is a pure function of the shape, so the copy is the same bits. */
void vsd_lbl_directions_make(const double *shape, vsd_lbl_directions *dirs)
{
    static _Thread_local struct {
        int valid, cubes;
        double shape[3];
        vsd_lbl_directions dirs;
    } last;
    const int cubes = shape == NULL;
    if (last.valid && last.cubes == cubes &&
        (cubes || (last.shape[0] == shape[0] && last.shape[1] == shape[1] && last.shape[2] == shape[2]))) {
        *dirs = last.dirs;
        return;
    }
    lattice_vectors(shape, dirs);
    solid_angles(dirs, shape);
    last.valid = 1;
    last.cubes = cubes;
    if (!cubes) memcpy(last.shape, shape, sizeof last.shape);
    last.dirs = *dirs;
}
