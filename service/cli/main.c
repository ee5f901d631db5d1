/* vsd — one executable, git-style subcommands. */
#include "commands.h"
#include "serve.h"
#include "vsd/render.h"
#include <stdio.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "usage: vsd <command> [options]\n"
            "\n"
            "commands:\n"
            "  render SCENE.json   render frames of a scene file to multilayer EXR (and a PNG preview)\n"
            "  info FILE.vdb       list the grids of OpenVDB files\n"
            "  compare A.exr B.exr relative RMSE of every pass of A against B (block-averaged)\n"
            "  methods [--json]    the rendering methods and their render.options (type, range, default)\n"
            "  export pov SCENE    write POV-Ray df3 grids, media/camera .inc, .pov and .ini\n"
            "  composite V P OUT   put vsd's volume EXR over a background plate EXR\n"
            "  farm slurm|status   render a sequence on Slurm (job-array script); frames done/missing\n"
            "  serve               run the render daemon (Unix socket; see docs/protocol.md)\n"
            "  version             print the version\n"
            "\n"
            "`vsd <command> --help` describes a command. Exit codes: 0 ok, 1 render or write failed,\n"
            "2 bad command line, 3 bad input (scene, VDB, environment), 130 interrupted.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return VSD_EXIT_USAGE;
    }
    if (strcmp(argv[1], "render") == 0) return vsd_cmd_render(argc - 1, argv + 1);
    if (strcmp(argv[1], "info") == 0) return vsd_cmd_info(argc - 1, argv + 1);
    if (strcmp(argv[1], "compare") == 0) return vsd_cmd_compare(argc - 1, argv + 1);
    if (strcmp(argv[1], "methods") == 0) return vsd_cmd_methods(argc - 1, argv + 1);
    if (strcmp(argv[1], "export") == 0) return vsd_cmd_export(argc - 1, argv + 1);
    if (strcmp(argv[1], "composite") == 0) return vsd_cmd_composite(argc - 1, argv + 1);
    if (strcmp(argv[1], "farm") == 0) return vsd_cmd_farm(argc - 1, argv + 1);
    if (strcmp(argv[1], "serve") == 0) return vsd_cmd_serve(argc - 1, argv + 1);
    if (strcmp(argv[1], "version") == 0 || strcmp(argv[1], "--version") == 0) {
        printf("vsd %s\n", vsd_version());
        return VSD_EXIT_OK;
    }
    if (strcmp(argv[1], "help") == 0 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        usage(stdout);
        return VSD_EXIT_OK;
    }
    fprintf(stderr, "vsd: unknown command '%s'\n\n", argv[1]);
    usage(stderr);
    return VSD_EXIT_USAGE;
}
