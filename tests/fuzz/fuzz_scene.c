/* libFuzzer target for the scene-file parser (core/src/scene/scene.c). The input is the
 * scene's JSON text, optionally followed by a NUL byte and NUL-separated overrides
 * ("key.path=value", as `vsd render --set` and RENDER.overrides pass them), so the override
 * syntax is fuzzed together with the document it edits. A parsed scene then goes through
 * what the CLI and the daemon do next: the frame-path expansion of its files and the
 * refractive-index grid lookup. */
#include "vsd/scene.h"
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_OVERRIDES 16

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *text = malloc(size + 1), err[2048], path[VSD_PATH_LEN];
    const char *overrides[MAX_OVERRIDES];
    vsd_scene *sc = malloc(sizeof *sc);
    int n = 0;
    if (!text || !sc) {
        free(text);
        free(sc);
        return 0;
    }
    memcpy(text, data, size);
    text[size] = '\0';
    /* text is the JSON up to the first NUL; each NUL-terminated piece after it an override */
    for (size_t at = strlen(text) + 1; at < size && n < MAX_OVERRIDES; at += strlen(text + at) + 1)
        overrides[n++] = text + at;
    err[0] = '\0';
    if (vsd_scene_parse(text, "/fuzz/scenes", overrides, n, sc, err, sizeof err) == VSD_OK) {
        if (sc->volume_count < 1 || sc->volume_count > VSD_MAX_VOLUMES) __builtin_trap();
        for (int v = 0; v < sc->volume_count; v++) {
            (void)vsd_frame_path(sc->volumes[v].file, vsd_scene_volume_frame(&sc->volumes[v], sc->frames.start), path,
                                 sizeof path, err, sizeof err);
            (void)vsd_scene_ior_grid(&sc->volumes[v]);
        }
        (void)vsd_frame_path(sc->environment.file, sc->frames.end, path, sizeof path, err, sizeof err);
    } else if (err[0] == '\0') {
        __builtin_trap(); /* an error must say why */
    }
    free(sc);
    free(text);
    return 0;
}
