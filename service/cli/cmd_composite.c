/* `vsd composite VOLUME.exr PLATE.exr OUT.exr`: vsd's premultiplied volume over a
 * background plate, e.g. POV-Ray's +FE +UA output (service/pipeline/composite.h). */
#include "commands.h"
#include "composite.h"
#include <stdio.h>
#include <string.h>

static void composite_usage(FILE *to)
{
    fputs("usage: vsd composite VOLUME.exr PLATE.exr OUT.exr [--plate-depth DEPTH.exr] [--no-depth]\n"
          "  OUT = VOLUME's Combined over PLATE (premultiplied), plus VOLUME's passes.\n"
          "  PLATE: R, G, B[, A] channels (POV-Ray +FE +UA) or a <layer>.Combined pass.\n"
          "  Where VOLUME has Depth and PLATE a Z channel (or --plate-depth, channel Z or R),\n"
          "  the nearer side wins per pixel; --no-depth always puts the volume in front.\n",
          to);
}

int vsd_cmd_composite(int argc, char **argv)
{
    const char *files[3] = {NULL, NULL, NULL};
    int nfiles = 0, i;
    vsd_composite_options opt;
    vsd_composite_report rep;
    char err[2048];
    vsd_status st;
    memset(&opt, 0, sizeof opt);
    for (i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            composite_usage(stdout);
            return VSD_EXIT_OK;
        } else if (strcmp(a, "--plate-depth") == 0) {
            if (i + 1 >= argc) {
                fprintf(stderr, "vsd composite: --plate-depth needs a file\n");
                return VSD_EXIT_USAGE;
            }
            opt.plate_depth = argv[++i];
        } else if (strcmp(a, "--no-depth") == 0) {
            opt.no_depth = 1;
        } else if (a[0] == '-' && a[1]) {
            fprintf(stderr, "vsd composite: unknown option '%s'\n", a);
            composite_usage(stderr);
            return VSD_EXIT_USAGE;
        } else if (nfiles < 3) {
            files[nfiles++] = a;
        } else {
            fprintf(stderr, "vsd composite: unexpected argument '%s'\n", a);
            return VSD_EXIT_USAGE;
        }
    }
    if (nfiles != 3) {
        composite_usage(stderr);
        return VSD_EXIT_USAGE;
    }
    st = vsd_composite_files(files[0], files[1], files[2], &opt, &rep, err, sizeof err);
    if (st) {
        fprintf(stderr, "vsd composite: %s\n", err);
        return rep.output_error ? VSD_EXIT_RENDER_FAILED : VSD_EXIT_INPUT;
    }
    printf("%s: %dx%d, layer %s, passes %s; plate %s; %s\n", files[2], rep.width, rep.height, rep.layer, rep.passes,
           rep.plate_channels,
           rep.by_depth ? "by depth" : "volume over plate (no depth on both sides)");
    if (rep.by_depth) printf("plate nearer than the volume's Depth (or the volume empty) at %ld pixels\n", rep.plate_wins);
    return VSD_EXIT_OK;
}
