/* The loader child's reply format (loader_wire.h). One copy per array on each side
 * (write into the pipe, read straight into the parent's final allocation); the parent
 * allocates nothing before the sizes it reads are checked against the child's own memory
 * limit, and rejects a volume whose brick slots point outside the voxel pool or whose
 * values or ranges are not finite (the renderer would read out of bounds or never stop). */
#define _GNU_SOURCE
#include "loader_wire.h"
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define WIRE_MAGIC "VSDLOAD1"
#define WIRE_END "VSDLEND1"

typedef struct wire_head {
    char magic[8];
    int32_t kind;         /* VSDD_WIRE_* */
    char code[32];        /* error code (VSD_E_*) when kind == VSDD_WIRE_ERROR */
    char msg[2048];
} wire_head;

/* The codes a child may report; anything else becomes "internal". */
static const char *known_code(const char *code)
{
    static const char *const codes[] = {VSD_E_INPUT, VSD_E_LIMIT, VSD_E_INVALID_SCENE, VSD_E_INTERNAL};
    size_t i;
    for (i = 0; i < sizeof codes / sizeof codes[0]; i++)
        if (strcmp(code, codes[i]) == 0) return codes[i];
    return VSD_E_INTERNAL;
}

static int put(int fd, const void *p, size_t n) { return n && vsd_proto_write_full(fd, p, n) ? -1 : 0; }

static int put_head(int fd, int kind, const vsdd_err *e)
{
    wire_head h;
    memset(&h, 0, sizeof h);
    memcpy(h.magic, WIRE_MAGIC, 8);
    h.kind = kind;
    if (e) {
        snprintf(h.code, sizeof h.code, "%s", e->code ? e->code : VSD_E_INTERNAL);
        snprintf(h.msg, sizeof h.msg, "%s", e->msg);
    }
    return put(fd, &h, sizeof h);
}

int vsdd_wire_put_error(int fd, const vsdd_err *e) { return put_head(fd, VSDD_WIRE_ERROR, e); }

static size_t cell_count(const vsd_volume *v)
{
    return (size_t)v->brick_dims[0] * (size_t)v->brick_dims[1] * (size_t)v->brick_dims[2];
}

int vsdd_wire_put_volume(int fd, const vsd_volume *v)
{
    size_t cells = cell_count(v);
    return put_head(fd, VSDD_WIRE_VOLUME, NULL) || put(fd, v, sizeof *v) ||
                   put(fd, v->brick_slots, cells * sizeof *v->brick_slots) ||
                   put(fd, v->voxels, (size_t)v->brick_count * VSD_BRICK_VOXELS * sizeof(float)) ||
                   put(fd, v->brick_min, cells * sizeof(float)) || put(fd, v->brick_max, cells * sizeof(float)) ||
                   put(fd, WIRE_END, 8)
               ? -1
               : 0;
}

int vsdd_wire_put_env(int fd, const vsd_env *env)
{
    return put_head(fd, VSDD_WIRE_ENV, NULL) || put(fd, env, sizeof *env) ||
                   put(fd, env->rgb, (size_t)env->width * (size_t)env->height * 3 * sizeof(float)) ||
                   put(fd, WIRE_END, 8)
               ? -1
               : 0;
}

/* ---- the parent's side ----------------------------------------------------------------- */

static int get(vsdd_wire_in *in, void *buf, size_t n)
{
    unsigned char *p = buf;
    while (n > 0) {
        struct pollfd pfd = {in->fd, POLLIN, 0};
        double left = in->deadline - vsd_clock_seconds();
        ssize_t got;
        int r;
        if (left <= 0) {
            in->timed_out = 1;
            return -1;
        }
        r = poll(&pfd, 1, (int)(left * 1000) + 1);
        if (r < 0 && errno == EINTR) continue;
        if (r == 0) continue; /* the deadline check above decides */
        if (r < 0) {
            in->short_read = 1;
            return -1;
        }
        got = read(in->fd, p, n);
        if (got < 0 && (errno == EINTR || errno == EAGAIN)) continue;
        if (got <= 0) {
            in->short_read = 1;
            return -1;
        }
        p += got;
        n -= (size_t)got;
    }
    return 0;
}

static int malformed(vsdd_wire_in *in, const char *why)
{
    snprintf(in->why, sizeof in->why, "%s", why);
    return -1;
}

static int all_finite(const float *f, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(f[i])) return 0;
    return 1;
}

static int get_volume(vsdd_wire_in *in, vsd_volume **out)
{
    vsd_volume head, *v;
    size_t cells, i, voxels;
    char end[8], err[512];
    int k;
    if (get(in, &head, sizeof head)) return -1;
    for (k = 0; k < 3; k++)
        if (head.brick_dims[k] < 0 || head.brick_dims[k] > (1 << 22)) return malformed(in, "brick grid size");
    cells = cell_count(&head);
    if (head.brick_count < 0 || (size_t)head.brick_count > cells) return malformed(in, "brick count");
    voxels = (size_t)head.brick_count * VSD_BRICK_VOXELS;
    if ((uint64_t)cells * 12 > in->max_bytes || (uint64_t)voxels * 4 > in->max_bytes)
        return malformed(in, "larger than the loader's memory limit");
    v = calloc(1, sizeof *v);
    if (!v) return malformed(in, "out of memory");
    memcpy(v, &head, sizeof *v);
    v->brick_slots = NULL, v->voxels = NULL, v->brick_min = NULL, v->brick_max = NULL;
    v->grid_name[sizeof v->grid_name - 1] = '\0';
    v->file[sizeof v->file - 1] = '\0';
    /* the same allocation vsd_volume_destroy frees (one malloc per array) */
    if (cells) {
        v->brick_slots = malloc(cells * sizeof *v->brick_slots);
        v->brick_min = malloc(cells * sizeof(float));
        v->brick_max = malloc(cells * sizeof(float));
    }
    if (voxels) v->voxels = malloc(voxels * sizeof(float));
    if ((cells && (!v->brick_slots || !v->brick_min || !v->brick_max)) || (voxels && !v->voxels)) {
        vsd_volume_destroy(v);
        return malformed(in, "out of memory");
    }
    if (get(in, v->brick_slots, cells * sizeof *v->brick_slots) || get(in, v->voxels, voxels * sizeof(float)) ||
        get(in, v->brick_min, cells * sizeof(float)) || get(in, v->brick_max, cells * sizeof(float)) ||
        get(in, end, 8)) {
        vsd_volume_destroy(v);
        return -1;
    }
    if (memcmp(end, WIRE_END, 8) != 0) {
        vsd_volume_destroy(v);
        return malformed(in, "no trailer");
    }
    for (i = 0; i < cells; i++)
        if (v->brick_slots[i] < -1 || v->brick_slots[i] >= v->brick_count) {
            vsd_volume_destroy(v);
            return malformed(in, "a brick slot outside the voxel pool");
        }
    for (k = 0; k < 16; k++)
        if (!isfinite(v->index_to_world[k])) {
            vsd_volume_destroy(v);
            return malformed(in, "a non-finite transform");
        }
    if (!all_finite(v->brick_min, cells) || !all_finite(v->brick_max, cells) || !isfinite(v->value_min) ||
        !isfinite(v->value_max) || vsd_volume_check_finite(v, err, sizeof err)) {
        vsd_volume_destroy(v);
        return malformed(in, "non-finite values");
    }
    *out = v;
    return VSDD_WIRE_VOLUME;
}

static int get_env(vsdd_wire_in *in, vsd_env **out)
{
    vsd_env head, *env;
    size_t n, i;
    char end[8];
    if (get(in, &head, sizeof head)) return -1;
    if (head.width <= 0 || head.height <= 0 || head.width > (1 << 20) || head.height > (1 << 20))
        return malformed(in, "map size");
    n = (size_t)head.width * (size_t)head.height * 3;
    if ((uint64_t)n * sizeof(float) > in->max_bytes) return malformed(in, "larger than the loader's memory limit");
    env = calloc(1, sizeof *env);
    if (!env) return malformed(in, "out of memory");
    memcpy(env, &head, sizeof *env);
    env->file[sizeof env->file - 1] = '\0';
    env->rgb = malloc(n * sizeof(float));
    if (!env->rgb) {
        vsd_env_destroy(env);
        return malformed(in, "out of memory");
    }
    if (get(in, env->rgb, n * sizeof(float)) || get(in, end, 8)) {
        vsd_env_destroy(env);
        return -1;
    }
    if (memcmp(end, WIRE_END, 8) != 0) {
        vsd_env_destroy(env);
        return malformed(in, "no trailer");
    }
    /* the loader's guarantee (env.c sanitise): finite, non-negative pixels */
    for (i = 0; i < n; i++)
        if (!(env->rgb[i] >= 0.0f) || isinf(env->rgb[i])) {
            vsd_env_destroy(env);
            return malformed(in, "negative or non-finite pixels");
        }
    *out = env;
    return VSDD_WIRE_ENV;
}

int vsdd_wire_get(vsdd_wire_in *in, vsdd_err *child_err, vsd_volume **vol, vsd_env **env)
{
    wire_head h;
    *vol = NULL;
    *env = NULL;
    if (get(in, &h, sizeof h)) return -1;
    if (memcmp(h.magic, WIRE_MAGIC, 8) != 0) return malformed(in, "bad magic");
    h.code[sizeof h.code - 1] = '\0';
    h.msg[sizeof h.msg - 1] = '\0';
    switch (h.kind) {
    case VSDD_WIRE_ERROR:
        child_err->code = known_code(h.code);
        snprintf(child_err->msg, sizeof child_err->msg, "%s", h.msg);
        return VSDD_WIRE_ERROR;
    case VSDD_WIRE_VOLUME: return get_volume(in, vol);
    case VSDD_WIRE_ENV: return get_env(in, env);
    default: return malformed(in, "unknown kind");
    }
}
