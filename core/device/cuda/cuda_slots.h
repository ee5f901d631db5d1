/* cuda_slots.h — the table of a vsd_cuda's resident slots (cuda_backend.h), shared by the
 * CUDA backend (cuda_context.cu) and its host emulation (tests/device_emulation), which
 * differ only in how a buffer is allocated and copied. One entry per slot descriptor used
 * so far, found by the descriptor's address and appended on its first use: no slot count
 * to raise, no numbers to keep apart. The search is linear: a renderer uses a few dozen
 * slots a few dozen times per render, which costs nothing beside a copy or a launch.
 * Plain C (static inline) so both the .cu and the emulator's .c compile it. */
#ifndef VSD_CUDA_SLOTS_H
#define VSD_CUDA_SLOTS_H
#include "cuda_backend.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct vsd_cuda_resident {
    vsd_cuda_slot slot;
    void *ptr;
    size_t bytes;      /* allocated */
    size_t used;       /* bytes the holder asked for */
    uint64_t key;
    int valid;
} vsd_cuda_resident;

typedef struct vsd_cuda_slots {
    vsd_cuda_resident *v;
    size_t n, cap;
    char method[64];   /* the last name vsd_cuda_set_method got */
} vsd_cuda_slots;

/* Slot s's entry, appended without a buffer on s's first use; NULL when host memory runs
 * out. The pointer stays valid until the next append. */
static inline vsd_cuda_resident *vsd_cuda_slots_get(vsd_cuda_slots *t, vsd_cuda_slot s)
{
    size_t i;
    for (i = 0; i < t->n; i++)
        if (t->v[i].slot == s) return &t->v[i];
    if (t->n == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 32;
        vsd_cuda_resident *v = (vsd_cuda_resident *)realloc(t->v, cap * sizeof *v);
        if (!v) return NULL;
        t->v = v;
        t->cap = cap;
    }
    memset(&t->v[t->n], 0, sizeof t->v[t->n]);
    t->v[t->n].slot = s;
    return &t->v[t->n++];
}

/* Device bytes the slots hold. */
static inline size_t vsd_cuda_slots_bytes(const vsd_cuda_slots *t)
{
    size_t i, n = 0;
    for (i = 0; i < t->n; i++) n += t->v[i].bytes;
    return n;
}

/* 1 when method (not NULL) differs from the last one named, which it then becomes: the
 * caller frees the buffers of the method slots (cuda_backend.h). */
static inline int vsd_cuda_slots_method_changed(vsd_cuda_slots *t, const char *method)
{
    if (!method || strncmp(t->method, method, sizeof t->method - 1) == 0) return 0;
    snprintf(t->method, sizeof t->method, "%s", method);
    return 1;
}

/* The VSD_ERR_NOMEM of `bytes` more for r's slot exceeding the budget ($VSD_CUDA_MAX_MB),
 * with what the slots hold now, by name. */
static inline vsd_status vsd_cuda_slots_over_budget(const vsd_cuda_slots *t, const vsd_cuda_resident *r, size_t bytes,
                                                    size_t budget, char *err, size_t errlen)
{
    char held[384] = "";
    size_t i, used = 0;
    for (i = 0; i < t->n && used < sizeof held; i++)
        if (t->v[i].bytes)
            used += (size_t)snprintf(held + used, sizeof held - used, "%s%s %.1f MiB", used ? ", " : "",
                                     t->v[i].slot->name, (double)t->v[i].bytes / (1024.0 * 1024.0));
    return vsd_fail(VSD_ERR_NOMEM, err, errlen,
                    "CUDA: %.1f MiB more device memory for %s would exceed VSD_CUDA_MAX_MB=%zu (%.1f MiB held%s%s)",
                    (double)bytes / (1024.0 * 1024.0), r->slot->name, budget >> 20,
                    (double)vsd_cuda_slots_bytes(t) / (1024.0 * 1024.0), held[0] ? ": " : "", held);
}

/* The VSD_ERR_NOMEM of a table entry that could not be added (host memory). */
static inline vsd_status vsd_cuda_slots_no_entry(vsd_cuda_slot s, char *err, size_t errlen)
{
    return vsd_fail(VSD_ERR_NOMEM, err, errlen, "CUDA: no host memory for the slot table entry of %s", s->name);
}

#endif
