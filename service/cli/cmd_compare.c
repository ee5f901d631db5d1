/* `vsd compare A.exr B.exr`: relative RMSE of each pass of A against B (the reference)
 * after a block average — how the tests and the benchmark measure agreement. */
#include "commands.h"
#include "vsd/compare.h"
#include "vsd/image.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const channel_suffix[] = {"R", "G", "B", "A"};

/* Gather the pass's channels of `img` into an interleaved buffer; 0 when absent. */
static int gather(const vsd_exr_image *img, const char *layer, vsd_pass p, float *out)
{
    int ch = vsd_pass_channels(p), c, i, n = img->width * img->height;
    for (c = 0; c < ch; c++) {
        char name[256];
        const float *plane;
        snprintf(name, sizeof name, "%s.%s.%s", layer, vsd_pass_name(p), ch == 1 ? "Z" : channel_suffix[c]);
        plane = vsd_exr_channel(img, name);
        if (!plane) return 0;
        for (i = 0; i < n; i++) out[(size_t)i * ch + c] = plane[i];
    }
    return 1;
}

int vsd_cmd_compare(int argc, char **argv)
{
    const char *paths[2] = {NULL, NULL}, *layer = "ViewLayer";
    int block = 4, i, np = 0, rc = VSD_EXIT_OK;
    vsd_exr_image *img[2] = {NULL, NULL};
    char err[1024];
    for (i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--block") == 0 && i + 1 < argc) block = atoi(argv[++i]);
        else if (strcmp(argv[i], "--layer") == 0 && i + 1 < argc) layer = argv[++i];
        else if (strcmp(argv[i], "--help") == 0) {
            printf("usage: vsd compare A.exr REFERENCE.exr [--block K] [--layer NAME]\n"
                   "prints the relative RMSE of every pass of A against REFERENCE after a KxK block average\n");
            return VSD_EXIT_OK;
        } else if (argv[i][0] != '-' && np < 2) paths[np++] = argv[i];
        else {
            fprintf(stderr, "vsd compare: unexpected argument '%s'\n", argv[i]);
            return VSD_EXIT_USAGE;
        }
    }
    if (np != 2 || block < 1) {
        fprintf(stderr, "usage: vsd compare A.exr REFERENCE.exr [--block K] [--layer NAME]\n");
        return VSD_EXIT_USAGE;
    }
    for (i = 0; i < 2; i++)
        if (vsd_exr_read(paths[i], &img[i], err, sizeof err) != VSD_OK) {
            fprintf(stderr, "vsd compare: %s\n", err);
            rc = VSD_EXIT_INPUT;
            goto done;
        }
    if (img[0]->width != img[1]->width || img[0]->height != img[1]->height) {
        fprintf(stderr, "vsd compare: sizes differ: %dx%d vs %dx%d\n", img[0]->width, img[0]->height,
                img[1]->width, img[1]->height);
        rc = VSD_EXIT_INPUT;
        goto done;
    }
    {
        size_t n = (size_t)img[0]->width * img[0]->height * 4;
        float *a = malloc(n * sizeof(float)), *b = malloc(n * sizeof(float));
        int p;
        for (p = 0; a && b && p < VSD_PASS_COUNT; p++) {
            double e;
            int ch = vsd_pass_channels((vsd_pass)p);
            if (!gather(img[0], layer, (vsd_pass)p, a) || !gather(img[1], layer, (vsd_pass)p, b)) continue;
            if (p == VSD_PASS_DEPTH) continue; /* 1e10 marks empty pixels: not a radiance */
            /* colour passes are compared on RGB (what the bench and the docs quote); Combined's
             * alpha, which follows the transmittance, is reported on its own line */
            if (vsd_block_rel_rmse(a, b, img[0]->width, img[0]->height, ch < 3 ? ch : 3, ch, block, &e, err, sizeof err))
                printf("%-14s %s\n", vsd_pass_name((vsd_pass)p), err);
            else
                printf("%-14s rel. RMSE %.4f\n", vsd_pass_name((vsd_pass)p), e);
            if (ch == 4 && !vsd_block_rel_rmse(a + 3, b + 3, img[0]->width, img[0]->height, 1, 4, block, &e, err,
                                               sizeof err))
                printf("%-14s rel. RMSE %.4f\n", "Alpha", e);
        }
        free(a);
        free(b);
    }
done:
    vsd_exr_image_destroy(img[0]);
    vsd_exr_image_destroy(img[1]);
    return rc;
}
