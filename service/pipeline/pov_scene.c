/* NAME_camera.inc, NAME.pov and NAME.ini of `vsd export pov` (pov_export.h). */
#include "pov_export.h"
#include "pov_camera.h"
#include "pov_file.h"
#include <math.h>
#include <stdio.h>
#include <string.h>

static vsd_status write_camera(const vsd_scene *sc, const char *path, char *err, size_t errlen)
{
    vsd_pov_file pf;
    vsd_status st = vsd_pov_file_open(&pf, path, err, errlen);
    if (st) return st;
    vsd_pov_write_camera(pf.f, sc);
    return vsd_pov_file_commit(&pf, err, errlen);
}

/* A demo scene: the camera, the frame's volume, a sun that the smoke shadows and a floor
 * to catch the shadow. Switches (povray Declare=NAME=1): vsd_alpha_only (volume only,
 * no light: the coverage test, fast), vsd_no_floor, vsd_plate (the volume casts its
 * shadow but is not seen: a plate for `vsd composite`), vsd_depth_pass (floor only, with
 * vsd_depth_texture: a depth plate for `vsd composite --plate-depth`). */
static vsd_status write_pov(const vsd_scene *sc, const vsd_pov_export_options *opt, const char *name,
                            double floor_z, const double centre[3], double extent, const char *path,
                            char *err, size_t errlen)
{
    vsd_pov_file pf;
    vsd_status st = vsd_pov_file_open(&pf, path, err, errlen);
    double c[3] = {centre[0], centre[2], centre[1]}, sun[3];
    /* a map's average is not known here: a neutral grey stands in for it */
    static const float grey[3] = {0.05f, 0.05f, 0.05f};
    const float *bg = sc->environment.file[0] ? grey : sc->environment.color;
    double bgs = sc->environment.file[0] ? 1.0 : sc->environment.strength;
    FILE *f;
    if (st) return st;
    f = pf.f;
    /* the sun comes from above, behind the camera's left shoulder (POV-Ray axes): its
     * shadow falls on the floor beside and behind the volume, where the camera sees it */
    {
        const double *m = sc->camera.matrix;
        double back[3] = {m[2], m[10], m[6]}, right[3] = {m[0], m[8], m[4]};  /* POV axes */
        double d[3] = {back[0] - 0.6 * right[0], 0, back[2] - 0.6 * right[2]}, len;
        len = sqrt(d[0] * d[0] + d[2] * d[2]);
        if (len < 1e-9) d[0] = 1, len = 1;
        d[0] /= len, d[2] /= len, d[1] = 1.3;
        len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int a = 0; a < 3; a++) sun[a] = c[a] + 20.0 * extent * d[a] / len;
    }
    fprintf(f, "// vsd export pov: frames %d-%d. Render from this folder: povray %s.ini\n"
               "// (or povray %s.pov +W%d +H%d +FE +UA Declare=vsd_frame=%d). docs/povray.md\n"
               "#version 3.7;\n"
               "global_settings { assumed_gamma 1.0 max_trace_level 16 }\n"
               "#include \"%s_camera.inc\"\n"
               "#ifndef (vsd_frame)\n"
               "  #if (clock_on)\n    #declare vsd_frame = frame_number;\n"
               "  #else\n    #declare vsd_frame = %d;\n  #end\n#end\n",
            opt->first, opt->last, name, name, sc->film.width, sc->film.height, opt->first, name, opt->first);
    fprintf(f, "// vsd's environment does not light POV-Ray media; with +UA the background is\n"
               "// transparent in the output anyway (transmit 1: POV-Ray's +UA alpha reads it).\n"
               "background { rgbt <%.6g, %.6g, %.6g, 1> }\n",
            bg[0] * bgs, bg[1] * bgs, bg[2] * bgs);
    fprintf(f, "#ifndef (vsd_depth_pass)\n"
               "  #include concat(\"%s_\", str(vsd_frame, -4, 0), \".inc\")\n"
               "  // vsd_plate: the volume shadows the floor but is not seen (no_image), for\n"
               "  // `vsd composite` to put vsd's own render of it on top\n"
               "  object { vsd_volume\n    #ifdef (vsd_plate) no_image #end\n  }\n"
               "#end\n",
            name);
    fprintf(f, "#ifndef (vsd_alpha_only)\n"
               "  #ifndef (vsd_depth_pass)\n"
               "    // media_attenuation on: the smoke shadows what this light reaches\n"
               "    light_source { <%.9g, %.9g, %.9g> rgb 1.5 parallel point_at <%.9g, %.9g, %.9g>\n"
               "                   media_interaction on media_attenuation on }\n"
               "  #end\n"
               "  #ifndef (vsd_no_floor)\n"
               "    // the floor under the volume (Blender z = %.9g); POV-Ray's y is Blender's z\n"
               "    plane { y, %.9g\n"
               "      #ifdef (vsd_depth_pass) texture { vsd_depth_texture }\n"
               "      #else pigment { checker rgb 0.6 rgb 0.4 scale %.9g } finish { ambient 0.1 diffuse 0.8 }\n"
               "      #end\n"
               "    }\n"
               "  #end\n"
               "#end\n",
            sun[0], sun[1], sun[2], c[0], c[1], c[2], floor_z, floor_z, extent > 0 ? extent / 4 : 1.0);
    return vsd_pov_file_commit(&pf, err, errlen);
}

static vsd_status write_ini(const vsd_scene *sc, const vsd_pov_export_options *opt, const char *name,
                            const char *path, char *err, size_t errlen)
{
    vsd_pov_file pf;
    vsd_status st = vsd_pov_file_open(&pf, path, err, errlen);
    if (st) return st;
    fprintf(pf.f,
            "; vsd export pov: render frames %d-%d with `povray %s.ini` from this folder.\n"
            "; POV-Ray names the outputs %s_pov_<frame>.exr, the frame number padded to the\n"
            "; width of Final_Frame. EXR with alpha (+FE +UA): the plate for `vsd composite`.\n"
            "Input_File_Name=%s.pov\n"
            "Initial_Frame=%d\n"
            "Final_Frame=%d\n"
            "Width=%d\n"
            "Height=%d\n"
            "Output_File_Type=E\n"
            "Output_Alpha=on\n"
            "Output_File_Name=%s_pov_\n"
            "Antialias=off\n",
            opt->first, opt->last, name, name, name, opt->first, opt->last, sc->film.width, sc->film.height, name);
    return vsd_pov_file_commit(&pf, err, errlen);
}

vsd_status vsd_pov_export_scene_files(const vsd_scene *sc, const vsd_pov_export_options *opt, double floor_z,
                                      const double centre[3], double extent, const char *outdir,
                                      vsd_pov_export_report *rep, char *err, size_t errlen)
{
    const char *name = opt->name && opt->name[0] ? opt->name : "vsd";
    char path[1024];
    vsd_status st;
    snprintf(path, sizeof path, "%s/%s_camera.inc", outdir, name);
    if ((st = write_camera(sc, path, err, errlen))) return st;
    snprintf(rep->pov, sizeof rep->pov, "%s/%s.pov", outdir, name);
    if ((st = write_pov(sc, opt, name, floor_z, centre, extent, rep->pov, err, errlen))) return st;
    snprintf(rep->ini, sizeof rep->ini, "%s/%s.ini", outdir, name);
    return write_ini(sc, opt, name, rep->ini, err, errlen);
}
