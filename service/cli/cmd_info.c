/* `vsd info FILE.vdb [FILE...]`: what each OpenVDB file holds, one block per grid, so users
 * can pick `volume.grid` / `emission_grid` for a scene. Every file is reported even when an
 * earlier one fails; the exit status says whether all could be read. */
#include "commands.h"

#include "vsd/vdbio.h"

#include <stdio.h>
#include <string.h>

static void info_usage(FILE *to)
{
    fputs("usage: vsd info FILE.vdb [FILE.vdb...]\n"
          "\n"
          "Print the grids of OpenVDB files: index (for files whose grids share a name),\n"
          "name, value type, active voxels, index and world bounding boxes, voxel size,\n"
          "half-float storage and compression. The world box is that of the active\n"
          "voxels' cells (index min - 1/2 .. max + 1/2) through the grid's transform.\n"
          "\n"
          "Exit status: 0 ok, 2 bad command line, 3 a file could not be read.\n",
          to);
}

static void print_grid(int index, const vsd_grid_info *g)
{
    printf("  grid %d: %s\n", index, g->name);
    printf("    type           %s\n", g->type);
    printf("    active voxels  %llu\n", (unsigned long long)g->active_voxels);
    if (g->index_bbox_min[0] > g->index_bbox_max[0]) {
        printf("    index bbox     empty\n");
        printf("    world bbox     empty\n");
    } else {
        printf("    index bbox     [%d %d %d] .. [%d %d %d]\n", g->index_bbox_min[0],
               g->index_bbox_min[1], g->index_bbox_min[2], g->index_bbox_max[0],
               g->index_bbox_max[1], g->index_bbox_max[2]);
        printf("    world bbox     [%.7g %.7g %.7g] .. [%.7g %.7g %.7g]\n", g->world_bbox_min[0],
               g->world_bbox_min[1], g->world_bbox_min[2], g->world_bbox_max[0],
               g->world_bbox_max[1], g->world_bbox_max[2]);
    }
    printf("    voxel size     %.7g %.7g %.7g\n", g->voxel_size[0], g->voxel_size[1], g->voxel_size[2]);
    printf("    half float     %s\n", g->half_float ? "yes" : "no");
    printf("    compression    %s\n", g->compression);
}

/* Returns 0 when the file was listed, 1 after printing its error. */
static int print_file(const char *path)
{
    vsd_grid_info *grids = NULL;
    int count = 0;
    char err[1024];
    vsd_status st = vsd_vdb_list(path, &grids, &count, err, sizeof err);
    if (st != VSD_OK) {
        fprintf(stderr, "vsd info: %s\n", err);
        return 1;
    }
    printf("%s: %d grid%s\n", path, count, count == 1 ? "" : "s");
    for (int i = 0; i < count; ++i)
        print_grid(i, &grids[i]);
    vsd_vdb_list_free(grids);
    return 0;
}

int vsd_cmd_info(int argc, char **argv)
{
    int files = 0, failed = 0, options_done = 0;
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i];
        if (!options_done && (!strcmp(a, "--help") || !strcmp(a, "-h"))) {
            info_usage(stdout);
            return VSD_EXIT_OK;
        }
        if (!options_done && !strcmp(a, "--")) {
            options_done = 1;
            continue;
        }
        if (!options_done && a[0] == '-' && a[1] != '\0') {
            fprintf(stderr, "vsd info: unknown option '%s'\n", a);
            info_usage(stderr);
            return VSD_EXIT_USAGE;
        }
    }
    options_done = 0;
    for (int i = 1; i < argc; ++i) {
        if (!options_done && !strcmp(argv[i], "--")) {
            options_done = 1;
            continue;
        }
        if (files++ > 0)
            putchar('\n');
        failed += print_file(argv[i]);
    }
    if (files == 0) {
        fputs("vsd info: no file given\n", stderr);
        info_usage(stderr);
        return VSD_EXIT_USAGE;
    }
    fflush(stdout);
    return failed ? VSD_EXIT_INPUT : VSD_EXIT_OK;
}
