/* A vsd volume frame as a POV-Ray include (pov_volume.h). */
#include "pov_volume.h"
#include "pov_camera.h"
#include <math.h>
#include <string.h>

void vsd_pov_box_matrix(const vsd_df3 *d, const vsd_volume *grid, const double object_matrix[16], double out[16])
{
    static const int swap[4] = {0, 2, 1, 3};
    double box[16], m[16];
    int i, j;
    vsd_df3_box_to_index(d, box);
    vsd_mat4_mul(grid->index_to_world, box, m);  /* box -> the grid's world */
    vsd_mat4_mul(object_matrix, m, m);           /* -> vsd world (volume.matrix after the grid's) */
    /* -> POV-Ray world: swap the output rows only. The box's own axes stay x, y, z: the
     * df3 layout fixes them. */
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) out[i * 4 + j] = m[swap[i] * 4 + j];
}

int vsd_pov_default_samples(const vsd_df3 *d)
{
    double diag = sqrt((double)d->size[0] * d->size[0] + (double)d->size[1] * d->size[1] +
                       (double)d->size[2] * d->size[2]);
    int n = (int)ceil(diag);
    return n < 16 ? 16 : n > 1000 ? 1000 : n;
}

static void write_container(FILE *f, const char *what)
{
    fprintf(f, "  box { <0, 0, 0>, <1, 1, 1>  // the df3 file's unit box: %s\n", what);
    fprintf(f, "    hollow\n    pigment { rgbt 1 }  // an invisible surface: only the media show\n");
}

static void write_transform(FILE *f, const double m[16])
{
    fprintf(f, "    // unit box -> vsd index space -> grid transform -> volume.matrix -> axis swap\n    ");
    vsd_pov_print_matrix(f, m);
    fprintf(f, "\n  }\n");
}

void vsd_pov_write_volume(FILE *f, const vsd_scene *sc, int frame, const vsd_df3 *d, const vsd_volume *dg,
                          const char *dname, const vsd_df3 *e, const vsd_volume *eg, const char *ename)
{
    const float *al = sc->volumes[0].medium.albedo, *ec = sc->volumes[0].medium.emission_color;
    double sigma = (double)sc->volumes[0].medium.density * d->scale, m[16];
    float g = sc->volumes[0].medium.anisotropy;
    vsd_pov_box_matrix(d, dg, sc->volumes[0].matrix, m);
    fprintf(f, "// vsd volume, frame %d, exported by vsd (docs/povray.md). Declares vsd_volume.\n", frame);
    fprintf(f, "// density grid '%s': df3 \"%s\", %dx%dx%d voxels from vsd index <%d, %d, %d>,\n"
               "//   df3 value 1 (65535) = grid value %.9g; sigma_t = medium.density %.9g * grid.\n",
            dg->grid_name, dname, d->size[0], d->size[1], d->size[2], d->index_min[0], d->index_min[1],
            d->index_min[2], (double)d->scale, (double)sc->volumes[0].medium.density);
    if (d->negative)
        fprintf(f, "//   %llu negative voxels were written as 0.\n", (unsigned long long)d->negative);
    fprintf(f, "// Not mapped: environment lighting (POV-Ray media scatter light_sources only),\n"
               "//   medium.ior. Override the sampling with Declare=vsd_media_samples=N.\n");
    fprintf(f, "#ifndef (vsd_media_samples)\n  #declare vsd_media_samples = %d;\n#end\n",
            vsd_pov_default_samples(e && e->size[0] * e->size[1] * e->size[2] > d->size[0] * d->size[1] * d->size[2]
                                        ? e
                                        : d));
    fprintf(f, "#declare vsd_volume = union {\n");
    write_container(f, "density");
    fprintf(f, "    interior {\n      media {\n        method 3 intervals 1 samples vsd_media_samples\n");
    fprintf(f, "        // at the grid maximum: sigma_s = albedo * sigma_t, sigma_a = (1 - albedo) * sigma_t\n");
    if (g == 0.0f)
        fprintf(f, "        scattering { 1, rgb <%.9g, %.9g, %.9g> extinction 1 }  // isotropic\n",
                (double)al[0] * sigma, (double)al[1] * sigma, (double)al[2] * sigma);
    else  /* POV-Ray's type 5 is Henyey-Greenstein; eccentricity > 0 scatters forward, as g */
        fprintf(f, "        scattering { 5, rgb <%.9g, %.9g, %.9g> eccentricity %.9g extinction 1 }\n",
                (double)al[0] * sigma, (double)al[1] * sigma, (double)al[2] * sigma, (double)g);
    fprintf(f, "        absorption rgb <%.9g, %.9g, %.9g>\n", (1.0 - al[0]) * sigma, (1.0 - al[1]) * sigma,
            (1.0 - al[2]) * sigma);
    fprintf(f, "        density { density_file df3 \"%s\" interpolate 1 }\n      }\n    }\n", dname);
    write_transform(f, m);
    if (e) {
        double s = (double)sc->volumes[0].medium.emission_strength * e->scale;
        vsd_pov_box_matrix(e, eg, sc->volumes[0].matrix, m);
        fprintf(f, "  // emission grid '%s': df3 \"%s\", %dx%dx%d voxels from vsd index <%d, %d, %d>,\n"
                   "  //   df3 value 1 = grid value %.9g; emission = color * strength %.9g * grid.\n",
                eg->grid_name, ename, e->size[0], e->size[1], e->size[2], e->index_min[0], e->index_min[1],
                e->index_min[2], (double)e->scale, (double)sc->volumes[0].medium.emission_strength);
        write_container(f, "emission");
        fprintf(f, "    interior {\n      media {\n        method 3 intervals 1 samples vsd_media_samples\n");
        fprintf(f, "        emission rgb <%.9g, %.9g, %.9g>\n", ec[0] * s, ec[1] * s, ec[2] * s);
        fprintf(f, "        density { density_file df3 \"%s\" interpolate 1 }\n      }\n    }\n", ename);
        write_transform(f, m);
    }
    fprintf(f, "}\n");
}
