#include "padded_grid.h"
#include <stdlib.h>
#include <string.h>

int vsd_padded_grid_build(vsd_padded_grid *p, const int32_t res[3], const float *values)
{
    int32_t i, j, k;
    memcpy(p->res, res, sizeof p->res);
    p->sx = (size_t)res[0] + 3;
    p->sy = p->sx * ((size_t)res[1] + 3);
    if (!(p->v = calloc(p->sy * ((size_t)res[2] + 3), sizeof *p->v))) return 0;
    for (k = 0; k < res[2]; k++)
        for (j = 0; j < res[1]; j++)
            for (i = 0; i < res[0]; i++)
                p->v[(size_t)(k + 1) * p->sy + (size_t)(j + 1) * p->sx + (size_t)(i + 1)] =
                    values[((size_t)k * res[1] + j) * res[0] + i];
    return 1;
}

void vsd_padded_grid_free(vsd_padded_grid *p)
{
    free(p->v);
    p->v = NULL;
}
