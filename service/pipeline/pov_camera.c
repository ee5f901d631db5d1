/* vsd's camera and axes in POV-Ray's terms (pov_camera.h). */
#include "pov_camera.h"
#include <math.h>
#include <string.h>

void vsd_pov_from_blender(const double b[3], double p[3])
{
    double t[3] = {b[0], b[2], b[1]};
    memcpy(p, t, sizeof t);
}

void vsd_pov_print_matrix(FILE *f, const double m[16])
{
    /* POV-Ray: p' = p.x*<a,b,c> + p.y*<d,e,f> + p.z*<g,h,i> + <j,k,l>, i.e. the columns of
     * our column-vector matrix, then its translation column. */
    fprintf(f, "matrix <%.17g, %.17g, %.17g,\n        %.17g, %.17g, %.17g,\n        %.17g, %.17g, %.17g,\n"
               "        %.17g, %.17g, %.17g>",
            m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10], m[3], m[7], m[11]);
}

static void print_vec(FILE *f, const char *name, const double v[3], const char *comment)
{
    fprintf(f, "#declare %s = <%.17g, %.17g, %.17g>;  // %s\n", name, v[0], v[1], v[2], comment);
}

void vsd_pov_write_camera(FILE *f, const vsd_scene *sc)
{
    const double *m = sc->camera.matrix;
    double bl[4][3], pv[4][3];
    int ortho = sc->camera.type == VSD_CAMERA_ORTHOGRAPHIC, c, a;
    /* columns of camera-to-world: right (+X), up (+Y), back (+Z), position; the matrix
     * carries no scale (the scene loader removes it), normalise anyway */
    for (c = 0; c < 4; c++) {
        double len = 0;
        for (a = 0; a < 3; a++) bl[c][a] = m[a * 4 + c];
        if (c == 2)
            for (a = 0; a < 3; a++) bl[c][a] = -bl[c][a];  /* forward = -back */
        if (c < 3) {
            for (a = 0; a < 3; a++) len += bl[c][a] * bl[c][a];
            len = sqrt(len);
            for (a = 0; a < 3; a++) bl[c][a] /= len;
        }
        vsd_pov_from_blender(bl[c], pv[c]);
    }
    fprintf(f, "// Camera exported by vsd (docs/povray.md). Blender (x, y, z) = POV-Ray <x, z, y>.\n"
               "// vsd: camera looks down its -Z, +Y up, %s spans the larger image dimension.\n",
            ortho ? "ortho_scale" : "the field of view");
    if (ortho)
        fprintf(f, "// ortho_scale %.17g; film %dx%d when exported.\n", sc->camera.ortho_scale, sc->film.width,
                sc->film.height);
    else
        fprintf(f, "// fov %.17g rad (%.9g deg); film %dx%d when exported.\n", sc->camera.fov,
                sc->camera.fov * 180.0 / M_PI, sc->film.width, sc->film.height);
    fprintf(f, "// Not mapped: clip_start %g, clip_end %g (POV-Ray has no clipping planes).\n",
            sc->camera.clip_start, sc->camera.clip_end);
    print_vec(f, "vsd_cam_location", pv[3], "Blender position, axes swapped");
    print_vec(f, "vsd_cam_direction", pv[2], "forward (Blender -Z of the camera), unit");
    print_vec(f, "vsd_cam_right", pv[0], "image right (camera +X), unit");
    print_vec(f, "vsd_cam_up", pv[1], "image up (camera +Y), unit");
    if (ortho)
        fprintf(f, "#declare vsd_cam_half = %.17g;  // half of ortho_scale: world half width across the larger side\n",
                0.5 * sc->camera.ortho_scale);
    else
        fprintf(f, "#declare vsd_cam_half = %.17g;  // tan(fov/2): half width at distance 1 across the larger side\n",
                tan(0.5 * sc->camera.fov));
    fprintf(f,
            "// vsd's rule for any +W/+H: the larger side gets vsd_cam_half, the other the same\n"
            "// per-pixel scale (square pixels).\n"
            "#if (image_width >= image_height)\n"
            "  #declare vsd_cam_half_w = vsd_cam_half;\n"
            "  #declare vsd_cam_half_h = vsd_cam_half * image_height / image_width;\n"
            "#else\n"
            "  #declare vsd_cam_half_h = vsd_cam_half;\n"
            "  #declare vsd_cam_half_w = vsd_cam_half * image_width / image_height;\n"
            "#end\n"
            "camera {\n"
            "  %s\n"
            "  location vsd_cam_location\n"
            "  direction vsd_cam_direction\n"
            "  right (2 * vsd_cam_half_w) * vsd_cam_right\n"
            "  up (2 * vsd_cam_half_h) * vsd_cam_up\n"
            "}\n"
            "// Distance along the view ray as colour (R = G = B = metres, as vsd's Depth pass), no light:\n"
            "// put it on your surfaces for a depth plate (`vsd composite --plate-depth`).\n"
            "// The colour_map is linear in the pattern, exact below 1e6 m.\n"
            "// (functions take no vector components: the numbers go in as scalars)\n"
            "#declare vsd_cam_lx = vsd_cam_location.x; #declare vsd_cam_ly = vsd_cam_location.y;\n"
            "#declare vsd_cam_lz = vsd_cam_location.z;\n"
            "#declare vsd_cam_dx = vsd_cam_direction.x; #declare vsd_cam_dy = vsd_cam_direction.y;\n"
            "#declare vsd_cam_dz = vsd_cam_direction.z;\n"
            "#declare vsd_depth_texture = texture {\n"
            "  pigment {\n"
            "    function { %s / 1e6 }\n"
            "    color_map { [0 rgb 0] [1 rgb 1e6] }\n"
            "  }\n"
            "  finish { ambient 0 diffuse 0 specular 0 reflection 0 emission 1 }\n"
            "}\n",
            ortho ? "orthographic" : "perspective",
            ortho ? "((x - vsd_cam_lx) * vsd_cam_dx + (y - vsd_cam_ly) * vsd_cam_dy + (z - vsd_cam_lz) * vsd_cam_dz)"
                  : "sqrt(pow(x - vsd_cam_lx, 2) + pow(y - vsd_cam_ly, 2) + pow(z - vsd_cam_lz, 2))");
}
