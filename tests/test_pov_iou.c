/* test_pov_iou A.exr CHANNEL_A B.exr CHANNEL_B MIN_IOU [THRESHOLD]: coverage masks
 * (alpha > THRESHOLD, default 0.5) of two images, their intersection over union and the
 * number of pixels where the alphas differ by more than 0.25. Exit 0 when IoU >= MIN_IOU,
 * 1 below, 2 on bad input (pipeline_povray.sh). */
#include "vsd/image.h"
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv)
{
    vsd_exr_image *a = NULL, *b = NULL;
    const float *pa, *pb;
    char err[1024];
    double min_iou, thr = argc > 6 ? atof(argv[6]) : 0.5, iou;
    long inter = 0, uni = 0, na = 0, nb = 0, far = 0, i, n;
    if (argc < 6) {
        fprintf(stderr, "usage: test_pov_iou A.exr CHANNEL B.exr CHANNEL MIN_IOU [THRESHOLD]\n");
        return 2;
    }
    min_iou = atof(argv[5]);
    if (vsd_exr_read(argv[1], &a, err, sizeof err) || vsd_exr_read(argv[3], &b, err, sizeof err)) {
        fprintf(stderr, "test_pov_iou: %s\n", err);
        return 2;
    }
    pa = vsd_exr_channel(a, argv[2]);
    pb = vsd_exr_channel(b, argv[4]);
    if (!pa || !pb || a->width != b->width || a->height != b->height) {
        fprintf(stderr, "test_pov_iou: missing channel or sizes differ\n");
        return 2;
    }
    n = (long)a->width * a->height;
    for (i = 0; i < n; i++) {
        int ia = pa[i] > thr, ib = pb[i] > thr;
        na += ia, nb += ib;
        inter += ia && ib;
        uni += ia || ib;
        far += (pa[i] - pb[i] > 0.25) || (pb[i] - pa[i] > 0.25);
    }
    iou = uni ? (double)inter / uni : 1.0;
    printf("coverage (alpha > %.2f): %ld vs %ld pixels, IoU %.4f (min %.4f); |alpha difference| > 0.25 at %ld of %ld\n",
           thr, na, nb, iou, min_iou, far, n);
    vsd_exr_image_destroy(a);
    vsd_exr_image_destroy(b);
    return iou >= min_iou && na > 0 ? 0 : 1;
}
