/* `vsd info FILE [FILE...]`: what each OpenVDB file holds, one block per grid, so users
 * can pick `grid` / `emission_grid` for a scene; and for a scene file, every volume of its
 * `volumes` list: the file it reads at the scene's first frame, the grids it uses, their
 * voxels and bounds in the world (through the volume's matrix), and its medium. Every file
 * is reported even when an earlier one fails; the exit status says whether all could be
 * read. */
#include "commands.h"

#include "vsd/scene.h"
#include "vsd/vdbio.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void info_usage(FILE *to)
{
    fputs("usage: vsd info FILE.vdb|SCENE.json [FILE...]\n"
          "\n"
          "Print the grids of OpenVDB files: index (for files whose grids share a name),\n"
          "name, value type, active voxels, index and world bounding boxes, voxel size,\n"
          "half-float storage and compression. The world box is that of the active\n"
          "voxels' cells (index min - 1/2 .. max + 1/2) through the grid's transform.\n"
          "\n"
          "For a scene file (a JSON object), print each of its volumes: the VDB file it\n"
          "reads at the scene's first frame (frame_offset applied), its density, emission\n"
          "and refractive-index grids with their active voxels, its world bounding box\n"
          "(the density grid's world box through volume.matrix), and its medium; then\n"
          "the box around all volumes.\n"
          "\n"
          "Exit status: 0 ok, 2 bad command line, 3 a file could not be read (a scene\n"
          "that does not load, or a volume's file or grid that is missing).\n",
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

/* A scene file is JSON: its first character (after a UTF-8 byte-order mark and white
 * space) is '{'. A VDB file starts with its magic number; a file that cannot be read goes
 * to the VDB reader, whose message names it. */
static int is_scene_file(const char *path)
{
    unsigned char buf[256];
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    size_t n = fread(buf, 1, sizeof buf, f), i = 0;
    fclose(f);
    if (n >= 3 && buf[0] == 0xEF && buf[1] == 0xBB && buf[2] == 0xBF)
        i = 3;
    while (i < n && (buf[i] == ' ' || buf[i] == '\t' || buf[i] == '\r' || buf[i] == '\n'))
        i++;
    return i < n && buf[i] == '{';
}

/* The grid the renderer reads for a selection: index >= 0 picks the n-th grid; a name the
 * first grid of that name; no name the first float grid. NULL when there is none. */
static const vsd_grid_info *find_grid(const vsd_grid_info *grids, int count, const char *name, int index,
                                      int *at)
{
    for (int i = 0; i < count; ++i) {
        int match = index >= 0 ? i == index : name[0] ? !strcmp(grids[i].name, name) : !strcmp(grids[i].type, "float");
        if (match) {
            *at = i;
            return &grids[i];
        }
    }
    return NULL;
}

static int bbox_empty(const double lo[3], const double hi[3])
{
    return lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2];
}

/* The box around the 8 corners of [lo, hi] through the row-major affine matrix m. */
static void transform_bbox(const double m[16], const double lo[3], const double hi[3], double out_lo[3],
                           double out_hi[3])
{
    for (int k = 0; k < 3; ++k) {
        out_lo[k] = 1e300;
        out_hi[k] = -1e300;
    }
    for (int c = 0; c < 8; ++c) {
        double p[3] = {(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]};
        for (int r = 0; r < 3; ++r) {
            double w = m[r * 4 + 0] * p[0] + m[r * 4 + 1] * p[1] + m[r * 4 + 2] * p[2] + m[r * 4 + 3];
            if (w < out_lo[r]) out_lo[r] = w;
            if (w > out_hi[r]) out_hi[r] = w;
        }
    }
}

static int is_identity(const double m[16])
{
    for (int i = 0; i < 16; ++i)
        if (m[i] != (i % 5 == 0 ? 1.0 : 0.0))
            return 0;
    return 1;
}

static void print_box(const char *label, const double lo[3], const double hi[3])
{
    if (bbox_empty(lo, hi))
        printf("    %-15s empty\n", label);
    else
        printf("    %-15s [%.7g %.7g %.7g] .. [%.7g %.7g %.7g]\n", label, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
}

/* One of a volume's grids: "density   grid 1 "density", float, 3456 active voxels". Returns
 * the grid, or NULL after printing why it is missing (then *bad is set). */
static const vsd_grid_info *print_volume_grid(const char *label, const vsd_grid_info *grids, int count,
                                              const char *name, int index, int *bad)
{
    int at = -1;
    const vsd_grid_info *g = find_grid(grids, count, name, index, &at);
    if (!g) {
        if (index >= 0)
            printf("    %-15s grid %d: not in the file (it has %d grid%s)\n", label, index, count, count == 1 ? "" : "s");
        else if (name[0])
            printf("    %-15s \"%s\": not in the file\n", label, name);
        else
            printf("    %-15s no float grid in the file\n", label);
        *bad = 1;
        return NULL;
    }
    printf("    %-15s grid %d \"%s\", %s, %llu active voxels\n", label, at, g->name, g->type,
           (unsigned long long)g->active_voxels);
    return g;
}

/* Volume v of a scene at scene frame `frame`. Returns 0 when its file and grids were read;
 * grows the scene's box by this volume's. */
static int print_scene_volume(const vsd_scene *sc, int v, int frame, double all_lo[3], double all_hi[3])
{
    const vsd_scene_volume *vol = &sc->volumes[v];
    const vsd_scene_medium *m = &vol->medium;
    int vframe = vsd_scene_volume_frame(vol, frame), bad = 0;
    char path[VSD_PATH_LEN + 32], err[1024];
    vsd_grid_info *grids = NULL;
    int count = 0;

    printf("  volume %d: ", v);
    if (vsd_frame_path(vol->file, vframe, path, sizeof path, err, sizeof err) != VSD_OK) {
        printf("%s\n", vol->file);
        fprintf(stderr, "vsd info: volumes[%d].file: %s\n", v, err);
        return 1;
    }
    printf("%s\n", path);
    if (vol->frame_offset)
        printf("    %-15s %d (scene frame %d, frame_offset %d)\n", "file frame", vframe, frame, vol->frame_offset);
    if (vsd_vdb_list(path, &grids, &count, err, sizeof err) != VSD_OK) {
        printf("    %-15s does not read (see the error)\n", "grids");
        fprintf(stderr, "vsd info: volumes[%d]: %s\n", v, err);
        bad = 1;
    } else {
        const vsd_grid_info *d = print_volume_grid("density grid", grids, count, vol->grid, vol->grid_index, &bad);
        if (vol->emission_grid[0])
            print_volume_grid("emission grid", grids, count, vol->emission_grid, -1, &bad);
        const char *ior = vsd_scene_ior_grid(vol);
        if (ior[0])
            print_volume_grid("ior grid", grids, count, ior, -1, &bad);
        if (d) {
            double lo[3], hi[3];
            if (d->index_bbox_min[0] > d->index_bbox_max[0] || bbox_empty(d->world_bbox_min, d->world_bbox_max)) {
                printf("    %-15s empty (no active voxels)\n", "world bbox");
            } else {
                transform_bbox(vol->matrix, d->world_bbox_min, d->world_bbox_max, lo, hi);
                if (!is_identity(vol->matrix))
                    print_box("grid bbox", d->world_bbox_min, d->world_bbox_max);
                print_box("world bbox", lo, hi);
                for (int k = 0; k < 3; ++k) {
                    if (lo[k] < all_lo[k]) all_lo[k] = lo[k];
                    if (hi[k] > all_hi[k]) all_hi[k] = hi[k];
                }
            }
            printf("    %-15s %.7g %.7g %.7g\n", "voxel size", d->voxel_size[0], d->voxel_size[1], d->voxel_size[2]);
        }
        if (bad) {
            fputs("    grids in the file:", stdout);
            for (int i = 0; i < count; ++i)
                printf("%s %d \"%s\" (%s)", i ? "," : "", i, grids[i].name, grids[i].type);
            putchar('\n');
            fprintf(stderr, "vsd info: volumes[%d]: %s: a grid the scene names is not in the file\n", v, path);
        }
        vsd_vdb_list_free(grids);
    }
    if (!is_identity(vol->matrix))
        for (int r = 0; r < 3; ++r)
            printf("    %-15s %.7g %.7g %.7g %.7g\n", r ? "" : "matrix", vol->matrix[r * 4], vol->matrix[r * 4 + 1],
                   vol->matrix[r * 4 + 2], vol->matrix[r * 4 + 3]);
    printf("    %-15s density %.7g, albedo %.7g %.7g %.7g, anisotropy %.7g\n", "medium", m->density, m->albedo[0],
           m->albedo[1], m->albedo[2], m->anisotropy);
    printf("    %-15s emission %.7g %.7g %.7g x %.7g, ior %.7g%s%s\n", "", m->emission_color[0],
           m->emission_color[1], m->emission_color[2], m->emission_strength, m->ior,
           strcmp(m->ior_from, "none") ? ", ior_from " : "", strcmp(m->ior_from, "none") ? m->ior_from : "");
    return bad;
}

/* Returns 0 when the scene and every volume's file and grids were read, 1 after printing
 * what failed. */
static int print_scene(const char *path)
{
    vsd_scene *sc = malloc(sizeof *sc); /* large (16 volumes' paths): not on the stack */
    char err[2048];
    int failed = 0, frame;
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    if (!sc) {
        fprintf(stderr, "vsd info: %s: out of memory\n", path);
        return 1;
    }
    if (vsd_scene_load(path, NULL, 0, sc, err, sizeof err) != VSD_OK) {
        fprintf(stderr, "vsd info: %s\n", err);
        free(sc);
        return 1;
    }
    frame = sc->frames.start;
    printf("%s: scene, %d volume%s, frame %d", path, sc->volume_count, sc->volume_count == 1 ? "" : "s", frame);
    if (sc->frames.end != sc->frames.start)
        printf(" (frames %d..%d)", sc->frames.start, sc->frames.end);
    putchar('\n');
    for (int v = 0; v < sc->volume_count; ++v)
        failed |= print_scene_volume(sc, v, frame, lo, hi);
    if (sc->volume_count > 1) {
        printf("  all volumes:\n");
        print_box("world bbox", lo, hi);
    }
    free(sc);
    return failed;
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
        failed += is_scene_file(argv[i]) ? print_scene(argv[i]) : print_file(argv[i]);
    }
    if (files == 0) {
        fputs("vsd info: no file given\n", stderr);
        info_usage(stderr);
        return VSD_EXIT_USAGE;
    }
    fflush(stdout);
    return failed ? VSD_EXIT_INPUT : VSD_EXIT_OK;
}
