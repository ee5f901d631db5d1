/* The CUDA backend's entry points in a build without nvcc: the library stays complete,
 * `render.device = cuda` fails with a clear error and `auto` uses the CPU. Only
 * vsd_cuda_open can be reached (nothing else runs without an open vsd_cuda). */
#include "device/cuda/cuda_backend.h"

int vsd_cuda_built(void) { return 0; }

vsd_status vsd_cuda_open(vsd_cuda **out, char *err, size_t errlen)
{
    *out = NULL;
    return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen, "this vsd was built without CUDA (no nvcc at build time)");
}

void vsd_cuda_close(vsd_cuda *c) { (void)c; }
const char *vsd_cuda_device_name(const vsd_cuda *c) { (void)c; return "none"; }
size_t vsd_cuda_resident_bytes(const vsd_cuda *c) { (void)c; return 0; }
uint64_t vsd_cuda_uploaded_bytes(const vsd_cuda *c) { (void)c; return 0; }
void vsd_cuda_seconds(const vsd_cuda *c, double *passes, double *downloads) { (void)c; *passes = *downloads = 0.0; }
void vsd_cuda_set_method(vsd_cuda *c, const char *method) { (void)c; (void)method; }

static vsd_status absent(char *err, size_t errlen)
{
    return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen, "this vsd was built without CUDA");
}

vsd_status vsd_cuda_upload(vsd_cuda *c, vsd_cuda_slot slot, uint64_t key, const void *host, size_t bytes,
                           void **dev, char *err, size_t errlen)
{
    (void)c; (void)slot; (void)key; (void)host; (void)bytes;
    *dev = NULL;
    return absent(err, errlen);
}

vsd_status vsd_cuda_scratch(vsd_cuda *c, vsd_cuda_slot slot, uint64_t key, size_t bytes, int zero, void **dev,
                            char *err, size_t errlen)
{
    (void)c; (void)slot; (void)key; (void)bytes; (void)zero;
    *dev = NULL;
    return absent(err, errlen);
}

vsd_status vsd_cuda_download(vsd_cuda *c, void *host, const void *dev, size_t bytes, char *err, size_t errlen)
{
    (void)c; (void)host; (void)dev; (void)bytes;
    return absent(err, errlen);
}

vsd_status vsd_cuda_run_pass(vsd_cuda *c, const struct vsd_device_pass *pass, const void *m,
                             const vsd_kernel_data *kd, vsd_pass_args a, int items, void *out, size_t out_bytes,
                             const vsd_cuda_progress *p, char *err, size_t errlen)
{
    (void)c; (void)pass; (void)m; (void)kd; (void)a; (void)items; (void)out; (void)out_bytes; (void)p;
    return absent(err, errlen);
}

vsd_status vsd_cuda_distance_map(vsd_cuda *c, const vsd_kvolume *kv, float threshold, uint8_t *skip_host,
                                 long long *occupied, char *err, size_t errlen)
{
    (void)c; (void)kv; (void)threshold; (void)skip_host; (void)occupied;
    return absent(err, errlen);
}
