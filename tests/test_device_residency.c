/* The CUDA backend's library side without a GPU: every method renders through the device
 * code paths (uploads, resident slots, generation keys, kernel-struct mirroring, device
 * passes) against tests/device_emulation/emulated_cuda.c, which runs the shared kernels
 * on host copies and reports host pointers, short uploads and stale slots. One renderer
 * takes a sequence of edits (camera, rotation, strength, anisotropy, density, frames,
 * albedo); after each, its image must equal a fresh CPU renderer's bit for bit (for a
 * method whose lighting warm-starts from the last solve, lbl, a CPU renderer that took the
 * same edits: a fresh one converges from elsewhere, to within the tolerance), a camera
 * change must copy at most 4 KiB, and the emulator must have reported nothing. The real
 * GPU is covered by test_cuda (skipped where none answers). */
#include "test_common.h"
#include "test_device_scenes.h"
#include "test_render_util.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

extern int emulated_cuda_errors;

typedef struct residency_case {
    const char *scene;
    const char *method;
    const char *options;   /* render.options as JSON, or NULL */
    int frame, next_frame; /* two frames of the sequence */
    int warm;              /* lighting warm-starts from the last solve: compare with a CPU
                              renderer that took the same edits */
    int two_volumes;       /* scene is ignored: test_smoke_and_fire's smoke and fire */
} residency_case;

/* The CPU twin of a warm case's renderer (NULL: compare with fresh CPU renderers). */
static vsd_renderer *cpu_twin;

static vsd_framebuffer *twin_render(const vsd_scene *sc, int frame)
{
    vsd_scene c = *sc;
    vsd_framebuffer *fb = NULL;
    char err[1024];
    vsd_status st;
    snprintf(c.render.device, sizeof c.render.device, "cpu");
    st = vsd_renderer_set_scene(cpu_twin, &c, err, sizeof err);
    if (!st) st = vsd_renderer_render(cpu_twin, frame, &fb, NULL, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "cpu twin: %s", err);
    return fb;
}

static vsd_framebuffer *cpu_render(vsd_scene sc, int frame)
{
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    char err[1024];
    vsd_status st;
    snprintf(sc.render.device, sizeof sc.render.device, "cpu");
    st = vsd_renderer_create(&sc, NULL, &r, err, sizeof err);
    if (!st) st = vsd_renderer_render(r, frame, &fb, NULL, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "cpu: %s", err);
    vsd_renderer_destroy(r);
    return fb;
}

typedef enum { EDIT_NONE, EDIT_CAMERA, EDIT_LIGHTING, EDIT_STRENGTH, EDIT_FRAME } edit_kind;

/* One step: apply the edit (already made to sc), render on the emulated device, compare. */
static void step(vsd_renderer *r, vsd_scene *sc, int frame, const char *label, edit_kind kind,
                 vsd_framebuffer **fb, const residency_case *c)
{
    vsd_render_stats st;
    vsd_framebuffer *ref;
    char err[1024];
    int errors0 = emulated_cuda_errors;
    vsd_status s = vsd_renderer_set_scene(r, sc, err, sizeof err);
    if (!s) s = vsd_renderer_render(r, frame, fb, &st, err, sizeof err);
    CHECK_MSG(s == VSD_OK, "%s %s %s: %s", c->scene, c->method, label, err);
    if (s) return;
    CHECK_MSG(strcmp(st.device, "cuda") == 0, "%s: rendered on %s", label, st.device);
    if (kind == EDIT_CAMERA)
        CHECK_MSG(st.device_uploaded_bytes <= 4096, "%s %s %s: a camera change copied %llu bytes", c->scene,
                  c->method, label, st.device_uploaded_bytes);
    if (kind == EDIT_NONE)
        CHECK_MSG(st.device_uploaded_bytes > 100000, "%s %s: the first render copied only %llu bytes", c->scene,
                  c->method, st.device_uploaded_bytes);
    ref = cpu_twin ? twin_render(sc, frame) : cpu_render(*sc, frame);
    if (ref && kind == EDIT_STRENGTH && !cpu_twin) {
        /* where nothing but the map lights the scene the kept renderer scales the image it
           lit at the old strength (renderer.c strength_scales): a fresh renderer's image to
           float rounding (the log-trilinear lookup's logarithms move by the factor's), not
           bit for bit; stale device data would be off by the factor itself */
        double e = fmax(test_max_rel_diff(*fb, ref, VSD_PASS_COMBINED), test_max_rel_diff(*fb, ref, VSD_PASS_VOLUME_DIR));
        CHECK_MSG(e <= 1e-5, "%s %s %s: the device-path image is %g off a fresh CPU render", c->scene, c->method, label,
                  e);
    } else if (ref)
        CHECK_MSG(memcmp(ref->pass[VSD_PASS_COMBINED], (*fb)->pass[VSD_PASS_COMBINED],
                         sizeof(float) * 4 * (size_t)ref->width * ref->height) == 0 &&
                  memcmp(ref->pass[VSD_PASS_VOLUME_DIR], (*fb)->pass[VSD_PASS_VOLUME_DIR],
                         sizeof(float) * 3 * (size_t)ref->width * ref->height) == 0,
                  "%s %s %s: the device-path image differs from a fresh CPU render", c->scene, c->method, label);
    CHECK_MSG(emulated_cuda_errors == errors0, "%s %s %s: %d emulator reports (see above)", c->scene, c->method,
              label, emulated_cuda_errors - errors0);
    printf("  %-16s copied %9llu bytes\n", label, st.device_uploaded_bytes);
    vsd_framebuffer_destroy(ref);
}

static void run_case(const residency_case *c)
{
    char m[64];
    const char *ov[5] = {m, "render.device=cuda", "film.width=40", "film.height=24", "render.samples=2"};
    vsd_scene sc;
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    char err[1024];
    vsd_status st;
    int f = c->frame;
    snprintf(m, sizeof m, "render.method=%s", c->method);
    if (c->two_volumes)
        st = test_smoke_and_fire(ov, 5, &sc) ? VSD_OK : VSD_ERR_INVALID;
    else
        st = vsd_scene_load(test_data(c->scene), ov, 5, &sc, err, sizeof err);
    if (!st && c->options) snprintf(sc.render.options_json, sizeof sc.render.options_json, "%s", c->options);
    if (!st) st = vsd_renderer_create(&sc, NULL, &r, err, sizeof err);
    if (!st && c->warm) {
        vsd_scene cs = sc;
        snprintf(cs.render.device, sizeof cs.render.device, "cpu");
        st = vsd_renderer_create(&cs, NULL, &cpu_twin, err, sizeof err);
    }
    CHECK_MSG(st == VSD_OK, "%s: %s", c->scene, err);
    if (st) return;
    printf("%s, %s %s:\n", c->scene, c->method, c->options ? c->options : "");
    step(r, &sc, f, "first", EDIT_NONE, &fb, c);
    sc.camera.matrix[3] += 0.3;
    step(r, &sc, f, "camera", EDIT_CAMERA, &fb, c);
    sc.environment.rotation_z += 1.0f;
    step(r, &sc, f, "rotation", EDIT_LIGHTING, &fb, c);
    sc.camera.matrix[7] += 0.2;
    step(r, &sc, f, "camera 2", EDIT_CAMERA, &fb, c);
    sc.environment.strength *= 2.0f;
    step(r, &sc, f, "strength", EDIT_STRENGTH, &fb, c);
    sc.volumes[0].medium.anisotropy = 0.5f;
    step(r, &sc, f, "anisotropy 0.5", EDIT_LIGHTING, &fb, c);
    sc.volumes[0].medium.anisotropy = 0.0f;
    step(r, &sc, f, "anisotropy 0", EDIT_LIGHTING, &fb, c);
    sc.volumes[0].medium.density *= 0.5f;
    step(r, &sc, f, "density", EDIT_LIGHTING, &fb, c);
    step(r, &sc, c->next_frame, "next frame", EDIT_FRAME, &fb, c);
    sc.volumes[0].medium.albedo[0] = 0.5f;
    step(r, &sc, c->next_frame, "albedo", EDIT_LIGHTING, &fb, c);
    if (sc.volume_count > 1) {
        /* the other volume's material: the device's volume table follows it */
        sc.volumes[1].medium.density *= 1.5f;
        sc.volumes[1].medium.anisotropy = 0.4f;
        step(r, &sc, c->next_frame, "volumes[1] medium", EDIT_LIGHTING, &fb, c);
    }
    step(r, &sc, f, "previous frame", EDIT_FRAME, &fb, c);
    vsd_renderer_destroy(r);
    vsd_renderer_destroy(cpu_twin);
    cpu_twin = NULL;
    vsd_framebuffer_destroy(fb);
}

/* Per-method settings that keep the test fast, and what it must know of a method; a
 * method of the registry without an entry runs with its defaults on both scenes. */
typedef struct method_tuning {
    const char *method;
    const char *options; /* render.options as JSON, or NULL */
    int smoke_only;      /* the fire adds nothing this method's device path does not already take */
    int warm;            /* residency_case.warm */
} method_tuning;

static const method_tuning tunings[] = {
    {"raymarch", "{\"lights\":16,\"pixel_samples\":1}", 1, 0},
    {"reference", NULL, 1, 0},
    /* the lights' term per ray on both sides, as lbl's below */
    {"constellation", "{\"lights\":16,\"view_bake\":false}", 0, 0},
    {"shgrid", "{\"grid\":16,\"lights\":8,\"pixel_samples\":1,\"view_bake\":false}", 0, 0},
    /* nodes 4 voxels apart, 6 orders, 48 and 12 directions: every stage of the default path
     * (nodes, single scattering, lights, delta-M's orders, the device view) at a tenth of its
     * lighting time (fire96 4.5 -> 0.3 s a lighting change: this test's 400 s were crm's).
     * The RBF fit's options it had (rbf_count, fit_iterations, coherent) touch nothing the
     * default path runs since it fits nothing (issue 31) */
    {"crm", "{\"node_spacing\":4,\"orders\":6,\"directions\":48,\"order_directions\":12}", 0, 0},
    /* lbl's view with the lights' term per ray on both sides (the CPU bakes it per view
     * by default, the device cannot keep a per-view array resident) */
    {"lbl", "{\"cells\":24,\"view_bake\":false}", 0, 1},
};

static const method_tuning *tuning_of(const char *method)
{
    static const method_tuning none = {NULL, NULL, 0, 0};
    size_t i;
    for (i = 0; i < sizeof tunings / sizeof tunings[0]; i++)
        if (strcmp(tunings[i].method, method) == 0) return &tunings[i];
    return &none;
}

int main(int argc, char **argv)
{
    const char *const *name;
    int methods = 0;
    /* every method of the registry that renders on the device (or the one named: a
       developer's shorter run; ctest names none) */
    for (name = vsd_method_names(); *name; name++) {
        if (argc > 1 && strcmp(argv[1], *name) != 0) continue;
        const method_tuning *t = tuning_of(*name);
        unsigned caps = vsd_method_capabilities(*name);
        residency_case smoke = {"scenes/smoke64_sunset.json", *name, t->options, 24, 25, t->warm, 0};
        residency_case fire = {"scenes/fire96_studio.json", *name, t->options, 48, 36, t->warm, 0};
        /* frames 24 and 12 of the smoke: the fire's 48 and 36 */
        residency_case both = {"smoke and fire", *name, t->options, TEST_SMOKE_AND_FIRE_FRAME, 12, t->warm, 1};
        if (!(caps & VSD_METHOD_CAP_CUDA_VIEW)) continue;
        methods++;
        run_case(&smoke);
        if (!t->smoke_only) run_case(&fire);
        if (caps & VSD_METHOD_CAP_SEVERAL_VOLUMES) run_case(&both);
    }
    CHECK(methods > 0);
    return test_finish("test_device_residency");
}
