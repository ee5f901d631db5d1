/* A part per volume for the record-grid methods (method_parts.h). */
#include "method_parts.h"
#include "src/grids/record_grid.h"
#include "src/grids/volume_groups.h"
#include "kernel/kernel_record_grid.h"
#include <stdio.h>
#include <xxhash.h>
#include <stdlib.h>
#include <string.h>

void vsd_part_ctx(const vsd_frame_ctx *ctx, const vsd_method_parts *p, int i, vsd_frame_ctx *out)
{
    *out = *ctx;
    out->kd.density = ctx->kd.volumes[i].density;
    out->kd.emission = ctx->kd.volumes[i].emission;
    out->kd.medium = ctx->kd.volumes[i].medium;
    out->density = ctx->volume_density[i];
    out->emission = ctx->volume_emission[i];
    out->info = NULL;
    out->info_len = 0;
    out->part.active = 1;
    out->part.volume = i;
    out->part.group = p->group[i];
    /* the part's frame-stage arrays are as old as its own frame stage */
    if (p->frame_gen[i]) out->frame_gen = p->frame_gen[i];
}

uint32_t vsd_ctx_group(const vsd_frame_ctx *ctx)
{
    return ctx->part.active ? ctx->part.group : 1u;
}

/* a part's error, prefixed with its volume */
static vsd_status part_failed(vsd_status st, int volume, char *err, size_t errlen)
{
    char why[512];
    snprintf(why, sizeof why, "%s", err);
    return vsd_fail(st, err, errlen, "volumes[%d]: %s", volume, why);
}

void vsd_parts_free(vsd_method_parts *p, const vsd_method *m)
{
    int i;
    for (i = 0; i < p->count; i++) m->destroy(p->state[i]);
    free(p->state);
    memset(p, 0, sizeof *p);
}

/* What part i's frame stage reads: its group and the frame inputs of the volumes `reads`
 * names (vsd_method_parts, frame_key). */
static uint64_t frame_key(const vsd_method_parts *p, vsd_part_reads_fn reads, const vsd_frame_ctx *pc, int i)
{
    uint32_t mask = reads ? reads(pc) : ~0u;
    uint64_t words[3 + 2 * VSD_KMAX_VOLUMES], key;
    size_t n = 0;
    int j;
    words[n++] = (uint64_t)pc->kd.volume_count;
    words[n++] = p->group[i];
    words[n++] = (uint64_t)(uintptr_t)pc->cuda;   /* a dropped device: its arrays are gone */
    for (j = 0; j < pc->kd.volume_count && j < VSD_KMAX_VOLUMES; j++)
        if ((mask >> j) & 1u) {
            words[n++] = (uint64_t)j;
            words[n++] = pc->volume_key[j];
        }
    key = XXH3_64bits(words, n * sizeof *words);
    return key ? key : 1;   /* 0 is "not prepared" */
}

vsd_status vsd_parts_prepare_frame(vsd_method_parts *p, const vsd_method *m, const void *options,
                                   vsd_part_reads_fn reads, vsd_frame_ctx *ctx, char *err, size_t errlen)
{
    int i, n = ctx->kd.volume_count;
    vsd_status st;
    if (p->count != n) {
        vsd_parts_free(p, m);
        if (!(p->state = calloc((size_t)n, sizeof *p->state)))
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory for %d volumes", m->name, n);
        for (; p->count < n; p->count++)
            if ((st = m->create(&p->state[p->count], ctx->scene, options, err, errlen))) return st;
    }
    vsd_volume_groups(&ctx->kd, p->group);
    p->frame_ran = 1;
    p->reframed = 0;
    for (i = 0; i < n; i++) {
        vsd_frame_ctx pc;
        uint64_t key;
        vsd_part_ctx(ctx, p, i, &pc);
        key = frame_key(p, reads, &pc, i);
        if (key == p->frame_key[i]) continue;   /* nothing its frame stage reads changed */
        p->frame_key[i] = 0;                     /* until this part's frame stage succeeds */
        p->frame_gen[i] = pc.frame_gen = ctx->frame_gen;
        if (m->prepare_frame && (st = m->prepare_frame(p->state[i], &pc, err, errlen)))
            return part_failed(st, i, err, errlen);
        p->frame_key[i] = key;
        p->reframed++;
    }
    return VSD_OK;
}

/* What part i's lighting reads beyond the frame stage (vsd_method_parts, light_key). */
static uint64_t light_key(const vsd_method_parts *p, const vsd_frame_ctx *ctx, int i)
{
    const vsd_kernel_data *kd = &ctx->kd;
    const vsd_scene *sc = ctx->scene;
    XXH3_state_t *h = XXH3_createState();
    uint64_t key;
    int j;
    if (!h) return 0;   /* 0 never matches a stored key: the part is lit */
    XXH3_64bits_reset(h);
    XXH3_64bits_update(h, &ctx->env_gen, sizeof ctx->env_gen);
    XXH3_64bits_update(h, &sc->environment.strength, sizeof sc->environment.strength);
    XXH3_64bits_update(h, &sc->environment.rotation_z, sizeof sc->environment.rotation_z);
    XXH3_64bits_update(h, &sc->environment.interpolation, sizeof sc->environment.interpolation);
    XXH3_64bits_update(h, &kd->scene_light_count, sizeof kd->scene_light_count);
    if (kd->scene_light_count > 0)
        XXH3_64bits_update(h, kd->scene_lights, sizeof(float) * VSD_KLIGHT_FLOATS * (size_t)kd->scene_light_count);
    for (j = 0; j < kd->volume_count; j++) {
        const vsd_kmedium *md = &kd->volumes[j].medium;
        float f[8] = {md->albedo.x, md->albedo.y, md->albedo.z, md->anisotropy,
                      md->emission.x, md->emission.y, md->emission.z, (float)md->has_emission};
        if (!p->materials_of_all && !((p->group[i] >> j) & 1u)) continue;
        XXH3_64bits_update(h, &j, sizeof j);
        XXH3_64bits_update(h, f, sizeof f);
    }
    key = XXH3_64bits_digest(h);
    XXH3_freeState(h);
    return key ? key : 1;
}

vsd_status vsd_parts_prepare_lighting(vsd_method_parts *p, const vsd_method *m, vsd_frame_ctx *ctx, char *err,
                                      size_t errlen)
{
    int i;
    vsd_status st;
    p->relit = 0;
    if (!p->frame_ran) p->reframed = 0;   /* a lighting edit alone */
    for (i = 0; i < p->count; i++) {
        vsd_frame_ctx pc;
        uint64_t key = light_key(p, ctx, i);
        if (!p->frame_ran && key == p->light_key[i]) continue;   /* nothing it reads changed */
        p->light_key[i] = 0;   /* until this part's lighting succeeds */
        vsd_part_ctx(ctx, p, i, &pc);
        if (m->prepare_lighting && (st = m->prepare_lighting(p->state[i], &pc, err, errlen))) {
            p->frame_ran = 1;   /* a failed stage leaves the next one to light every part */
            return part_failed(st, i, err, errlen);
        }
        p->light_key[i] = key;
        p->relit++;
    }
    p->frame_ran = 0;
    return VSD_OK;
}

vsd_status vsd_parts_render(const vsd_method_parts *p, vsd_part_view_fn view, vsd_frame_ctx *ctx,
                            vsd_framebuffer *fb, int n, double step, double stop, const vsd_view_sampling *vs,
                            int *samples, char *err, size_t errlen)
{
    vsd_frame_ctx *pc = calloc((size_t)p->count, sizeof *pc);
    vsd_krecord_grid *grids = calloc((size_t)p->count, sizeof *grids);
    vsd_status st = VSD_OK;
    int i, records = 0, groups = 0;
    if (!pc || !grids) st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d volumes", p->count);
    for (i = 0; i < p->count && st == VSD_OK; i++) {
        vsd_part_ctx(ctx, p, i, &pc[i]);
        if ((st = view(p->state[i], &pc[i], &grids[i], err, errlen))) st = part_failed(st, i, err, errlen);
        records += grids[i].record_count;
        groups += (p->group[i] & ((1u << i) - 1u)) == 0;   /* counted at its first member */
    }
    if (st == VSD_OK && ctx->info && ctx->info_len)
        snprintf(ctx->info, ctx->info_len, "volumes=%d groups=%d records=%d reframed=%d relit=%d", p->count, groups,
                 records, p->reframed, p->relit);
    if (st == VSD_OK)
        st = vsd_record_grids_render(ctx, fb, grids, p->count, n, step, stop, vs, samples, err, errlen);
    free(pc);
    free(grids);
    return st;
}
