/* `vsd export pov SCENE.json [--frames A-B] OUTDIR`: the scene's volume, camera and
 * medium as POV-Ray files (service/pipeline/pov_export.h, docs/povray.md). */
#include "commands.h"
#include "frame_range.h"
#include "pov_export.h"
#include "vsd/scene.h"
#include <stdio.h>
#include <string.h>

#define MAX_SETS 64

static void export_usage(FILE *to)
{
    fputs("usage: vsd export pov SCENE.json [--frames A-B] [--name NAME] [--set key=value]... OUTDIR\n"
          "  Writes NAME_density_####.df3 (and NAME_emission_####.df3), NAME_####.inc per frame,\n"
          "  NAME_camera.inc, NAME.pov and NAME.ini into OUTDIR (created if missing).\n"
          "  --frames A-B   frames to export (default: the scene's frames.start-end)\n"
          "  --name NAME    file name prefix (default: the scene file's name without .json)\n"
          "  --set k=v      scene override, as for vsd render\n"
          "Then: cd OUTDIR && povray NAME.ini   (docs/povray.md)\n",
          to);
}

/* "dir/smoke.json" -> "smoke", keeping only characters the exporter accepts. */
static void stem(const char *path, char *out, size_t len)
{
    const char *b = strrchr(path, '/'), *dot;
    size_t n, i, o = 0;
    b = b ? b + 1 : path;
    dot = strrchr(b, '.');
    n = dot && dot != b ? (size_t)(dot - b) : strlen(b);
    for (i = 0; i < n && o + 1 < len; i++) {
        char c = b[i];
        int ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '.';
        out[o++] = ok ? c : '_';
    }
    out[o] = '\0';
    if (!o) snprintf(out, len, "vsd");
}

int vsd_cmd_export(int argc, char **argv)
{
    const char *scene_path = NULL, *outdir = NULL, *frames = NULL, *name = NULL;
    const char *sets[MAX_SETS];
    int nsets = 0, i;
    char err[2048], namebuf[128];
    vsd_scene sc;
    vsd_pov_export_options opt;
    vsd_pov_export_report rep;
    vsd_status st;
    if (argc < 2 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0) {
        export_usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? VSD_EXIT_USAGE : VSD_EXIT_OK;
    }
    if (strcmp(argv[1], "pov") != 0) {
        fprintf(stderr, "vsd export: unknown format '%s' (available: pov)\n", argv[1]);
        return VSD_EXIT_USAGE;
    }
    for (i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            export_usage(stdout);
            return VSD_EXIT_OK;
        } else if (strcmp(a, "--frames") == 0 || strcmp(a, "--name") == 0 || strcmp(a, "--set") == 0) {
            if (i + 1 >= argc) {
                fprintf(stderr, "vsd export: %s needs a value\n", a);
                return VSD_EXIT_USAGE;
            }
            if (a[2] == 'f') frames = argv[++i];
            else if (a[2] == 'n') name = argv[++i];
            else if (nsets < MAX_SETS) sets[nsets++] = argv[++i];
            else {
                fprintf(stderr, "vsd export: more than %d --set\n", MAX_SETS);
                return VSD_EXIT_USAGE;
            }
        } else if (a[0] == '-' && a[1]) {
            fprintf(stderr, "vsd export: unknown option '%s'\n", a);
            export_usage(stderr);
            return VSD_EXIT_USAGE;
        } else if (!scene_path) scene_path = a;
        else if (!outdir) outdir = a;
        else {
            fprintf(stderr, "vsd export: unexpected argument '%s'\n", a);
            return VSD_EXIT_USAGE;
        }
    }
    if (!scene_path || !outdir) {
        fprintf(stderr, "vsd export pov: need SCENE.json and OUTDIR\n");
        export_usage(stderr);
        return VSD_EXIT_USAGE;
    }
    if ((st = vsd_scene_load(scene_path, sets, nsets, &sc, err, sizeof err))) {
        fprintf(stderr, "vsd export: %s\n", err);
        return VSD_EXIT_INPUT;
    }
    memset(&opt, 0, sizeof opt);
    opt.first = sc.frames.start;
    opt.last = sc.frames.end;
    if (frames && vsd_parse_frame_range(frames, &opt.first, &opt.last, err, sizeof err) != 0) {
        fprintf(stderr, "vsd export: --frames: %s\n", err);
        return VSD_EXIT_USAGE;
    }
    if (!name) {
        stem(scene_path, namebuf, sizeof namebuf);
        name = namebuf;
    }
    opt.name = name;
    st = vsd_pov_export(&sc, &opt, outdir, &rep, err, sizeof err);
    if (st) {
        fprintf(stderr, "vsd export: %s\n", err);
        if (st == VSD_ERR_INVALID && !rep.output_error && strstr(err, "name '")) return VSD_EXIT_USAGE;
        return rep.output_error || st == VSD_ERR_NOMEM ? VSD_EXIT_RENDER_FAILED : VSD_EXIT_INPUT;
    }
    printf("exported frames %d-%d to %s: %s, %s, %s_camera.inc, %d frame include(s)\n", opt.first, opt.last, outdir,
           rep.pov, rep.ini, name, rep.frames);
    if (rep.negative_voxels)
        fprintf(stderr, "vsd export: warning: %llu negative voxels written as 0\n",
                (unsigned long long)rep.negative_voxels);
    printf("render: cd %s && povray %s.ini\n", outdir, name);
    return VSD_EXIT_OK;
}
