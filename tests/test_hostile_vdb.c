/* test_hostile_vdb.c — issue 16's mutation experiment as a test: byte-mutated copies of
 * two shared VDBs, made by a committed seeded mutator, each rendered by the path tracer at
 * 16x9 with 1 sample per pixel. Every file must give either an image or an error with a
 * message, and no render may take longer than 5 s: before values were checked and the
 * trackers capped, 3% of such files kept a renderer busy for more than 30 s (NaN, Inf or
 * ~6e4 voxels blowing up the delta tracker's majorants).
 *
 * The mutator: test_urand (test_common) from a fixed seed; per copy, 1 to 8 bytes anywhere after the
 * first 8 are overwritten with random values (the copies alternate between the files).
 * VSD_HOSTILE_COPIES overrides the count (default 300). */
#include "test_common.h"
#include "vsd/scene.h"
#include "vsd/render.h"
#include "vsd/image.h"
#include <math.h>
#include "src/common/clock.h"
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LIMIT_SECONDS 5.0

static unsigned long long rng_state = 20261202ull;

static uint64_t next_random(void) { return (uint64_t)(test_urand(&rng_state) * 4294967296.0); }

static int write_all(const char *path, const unsigned char *buf, long size)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(buf, 1, (size_t)size, f) == (size_t)size;
    if (f) ok = fclose(f) == 0 && ok;
    return ok;
}

/* Finite but absurd densities (what a corrupt file can decode to: 1e6 and 3e38, the latter
 * an infinite majorant once scaled): every method renders them in bounded time, to a finite
 * image that is opaque where the volume is (the trackers' event cap, kernel_volume.h). */
static void test_absurd_values(void)
{
    static const char *const methods[] = {"reference", "raymarch", "shgrid", "constellation", "crm", "lbl"};
    const int method_count = (int)(sizeof methods / sizeof methods[0]);
    const float values[2] = {1.0e6f, 3.0e38f};
    const int32_t dims[3] = {16, 16, 16}, org[3] = {0, 0, 0};
    const double to_world[16] = {0.125, 0, 0, 0, 0, 0.125, 0, 0, 0, 0, 0.125, 0, 0, 0, 0, 1};
    float *dense = calloc(16 * 16 * 16, sizeof *dense);
    int v, m, k;
    for (v = 0; v < 2 && dense; v++) {
        vsd_volume *vol = NULL;
        char err[1024] = "";
        for (k = 0; k < 16 * 16 * 16; k++) dense[k] = values[v];
        CHECK_MSG(vsd_volume_create_dense(dense, dims, org, to_world, &vol, err, sizeof err) == VSD_OK, "%s", err);
        for (m = 0; vol && m < method_count; m++) {
            char method[64];
            const char *ov[] = {"frames.start=1", "frames.end=1", "film.width=16", "film.height=9", method,
                                "render.samples=1", "render.device=cpu", "medium.density=8"};
            vsd_scene sc;
            vsd_renderer *r = NULL;
            vsd_framebuffer *fb = NULL;
            vsd_render_options o;
            vsd_render_stats st;
            double t0;
            vsd_status s;
            snprintf(method, sizeof method, "render.method=%s", methods[m]);
            if (vsd_scene_load(test_data("scenes/smoke64_sunset.json"), ov, 8, &sc, err, sizeof err) != VSD_OK) {
                CHECK_MSG(0, "scene: %s", err);
                continue;
            }
            memset(&o, 0, sizeof o);
            o.threads = 1;
            t0 = vsd_clock_seconds();
            s = vsd_renderer_create(&sc, &o, &r, err, sizeof err);
            if (s == VSD_OK) {
                vsd_renderer_use_volume(r, 0, vol, NULL, NULL);
                s = vsd_renderer_render(r, 1, &fb, &st, err, sizeof err);
            }
            t0 = vsd_clock_seconds() - t0;
            printf("density %g, %s: %.2f s, %s\n", (double)values[v], methods[m], t0, s == VSD_OK ? "image" : err);
            /* the values are reported, naming the setting that decides (default 1e4) */
            if (s == VSD_OK) CHECK_CONTAINS(st.warnings, "above volume.warn_above (10000)");
            CHECK_MSG(t0 <= LIMIT_SECONDS, "density %g, %s: %.1f s", (double)values[v], methods[m], t0);
            CHECK_MSG(s == VSD_OK || strlen(err) > 10, "density %g, %s: status %d, \"%s\"", (double)values[v],
                      methods[m], (int)s, err);
            if (s == VSD_OK && fb) {
                int bad = 0, p;
                for (p = 0; p < VSD_PASS_COUNT; p++)
                    for (k = 0; fb->pass[p] && k < 16 * 9 * vsd_pass_channels((vsd_pass)p); k++)
                        bad += !isfinite(fb->pass[p][k]);
                CHECK_MSG(bad == 0, "density %g, %s: %d non-finite pixel values", (double)values[v], methods[m], bad);
            }
            vsd_framebuffer_destroy(fb);
            vsd_renderer_destroy(r);
        }
        vsd_volume_destroy(vol);
    }
    free(dense);
}

int main(void)
{
    const char *sources[2] = {"smoke64/fluid_data_0024.vdb", "cloud/cloud128.vdb"};
    unsigned char *orig[2], *copy = NULL;
    long size[2] = {0, 0};
    const char *env = getenv("VSD_HOSTILE_COPIES");
    int copies = env && atoi(env) > 0 ? atoi(env) : 300, i, images = 0, errors = 0;
    double worst = 0.0;
    int worst_copy = -1;
    char path[1024], file_set[1100];
    for (i = 0; i < 2; i++) {
        orig[i] = test_read_file(test_data(sources[i]), &size[i]);
        CHECK_MSG(orig[i] != NULL, "cannot read %s", test_data(sources[i]));
        if (!orig[i]) return test_finish("test_hostile_vdb");
    }
    copy = malloc((size_t)(size[0] > size[1] ? size[0] : size[1]));
    snprintf(path, sizeof path, "%s", test_tmp("hostile.vdb"));
    snprintf(file_set, sizeof file_set, "volume.file=%s", path);
    for (i = 0; i < copies && copy; i++) {
        int which = i & 1, m, count = 1 + (int)(next_random() % 8);
        const char *ov[] = {file_set, "volume.grid=density", "frames.start=1", "frames.end=1", "film.width=16",
                            "film.height=9", "render.method=reference", "render.samples=1", "render.device=cpu"};
        vsd_scene sc;
        vsd_renderer *r = NULL;
        vsd_framebuffer *fb = NULL;
        vsd_render_options o;
        vsd_render_stats st;
        char err[1024] = "";
        double t0, dt;
        vsd_status s;
        memcpy(copy, orig[which], (size_t)size[which]);
        for (m = 0; m < count; m++) copy[8 + next_random() % (uint64_t)(size[which] - 8)] = (unsigned char)next_random();
        if (!write_all(path, copy, size[which])) {
            CHECK_MSG(0, "cannot write %s", path);
            break;
        }
        if (vsd_scene_load(test_data("scenes/smoke64_sunset.json"), ov, 9, &sc, err, sizeof err) != VSD_OK) {
            CHECK_MSG(0, "scene: %s", err);
            break;
        }
        memset(&o, 0, sizeof o);
        o.threads = 1;
        t0 = vsd_clock_seconds();
        s = vsd_renderer_create(&sc, &o, &r, err, sizeof err);
        if (s == VSD_OK) s = vsd_renderer_render(r, 1, &fb, &st, err, sizeof err);
        dt = vsd_clock_seconds() - t0;
        if (dt > worst) {
            worst = dt;
            worst_copy = i;
        }
        if (s == VSD_OK) {
            images++;
            CHECK_MSG(fb && fb->width == 16 && fb->height == 9, "copy %d: no 16x9 image", i);
            if (fb) {
                /* an image is finite: no NaN or Inf reaches a pass */
                int p, bad = 0;
                size_t k;
                for (p = 0; p < VSD_PASS_COUNT; p++)
                    for (k = 0; fb->pass[p] && k < (size_t)16 * 9 * vsd_pass_channels((vsd_pass)p); k++)
                        bad += !isfinite(fb->pass[p][k]);
                CHECK_MSG(bad == 0, "copy %d (%s, %d bytes changed): %d non-finite pixel values", i, sources[which],
                          count, bad);
            }
        } else {
            errors++;
            /* an error names its problem: a message, not just a status */
            CHECK_MSG(strlen(err) > 10, "copy %d (%s, %d bytes changed): status %d with message \"%s\"", i,
                      sources[which], count, (int)s, err);
        }
        CHECK_MSG(dt <= LIMIT_SECONDS, "copy %d (%s, %d bytes changed) took %.1f s: %s", i, sources[which], count, dt,
                  s == VSD_OK ? "image" : err);
        vsd_framebuffer_destroy(fb);
        vsd_renderer_destroy(r);
    }
    test_absurd_values();
    printf("%d mutated copies: %d images, %d errors; slowest %.2f s (copy %d)\n", copies, images, errors, worst,
           worst_copy);
    free(copy);
    free(orig[0]);
    free(orig[1]);
    return test_finish("test_hostile_vdb");
}
