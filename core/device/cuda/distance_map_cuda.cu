// The distance map of Navarro et al. §4.1 on the GPU (per volume frame, as the paper does):
// voxel occupancy from the bricks, cell occupancy (a cell reads its 8 corner voxels), then
// the separable exact EDT with one thread per line, running the line transform the CPU
// runs (kernel/kernel_edt.h), and the leap radii. Same map as src/grids/distance_map.c.
#include "cuda_internal.cuh"
#include "kernel/kernel_edt.h"

// |voxel| > threshold, 0 where the brick is absent.
__global__ void vsd_cuda_occ_voxels(const int32_t *slots, const float *voxels, int3 bd, int3 dims, float threshold,
                                    uint8_t *vocc)
{
    size_t n = (size_t)dims.x * dims.y * dims.z;
    size_t i = (size_t)blockIdx.x * blockDim.x + threadIdx.x;
    if (i >= n) return;
    int x = (int)(i % dims.x), y = (int)((i / dims.x) % dims.y), z = (int)(i / ((size_t)dims.x * dims.y));
    int32_t slot = slots[((size_t)(z >> 3) * bd.y + (y >> 3)) * bd.x + (x >> 3)];
    float v = slot < 0 ? 0.0f : voxels[(size_t)slot * 512 + ((z & 7) * 8 + (y & 7)) * 8 + (x & 7)];
    vocc[i] = fabsf(v) > threshold;
}

// Cell c is occupied when a voxel of c + {0,1}^3 inside the box is; d2 starts at 0 there.
__global__ void vsd_cuda_occ_cells(const uint8_t *vocc, int3 dims, float *d2, unsigned long long *occupied)
{
    size_t n = (size_t)dims.x * dims.y * dims.z;
    size_t i = (size_t)blockIdx.x * blockDim.x + threadIdx.x;
    if (i >= n) return;
    int x = (int)(i % dims.x), y = (int)((i / dims.x) % dims.y), z = (int)(i / ((size_t)dims.x * dims.y));
    int o = 0;
    for (int dz = 0; dz < 2 && z + dz < dims.z; dz++)
        for (int dy = 0; dy < 2 && y + dy < dims.y; dy++)
            for (int dx = 0; dx < 2 && x + dx < dims.x; dx++)
                o |= vocc[((size_t)(z + dz) * dims.y + (y + dy)) * dims.x + (x + dx)];
    d2[i] = o ? 0.0f : VSD_EDT_INF;
    if (o) atomicAdd(occupied, 1ull);
}

// Lines [l0, l1) of the pass along `axis`; each thread gathers its line into scratch,
// transforms it and scatters it back.
__global__ void vsd_cuda_edt_lines(float *d2, int3 dims, int axis, int l0, int l1, float *fbuf, int32_t *vbuf,
                                   double *zbuf)
{
    int l = l0 + (int)(blockIdx.x * blockDim.x + threadIdx.x);
    if (l >= l1) return;
    int n = axis == 0 ? dims.x : (axis == 1 ? dims.y : dims.z);
    size_t stride = axis == 0 ? 1 : (axis == 1 ? (size_t)dims.x : (size_t)dims.x * dims.y), base;
    if (axis == 0) base = (size_t)l * dims.x;                                      // l = z * dims.y + y
    else if (axis == 1) base = (size_t)(l / dims.x) * dims.x * dims.y + l % dims.x; // l = z * dims.x + x
    else base = (size_t)l;                                                         // l = y * dims.x + x
    float *f = fbuf + (size_t)(l - l0) * 2 * n;
    int32_t *v = vbuf + (size_t)(l - l0) * n;
    double *z = zbuf + (size_t)(l - l0) * (n + 1);
    for (int q = 0; q < n; q++) f[q] = d2[base + q * stride];
    vsd_edt_line(f, n, f + n, v, z);
    for (int q = 0; q < n; q++) d2[base + q * stride] = f[n + q];
}

__global__ void vsd_cuda_edt_skip(const float *d2, size_t n, uint8_t *skip)
{
    size_t i = (size_t)blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n) skip[i] = vsd_edt_skip(d2[i]);
}

static unsigned blocks_for(size_t n, unsigned per) { return (unsigned)((n + per - 1) / per); }

extern "C" vsd_status vsd_cuda_distance_map(vsd_cuda *c, const vsd_kvolume *kv, float threshold, uint8_t *skip_host,
                                            long long *occupied, char *err, size_t errlen)
{
    int3 bd = make_int3(kv->dims[0], kv->dims[1], kv->dims[2]);
    int3 dims = make_int3(8 * bd.x, 8 * bd.y, 8 * bd.z);
    size_t n = (size_t)dims.x * dims.y * dims.z;
    int nmax = dims.x > dims.y ? (dims.x > dims.z ? dims.x : dims.z) : (dims.y > dims.z ? dims.y : dims.z);
    // lines per launch: bounds the scratch to batch x 20 bytes x longest axis
    size_t most_lines = (size_t)dims.x * dims.y * dims.z / (size_t)(nmax > 0 ? nmax : 1);
    const int batch = most_lines < 16384 ? (int)most_lines : 16384;
    uint8_t *vocc = NULL, *skip = NULL;
    float *d2 = NULL, *fbuf = NULL;
    int32_t *vbuf = NULL;
    double *zbuf = NULL;
    unsigned long long *count = NULL, host_count = 0;
    vsd_status st = VSD_OK;
    cudaError_t e;
    if (n == 0) return VSD_OK;
    vsd_cuda_use(c);
    {
        // the scratch below counts against the context's budget like its slots
        size_t scratch = n * (2 + sizeof(float)) + (size_t)batch * nmax * (2 * sizeof(float) + sizeof(int32_t)) +
                         (size_t)batch * (nmax + 1) * sizeof(double);
        if (c->budget && vsd_cuda_resident_bytes(c) + scratch > c->budget)
            return vsd_fail(VSD_ERR_NOMEM, err, errlen,
                            "CUDA: the distance map's %.1f MiB of scratch would exceed VSD_CUDA_MAX_MB=%zu",
                            (double)scratch / (1024.0 * 1024.0), c->budget >> 20);
    }
#define TRY(call, what) do { if ((e = (call)) != cudaSuccess) { st = vsd_cuda_fail(e, what, err, errlen); goto done; } } while (0)
    TRY(cudaMalloc((void **)&vocc, n), "allocating the distance map");
    TRY(cudaMalloc((void **)&skip, n), "allocating the distance map");
    TRY(cudaMalloc((void **)&d2, n * sizeof(float)), "allocating the distance map");
    TRY(cudaMalloc((void **)&fbuf, (size_t)batch * 2 * nmax * sizeof(float)), "allocating the distance map");
    TRY(cudaMalloc((void **)&vbuf, (size_t)batch * nmax * sizeof(int32_t)), "allocating the distance map");
    TRY(cudaMalloc((void **)&zbuf, (size_t)batch * (nmax + 1) * sizeof(double)), "allocating the distance map");
    TRY(cudaMalloc((void **)&count, sizeof *count), "allocating the distance map");
    TRY(cudaMemsetAsync(count, 0, sizeof *count, c->stream), "clearing the distance map");
    vsd_cuda_occ_voxels<<<blocks_for(n, 256), 256, 0, c->stream>>>(kv->brick_slots, kv->voxels, bd, dims, threshold,
                                                                   vocc);
    vsd_cuda_occ_cells<<<blocks_for(n, 256), 256, 0, c->stream>>>(vocc, dims, d2, count);
    for (int axis = 0; axis < 3; axis++) {
        int lines = axis == 0 ? dims.y * dims.z : (axis == 1 ? dims.x * dims.z : dims.x * dims.y);
        for (int l0 = 0; l0 < lines; l0 += batch) {
            int l1 = l0 + batch < lines ? l0 + batch : lines;
            vsd_cuda_edt_lines<<<blocks_for((size_t)(l1 - l0), 64), 64, 0, c->stream>>>(d2, dims, axis, l0, l1, fbuf,
                                                                                        vbuf, zbuf);
        }
    }
    vsd_cuda_edt_skip<<<blocks_for(n, 256), 256, 0, c->stream>>>(d2, n, skip);
    if ((st = vsd_cuda_finish(c, "distance map", err, errlen))) goto done;
    TRY(cudaMemcpyAsync(skip_host, skip, n, cudaMemcpyDeviceToHost, c->stream), "copying the distance map");
    TRY(cudaMemcpyAsync(&host_count, count, sizeof host_count, cudaMemcpyDeviceToHost, c->stream),
        "copying the distance map");
    if ((st = vsd_cuda_finish(c, "copying the distance map", err, errlen))) goto done;
    *occupied = (long long)host_count;
#undef TRY
done:
    cudaFree(vocc); cudaFree(skip); cudaFree(d2); cudaFree(fbuf); cudaFree(vbuf); cudaFree(zbuf); cudaFree(count);
    return st;
}
