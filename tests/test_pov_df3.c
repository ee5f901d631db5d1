/* df3 files and the volume .inc of `vsd export pov` (service/pipeline/df3.h, pov_volume.h):
 * the encoder's bounds and values, the file bytes (big-endian header and voxels, x
 * fastest) and their round trip, POV-Ray's measured interpolation rule over the padded
 * grid against vsd's own field, the box transform, the coefficients in the .inc, and
 * the errors. No POV-Ray needed. */
#define _POSIX_C_SOURCE 200809L
#include "test_common.h"
#include "df3.h"
#include "pov_export.h"
#include "pov_volume.h"
#include "vsd/scene.h"
#include "vsd/volume.h"
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define NX 7
#define NY 5
#define NZ 9
static const int32_t LO[3] = {-4, 10, 3};
static const double I2W[16] = {0.25, 0, 0, 1, 0, 0.5, 0, 2, 0, 0, 0.125, 3, 0, 0, 0, 1};

/* Values on a 7x5x9 block: zero planes around a non-zero core, one negative voxel. */
static float value_at(int x, int y, int z)
{
    if (x < 1 || x > 5 || y < 2 || y > 3 || z < 1 || z > 8) return 0.0f;
    if (x == 3 && y == 2 && z == 4) return -0.5f;
    return 0.1f + 0.37f * x + 0.05f * y * z;
}

static vsd_volume *make_volume(void)
{
    static float v[NX * NY * NZ];
    const int32_t dims[3] = {NX, NY, NZ};
    vsd_volume *vol = NULL;
    int x, y, z;
    char err[256];
    for (z = 0; z < NZ; z++)
        for (y = 0; y < NY; y++)
            for (x = 0; x < NX; x++) v[(z * NY + y) * NX + x] = value_at(x, y, z);
    CHECK_MSG(vsd_volume_create_dense(v, dims, LO, I2W, &vol, err, sizeof err) == VSD_OK, "%s", err);
    snprintf(vol->grid_name, sizeof vol->grid_name, "density");
    return vol;
}

/* POV-Ray 3.7's df3 `interpolate 1`, as measured (docs/povray.md): voxel n at u = n/S,
 * linear between neighbours, the last cell interpolating towards voxel 0 (wrap). */
static double pov_trilinear(const vsd_df3 *d, const double u[3])
{
    int i0[3], i1[3], a, c;
    double t[3], sum = 0;
    for (a = 0; a < 3; a++) {
        double s = u[a] * d->size[a];
        i0[a] = (int)s;
        t[a] = s - i0[a];
        i0[a] %= d->size[a];
        i1[a] = (i0[a] + 1) % d->size[a];
    }
    for (c = 0; c < 8; c++) {
        double w = 1;
        int p[3];
        for (a = 0; a < 3; a++) {
            int hi = (c >> a) & 1;
            p[a] = hi ? i1[a] : i0[a];
            w *= hi ? t[a] : 1 - t[a];
        }
        sum += w * vsd_df3_value(d, p[0], p[1], p[2]);
    }
    return sum;
}

static void check_encoding(const vsd_volume *vol, vsd_df3 *d)
{
    char err[512];
    int x, y, z;
    float max = 0;
    CHECK_MSG(vsd_df3_from_volume(vol, d, err, sizeof err) == VSD_OK, "%s", err);
    /* non-zero core x 1..5, y 2..3, z 1..8 plus one zero voxel each side */
    CHECK(d->size[0] == 7 && d->size[1] == 4 && d->size[2] == 10);
    CHECK(d->index_min[0] == LO[0] + 0 && d->index_min[1] == LO[1] + 1 && d->index_min[2] == LO[2] + 0);
    CHECK(d->negative == 1);
    for (z = 0; z < NZ; z++)
        for (y = 0; y < NY; y++)
            for (x = 0; x < NX; x++)
                if (value_at(x, y, z) > max) max = value_at(x, y, z);
    CHECK_NEAR(d->scale, max, 0);
    /* every df3 voxel decodes to the grid's value to within half a quantisation step */
    for (z = 0; z < d->size[2]; z++)
        for (y = 0; y < d->size[1]; y++)
            for (x = 0; x < d->size[0]; x++) {
                int gx = d->index_min[0] + x - LO[0], gy = d->index_min[1] + y - LO[1], gz = d->index_min[2] + z - LO[2];
                float g = (gx >= 0 && gx < NX && gy >= 0 && gy < NY && gz >= 0 && gz < NZ) ? value_at(gx, gy, gz) : 0;
                if (g < 0) g = 0;
                CHECK_NEAR(vsd_df3_value(d, x, y, z), g, 0.5 * max / 65535 + 1e-7);
                if (x == 0 || y == 0 || z == 0 || x == d->size[0] - 1 || y == d->size[1] - 1 || z == d->size[2] - 1)
                    CHECK(d->data[((size_t)z * d->size[1] + y) * d->size[0] + x] == 0);
            }
}

static void check_file(const vsd_df3 *d)
{
    char err[512], path[1100];
    unsigned char *bytes;
    size_t n = (size_t)d->size[0] * d->size[1] * d->size[2], len, i;
    vsd_df3 back;
    FILE *f;
    snprintf(path, sizeof path, "%s", test_tmp("pov_df3.df3"));
    CHECK_MSG(vsd_df3_write(path, d, err, sizeof err) == VSD_OK, "%s", err);
    f = fopen(path, "rb");
    CHECK(f != NULL);
    if (!f) return;
    bytes = malloc(6 + 2 * n + 16);
    len = fread(bytes, 1, 6 + 2 * n + 16, f);
    fclose(f);
    CHECK(len == 6 + 2 * n);
    for (i = 0; i < 3; i++) CHECK((bytes[2 * i] << 8 | bytes[2 * i + 1]) == d->size[i]);
    for (i = 0; i < n && len == 6 + 2 * n; i++) {
        unsigned v = (unsigned)(bytes[6 + 2 * i] << 8 | bytes[7 + 2 * i]);
        if (v != d->data[i]) {
            CHECK_MSG(0, "voxel %zu: file has %u, memory %u", i, v, d->data[i]);
            break;
        }
    }
    free(bytes);
    CHECK_MSG(vsd_df3_read(path, &back, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(back.size[0] == d->size[0] && back.size[1] == d->size[1] && back.size[2] == d->size[2]);
    CHECK(back.data && memcmp(back.data, d->data, 2 * n) == 0);
    vsd_df3_free(&back);
    /* truncated file: a format error naming the file */
    f = fopen(path, "r+b");
    if (f) {
        CHECK(ftruncate(fileno(f), 6 + 10) == 0);
        fclose(f);
    }
    CHECK(vsd_df3_read(path, &back, err, sizeof err) == VSD_ERR_FORMAT);
    CHECK_CONTAINS(err, "truncated");
    CHECK_CONTAINS(err, "pov_df3.df3");
    CHECK(vsd_df3_write("/nonexistent-dir/x.df3", d, err, sizeof err) == VSD_ERR_IO);
    CHECK_CONTAINS(err, "/nonexistent-dir/x.df3");
}

/* POV-Ray's field over the padded df3 at box point u equals vsd's trilinear field at the
 * index point the box transform gives (to the 16-bit quantisation). */
static void check_field(const vsd_volume *vol, const vsd_df3 *d)
{
    unsigned long long rng = 12345;
    double m[16], worst = 0;
    int n, a;
    vsd_df3_box_to_index(d, m);
    for (n = 0; n < 20000; n++) {
        double u[3], p[3], pov, ref;
        for (a = 0; a < 3; a++) u[a] = test_urand(&rng) * 0.999999;
        for (a = 0; a < 3; a++) p[a] = m[a * 4 + a] * u[a] + m[a * 4 + 3];
        pov = pov_trilinear(d, u);
        ref = vsd_volume_sample_index(vol, p);
        if (ref < 0) ref = 0;  /* clamped voxels: compare only where no negative voxel reaches */
        if (p[0] > LO[0] + 1.5 && p[0] < LO[0] + 4.5 && p[1] < LO[1] + 3 && p[2] > LO[2] + 2.5 && p[2] < LO[2] + 5.5)
            continue;
        if (fabs(pov - ref) > worst) worst = fabs(pov - ref);
    }
    printf("POV-Ray's df3 field vs vsd's: max |difference| %.3g (quantisation step %.3g)\n", worst,
           d->scale / 65535.0);
    CHECK(worst <= d->scale / 65535.0);
}

/* The box transform sends df3 voxel n to the world point of index index_min + n, with the
 * axes swapped for POV-Ray. */
static void check_box_matrix(const vsd_volume *vol, const vsd_df3 *d)
{
    const double obj[16] = {0, -2, 0, 5, 1, 0, 0, 6, 0, 0, 3, 7, 0, 0, 0, 1};
    double m[16];
    int n[3] = {2, 3, 4}, a;
    double u[3], idx[3], bw[3], w[3];
    vsd_pov_box_matrix(d, vol, obj, m);
    for (a = 0; a < 3; a++) {
        u[a] = (double)n[a] / d->size[a];
        idx[a] = d->index_min[a] + n[a];
    }
    for (a = 0; a < 3; a++) w[a] = m[a * 4] * u[0] + m[a * 4 + 1] * u[1] + m[a * 4 + 2] * u[2] + m[a * 4 + 3];
    {
        double gw[3];
        for (a = 0; a < 3; a++)
            gw[a] = I2W[a * 4] * idx[0] + I2W[a * 4 + 1] * idx[1] + I2W[a * 4 + 2] * idx[2] + I2W[a * 4 + 3];
        for (a = 0; a < 3; a++) bw[a] = obj[a * 4] * gw[0] + obj[a * 4 + 1] * gw[1] + obj[a * 4 + 2] * gw[2] + obj[a * 4 + 3];
    }
    CHECK_NEAR(w[0], bw[0], 1e-12);
    CHECK_NEAR(w[1], bw[2], 1e-12);  /* POV-Ray y = Blender z */
    CHECK_NEAR(w[2], bw[1], 1e-12);
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    char *s;
    long n;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    s = calloc((size_t)n + 1, 1);
    if (s && fread(s, 1, (size_t)n, f) != (size_t)n) s[0] = '\0';
    fclose(f);
    return s;
}

static void check_inc(const vsd_volume *vol, const vsd_df3 *d)
{
    vsd_scene sc;
    vsd_pov_export_report rep;
    char err[512], dir[1100], path[1200], want[256];
    char *inc;
    vsd_scene_defaults(&sc);
    sc.volumes[0].medium.density = 4;
    sc.volumes[0].medium.albedo[0] = 0.5f, sc.volumes[0].medium.albedo[1] = 0.25f, sc.volumes[0].medium.albedo[2] = 1.0f;
    sc.volumes[0].medium.anisotropy = 0.3f;
    sc.volumes[0].medium.emission_strength = 2;
    sc.volumes[0].medium.emission_color[0] = 1, sc.volumes[0].medium.emission_color[1] = 0.5f, sc.volumes[0].medium.emission_color[2] = 0;
    snprintf(dir, sizeof dir, "%s", test_tmp("pov_df3_export"));
    CHECK_MSG(vsd_pov_prepare_dir(dir, err, sizeof err) == VSD_OK, "%s", err);
    memset(&rep, 0, sizeof rep);
    CHECK_MSG(vsd_pov_export_frame(&sc, 7, vol, vol, dir, "t", &rep, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(rep.frames == 1 && rep.negative_voxels == 2);
    snprintf(path, sizeof path, "%s/t_0007.inc", dir);
    inc = slurp(path);
    CHECK_MSG(inc != NULL, "%s missing", path);
    if (!inc) return;
    CHECK_CONTAINS(inc, "#declare vsd_volume = union {");
    CHECK_CONTAINS(inc, "density { density_file df3 \"t_density_0007.df3\" interpolate 1 }");
    CHECK_CONTAINS(inc, "density { density_file df3 \"t_emission_0007.df3\" interpolate 1 }");
    /* sigma at the grid maximum = medium.density * max */
    {
        double s = 4.0 * d->scale;
        snprintf(want, sizeof want, "scattering { 5, rgb <%.9g, %.9g, %.9g> eccentricity %.9g extinction 1 }",
                 0.5f * s, 0.25f * s, 1.0f * s, (double)0.3f);
        CHECK_CONTAINS(inc, want);
        snprintf(want, sizeof want, "absorption rgb <%.9g, %.9g, %.9g>", (1 - 0.5f) * s, (1 - 0.25f) * s, 0.0);
        CHECK_CONTAINS(inc, want);
        snprintf(want, sizeof want, "emission rgb <%.9g, %.9g, %.9g>", 2.0 * d->scale, 0.5f * 2.0 * d->scale, 0.0);
        CHECK_CONTAINS(inc, want);
    }
    free(inc);
    snprintf(path, sizeof path, "%s/t_emission_0007.df3", dir);
    {
        vsd_df3 e;
        CHECK_MSG(vsd_df3_read(path, &e, err, sizeof err) == VSD_OK, "%s", err);
        CHECK(e.data && e.size[0] == d->size[0] && memcmp(e.data, d->data, 2 * (size_t)d->size[0] * d->size[1] * d->size[2]) == 0);
        vsd_df3_free(&e);
    }
    /* errors: the output folder is a file; a bad name */
    CHECK(vsd_pov_prepare_dir(path, err, sizeof err) == VSD_ERR_IO);
    CHECK_CONTAINS(err, "not a folder");
    CHECK(vsd_pov_export_frame(&sc, 7, vol, NULL, dir, "a b", &rep, err, sizeof err) == VSD_ERR_INVALID);
    CHECK_CONTAINS(err, "name 'a b'");
}

int main(void)
{
    vsd_volume *vol = make_volume(), *empty = NULL;
    vsd_df3 d;
    char err[256];
    if (!vol) return test_finish("test_pov_df3");
    check_encoding(vol, &d);
    check_file(&d);
    check_field(vol, &d);
    check_box_matrix(vol, &d);
    check_inc(vol, &d);
    vsd_df3_free(&d);
    /* an empty grid: a valid 2x2x2 file of zeros, scale 0 */
    CHECK(vsd_volume_create_empty(NULL, &empty, err, sizeof err) == VSD_OK);
    CHECK(vsd_df3_from_volume(empty, &d, err, sizeof err) == VSD_OK);
    CHECK(d.size[0] == 2 && d.size[1] == 2 && d.size[2] == 2 && d.scale == 0 && d.data && d.data[7] == 0);
    vsd_df3_free(&d);
    vsd_volume_destroy(empty);
    vsd_volume_destroy(vol);
    return test_finish("test_pov_df3");
}
