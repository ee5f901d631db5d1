/* df3 files and the volume .inc of `vsd export pov` (service/pipeline/df3.h, pov_volume.h):
 * the encoder's bounds and values, the file bytes (big-endian header and voxels, x
 * fastest) and their round trip, POV-Ray's measured interpolation rule over the padded
 * grid against vsd's own field, the box transform, the coefficients in the .inc, and
 * the errors. Scenes of several volumes (shared data's VDBs): a df3 per volume and grid,
 * each volume's own media block, box matrix and frame, and load errors naming the
 * volume. No POV-Ray needed. */
#define _POSIX_C_SOURCE 200809L
#include "test_common.h"
#include "df3.h"
#include "pov_export.h"
#include "pov_volume.h"
#include "vsd/scene.h"
#include "vsd/vdbio.h"
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

/* ---- scenes of several volumes ---------------------------------------------------- */

static vsd_volume *load(const char *file, const char *grid)
{
    vsd_grid_select sel;
    vsd_volume *v = NULL;
    char err[1024];
    sel.name = grid;
    sel.index = -1;
    CHECK_MSG(vsd_vdb_load(file, sel, &v, err, sizeof err) == VSD_OK, "%s", err);
    return v;
}

/* The df3 file `path` holds exactly what the encoder makes of `grid`, and every voxel of it
 * decodes to the grid's own value at its index (to half a quantisation step). `*enc`
 * receives the encoding (placement and scale) for the caller's checks of the .inc. */
static void check_df3_file(const char *path, const vsd_volume *grid, vsd_df3 *enc)
{
    char err[1024];
    vsd_df3 back;
    int x, y, z;
    size_t n;
    long nonzero = 0;
    memset(enc, 0, sizeof *enc);
    CHECK_MSG(vsd_df3_from_volume(grid, enc, err, sizeof err) == VSD_OK, "%s", err);
    CHECK_NEAR(enc->scale, grid->value_max, 0);
    CHECK_MSG(vsd_df3_read(path, &back, err, sizeof err) == VSD_OK, "%s", err);
    n = (size_t)enc->size[0] * enc->size[1] * enc->size[2];
    CHECK_MSG(back.size[0] == enc->size[0] && back.size[1] == enc->size[1] && back.size[2] == enc->size[2],
              "%s: %dx%dx%d, grid '%s' encodes as %dx%dx%d", path, back.size[0], back.size[1], back.size[2],
              grid->grid_name, enc->size[0], enc->size[1], enc->size[2]);
    if (back.data && back.size[0] == enc->size[0] && back.size[1] == enc->size[1] && back.size[2] == enc->size[2]) {
        CHECK_MSG(memcmp(back.data, enc->data, 2 * n) == 0, "%s: voxels differ from grid '%s'", path,
                  grid->grid_name);
        for (z = 0; z < back.size[2]; z++)
            for (y = 0; y < back.size[1]; y++)
                for (x = 0; x < back.size[0]; x++) {
                    double p[3] = {enc->index_min[0] + x, enc->index_min[1] + y, enc->index_min[2] + z};
                    double g = vsd_volume_sample_index(grid, p), v;
                    if (g < 0) g = 0;
                    v = back.data[((size_t)z * back.size[1] + y) * back.size[0] + x] * (double)enc->scale / 65535.0;
                    if (v > 0) nonzero++;
                    if (fabs(v - g) > 0.5 * enc->scale / 65535.0 + 1e-6 * enc->scale) {
                        CHECK_MSG(0, "%s voxel %d %d %d: %.9g, grid '%s' %.9g", path, x, y, z, v, grid->grid_name, g);
                        z = back.size[2];
                        break;
                    }
                }
        CHECK_MSG(nonzero > 100, "%s: only %ld non-zero voxels", path, nonzero);
    }
    vsd_df3_free(&back);
}

/* The first "matrix <...>" after `after` in `s`, as a row-major 4x4 (column vectors). */
static int parse_box_matrix(const char *s, const char *after, double m[16])
{
    const char *p = s ? strstr(s, after) : NULL;
    double c[12];
    int k;
    if (!p || !(p = strstr(p, "matrix <"))) return 0;
    if (sscanf(p, "matrix <%lf ,%lf ,%lf ,%lf ,%lf ,%lf ,%lf ,%lf ,%lf ,%lf ,%lf ,%lf >", &c[0], &c[1], &c[2], &c[3],
               &c[4], &c[5], &c[6], &c[7], &c[8], &c[9], &c[10], &c[11]) != 12)
        return 0;
    /* POV-Ray: p' = x*<c0,c1,c2> + y*<c3,c4,c5> + z*<c6,c7,c8> + <c9,c10,c11> */
    memset(m, 0, 16 * sizeof *m);
    for (k = 0; k < 4; k++) {
        m[0 * 4 + k] = c[3 * k];
        m[1 * 4 + k] = c[3 * k + 1];
        m[2 * 4 + k] = c[3 * k + 2];
    }
    m[15] = 1;
    return 1;
}

/* The box matrix written after `after` in `inc` sends df3 voxel n to the POV-Ray point of
 * vsd's world point volume.matrix * index_to_world * (index_min + n), y and z swapped. */
static void check_box(const char *inc, const char *after, const vsd_df3 *enc, const vsd_volume *grid,
                      const double obj[16])
{
    static const int corners[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    double m[16];
    int c, a;
    if (!parse_box_matrix(inc, after, m)) {
        CHECK_MSG(0, "no box matrix after '%s'", after);
        return;
    }
    for (c = 0; c < 5; c++) {
        int n[3];
        double u[3], idx[3], gw[3], bw[3], w[3], scale = 0;
        for (a = 0; a < 3; a++) {
            n[a] = c < 4 ? corners[c][a] * (enc->size[a] - 1) : enc->size[a] / 2;
            u[a] = (double)n[a] / enc->size[a];
            idx[a] = enc->index_min[a] + n[a];
        }
        for (a = 0; a < 3; a++) {
            w[a] = m[a * 4] * u[0] + m[a * 4 + 1] * u[1] + m[a * 4 + 2] * u[2] + m[a * 4 + 3];
            gw[a] = grid->index_to_world[a * 4] * idx[0] + grid->index_to_world[a * 4 + 1] * idx[1] +
                    grid->index_to_world[a * 4 + 2] * idx[2] + grid->index_to_world[a * 4 + 3];
        }
        for (a = 0; a < 3; a++) {
            bw[a] = obj[a * 4] * gw[0] + obj[a * 4 + 1] * gw[1] + obj[a * 4 + 2] * gw[2] + obj[a * 4 + 3];
            scale += fabs(bw[a]);
        }
        CHECK_NEAR(w[0], bw[0], 1e-12 * (1 + scale));
        CHECK_NEAR(w[1], bw[2], 1e-12 * (1 + scale));  /* POV-Ray y = Blender z */
        CHECK_NEAR(w[2], bw[1], 1e-12 * (1 + scale));
    }
}

static int exists(const char *dir, const char *file)
{
    char path[1400];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    return access(path, F_OK) == 0;
}

/* The same small VDB twice: volumes[0] its density, scaled and moved, a grey-blue
 * isotropic medium; volumes[1] rotated and moved, another density, albedo and a backward
 * lobe, with its `heat` grid as emission. */
static void check_two_volumes(void)
{
    static const double M0[16] = {2, 0, 0, 1, 0, 1, 0, -3, 0, 0, 0.5, 2, 0, 0, 0, 1};
    static const double M1[16] = {0, -1, 0, 10, 1, 0, 0, 0, 0, 0, 1.5, -4, 0, 0, 0, 1};
    char json[4096], err[2048], dir[1100], path[1300], want[1200], file[1100];
    vsd_scene sc;
    vsd_pov_export_options opt;
    vsd_pov_export_report rep;
    vsd_volume *dens, *heat;
    vsd_df3 d0, d1, e1;
    char *inc, *sec1;
    snprintf(file, sizeof file, "%s", test_data("external/usd_densityAndHeat.vdb"));
    snprintf(json, sizeof json,
             "{\"version\":1,\"frames\":{\"start\":3,\"end\":3},\"volumes\":["
             "{\"file\":\"%s\",\"matrix\":[2,0,0,1, 0,1,0,-3, 0,0,0.5,2, 0,0,0,1],"
             "\"medium\":{\"density\":3,\"albedo\":[0.9,0.5,0.2]}},"
             "{\"file\":\"%s\",\"emission_grid\":\"heat\",\"matrix\":[0,-1,0,10, 1,0,0,0, 0,0,1.5,-4, 0,0,0,1],"
             "\"medium\":{\"density\":0.25,\"albedo\":[0.1,0.6,0.3],\"anisotropy\":-0.4,"
             "\"emission_color\":[1,0.5,0.25],\"emission_strength\":7}}]}",
             file, file);
    CHECK_MSG(vsd_scene_parse(json, "", NULL, 0, &sc, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(sc.volume_count == 2);
    snprintf(dir, sizeof dir, "%s", test_tmp("pov_two_volumes"));
    memset(&opt, 0, sizeof opt);
    opt.name = "two";
    opt.first = opt.last = 3;
    CHECK_MSG(vsd_pov_export(&sc, &opt, dir, &rep, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(rep.frames == 1);
    /* a df3 per volume, emission only where the volume has it; no un-indexed names */
    CHECK(exists(dir, "two_v0_density_0003.df3"));
    CHECK(exists(dir, "two_v1_density_0003.df3"));
    CHECK(exists(dir, "two_v1_emission_0003.df3"));
    CHECK(!exists(dir, "two_v0_emission_0003.df3"));
    CHECK(!exists(dir, "two_density_0003.df3") && !exists(dir, "two_emission_0003.df3"));
    CHECK(exists(dir, "two_0003.inc") && exists(dir, "two.pov") && exists(dir, "two_camera.inc"));

    dens = load(sc.volumes[0].file, "density");
    heat = load(sc.volumes[1].file, "heat");
    if (!dens || !heat) goto done;
    snprintf(path, sizeof path, "%s/two_v0_density_0003.df3", dir);
    check_df3_file(path, dens, &d0);
    snprintf(path, sizeof path, "%s/two_v1_density_0003.df3", dir);
    check_df3_file(path, dens, &d1);
    snprintf(path, sizeof path, "%s/two_v1_emission_0003.df3", dir);
    check_df3_file(path, heat, &e1);

    snprintf(path, sizeof path, "%s/two_0003.inc", dir);
    inc = slurp(path);
    CHECK_MSG(inc != NULL, "%s missing", path);
    if (!inc) goto free_df3;
    CHECK_CONTAINS(inc, "#declare vsd_volume = union {");
    sec1 = strstr(inc, "  // volumes[1]: ");
    CHECK_MSG(sec1 != NULL, "no volumes[1] section in %s", path);
    CHECK(strstr(inc, "  // volumes[0]: ") && strstr(inc, "  // volumes[0]: ") < sec1);
    if (sec1) {
        double s0 = 3.0 * d0.scale, s1 = 0.25 * d1.scale, se = 7.0 * e1.scale;
        char *sec0 = inc;
        *sec1 = '\0';  /* inc: header + volumes[0]; sec1 + 1: volumes[1] to the end */
        sec1++;
        snprintf(want, sizeof want, "%s (frame 3)\n", sc.volumes[1].file);
        CHECK_CONTAINS(sec1, want);
        /* volumes[0]: its own df3, coefficients (density 3 at its maximum), no emission */
        CHECK_CONTAINS(sec0, "density { density_file df3 \"two_v0_density_0003.df3\" interpolate 1 }");
        snprintf(want, sizeof want, "scattering { 1, rgb <%.9g, %.9g, %.9g> extinction 1 }", 0.9f * s0, 0.5f * s0,
                 0.2f * s0);
        CHECK_CONTAINS(sec0, want);
        snprintf(want, sizeof want, "absorption rgb <%.9g, %.9g, %.9g>", (1.0 - 0.9f) * s0, (1.0 - 0.5f) * s0,
                 (1.0 - 0.2f) * s0);
        CHECK_CONTAINS(sec0, want);
        CHECK(!strstr(sec0, "emission rgb") && !strstr(sec0, "two_v1_"));
        check_box(sec0, "two_v0_density_0003.df3\" interpolate", &d0, dens, M0);
        /* volumes[1]: density 0.25, its albedo, Henyey-Greenstein g = -0.4, heat as emission */
        CHECK_CONTAINS(sec1, "density { density_file df3 \"two_v1_density_0003.df3\" interpolate 1 }");
        CHECK_CONTAINS(sec1, "density { density_file df3 \"two_v1_emission_0003.df3\" interpolate 1 }");
        snprintf(want, sizeof want, "scattering { 5, rgb <%.9g, %.9g, %.9g> eccentricity %.9g extinction 1 }",
                 0.1f * s1, 0.6f * s1, 0.3f * s1, (double)-0.4f);
        CHECK_CONTAINS(sec1, want);
        snprintf(want, sizeof want, "absorption rgb <%.9g, %.9g, %.9g>", (1.0 - 0.1f) * s1, (1.0 - 0.6f) * s1,
                 (1.0 - 0.3f) * s1);
        CHECK_CONTAINS(sec1, want);
        snprintf(want, sizeof want, "emission rgb <%.9g, %.9g, %.9g>", 1.0f * se, 0.5f * se, 0.25f * se);
        CHECK_CONTAINS(sec1, want);
        CHECK(!strstr(sec1, "two_v0_"));
        check_box(sec1, "two_v1_density_0003.df3\" interpolate", &d1, dens, M1);
        check_box(sec1, "two_v1_emission_0003.df3\" interpolate", &e1, heat, M1);
    }
    free(inc);
free_df3:
    vsd_df3_free(&d0);
    vsd_df3_free(&d1);
    vsd_df3_free(&e1);
done:
    vsd_volume_destroy(dens);
    vsd_volume_destroy(heat);
}

/* volumes[1] reads its file at frame + frame_offset; the df3 names keep the scene frame. */
static void check_frame_offset(void)
{
    char json[4096], err[2048], dir[1100], path[1300], file[1100], want[1200];
    vsd_scene sc;
    vsd_pov_export_options opt;
    vsd_pov_export_report rep;
    vsd_volume *f5, *f8;
    vsd_df3 a, b;
    char *inc;
    snprintf(file, sizeof file, "%s", test_data("smoke64/fluid_data_####.vdb"));
    snprintf(json, sizeof json,
             "{\"version\":1,\"volumes\":[{\"file\":\"%s\"},"
             "{\"file\":\"%s\",\"frame_offset\":3,\"matrix\":[1,0,0,3, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]}",
             file, file);
    CHECK_MSG(vsd_scene_parse(json, "", NULL, 0, &sc, err, sizeof err) == VSD_OK, "%s", err);
    snprintf(dir, sizeof dir, "%s", test_tmp("pov_frame_offset"));
    memset(&opt, 0, sizeof opt);
    opt.name = "off";
    opt.first = opt.last = 5;
    CHECK_MSG(vsd_pov_export(&sc, &opt, dir, &rep, err, sizeof err) == VSD_OK, "%s", err);
    f5 = load(test_data("smoke64/fluid_data_0005.vdb"), "density");
    f8 = load(test_data("smoke64/fluid_data_0008.vdb"), "density");
    if (f5 && f8) {
        snprintf(path, sizeof path, "%s/off_v0_density_0005.df3", dir);
        check_df3_file(path, f5, &a);
        vsd_df3_free(&a);
        snprintf(path, sizeof path, "%s/off_v1_density_0005.df3", dir);
        check_df3_file(path, f8, &b);
        vsd_df3_free(&b);
        /* the two frames differ, so the check above tells them apart */
        CHECK(vsd_df3_from_volume(f5, &a, err, sizeof err) == VSD_OK);
        CHECK(a.scale != b.scale || a.size[0] != b.size[0] || a.size[2] != b.size[2] ||
              memcmp(a.data, b.data, 2 * (size_t)a.size[0] * a.size[1] * a.size[2]) != 0);
        vsd_df3_free(&a);
    }
    snprintf(path, sizeof path, "%s/off_0005.inc", dir);
    inc = slurp(path);
    CHECK_MSG(inc != NULL, "%s missing", path);
    if (inc) {
        snprintf(want, sizeof want, "fluid_data_0005.vdb (frame 5)\n");
        CHECK_CONTAINS(inc, want);
        snprintf(want, sizeof want, "fluid_data_0008.vdb (frame 8)\n");
        CHECK_CONTAINS(inc, want);
        free(inc);
    }
    vsd_volume_destroy(f5);
    vsd_volume_destroy(f8);
}

/* Boxes that would coincide get containers that do not: POV-Ray keeps only one medium
 * of coinciding containers (docs/povray.md). Two volumes of one grid in one place, the
 * second with that grid as its emission too: three boxes on one df3 placement. Each
 * container holds the df3's unit cube (its density is 0 outside), the first is the cube,
 * and no two share a face plane (at least 1e-3 world units apart on every side). */
static void check_coincident_boxes(void)
{
    char json[4096], err[2048], dir[1100], path[1300], file[1100];
    vsd_scene sc;
    vsd_pov_export_options opt;
    vsd_pov_export_report rep;
    double wlo[3][3], whi[3][3];
    const char *p;
    char *inc;
    int n = 0, i, j, a;
    snprintf(file, sizeof file, "%s", test_data("external/usd_densityAndHeat.vdb"));
    snprintf(json, sizeof json,
             "{\"version\":1,\"volumes\":[{\"file\":\"%s\",\"matrix\":[0.5,0,0,1, 0,0.5,0,2, 0,0,0.5,3, 0,0,0,1]},"
             "{\"file\":\"%s\",\"emission_grid\":\"density\",\"matrix\":[0.5,0,0,1, 0,0.5,0,2, 0,0,0.5,3, 0,0,0,1],"
             "\"medium\":{\"emission_strength\":2}}]}",
             file, file);
    CHECK_MSG(vsd_scene_parse(json, "", NULL, 0, &sc, err, sizeof err) == VSD_OK, "%s", err);
    snprintf(dir, sizeof dir, "%s", test_tmp("pov_coincident"));
    memset(&opt, 0, sizeof opt);
    opt.name = "co";
    opt.first = opt.last = 1;
    CHECK_MSG(vsd_pov_export(&sc, &opt, dir, &rep, err, sizeof err) == VSD_OK, "%s", err);
    snprintf(path, sizeof path, "%s/co_0001.inc", dir);
    inc = slurp(path);
    CHECK_MSG(inc != NULL, "%s missing", path);
    if (!inc) return;
    for (p = strstr(inc, "  box { <"); p && n < 3; p = strstr(p + 1, "  box { <"), n++) {
        double lo[3], hi[3], m[16];
        CHECK(sscanf(p, "  box { <%lf, %lf, %lf>, <%lf, %lf, %lf>", &lo[0], &lo[1], &lo[2], &hi[0], &hi[1], &hi[2]) == 6);
        CHECK(parse_box_matrix(p, "box", m));
        for (a = 0; a < 3; a++) {
            CHECK(lo[a] <= 0 && hi[a] >= 1);
            if (n == 0) CHECK(lo[a] == 0 && hi[a] == 1);
        }
        /* the matrices are diagonal with positive scales here: world bounds are the mapped corners */
        for (a = 0; a < 3; a++) {
            wlo[n][a] = m[a * 4] * lo[0] + m[a * 4 + 1] * lo[1] + m[a * 4 + 2] * lo[2] + m[a * 4 + 3];
            whi[n][a] = m[a * 4] * hi[0] + m[a * 4 + 1] * hi[1] + m[a * 4 + 2] * hi[2] + m[a * 4 + 3];
        }
    }
    CHECK_MSG(n == 3, "%d boxes in %s", n, path);
    for (i = 0; i < n; i++)
        for (j = i + 1; j < n; j++)
            for (a = 0; a < 3; a++) {
                CHECK_MSG(fabs(wlo[i][a] - wlo[j][a]) >= 1e-3 && fabs(whi[i][a] - whi[j][a]) >= 1e-3,
                          "boxes %d and %d share a face on axis %d: %.9g/%.9g, %.9g/%.9g", i, j, a, wlo[i][a],
                          wlo[j][a], whi[i][a], whi[j][a]);
                /* grown by at most a few voxels (0.35 world units each here) */
                CHECK(wlo[j][a] >= wlo[0][a] - 3 && whi[j][a] <= whi[0][a] + 3);
            }
    free(inc);
}

/* A load error of one volume names it and its file (once), and keeps the loader's reason. */
static void check_volume_errors(void)
{
    char json[4096], err[2048], dir[1100], file[1100], want[1300];
    const char *p;
    vsd_scene sc;
    vsd_pov_export_options opt;
    vsd_pov_export_report rep;
    snprintf(file, sizeof file, "%s", test_data("external/usd_densityAndHeat.vdb"));
    snprintf(dir, sizeof dir, "%s", test_tmp("pov_volume_errors"));
    memset(&opt, 0, sizeof opt);
    opt.name = "bad";
    opt.first = opt.last = 1;
    /* a missing file */
    snprintf(json, sizeof json, "{\"version\":1,\"volumes\":[{\"file\":\"%s\"},{\"file\":\"/nonexistent-dir/x.vdb\"}]}",
             file);
    CHECK_MSG(vsd_scene_parse(json, "", NULL, 0, &sc, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(vsd_pov_export(&sc, &opt, dir, &rep, err, sizeof err) != VSD_OK);
    CHECK_CONTAINS(err, "volumes[1] (/nonexistent-dir/x.vdb): ");
    CHECK(!rep.output_error);
    /* a missing grid: the loader's message (it names the grid) without its path again */
    snprintf(json, sizeof json,
             "{\"version\":1,\"volumes\":[{\"file\":\"%s\"},{\"file\":\"%s\",\"grid\":\"nosuch\"}]}", file, file);
    CHECK_MSG(vsd_scene_parse(json, "", NULL, 0, &sc, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(vsd_pov_export(&sc, &opt, dir, &rep, err, sizeof err) == VSD_ERR_NOT_FOUND);
    snprintf(want, sizeof want, "volumes[1] (%s): ", sc.volumes[1].file);
    CHECK_MSG(strncmp(err, want, strlen(want)) == 0, "'%s' should start with '%s'", err, want);
    CHECK_CONTAINS(err, "nosuch");
    p = strstr(err, sc.volumes[1].file);
    CHECK(p && !strstr(p + 1, sc.volumes[1].file));
    /* volumes[0]'s emission grid missing: index 0 named */
    snprintf(json, sizeof json,
             "{\"version\":1,\"volumes\":[{\"file\":\"%s\",\"emission_grid\":\"nosuch_heat\","
             "\"medium\":{\"emission_strength\":1}},{\"file\":\"%s\"}]}",
             file, file);
    CHECK_MSG(vsd_scene_parse(json, "", NULL, 0, &sc, err, sizeof err) == VSD_OK, "%s", err);
    CHECK(vsd_pov_export(&sc, &opt, dir, &rep, err, sizeof err) == VSD_ERR_NOT_FOUND);
    snprintf(want, sizeof want, "volumes[0] (%s): ", sc.volumes[0].file);
    CHECK_MSG(strncmp(err, want, strlen(want)) == 0, "'%s' should start with '%s'", err, want);
    CHECK_CONTAINS(err, "nosuch_heat");
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
    check_two_volumes();
    check_frame_offset();
    check_coincident_boxes();
    check_volume_errors();
    /* an empty grid: a valid 2x2x2 file of zeros, scale 0 */
    CHECK(vsd_volume_create_empty(NULL, &empty, err, sizeof err) == VSD_OK);
    CHECK(vsd_df3_from_volume(empty, &d, err, sizeof err) == VSD_OK);
    CHECK(d.size[0] == 2 && d.size[1] == 2 && d.size[2] == 2 && d.scale == 0 && d.data && d.data[7] == 0);
    vsd_df3_free(&d);
    vsd_volume_destroy(empty);
    vsd_volume_destroy(vol);
    return test_finish("test_pov_df3");
}
