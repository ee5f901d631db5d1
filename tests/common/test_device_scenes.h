/* test_device_scenes.h — scenes the CUDA tests share (test_cuda on a GPU, test_device_residency
 * against the emulated backend), built from the scene files the GPU bundle carries
 * (scripts/gpu-bundle.sh), so no new data travels. */
#ifndef VSD_TEST_DEVICE_SCENES_H
#define VSD_TEST_DEVICE_SCENES_H
#include "vsd/scene.h"

/* Two volumes: smoke64_sunset.json's smoke (frame 24) and fire96_studio.json's fire with its
 * emission as volumes[1], entering at scene frame 24 on its frame 48 (frame_offset 24),
 * scaled 0.8 and moved so that it overlaps the smoke's lower half; the smoke's map, camera
 * and film. ov (--set style) applies to the smoke's file; the fire keeps its own medium.
 * Returns 0 and a failed CHECK on an error. Render it at frame 24. */
int test_smoke_and_fire(const char *const *ov, int nov, vsd_scene *sc);
#define TEST_SMOKE_AND_FIRE_FRAME 24

#endif
