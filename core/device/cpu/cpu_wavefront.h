/* cpu_wavefront.h — a grid of tiles on the CPU pool in wavefront order: tile (u, v) starts
 * only once tiles (u - 1, v) and (u, v - 1) have finished, and tiles on one anti-diagonal
 * (u + v constant) run side by side. What a tile reads from the tiles before it is then
 * theirs from this pass, and from the tiles after it theirs from the pass before, whatever
 * the thread count: a Gauss-Seidel sweep over a grid of rows (lbl's lattice, issue 32) gives
 * the same bits on one thread or sixteen. */
#ifndef VSD_CPU_WAVEFRONT_H
#define VSD_CPU_WAVEFRONT_H
#include "vsd/status.h"

typedef void (*vsd_wavefront_fn)(void *user, int u, int v);

/* fn(user, u, v) once for every tile of [0, nu) x [0, nv), in wavefront order (above), on
 * `threads` threads (0 = all cores). VSD_ERR_NOMEM when the tiles' flags cannot be
 * allocated (nothing run). */
vsd_status vsd_cpu_run_wavefront(int nu, int nv, int threads, vsd_wavefront_fn fn, void *user, const char *stage);

#endif
