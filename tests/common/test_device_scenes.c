/* Scenes the CUDA tests share (test_device_scenes.h). */
#include "test_device_scenes.h"
#include "test_common.h"
#include <string.h>

int test_smoke_and_fire(const char *const *ov, int nov, vsd_scene *sc)
{
    vsd_scene fire;
    char err[1024];
    vsd_status st = vsd_scene_load(test_data("scenes/smoke64_sunset.json"), ov, nov, sc, err, sizeof err);
    if (!st) st = vsd_scene_load(test_data("scenes/fire96_studio.json"), NULL, 0, &fire, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "smoke and fire: %s", err);
    if (st) return 0;
    sc->volumes[1] = fire.volumes[0];
    sc->volumes[1].frame_offset = 48 - TEST_SMOKE_AND_FIRE_FRAME;
    {
        /* the fire's own matrix scaled 0.8 about the origin, then moved by (0.2, 0.1, -0.3):
         * it overlaps the smoke without coinciding with it */
        double *m = sc->volumes[1].matrix;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++) m[4 * r + c] *= 0.8;
        m[3] += 0.2;
        m[7] += 0.1;
        m[11] -= 0.3;
    }
    sc->volume_count = 2;
    return 1;
}
