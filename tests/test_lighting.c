/* The light constellation (vsd/lighting.h): power conservation, equal energy of the
 * median cut, one bright texel giving a light in its direction, k-means, rotation
 * without recomputation agreeing with the environment lookup's own rotation, and the
 * sub-lights of a grouped constellation (the same lights, each split again), and the map
 * averaged per HEALPix pixel (src/lighting/env_healpix.h: a constant map stays constant and
 * the integral is kept), and the split of a map into its bright texels as lights and the
 * remainder (src/lighting/env_bright.h: the two sum to the map, only texels above the
 * threshold leave it). */
#include "test_common.h"
#include "vsd/lighting.h"
#include "vsd/env.h"
#include "kernel/kernel_env.h"
#include "src/lighting/env_healpix.h"
#include "src/lighting/env_bright.h"
#include "src/render/kernel_setup.h"
#include "src/grids/record_grid.h"
#include "kernel/kernel_record_grid.h"
#include <stdlib.h>
#include <string.h>
#include <math.h>

static vsd_env *make_env(int w, int h, const float rgb[3])
{
    vsd_env *e = NULL;
    CHECK(vsd_env_create_uniform(rgb, w, h, &e, NULL, 0) == VSD_OK);
    return e;
}

/* A smooth, strongly varying map: a bright lobe plus a coloured gradient. */
static vsd_env *smooth_env(int w, int h)
{
    float zero[3] = {0, 0, 0};
    vsd_env *e = make_env(w, h, zero);
    int x, y;
    if (!e) return NULL;
    for (y = 0; y < h; y++)
        for (x = 0; x < w; x++) {
            float *p = e->rgb + 3 * ((size_t)y * w + x);
            float u = (x + 0.5f) / w, v = (y + 0.5f) / h;
            float lobe = 20.0f * expf(-((u - 0.3f) * (u - 0.3f) + (v - 0.35f) * (v - 0.35f)) / 0.004f);
            p[0] = 0.2f + u + lobe;
            p[1] = 0.1f + v + 0.8f * lobe;
            p[2] = 0.5f * (1 - v) + 0.5f * lobe;
        }
    return e;
}

static double angle_between(const float a[3], const float b[3])
{
    double d = (double)a[0] * b[0] + (double)a[1] * b[1] + (double)a[2] * b[2];
    return acos(d > 1 ? 1 : (d < -1 ? -1 : d));
}

/* Total power == the map's integral, for both methods and several N (a uniform map's
 * integral is 4 pi c exactly, and its lights' solid angles cover the sphere). */
static void test_power_conservation(void)
{
    float c[3] = {0.5f, 1.0f, 2.0f};
    vsd_env *u = make_env(64, 32, c), *s = smooth_env(256, 128);
    const int ns[] = {1, 7, 64, 300};
    int m, i, k;
    double integ[3];
    if (!u || !s) return;
    vsd_env_integral(u, integ);
    for (k = 0; k < 3; k++) CHECK_NEAR(integ[k], 4 * M_PI * c[k], 1e-6 * 4 * M_PI * c[k]);
    for (m = 0; m < 2; m++)
        for (i = 0; i < 4; i++) {
            vsd_light_constellation lc;
            double sum[3] = {0, 0, 0}, omega = 0;
            int l;
            CHECK(vsd_constellation_build(u, ns[i], (vsd_lights_method)m, &lc, NULL, 0) == VSD_OK);
            CHECK(lc.count >= 1 && lc.count <= ns[i]);
            for (l = 0; l < lc.count; l++) {
                for (k = 0; k < 3; k++) sum[k] += lc.lights[l].power[k];
                omega += lc.lights[l].solid_angle;
            }
            for (k = 0; k < 3; k++) CHECK_NEAR(sum[k], 4 * M_PI * c[k], 1e-5 * 4 * M_PI * c[k]);
            CHECK_NEAR(omega, 4 * M_PI, 1e-5 * 4 * M_PI);
            vsd_constellation_free(&lc);

            vsd_env_integral(s, integ);
            CHECK(vsd_constellation_build(s, ns[i], (vsd_lights_method)m, &lc, NULL, 0) == VSD_OK);
            sum[0] = sum[1] = sum[2] = 0;
            for (l = 0; l < lc.count; l++)
                for (k = 0; k < 3; k++) sum[k] += lc.lights[l].power[k];
            for (k = 0; k < 3; k++) {
                CHECK_NEAR(sum[k], integ[k], 1e-5 * integ[k]);
                CHECK_NEAR(lc.total_power[k], integ[k], 1e-5 * integ[k]);
            }
            vsd_constellation_free(&lc);
        }
    vsd_env_destroy(u);
    vsd_env_destroy(s);
}

/* Median cut gives equal energy up to the granularity of one texel column/row: on a
 * 512x256 smooth map with N = 16 every light holds 1/16 of the luminance energy within
 * 15%. */
static void test_equal_energy(void)
{
    vsd_env *s = smooth_env(512, 256);
    vsd_light_constellation lc;
    double total = 0;
    int l;
    if (!s) return;
    CHECK(vsd_constellation_build(s, 16, VSD_LIGHTS_MEDIAN_CUT, &lc, NULL, 0) == VSD_OK);
    CHECK(lc.count == 16);
    for (l = 0; l < lc.count; l++)
        total += 0.2126 * lc.lights[l].power[0] + 0.7152 * lc.lights[l].power[1] + 0.0722 * lc.lights[l].power[2];
    for (l = 0; l < lc.count; l++) {
        double e = 0.2126 * lc.lights[l].power[0] + 0.7152 * lc.lights[l].power[1] + 0.0722 * lc.lights[l].power[2];
        CHECK_MSG(fabs(e - total / 16) < 0.15 * total / 16, "light %d: energy %g, expected %g", l, e, total / 16);
    }
    vsd_constellation_free(&lc);
    vsd_env_destroy(s);
}

/* One bright texel in a black map: one light, in the texel's direction, holding all the
 * power (both methods, several texels including one near a pole). */
static void test_bright_texel(void)
{
    const int texels[][2] = {{17, 9}, {40, 20}, {5, 1}, {63, 16}};
    int t, m;
    for (t = 0; t < 4; t++)
        for (m = 0; m < 2; m++) {
            float zero[3] = {0, 0, 0}, dir[3];
            vsd_env *e = make_env(64, 32, zero);
            vsd_light_constellation lc;
            double integ[3];
            float *p;
            if (!e) return;
            p = e->rgb + 3 * (texels[t][1] * 64 + texels[t][0]);
            p[0] = 500.0f; p[1] = 400.0f; p[2] = 300.0f;
            vsd_env_integral(e, integ);
            vsd_env_texel_direction(e, texels[t][0], texels[t][1], dir);
            CHECK(vsd_constellation_build(e, 64, (vsd_lights_method)m, &lc, NULL, 0) == VSD_OK);
            CHECK_MSG(lc.count == 1, "texel %d method %d: %d lights", t, m, lc.count);
            if (lc.count >= 1) {
                /* texels are 0.1 rad wide; 1e-3 rad is float rounding of acos near 1 */
                CHECK_MSG(angle_between(lc.lights[0].dir, dir) < 1e-3, "texel %d method %d: light off by %g rad", t, m,
                          angle_between(lc.lights[0].dir, dir));
                CHECK_NEAR(lc.lights[0].power[0], integ[0], 1e-5 * integ[0]);
                CHECK_NEAR(lc.lights[0].power[2], integ[2], 1e-5 * integ[2]);
                /* the kernel's own lookup finds the bright texel in that direction */
                {
                    vsd_kenv ke;
                    memset(&ke, 0, sizeof ke);
                    ke.width = 64; ke.height = 32; ke.cos_rot = 1; ke.sin_rot = 0;
                    CHECK(vsd_env_texel(&ke, f3(dir[0], dir[1], dir[2]), NULL) == texels[t][1] * 64 + texels[t][0]);
                }
            }
            vsd_constellation_free(&lc);
            vsd_env_destroy(e);
        }
}

/* Rotation without recomputation: for rotation r the kernel lights point to world
 * directions that kernel_env.h, rotated by r, maps back onto the light's own texel; the
 * weights scale with strength; nothing else changes. */
static void test_rotation(void)
{
    vsd_env *s = smooth_env(128, 64);
    vsd_light_constellation lc;
    const float rots[] = {0.0f, 0.7f, -2.5f, 3.1f};
    int r, l;
    if (!s) return;
    CHECK(vsd_constellation_build(s, 32, VSD_LIGHTS_MEDIAN_CUT, &lc, NULL, 0) == VSD_OK);
    for (r = 0; r < 4; r++) {
        float *kl = malloc(sizeof(float) * 8 * (size_t)lc.count);
        vsd_kenv k0, kr;
        memset(&k0, 0, sizeof k0);
        k0.width = 128; k0.height = 64; k0.cos_rot = 1; k0.sin_rot = 0;
        kr = k0;
        kr.cos_rot = cosf(rots[r]);
        kr.sin_rot = sinf(rots[r]);
        vsd_constellation_kernel_lights(&lc, 2.5f, rots[r], kl);
        for (l = 0; l < lc.count; l++) {
            const float *o = kl + 8 * l;
            vsd_f3 tex = f3(lc.lights[l].dir[0], lc.lights[l].dir[1], lc.lights[l].dir[2]);
            CHECK(vsd_env_texel(&kr, f3(o[0], o[1], o[2]), NULL) == vsd_env_texel(&k0, tex, NULL));
            CHECK_NEAR(o[0] * o[0] + o[1] * o[1] + o[2] * o[2], 1.0, 1e-5);
            CHECK_NEAR(o[2], lc.lights[l].dir[2], 0);
            CHECK_NEAR(o[4], 2.5 * lc.lights[l].power[0], 1e-6 * o[4]);
            CHECK_NEAR(o[6], 2.5 * lc.lights[l].power[2], 1e-6 * o[6]);
        }
        free(kl);
    }
    vsd_constellation_free(&lc);
    vsd_env_destroy(s);
}

/* k-means moves lights toward their clusters' centroids: unequal energies, and the sum
 * of energy-weighted angular spread does not grow compared with the median cut. */
static void test_kmeans_clusters(void)
{
    vsd_env *s = smooth_env(256, 128);
    vsd_light_constellation mc, km;
    double emin = 1e30, emax = 0;
    int l;
    if (!s) return;
    CHECK(vsd_constellation_build(s, 16, VSD_LIGHTS_MEDIAN_CUT, &mc, NULL, 0) == VSD_OK);
    CHECK(vsd_constellation_build(s, 16, VSD_LIGHTS_KMEANS, &km, NULL, 0) == VSD_OK);
    CHECK(km.count >= 1 && km.count <= 16);
    for (l = 0; l < km.count; l++) {
        double e = 0.2126 * km.lights[l].power[0] + 0.7152 * km.lights[l].power[1] + 0.0722 * km.lights[l].power[2];
        emin = fmin(emin, e);
        emax = fmax(emax, e);
    }
    CHECK_MSG(emax > 1.3 * emin, "k-means energies %g..%g look equal", emin, emax);
    vsd_constellation_free(&mc);
    vsd_constellation_free(&km);
    vsd_env_destroy(s);
}

static void test_errors(void)
{
    float c[3] = {1, 1, 1};
    vsd_env *u = make_env(8, 4, c);
    vsd_light_constellation lc;
    char err[256] = "";
    if (!u) return;
    CHECK(vsd_constellation_build(u, 0, VSD_LIGHTS_MEDIAN_CUT, &lc, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "out of range");
    CHECK(vsd_constellation_build(u, 70000, VSD_LIGHTS_MEDIAN_CUT, &lc, err, sizeof err) == VSD_ERR_INVALID);
    /* more lights than texels: every texel its own light at most */
    CHECK(vsd_constellation_build(u, 100, VSD_LIGHTS_MEDIAN_CUT, &lc, err, sizeof err) == VSD_OK);
    CHECK(lc.count == 32);
    vsd_constellation_free(&lc);
    vsd_env_destroy(u);
}

#define PI_DEG 3.14159265358979323846
/* the sub-lights of smooth_env(256, 128), 32 lights x 8 (measured on 2026-12: centroid
 * 0.257 deg, farthest sub-light 57.77 deg): bounds 2x and +1.2 deg */
#define SUB_CENTROID_DEG 0.5
#define SUB_FARTHEST_DEG 59.0
/* vsd_constellation_build_grouped: the lights are the ungrouped build's, bit for bit; each
 * light's sub-lights sum to its power and lie nearer its direction than a region's size;
 * the kernel layout carries each sub-light's light index in its 8th float. */
static void test_sub_lights(void)
{
    vsd_env *e = smooth_env(256, 128);
    vsd_light_constellation plain, grouped;
    float *kl;
    int i, k, ch, bad_group = 0;
    double worst_power = 0.0, worst_angle = 0.0, worst_centroid = 0.0;
    if (!e) return;
    CHECK(vsd_constellation_build(e, 32, VSD_LIGHTS_MEDIAN_CUT, &plain, NULL, 0) == VSD_OK);
    CHECK(vsd_constellation_build_grouped(e, 32, 8, VSD_LIGHTS_MEDIAN_CUT, &grouped, NULL, 0) == VSD_OK);
    CHECK(plain.count == grouped.count && plain.sub_count == 0);
    CHECK(memcmp(plain.lights, grouped.lights, sizeof *plain.lights * (size_t)plain.count) == 0);
    CHECK_MSG(grouped.sub_count > 4 * grouped.count && grouped.sub_count <= 8 * grouped.count, "%d sub-lights for %d lights",
              grouped.sub_count, grouped.count);
    for (k = 0; k < grouped.count; k++) {
        double sum[3] = {0, 0, 0}, centroid[3] = {0, 0, 0}, len;
        float cdir[3];
        for (i = 0; i < grouped.sub_count; i++) {
            const float *pw = grouped.sub[i].power;
            const double lum = 0.2126 * pw[0] + 0.7152 * pw[1] + 0.0722 * pw[2];
            if (grouped.sub_group[i] != k) continue;
            for (ch = 0; ch < 3; ch++) sum[ch] += pw[ch];
            for (ch = 0; ch < 3; ch++) centroid[ch] += lum * grouped.sub[i].dir[ch];
            worst_angle = fmax(worst_angle, angle_between(grouped.sub[i].dir, grouped.lights[k].dir));
        }
        for (ch = 0; ch < 3; ch++)
            worst_power = fmax(worst_power, fabs(sum[ch] - grouped.lights[k].power[ch]) / grouped.lights[k].power[ch]);
        len = sqrt(centroid[0] * centroid[0] + centroid[1] * centroid[1] + centroid[2] * centroid[2]);
        for (ch = 0; ch < 3; ch++) cdir[ch] = (float)(len > 0 ? centroid[ch] / len : 0.0);
        worst_centroid = fmax(worst_centroid, angle_between(cdir, grouped.lights[k].dir));
    }
    for (i = 0; i < grouped.sub_count; i++) bad_group += grouped.sub_group[i] < 0 || grouped.sub_group[i] >= grouped.count;
    kl = malloc(sizeof *kl * 8 * (size_t)(grouped.count + grouped.sub_count));
    if (kl) {
        vsd_constellation_kernel_lights(&grouped, 1.0f, 0.0f, kl);
        for (i = 0; i < grouped.sub_count; i++) bad_group += (int)kl[8 * (grouped.count + i) + 7] != grouped.sub_group[i];
    }
    printf("sub-lights: %d for %d lights, power per light within %.2g, farthest %.2f deg from its light, their "
           "luminance-weighted centroid at most %.3f deg from it\n",
           grouped.sub_count, grouped.count, worst_power, worst_angle * 180.0 / PI_DEG, worst_centroid * 180.0 / PI_DEG);
    CHECK_MSG(worst_power < 1e-4, "sub-lights' power off their light's by %.3g", worst_power);
    /* Each sub-light is the energy centroid of a part of its light's region, and the light
     * the centroid of the whole: the sub-lights' luminance-weighted mean direction is the
     * light's direction but for each part's spread (|sum of unit vectors| < its energy).
     * Measured at most 0.257 deg on this map; the bound allows float rounding and
     * spread, and a sub-light turned by a few degrees (or a wrong group) fails it. */
    CHECK_MSG(worst_centroid * 180.0 / PI_DEG < SUB_CENTROID_DEG,
              "the sub-lights' centroid is %.3f deg from its light (bound %.2f deg)", worst_centroid * 180.0 / PI_DEG,
              SUB_CENTROID_DEG);
    /* The farthest sub-light of a correct split of this map (32 lights x 8, median cut) lies
     * 57.77 deg from its light (a region near the pole, wide in longitude);
     * the bound was 1.2 rad (68.8 deg), which a sub-light turned by 10 deg passed. */
    CHECK_MSG(worst_angle * 180.0 / PI_DEG < SUB_FARTHEST_DEG, "a sub-light %.2f deg from its light (bound %.1f deg)",
              worst_angle * 180.0 / PI_DEG, SUB_FARTHEST_DEG);
    CHECK_MSG(bad_group == 0, "%d sub-lights name a wrong light", bad_group);
    vsd_constellation_free(&plain);
    CHECK(vsd_constellation_build_grouped(e, 32, 65, VSD_LIGHTS_MEDIAN_CUT, &plain, NULL, 0) == VSD_ERR_INVALID);
    free(kl);
    vsd_constellation_free(&grouped);
    vsd_env_destroy(e);
}

static void test_healpix_average(void)
{
    enum { NSIDE = 4, NPIX = 12 * NSIDE * NSIDE };
    const float one[3] = {0.5f, 1.0f, 2.0f};
    static float out[4 * NPIX];
    vsd_env *flat = make_env(128, 64, one), *sky = smooth_env(512, 256);
    vsd_kenv ke;
    double integral[3], sum[3] = {0, 0, 0}, worst_flat = 0.0;
    int i, c;
    if (!flat || !sky) return;
    memset(&ke, 0, sizeof ke);
    ke.cos_rot = 1.0f;
    ke.strength = 2.0f;
    CHECK(vsd_env_healpix_radiance(flat, &ke, NSIDE, out));
    for (i = 0; i < NPIX; i++)
        for (c = 0; c < 3; c++) worst_flat = fmax(worst_flat, fabs(out[4 * i + c] - 2.0 * one[c]) / (2.0 * one[c]));
    CHECK(vsd_env_healpix_radiance(sky, &ke, NSIDE, out));
    vsd_env_integral(sky, integral);
    for (i = 0; i < NPIX; i++)
        for (c = 0; c < 3; c++) sum[c] += out[4 * i + c] * 4.0 * 3.14159265358979 / NPIX;
    printf("healpix average: constant map off by %.2g; integral %.4f against the map's x2 %.4f\n", worst_flat, sum[1],
           2.0 * integral[1]);
    CHECK_MSG(worst_flat < 1e-6, "a constant map averaged per pixel is off by %.3g", worst_flat);
    for (c = 0; c < 3; c++)
        CHECK_MSG(fabs(sum[c] - 2.0 * integral[c]) < 0.02 * 2.0 * integral[c], "channel %d: %.4f against %.4f", c, sum[c],
                  2.0 * integral[c]);
    vsd_env_destroy(flat);
    vsd_env_destroy(sky);
}

/* The smooth map's lobe is far above 3x the mean, its gradient below: the lights take the
 * lobe's texels (lights' power + the remainder's integral = the map's integral, per
 * channel), the remainder keeps every texel at or under the threshold unchanged and is
 * black where it took one, and a uniform map gives no light and an unchanged copy. */
static void test_bright_split(void)
{
    const float grey[3] = {0.5f, 0.5f, 0.5f};
    vsd_env *e = smooth_env(128, 64), *u = make_env(32, 16, grey);
    vsd_env rest;
    vsd_light_constellation lc;
    double fraction, whole[3], left[3], lights[3] = {0, 0, 0}, mean_lum = 0.0;
    size_t i, n, taken = 0, kept_wrong = 0;
    int k, c;
    if (!e || !u) goto done;
    CHECK(vsd_env_split_bright(e, 3.0, 16, &rest, &lc, &fraction, NULL, 0) == VSD_OK);
    if (!rest.rgb) goto done;
    vsd_env_integral(e, whole);
    vsd_env_integral(&rest, left);
    for (k = 0; k < lc.count; k++)
        for (c = 0; c < 3; c++) lights[c] += lc.lights[k].power[c];
    for (c = 0; c < 3; c++) CHECK_NEAR(lights[c] + left[c], whole[c], 1e-4 * whole[c]);
    CHECK_MSG(lc.count >= 1 && lc.count <= 16, "%d lights", lc.count);
    CHECK_MSG(fraction > 0.05 && fraction < 0.95, "the lobe is %.3f of the map", fraction);
    mean_lum = (0.2126 * whole[0] + 0.7152 * whole[1] + 0.0722 * whole[2]) / (4.0 * M_PI);
    n = (size_t)e->width * e->height;
    for (i = 0; i < n; i++) {
        const float *p = e->rgb + 3 * i, *q = rest.rgb + 3 * i;
        double lum = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        if (lum > 3.0 * mean_lum * (1 + 1e-6)) {
            taken++;
            kept_wrong += q[0] != 0.0f || q[1] != 0.0f || q[2] != 0.0f;
        } else if (lum < 3.0 * mean_lum * (1 - 1e-6)) {
            kept_wrong += q[0] != p[0] || q[1] != p[1] || q[2] != p[2];
        }
    }
    CHECK_MSG(taken > 0 && kept_wrong == 0, "%zu texels above the threshold, %zu wrong in the remainder", taken,
              kept_wrong);
    free(rest.rgb);
    vsd_constellation_free(&lc);
    CHECK(vsd_env_split_bright(u, 3.0, 16, &rest, &lc, &fraction, NULL, 0) == VSD_OK);
    CHECK_MSG(lc.count == 0 && fraction == 0.0, "a uniform map gave %d lights (%.3f)", lc.count, fraction);
    if (rest.rgb) CHECK(memcmp(rest.rgb, u->rgb, sizeof(float) * 3 * 32 * 16) == 0);
    free(rest.rgb);
    vsd_constellation_free(&lc);
done:
    vsd_env_destroy(e);
    vsd_env_destroy(u);
}

/* g: a lights-only record grid of recs records at random positions in a cube of side
 * `extent` about the origin, each light's transmittance random in [0, 1). */
static void random_lights_grid(vsd_krecord_grid *g, const vsd_kernel_data *kd, const float *lights, int light_count,
                               int sub_count, float *pos, float *trans, int recs, float extent, unsigned long long *seed)
{
    int r, q, k;
    for (r = 0; r < recs; r++) {
        for (q = 0; q < 3; q++) pos[4 * r + q] = extent * (float)(test_urand(seed) - 0.5);
        pos[4 * r + 3] = 0.0f;
        for (k = 0; k < light_count; k++) trans[r * light_count + k] = (float)test_urand(seed);
    }
    memset(g, 0, sizeof *g);
    g->kd = kd;
    g->kind = VSD_RECORDS_LIGHTS;
    g->interp = VSD_RECORDS_TRILINEAR;
    g->lights = lights;
    g->light_count = light_count;
    g->sub_count = sub_count;
    g->light_trans = trans;
    g->record_pos = pos;
    g->record_count = recs;
}

/* The per-view bake of the lights' term (vsd_record_grid_bake_view) against the view's own
 * per-ray weights and radiance (vsd_records_light_weights, vsd_records_radiance), record by
 * record, bit for bit: with sub-lights grouped by light (summed across the lights, each
 * light's run in its order, short runs padded: here 3, 0, 8, 1 and 5 sub-lights) and not
 * grouped (the same sub-lights shuffled). */
static void test_bake_sub_lights(void)
{
    enum { L = 5, RECS = 300 };
    static const int runs[L] = {3, 0, 8, 1, 5};
    float lights[8 * (L + 17)], pos[4 * RECS], trans[RECS * L], out[3 * RECS];
    vsd_kernel_data kd;
    vsd_krecord_grid g;
    unsigned long long seed = 7;
    int k, q, n = 0, r, shuffled, bad = 0;
    memset(&kd, 0, sizeof kd);
    kd.medium.anisotropy = 0.6f;
    kd.camera.cam_to_world.m[0] = kd.camera.cam_to_world.m[5] = kd.camera.cam_to_world.m[10] = 1.0f;
    kd.camera.cam_to_world.m[3] = 0.3f, kd.camera.cam_to_world.m[7] = -4.0f, kd.camera.cam_to_world.m[11] = 1.0f;
    for (k = 0; k < L; k++) {
        float *l = lights + 8 * k;
        vsd_f3 w = f3_normalize(f3(sinf(1.3f * k), cosf(0.7f * k + 0.2f), 0.4f - 0.2f * k));
        l[0] = w.x, l[1] = w.y, l[2] = w.z, l[3] = 0.0f, l[4] = 1.0f + k, l[5] = 0.5f, l[6] = 0.25f * k, l[7] = 0.0f;
    }
    for (k = 0; k < L; k++)
        for (q = 0; q < runs[k]; q++, n++) {
            float *l = lights + 8 * (L + n);
            vsd_f3 w = f3_normalize(f3(lights[8 * k] + 0.1f * q, lights[8 * k + 1] - 0.05f * q, lights[8 * k + 2] + 0.03f));
            l[0] = w.x, l[1] = w.y, l[2] = w.z, l[3] = 0.0f;
            l[4] = 0.1f * (q + 1), l[5] = 0.07f * (k + 1), l[6] = 0.3f / (q + 1), l[7] = (float)k;
        }
    random_lights_grid(&g, &kd, lights, L, n, pos, trans, RECS, 2.0f, &seed);
    for (shuffled = 0; shuffled < 2; shuffled++) {
        if (shuffled)   /* the sub-lights out of their lights' order: the ungrouped sums */
            for (q = 0; q < 8; q++) {
                float t[8];
                memcpy(t, lights + 8 * (L + q), sizeof t);
                memcpy(lights + 8 * (L + q), lights + 8 * (L + n - 1 - q), sizeof t);
                memcpy(lights + 8 * (L + n - 1 - q), t, sizeof t);
            }
        vsd_record_grid_bake_view(&g, pos, 2, out);
        bad = 0;
        for (r = 0; r < RECS; r++) {
            float ph[VSD_RECORDS_PH_FLOATS];
            vsd_f3 d = f3_normalize(f3(pos[4 * r] - 0.3f, pos[4 * r + 1] + 4.0f, pos[4 * r + 2] - 1.0f)), v;
            vsd_records_light_weights(lights, L, n, d, kd.medium.anisotropy, ph);
            v = vsd_records_radiance(&g, r, NULL, ph);
            bad += memcmp(&v.x, out + 3 * r, sizeof(float)) || memcmp(&v.y, out + 3 * r + 1, sizeof(float)) ||
                   memcmp(&v.z, out + 3 * r + 2, sizeof(float));
        }
        CHECK_MSG(bad == 0, "the bake (%s sub-lights) differs from the view's weights at %d of %d records",
                  shuffled ? "shuffled" : "grouped", bad, RECS);
        printf("bake with %d sub-lights %s (runs 3, 0, 8, 1, 5): the view's per-ray weights bit for bit at %d "
               "records\n", n, shuffled ? "shuffled" : "grouped", RECS);
    }
}

/* The perspective bake's phase table (record_grid_bake.c): with a camera whose film the
 * records outnumber, their weights come from a table over the camera's tangent plane, mixed
 * bilinearly: within 3e-4 of each record's own weights (g 0.7, a light shining toward the
 * camera through the middle of the film, sub-lights), bit for bit where the direction falls
 * outside the film and its margin; and some records do differ (the table was used). */
static void test_bake_phase_table(void)
{
    enum { L = 6, SUBS = 4, RECS = 24000 };
    static float lights[8 * L * (1 + SUBS)], pos[4 * RECS], trans[RECS * L], out[3 * RECS];
    vsd_kernel_data kd;
    vsd_krecord_grid g;
    unsigned long long seed = 11;
    const float *m;
    int k, q, r, inside = 0, outside = 0, differ = 0, outside_exact = 1;
    double worst = 0.0;
    memset(&kd, 0, sizeof kd);
    kd.medium.anisotropy = 0.7f;
    /* eye at (0, -4, 0) looking along +y, up +z: columns right, up, -forward */
    kd.camera.cam_to_world.m[0] = 1.0f, kd.camera.cam_to_world.m[9] = 1.0f, kd.camera.cam_to_world.m[6] = -1.0f;
    kd.camera.cam_to_world.m[7] = -4.0f;
    kd.camera.tan_half_fov = 0.36f;
    kd.camera.width = 160, kd.camera.height = 90;
    m = kd.camera.cam_to_world.m;
    for (k = 0; k < L; k++) {
        /* light 0 travels toward the camera (forward scattering into the eye), the others around */
        vsd_f3 w = k == 0 ? f3(0.02f, -1.0f, 0.01f) : f3_normalize(f3(sinf(1.3f * k), cosf(0.7f * k + 0.2f), 0.4f - 0.2f * k));
        float *l = lights + 8 * k;
        w = f3_normalize(w);
        l[0] = w.x, l[1] = w.y, l[2] = w.z, l[3] = 0.0f, l[4] = 1.0f + k, l[5] = 0.5f, l[6] = 0.25f * k, l[7] = 0.0f;
        for (q = 0; q < SUBS; q++) {
            float *sl = lights + 8 * (L + k * SUBS + q);
            vsd_f3 v = f3_normalize(f3(w.x + 0.04f * q, w.y - 0.03f * q, w.z + 0.02f));
            sl[0] = v.x, sl[1] = v.y, sl[2] = v.z, sl[3] = 0.0f;
            sl[4] = 0.1f * (q + 1), sl[5] = 0.07f * (k + 1), sl[6] = 0.3f / (q + 1), sl[7] = (float)k;
        }
    }
    random_lights_grid(&g, &kd, lights, L, L * SUBS, pos, trans, RECS, 3.0f, &seed);
    vsd_record_grid_bake_view(&g, pos, 2, out);
    for (r = 0; r < RECS; r++) {
        float ph[VSD_RECORDS_PH_FLOATS];
        const vsd_f3 d = f3_normalize(f3(pos[4 * r] - m[3], pos[4 * r + 1] - m[7], pos[4 * r + 2] - m[11]));
        const float a = fabsf(d.x / d.y), b = fabsf(d.z / d.y);
        /* beyond the table: the film's half-extents (0.36 across, 0.2025 up) and its margin (1.15, the
         * last node up to one step further) */
        const int beyond = a > 0.36f * 1.3f || b > 0.2025f * 1.3f;
        vsd_f3 v;
        int c, same;
        vsd_records_light_weights(lights, L, L * SUBS, d, kd.medium.anisotropy, ph);
        v = vsd_records_radiance(&g, r, NULL, ph);
        same = !memcmp(&v.x, out + 3 * r, sizeof(float)) && !memcmp(&v.y, out + 3 * r + 1, sizeof(float)) &&
               !memcmp(&v.z, out + 3 * r + 2, sizeof(float));
        differ += !same;
        if (beyond) {
            outside++;
            outside_exact &= same;
            continue;
        }
        inside++;
        for (c = 0; c < 3; c++) {
            const double e = (&v.x)[c], t = out[3 * r + c];
            worst = fmax(worst, fabs(t - e) / fmax(fabs(e), 1e-6));
        }
    }
    printf("bake's phase table: %d records inside the film, worst relative difference %.2e; %d beyond it, %s; "
           "%d differ in all\n", inside, worst, outside, outside_exact ? "bit for bit" : "NOT bit for bit", differ);
    CHECK_MSG(inside > 1000 && outside > 1000, "the records should fall on both sides of the table (%d, %d)", inside,
              outside);
    CHECK_MSG(differ > 0, "no record differs from its own weights: the table was not used");
    CHECK_MSG(worst < 3e-4, "the table's weights differ from the records' own by %.2e", worst);
    CHECK_MSG(outside_exact, "a record beyond the table did not take its own weights");
}

int main(void)
{
    test_bake_phase_table();
    test_bake_sub_lights();
    test_bright_split();
    test_healpix_average();
    test_sub_lights();
    test_power_conservation();
    test_equal_energy();
    test_bright_texel();
    test_rotation();
    test_kmeans_clusters();
    test_errors();
    return test_finish("test_lighting");
}
