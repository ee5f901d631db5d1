/* libFuzzer target for the OpenVDB loader (vdbio/: the structural and tree scans, then OpenVDB): the input is a whole .vdb file.
 * It goes through what the daemon does with a PUT blob named by a scene: vsd_vdb_list (the
 * structural scan, then OpenVDB's metadata), then vsd_vdb_load of the first float grid and,
 * when there are several grids, of the last one by index. Every outcome must be a volume or
 * an error status with a message; never a crash, a sanitizer report or a huge allocation. */
#include "fuzz_file.h"
#include "vsd/vdbio.h"
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = vsd_fuzz_file(data, size);
    vsd_grid_info *grids = NULL;
    vsd_volume *vol = NULL;
    vsd_grid_select sel = {NULL, -1};
    char err[1024];
    int n = 0;
    if (!path) return 0;
    err[0] = '\0';
    if (vsd_vdb_list(path, &grids, &n, err, sizeof err) == VSD_OK) {
        /* what the daemon checks before loading: names are terminated, counts sane */
        for (int i = 0; i < n; i++)
            if (memchr(grids[i].name, '\0', sizeof grids[i].name) == NULL) __builtin_trap();
        vsd_vdb_list_free(grids);
    } else if (err[0] == '\0') {
        __builtin_trap(); /* an error must say why */
    }
    err[0] = '\0';
    if (vsd_vdb_load(path, sel, &vol, err, sizeof err) == VSD_OK) {
        if (!vol) __builtin_trap();
        vsd_volume_destroy(vol);
        vol = NULL;
    } else if (vol || err[0] == '\0') {
        __builtin_trap();
    }
    if (n > 1) {
        sel.index = n - 1;
        if (vsd_vdb_load(path, sel, &vol, err, sizeof err) == VSD_OK) vsd_volume_destroy(vol);
    }
    return 0;
}
