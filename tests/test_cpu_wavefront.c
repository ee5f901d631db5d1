/* test_cpu_wavefront.c — the CPU pool's wavefront order (device/cpu/cpu_wavefront.h):
 *   1. every tile runs once, after the tile before it along u and the one before it along v
 *      have finished and before the tiles after it along u and v have started, on 1, 2, 3
 *      and 7 threads, on grids of 1 x 1, 1 x 9, 9 x 1 and 7 x 5 tiles;
 *   2. a Gauss-Seidel sweep over a grid (each tile's new value from the new values before it
 *      and the old ones after it, as lbl's lattice does) gives the same bits on any thread
 *      count, tiles slowed at random so that the threads interleave differently each run;
 *      a sweep whose tiles may run in any order (the pool's plain items) is the negative
 *      control: its bits do change with the order. */
#include "test_common.h"
#include "device/cpu/cpu_wavefront.h"
#include "device/cpu/cpu_tiles.h"
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

enum { MAX_TILES = 64 };

typedef struct order_check {
    int nu, nv;
    atomic_int state[MAX_TILES];   /* 0 not started, 1 running, 2 finished */
    atomic_int runs[MAX_TILES];
    atomic_int bad;
} order_check;

static int state_of(order_check *c, int u, int v)
{
    if (u < 0 || v < 0) return 2;
    if (u >= c->nu || v >= c->nv) return 0;
    return atomic_load(&c->state[u + v * c->nu]);
}

static void pause_a_little(unsigned seed)
{
    struct timespec ts = {0, (long)(seed % 7) * 20000L};
    if (ts.tv_nsec) nanosleep(&ts, NULL);
}

static void check_tile(void *user, int u, int v)
{
    order_check *c = user;
    const int t = u + v * c->nu;
    if (state_of(c, u - 1, v) != 2 || state_of(c, u, v - 1) != 2) atomic_fetch_add(&c->bad, 1);
    if (state_of(c, u + 1, v) != 0 || state_of(c, u, v + 1) != 0) atomic_fetch_add(&c->bad, 1);
    atomic_store(&c->state[t], 1);
    atomic_fetch_add(&c->runs[t], 1);
    pause_a_little((unsigned)(t * 2654435761u) >> 7);
    atomic_store(&c->state[t], 2);
}

static void test_order(void)
{
    static const int grids[][2] = {{1, 1}, {1, 9}, {9, 1}, {7, 5}};
    static const int threads[] = {1, 2, 3, 7};
    size_t g, k;
    for (g = 0; g < sizeof grids / sizeof grids[0]; g++)
        for (k = 0; k < sizeof threads / sizeof threads[0]; k++) {
            order_check c;
            int t, once = 1;
            memset(&c, 0, sizeof c);
            c.nu = grids[g][0];
            c.nv = grids[g][1];
            CHECK(vsd_cpu_run_wavefront(c.nu, c.nv, threads[k], check_tile, &c, "test") == VSD_OK);
            for (t = 0; t < c.nu * c.nv; t++) once &= atomic_load(&c.runs[t]) == 1;
            CHECK_MSG(once && atomic_load(&c.bad) == 0, "[1] %d x %d tiles, %d threads: %d order violations, %s",
                      c.nu, c.nv, threads[k], atomic_load(&c.bad), once ? "each tile once" : "a tile not run once");
        }
    printf("[1] wavefront order held on 4 grids x 4 thread counts\n");
}

/* [2] values on a 9 x 6 grid: new(u, v) from new(u - 1, v), new(u, v - 1), old(u + 1, v),
 * old(u, v + 1) in float, where the order of the terms' updates matters to the bits */
enum { GU = 9, GV = 6 };
typedef struct sweep {
    float value[GU * GV];
    unsigned salt;
} sweep;

static float at(const sweep *s, int u, int v) { return u < 0 || v < 0 || u >= GU || v >= GV ? 0.1f : s->value[u + v * GU]; }

static void sweep_tile(void *user, int u, int v)
{
    sweep *s = user;
    const float x = 0.3f * at(s, u - 1, v) + 0.7f * at(s, u, v - 1) + 0.11f * at(s, u + 1, v) + 0.13f * at(s, u, v + 1);
    pause_a_little(s->salt + (unsigned)(u * 31 + v * 17));
    s->value[u + v * GU] = x / 1.2f + 1.0f / (float)(1 + u + 2 * v);
}

static void sweep_items(void *user, int k0, int y0, int k1, int y1)
{
    int k;
    (void)y0, (void)y1;
    for (k = k0; k < k1; k++) sweep_tile(user, k % GU, k / GU);
}

static void run_sweeps(int threads, unsigned salt, int wavefront, sweep *s)
{
    int pass, k;
    for (k = 0; k < GU * GV; k++) s->value[k] = 1.0f;
    s->salt = salt;
    for (pass = 0; pass < 3; pass++) {
        if (wavefront) CHECK(vsd_cpu_run_wavefront(GU, GV, threads, sweep_tile, s, "test") == VSD_OK);
        else CHECK(vsd_cpu_run_each(GU * GV, threads, sweep_items, s, "test") == VSD_OK);
    }
}

static void test_same_bits(void)
{
    sweep one, many, any;
    int differ = 0, differ_any = 0, trial, k;
    run_sweeps(1, 0, 1, &one);
    for (trial = 0; trial < 6; trial++) {
        run_sweeps(trial % 2 ? 3 : 2, (unsigned)trial * 7919u, 1, &many);
        for (k = 0; k < GU * GV; k++) differ += memcmp(&one.value[k], &many.value[k], sizeof(float)) != 0;
        run_sweeps(trial % 2 ? 3 : 2, (unsigned)trial * 7919u, 0, &any);
        for (k = 0; k < GU * GV; k++) differ_any += memcmp(&one.value[k], &any.value[k], sizeof(float)) != 0;
    }
    printf("[2] Gauss-Seidel sweeps on 2 and 3 threads: %d values differ from one thread's; the same sweep as "
           "plain items: %d differ\n", differ, differ_any);
    CHECK_MSG(differ == 0, "[2] the wavefront's result depends on the threads: %d values differ", differ);
    CHECK_MSG(differ_any > 0, "[2] the negative control never differed: the test cannot tell orders apart");
}

int main(void)
{
    test_order();
    test_same_bits();
    return test_finish("test_cpu_wavefront");
}
