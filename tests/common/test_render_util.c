/* test_render_util.c — what the rendering tests share: scenes from the shared data,
 * one-off renders, the block relative RMSE of `vsd compare`, and the checks every fast
 * method's comparison with `reference` makes (passes add up, negative controls fail). */
#include "test_render_util.h"
#include "test_common.h"
#include "vsd/compare.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <pthread.h>
#include <unistd.h>

/* Value of `key` in a "key=value key=value" string; 0 when absent (and a failed CHECK). */
static int info_value(const char *info, const char *key, double *v)
{
    size_t n = strlen(key);
    const char *p = info;
    while ((p = strstr(p, key)) != NULL) {
        if ((p == info || p[-1] == ' ') && p[n] == '=') {
            *v = strtod(p + n + 1, NULL);
            return 1;
        }
        p += n;
    }
    CHECK_MSG(0, "method_info has no %s: \"%s\"", key, info);
    *v = -1;
    return 0;
}

double test_info(const vsd_render_stats *s, const char *key)
{
    double v = -1;
    info_value(s->method_info, key, &v);
    return v;
}

int test_load_scene(const char *rel, const char *const *ov, int nov, vsd_scene *sc)
{
    char err[1024];
    vsd_status st = vsd_scene_load(test_data(rel), ov, nov, sc, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "%s: %s", rel, err);
    return st == VSD_OK;
}

int test_parse_scene(const char *json, const char *const *ov, int nov, vsd_scene *sc)
{
    char err[1024];
    vsd_status st = vsd_scene_parse(json, "", ov, nov, sc, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "scene: %s", err);
    return st == VSD_OK;
}

vsd_renderer *test_make_renderer(const vsd_scene *sc, const char *cache_dir)
{
    vsd_render_options o;
    vsd_renderer *r = NULL;
    char err[1024] = "";
    memset(&o, 0, sizeof o);
    o.cache_dir = cache_dir;
    CHECK_MSG(vsd_renderer_create(sc, &o, &r, err, sizeof err) == VSD_OK, "create: %s", err);
    return r;
}

int test_render(vsd_renderer *r, int frame, vsd_framebuffer **fb, vsd_render_stats *stats)
{
    char err[1024] = "";
    vsd_status st = r ? vsd_renderer_render(r, frame, fb, stats, err, sizeof err) : VSD_ERR_INVALID;
    CHECK_MSG(st == VSD_OK, "render frame %d: %s", frame, err);
    return st == VSD_OK;
}

/* One render by a fresh renderer (in-memory volume / environment when given). */
vsd_framebuffer *test_render_fresh(const vsd_scene *sc, const char *cache_dir, const vsd_volume *vol,
                                     const vsd_env *env, int frame, vsd_render_stats *stats)
{
    vsd_renderer *r = test_make_renderer(sc, cache_dir);
    vsd_framebuffer *fb = NULL;
    if (!r) return NULL;
    if (vol) vsd_renderer_use_volume(r, 0, vol, NULL, NULL);
    if (env) vsd_renderer_use_env(r, env);
    if (!test_render(r, frame, &fb, stats)) {
        vsd_framebuffer_destroy(fb);
        fb = NULL;
    }
    vsd_renderer_destroy(r);
    return fb;
}

void test_expect_render_error(const vsd_scene *sc, const vsd_volume *const *vols, int nvols, char *err, size_t errlen)
{
    vsd_renderer *r = NULL;
    vsd_render_options o;
    vsd_framebuffer *fb = NULL;
    vsd_status st;
    int i;
    err[0] = '\0';
    memset(&o, 0, sizeof o);
    st = vsd_renderer_create(sc, &o, &r, err, errlen);
    if (st == VSD_OK) {
        for (i = 0; i < nvols; i++) vsd_renderer_use_volume(r, i, vols[i], NULL, NULL);
        st = vsd_renderer_render(r, sc->frames.start, &fb, NULL, err, errlen);
    }
    CHECK_MSG(st != VSD_OK, "rendered a scene that must be refused (method %s)", sc->render.method);
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
}

/* Relative RMSE of pass p of a against b after 4x4 block averages, as `vsd compare`. */
double test_rel_err(const vsd_framebuffer *a, const vsd_framebuffer *b, vsd_pass p)
{
    double e = 1e9;
    int ch = vsd_pass_channels(p);
    char err[256] = "";
    CHECK_MSG(vsd_block_rel_rmse(a->pass[p], b->pass[p], b->width, b->height, ch, ch, 4, &e, err, sizeof err) ==
                  VSD_OK, "%s: %s", vsd_pass_name(p), err);
    return e;
}

/* Same metric on raw planes (for images assembled by the test). */
double test_rel_err_planes(const float *a, const float *b, int w, int h, int ch)
{
    double e = 1e9;
    CHECK(vsd_block_rel_rmse(a, b, w, h, ch, ch, 4, &e, NULL, 0) == VSD_OK);
    return e;
}

size_t test_pass_floats(const vsd_framebuffer *fb, vsd_pass p)
{
    return (size_t)fb->width * fb->height * vsd_pass_channels(p);
}

/* Every pass bit for bit. */
int test_identical(const vsd_framebuffer *a, const vsd_framebuffer *b)
{
    int p;
    if (!a || !b || a->width != b->width || a->height != b->height) return 0;
    for (p = 0; p < VSD_PASS_COUNT; p++)
        if (memcmp(a->pass[p], b->pass[p], test_pass_floats(a, (vsd_pass)p) * sizeof(float)) != 0) return 0;
    return 1;
}

/* max |a - b| / max |b| over pass p. */
double test_max_rel_diff(const vsd_framebuffer *a, const vsd_framebuffer *b, vsd_pass p)
{
    double md = 0, mx = 0;
    size_t i, n = test_pass_floats(b, p);
    for (i = 0; i < n; i++) {
        md = fmax(md, fabs((double)a->pass[p][i] - b->pass[p][i]));
        mx = fmax(mx, fabs((double)b->pass[p][i]));
    }
    return mx > 0 ? md / mx : md;
}

/* Sum of the green channel of an RGB (or RGBA) pass. */
double test_pass_sum(const vsd_framebuffer *fb, vsd_pass p)
{
    int ch = vsd_pass_channels(p);
    size_t i, n = (size_t)fb->width * fb->height;
    double s = 0;
    for (i = 0; i < n; i++) s += fb->pass[p][i * ch + 1];
    return s;
}

/* Combined (transparent film, no emission) is VolumeDir + VolumeInd per pixel: the
 * negative controls below rely on it, and it is a contract of the passes. */
void test_check_pass_sum(const char *what, const vsd_framebuffer *fb)
{
    size_t i, n = (size_t)fb->width * fb->height;
    double md = 0, mx = 0;
    for (i = 0; i < n; i++) {
        int c;
        for (c = 0; c < 3; c++) {
            double sum = (double)fb->pass[VSD_PASS_VOLUME_DIR][3 * i + c] + fb->pass[VSD_PASS_VOLUME_IND][3 * i + c];
            md = fmax(md, fabs(fb->pass[VSD_PASS_COMBINED][4 * i + c] - sum));
            mx = fmax(mx, fabs(sum));
        }
    }
    CHECK_MSG(md <= 1e-6 * mx, "%s: Combined differs from VolumeDir + VolumeInd by %g (max %g)", what, md, mx);
}

/* Negative controls made from the method's own passes, scored like it against the reference's
 * Combined: multiple scattering removed (Combined - VolumeInd), halved (Combined -
 * VolumeInd / 2) and albedo 0 (no scattered light, its alpha kept). Each must fail `tol`. */
void test_scattering_control(const vsd_framebuffer *method, float keep_ind, float *img)
{
    size_t n = (size_t)method->width * method->height, i;
    for (i = 0; i < n; i++) {
        int c;
        for (c = 0; c < 3; c++)
            img[4 * i + c] = keep_ind < 0 ? 0.0f
                                          : method->pass[VSD_PASS_COMBINED][4 * i + c] -
                                                (1.0f - keep_ind) * method->pass[VSD_PASS_VOLUME_IND][3 * i + c];
        img[4 * i + 3] = method->pass[VSD_PASS_COMBINED][4 * i + 3];
    }
}

void test_check_controls(const char *what, const vsd_framebuffer *method, const vsd_framebuffer *ref, double tol)
{
    static const float keep_ind[3] = {0.0f, 0.5f, -1.0f};   /* -1: no scattered light at all */
    size_t n = (size_t)method->width * method->height;
    float *img = malloc(n * 4 * sizeof(float));
    double e[3] = {0, 0, 0};
    int k;
    CHECK(img != NULL);
    if (!img) return;
    for (k = 0; k < 3; k++) {
        test_scattering_control(method, keep_ind[k], img);
        e[k] = test_rel_err_planes(img, ref->pass[VSD_PASS_COMBINED], method->width, method->height, 4);
    }
    free(img);
    printf("    %s controls, Combined rel. RMSE: no multiple %.4f, half multiple %.4f, albedo 0 %.4f (tolerance %.3f)\n",
           what, e[0], e[1], e[2], tol);
    CHECK_MSG(e[0] > tol && e[1] > tol && e[2] > tol, "%s: a control passes the Combined tolerance %.3f: %.4f %.4f %.4f",
              what, tol, e[0], e[1], e[2]);
}

/* 32^3 voxels over [0,2]^3 (voxel 1/16), a ball of density 1 of radius 12 voxels (0.75)
 * around the grid's centre; medium density 4, so the optical radius is 3, albedo 0.9, g 0:
 * a few scattering orders matter. */
vsd_volume *test_ball_volume(void)
{
    const int n = 32;
    int32_t dims[3] = {32, 32, 32}, lo[3] = {0, 0, 0};
    double m[16] = {1.0 / 16, 0, 0, 0, 0, 1.0 / 16, 0, 0, 0, 0, 1.0 / 16, 0, 0, 0, 0, 1};
    float *v = calloc((size_t)n * n * n, sizeof(float));
    vsd_volume *vol = NULL;
    int x, y, z;
    if (!v) return NULL;
    for (z = 0; z < n; z++)
        for (y = 0; y < n; y++)
            for (x = 0; x < n; x++) {
                double dx = x - 15.5, dy = y - 15.5, dz = z - 15.5;
                if (dx * dx + dy * dy + dz * dz <= 12.0 * 12.0) v[((size_t)z * n + y) * n + x] = 1.0f;
            }
    CHECK(vsd_volume_create_dense(v, dims, lo, m, &vol, NULL, 0) == VSD_OK);
    free(v);
    return vol;
}

void test_check_emission_split(const char *label, const char *method, double tol_dir, double tol_ind,
                               double ratio_dir, double ratio_ind)
{
    static const char *const black[] = {"film.width=64", "film.height=36", "environment.file=null",
                                        "environment.color=[0,0,0]"};
    const char *ref_ov[6], *m_ov[5];
    char method_ov[160];
    vsd_scene ref_sc, m_sc;
    vsd_framebuffer *ref = NULL, *m = NULL;
    int i;
    snprintf(method_ov, sizeof method_ov, "render.method=%s", method);
    for (i = 0; i < 4; i++) ref_ov[i] = m_ov[i] = black[i];
    ref_ov[4] = "render.method=reference";
    ref_ov[5] = "render.samples=256";
    m_ov[4] = method_ov;
    printf("%s fire96 in a black world: emission scattered once is VolumeDir\n", label);
    if (!test_load_scene("scenes/fire96_studio.json", ref_ov, 6, &ref_sc) ||
        !test_load_scene("scenes/fire96_studio.json", m_ov, 5, &m_sc))
        return;
    ref = test_render_fresh(&ref_sc, NULL, NULL, NULL, 48, NULL);
    m = test_render_fresh(&m_sc, NULL, NULL, NULL, 48, NULL);
    CHECK(ref && m);
    if (ref && m) {
        double dir = test_rel_err(m, ref, VSD_PASS_VOLUME_DIR), ind = test_rel_err(m, ref, VSD_PASS_VOLUME_IND);
        double mdir = test_pass_sum(m, VSD_PASS_VOLUME_DIR) / test_pass_sum(ref, VSD_PASS_VOLUME_DIR);
        double mind = test_pass_sum(m, VSD_PASS_VOLUME_IND) / test_pass_sum(ref, VSD_PASS_VOLUME_IND);
        printf("    %s VolumeDir %.4f (mean ratio %.3f), VolumeInd %.4f (mean ratio %.3f)\n", method, dir, mdir, ind,
               mind);
        CHECK_MSG(dir < tol_dir && ind < tol_ind, "%s fire96 black world: VolumeDir %.4f, VolumeInd %.4f", method, dir,
                  ind);
        CHECK_MSG(fabs(mdir - 1.0) < ratio_dir && fabs(mind - 1.0) < ratio_ind, "%s mean ratios %.3f / %.3f", method,
                  mdir, mind);
    }
    vsd_framebuffer_destroy(ref);
    vsd_framebuffer_destroy(m);
}

const char *const test_ball_json =
    "{\"version\":1,\"volume\":{\"file\":\"memory.vdb\"},"
    "\"medium\":{\"density\":4.0,\"albedo\":[0.9,0.9,0.9],\"anisotropy\":0},"
    "\"environment\":{\"color\":[1,1,1]},"
    "\"camera\":{\"type\":\"orthographic\",\"ortho_scale\":1.8,\"position\":[0.96875,-4,0.96875],"
    "\"look_at\":[0.96875,0.96875,0.96875],\"up\":[0,0,1]},"
    "\"film\":{\"width\":32,\"height\":32},\"render\":{\"method\":\"crm\"}}";

vsd_framebuffer *test_render_in_memory(const vsd_scene *sc, const vsd_volume *vol, const vsd_env *env, int threads)
{
    vsd_render_options ro = {0};
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    char err[1024];
    vsd_status st;
    ro.threads = threads;
    st = vsd_renderer_create(sc, &ro, &r, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "create: %s", err);
    if (st) return NULL;
    vsd_renderer_use_volume(r, 0, vol, NULL, NULL);
    if (env) vsd_renderer_use_env(r, env);
    st = vsd_renderer_render(r, 1, &fb, NULL, err, sizeof err);
    CHECK_MSG(st == VSD_OK, "render: %s", err);
    vsd_renderer_destroy(r);
    return fb;
}

long test_exr_bytes_diff(const unsigned char *exr, size_t len, const vsd_framebuffer *fb, const char *dir,
                         const char *tag)
{
    char path[1200], err[512];
    FILE *f;
    vsd_exr_image *img = NULL;
    long diff = 0;
    int p, ch;
    if (!fb) return -1;
    snprintf(path, sizeof path, "%s/cmp_%s_%lx.exr", dir, tag, (unsigned long)pthread_self());
    f = fopen(path, "wb");
    if (!f) return -1;
    fwrite(exr, 1, len, f);
    fclose(f);
    if (vsd_exr_read(path, &img, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    unlink(path);
    if (img->width != fb->width || img->height != fb->height) diff = -1;
    for (p = 0; p < VSD_PASS_COUNT && diff >= 0; p++) {
        static const char *const rgba[] = {"R", "G", "B", "A"};
        int nch = vsd_pass_channels((vsd_pass)p);
        for (ch = 0; ch < nch; ch++) {
            char name[128];
            const float *plane;
            long i, n = (long)fb->width * fb->height;
            snprintf(name, sizeof name, "ViewLayer.%s.%s", vsd_pass_name((vsd_pass)p), nch == 1 ? "Z" : rgba[ch]);
            plane = vsd_exr_channel(img, name);
            if (!plane) {
                fprintf(stderr, "missing channel %s\n", name);
                diff = -1;
                break;
            }
            for (i = 0; i < n; i++)
                if (memcmp(&plane[i], &fb->pass[p][i * nch + ch], sizeof(float)) != 0) diff++;
        }
    }
    vsd_exr_image_destroy(img);
    return diff;
}
