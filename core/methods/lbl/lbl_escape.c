#include "lbl_escape.h"
#include "src/common/fibonacci_sphere.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* the lattice vectors with components in [-2, 2] whose components share no factor (98: the
 * 26 neighbours and the knight's moves between them), so each direction once */
enum { REACH = 2, VECTORS = 98, FIB = 16384 };

static int gcd(int a, int b) { return b ? gcd(b, a % b) : a; }

/* the vectors, and their world lengths in cube-equivalent cells */
static void lattice_vectors(const double *shape, int d[VECTORS][3], double len[VECTORS])
{
    int k = 0, x, y, z;
    for (z = -REACH; z <= REACH; z++)
        for (y = -REACH; y <= REACH; y++)
            for (x = -REACH; x <= REACH; x++) {
                double w[3];
                if (gcd(gcd(abs(x), abs(y)), abs(z)) != 1) continue;
                d[k][0] = x, d[k][1] = y, d[k][2] = z;
                w[0] = x * (shape ? shape[0] : 1.0), w[1] = y * (shape ? shape[1] : 1.0), w[2] = z * (shape ? shape[2] : 1.0);
                len[k++] = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
            }
}

/* each vector's share of the sphere: the Fibonacci points nearest it in world directions */
static void solid_angles(const int d[VECTORS][3], const double len[VECTORS], const double *shape, double share[VECTORS])
{
    int k, v;
    memset(share, 0, sizeof(double) * VECTORS);
    for (k = 0; k < FIB; k++) {
        double p[3], best = -2.0;
        int arg = 0;
        vsd_fibonacci_point(k, FIB, p);
        for (v = 0; v < VECTORS; v++) {
            double c = 0.0;
            int a;
            for (a = 0; a < 3; a++) c += p[a] * d[v][a] * (shape ? shape[a] : 1.0);
            c /= len[v];
            if (c > best) best = c, arg = v;
        }
        share[arg] += 1.0 / FIB;
    }
}

int vsd_lbl_escape_keep(const int32_t res[3], const float *sigma, double cell_world, const double *shape, float *keep)
{
    const size_t n = (size_t)res[0] * res[1] * res[2];
    int d[VECTORS][3], v;
    double len[VECTORS], share[VECTORS];
    float *tau = malloc(n * sizeof *tau), *sphere = calloc(n, sizeof *sphere), *axes = calloc(n, sizeof *axes);
    size_t c;
    if (!tau || !sphere || !axes) {
        free(tau), free(sphere), free(axes);
        return 0;
    }
    lattice_vectors(shape, d, len);
    solid_angles(d, len, shape, share);
    for (v = 0; v < VECTORS; v++) {
        const double step = len[v] * cell_world;
        const int axis = abs(d[v][0]) + abs(d[v][1]) + abs(d[v][2]) == 1;
        int32_t i, x, y, z;
        /* cell c + d before cell c: each coordinate runs against d's sign */
        for (i = 0; i < res[2]; i++) {
            z = d[v][2] > 0 ? res[2] - 1 - i : i;
            for (y = d[v][1] > 0 ? res[1] - 1 : 0; d[v][1] > 0 ? y >= 0 : y < res[1]; y += d[v][1] > 0 ? -1 : 1)
                for (x = d[v][0] > 0 ? res[0] - 1 : 0; d[v][0] > 0 ? x >= 0 : x < res[0]; x += d[v][0] > 0 ? -1 : 1) {
                    const int32_t nx = x + d[v][0], ny = y + d[v][1], nz = z + d[v][2];
                    const size_t here = ((size_t)z * res[1] + y) * res[0] + x;
                    float t;
                    if (nx < 0 || ny < 0 || nz < 0 || nx >= res[0] || ny >= res[1] || nz >= res[2]) {
                        /* the step leaves the box: the share of it up to the box's face */
                        const int32_t p[3] = {x, y, z};
                        double frac = 1.0;
                        int a;
                        for (a = 0; a < 3; a++)
                            if (d[v][a]) {
                                double to_face = d[v][a] > 0 ? res[a] - 0.5 - p[a] : p[a] + 0.5;
                                frac = fmin(frac, to_face / abs(d[v][a]));
                            }
                        tau[here] = (float)(frac * sigma[here] * step);
                    } else {
                        const size_t next = ((size_t)nz * res[1] + ny) * res[0] + nx;
                        tau[here] = tau[next] + (float)(0.5 * ((double)sigma[here] + sigma[next]) * step);
                    }
                    t = expf(-tau[here]);
                    sphere[here] += (float)share[v] * t;
                    if (axis) axes[here] += t * (1.0f / 6.0f);
                }
        }
    }
    for (c = 0; c < n; c++) keep[c] = 1.0f - fmaxf(0.0f, sphere[c] - axes[c]);
    free(tau), free(sphere), free(axes);
    return 1;
}
