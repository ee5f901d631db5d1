#include "vsd/compare.h"
#include <math.h>

vsd_status vsd_block_rel_rmse(const float *a, const float *b, int width, int height, int channels,
                              int stride, int block, double *rel_rmse, char *err, size_t errlen)
{
    int bw = block > 0 ? width / block : 0, bh = block > 0 ? height / block : 0;
    int bx, by, c, x, y;
    double se = 0, ref = 0, n = 0;
    if (bw == 0 || bh == 0 || channels < 1 || stride < channels)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "compare: a %dx%d image has no whole %dx%d block",
                        width, height, block, block);
    for (by = 0; by < bh; by++)
        for (bx = 0; bx < bw; bx++)
            for (c = 0; c < channels; c++) {
                double sa = 0, sb = 0;
                for (y = by * block; y < (by + 1) * block; y++)
                    for (x = bx * block; x < (bx + 1) * block; x++) {
                        size_t i = ((size_t)y * width + x) * stride + c;
                        sa += a[i];
                        sb += b[i];
                    }
                sa /= block * block;
                sb /= block * block;
                se += (sa - sb) * (sa - sb);
                ref += fabs(sb);
                n += 1;
            }
    if (ref <= 0)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "compare: the reference image is black");
    *rel_rmse = sqrt(se / n) / (ref / n);
    return VSD_OK;
}
