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

/* The container of the k-th box of the .inc (k = 0, 1, ... over every volume's density and
 * emission boxes): the df3's unit cube, for k > 0 grown on every side by k times half a
 * voxel, and by at least k * VSD_POV_BOX_MARGIN world units. POV-Ray 3.7 (measured)
 * keeps only one of two media containers whose surfaces coincide (to about 1e-4 units):
 * a volume whose emission grid is its density grid, or two volumes of one grid in one
 * place, would lose a medium. df3 density is 0 outside the unit cube (measured) and the
 * df3's own border voxels are 0, so the field is unchanged. m: the box's matrix. */
#define VSD_POV_BOX_MARGIN 0.002
static void write_container(FILE *f, const char *what, int k, const vsd_df3 *d, const double m[16])
{
    double lo[3], hi[3];
    int a;
    if (k == 0) {
        fprintf(f, "  box { <0, 0, 0>, <1, 1, 1>  // the df3 file's unit box: %s\n", what);
    } else {
        for (a = 0; a < 3; a++) {
            double len = sqrt(m[a] * m[a] + m[4 + a] * m[4 + a] + m[8 + a] * m[8 + a]);  /* world length of unit axis a */
            double g = 0.5 / d->size[a];
            if (len > 0 && VSD_POV_BOX_MARGIN / len > g) g = VSD_POV_BOX_MARGIN / len;
            lo[a] = -k * g;
            hi[a] = 1 + k * g;
        }
        fprintf(f, "  box { <%.9g, %.9g, %.9g>, <%.9g, %.9g, %.9g>  // the df3 file's unit box: %s,\n"
                   "    // grown (its density is 0 outside) so that no two containers coincide\n",
                lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], what);
    }
    fprintf(f, "    hollow\n    pigment { rgbt 1 }  // an invisible surface: only the media show\n");
}

static void write_transform(FILE *f, const double m[16])
{
    fprintf(f, "    // unit box -> vsd index space -> grid transform -> volume.matrix -> axis swap\n    ");
    vsd_pov_print_matrix(f, m);
    fprintf(f, "\n  }\n");
}

/* A path in a comment: control characters (a newline would end the comment) as '?'. */
static void print_comment_text(FILE *f, const char *s)
{
    for (; *s; s++) fputc((unsigned char)*s < 0x20 || *s == 0x7f ? '?' : *s, f);
}

/* The density grid's df3 in comments, each line starting with `lead` ("" or "  "). */
static void describe_density(FILE *f, const char *lead, const vsd_pov_volume_part *p)
{
    const vsd_df3 *d = p->density;
    fprintf(f, "%s// density grid '%s': df3 \"%s\", %dx%dx%d voxels from vsd index <%d, %d, %d>,\n"
               "%s//   df3 value 1 (65535) = grid value %.9g; sigma_t = medium.density %.9g * grid.\n",
            lead, p->density_grid->grid_name, p->density_df3, d->size[0], d->size[1], d->size[2], d->index_min[0],
            d->index_min[1], d->index_min[2], lead, (double)d->scale, (double)p->volume->medium.density);
    if (d->negative)
        fprintf(f, "%s//   %llu negative voxels were written as 0.\n", lead, (unsigned long long)d->negative);
}

/* One volume's boxes inside the union: density media, then emission media. */
static void write_part(FILE *f, const vsd_pov_volume_part *p, int *box)
{
    const vsd_scene_medium *md = &p->volume->medium;
    const float *al = md->albedo, *ec = md->emission_color;
    const vsd_df3 *d = p->density, *e = p->emission;
    double sigma = (double)md->density * d->scale, m[16];
    float g = md->anisotropy;
    vsd_pov_box_matrix(d, p->density_grid, p->volume->matrix, m);
    write_container(f, "density", (*box)++, d, m);
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
    fprintf(f, "        density { density_file df3 \"%s\" interpolate 1 }\n      }\n    }\n", p->density_df3);
    write_transform(f, m);
    if (e) {
        double s = (double)md->emission_strength * e->scale;
        vsd_pov_box_matrix(e, p->emission_grid, p->volume->matrix, m);
        fprintf(f, "  // emission grid '%s': df3 \"%s\", %dx%dx%d voxels from vsd index <%d, %d, %d>,\n"
                   "  //   df3 value 1 = grid value %.9g; emission = color * strength %.9g * grid.\n",
                p->emission_grid->grid_name, p->emission_df3, e->size[0], e->size[1], e->size[2], e->index_min[0],
                e->index_min[1], e->index_min[2], (double)e->scale, (double)md->emission_strength);
        write_container(f, "emission", (*box)++, e, m);
        fprintf(f, "    interior {\n      media {\n        method 3 intervals 1 samples vsd_media_samples\n");
        fprintf(f, "        emission rgb <%.9g, %.9g, %.9g>\n", ec[0] * s, ec[1] * s, ec[2] * s);
        fprintf(f, "        density { density_file df3 \"%s\" interpolate 1 }\n      }\n    }\n", p->emission_df3);
        write_transform(f, m);
    }
}

static long long voxels(const vsd_df3 *d)
{
    return (long long)d->size[0] * d->size[1] * d->size[2];
}

void vsd_pov_write_volumes(FILE *f, int frame, const vsd_pov_volume_part *parts, int count)
{
    int i, samples = 16, box = 0;
    for (i = 0; i < count; i++) {
        const vsd_df3 *d = parts[i].density, *e = parts[i].emission;
        int n = vsd_pov_default_samples(e && voxels(e) > voxels(d) ? e : d);
        if (n > samples) samples = n;
    }
    if (count == 1) {
        fprintf(f, "// vsd volume, frame %d, exported by vsd (docs/povray.md). Declares vsd_volume.\n", frame);
        describe_density(f, "", &parts[0]);
    } else
        fprintf(f, "// vsd volumes[0..%d], frame %d, exported by vsd (docs/povray.md). Declares vsd_volume,\n"
                   "// a union of every volume's boxes, each with its own media and transform.\n",
                count - 1, frame);
    fprintf(f, "// Not mapped: environment lighting (POV-Ray media scatter light_sources only),\n"
               "//   medium.ior. Override the sampling with Declare=vsd_media_samples=N.\n");
    fprintf(f, "#ifndef (vsd_media_samples)\n  #declare vsd_media_samples = %d;\n#end\n", samples);
    fprintf(f, "#declare vsd_volume = union {\n");
    for (i = 0; i < count; i++) {
        if (count > 1) {
            char path[VSD_PATH_LEN], perr[8];
            const vsd_scene_volume *v = parts[i].volume;
            int vf = vsd_scene_volume_frame(v, frame);
            fprintf(f, "  // volumes[%d]: ", parts[i].index);
            print_comment_text(f, vsd_frame_path(v->file, vf, path, sizeof path, perr, sizeof perr) ? v->file : path);
            fprintf(f, " (frame %d)\n", vf);
            describe_density(f, "  ", &parts[i]);
        }
        write_part(f, &parts[i], &box);
    }
    fprintf(f, "}\n");
}
