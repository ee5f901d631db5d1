/* libFuzzer target for the environment-map readers: vsd_env_load picks OpenEXR (through
 * OpenEXR's C++ API, core/src/image/exr_read.cpp) or Radiance RGBE (core/src/env/rgbe.c) by
 * the first bytes, so one target covers both; the corpus holds small .exr files of every
 * compression Blender writes and flat / run-length .hdr files. EXR inputs also go through
 * vsd_exr_read_attr, the reader behind --continue's scene-hash check. */
#include "fuzz_file.h"
#include "vsd/env.h"
#include "vsd/image.h"
#include <math.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = vsd_fuzz_file(data, size);
    vsd_env *env = NULL;
    char err[1024], value[256];
    if (!path) return 0;
    err[0] = '\0';
    if (vsd_env_load(path, NULL, &env, err, sizeof err) == VSD_OK) {
        /* the contract the renderer relies on: a real size, finite non-negative texels */
        size_t n;
        if (!env || env->width <= 0 || env->height <= 0 || !env->rgb) __builtin_trap();
        n = (size_t)env->width * (size_t)env->height * 3;
        for (size_t i = 0; i < n; i++)
            if (!(env->rgb[i] >= 0.0f) || isinf(env->rgb[i])) __builtin_trap();
        vsd_env_destroy(env);
    } else if (env || err[0] == '\0') {
        __builtin_trap();
    }
    if (size >= 4 && memcmp(data, "\x76\x2f\x31\x01", 4) == 0)
        (void)vsd_exr_read_attr(path, "vsd/scene_hash", value, sizeof value, err, sizeof err);
    return 0;
}
