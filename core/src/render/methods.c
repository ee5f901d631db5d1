/* The method registry: one table, so the CLI, the daemon's HELLO and the option checks
 * all list the same methods. */
#include "method.h"
#include "device/cpu/cpu_tiles.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>

static const vsd_method *const registry[] = { &vsd_method_reference, &vsd_method_raymarch, &vsd_method_shgrid,
                                                &vsd_method_constellation, &vsd_method_crm, &vsd_method_lbl };
#define REGISTRY_COUNT (sizeof registry / sizeof registry[0])

const char *const *vsd_method_names(void)
{
    static const char *names[REGISTRY_COUNT + 1];
    size_t i;
    for (i = 0; i < REGISTRY_COUNT; i++) names[i] = registry[i]->name;
    names[REGISTRY_COUNT] = NULL;
    return names;
}

const vsd_method *vsd_method_find(const char *name)
{
    size_t i;
    for (i = 0; i < REGISTRY_COUNT; i++)
        if (strcmp(registry[i]->name, name) == 0) return registry[i];
    return NULL;
}

vsd_status vsd_method_check_lights(const vsd_method *m, const vsd_scene *sc, char *err, size_t errlen)
{
    char which[256] = "";
    size_t i;
    if (sc->light_count == 0) return VSD_OK;
    if (sc->medium.ior != 1.0f || vsd_scene_ior_grid(sc)[0])
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                        "lights: extra lights through a refracting medium (medium.ior, volume.ior_grid) are not "
                        "supported yet: a bent ray cannot be aimed at a point or a sun");
    if (m->scene_lights) return VSD_OK;
    for (i = 0; i < REGISTRY_COUNT; i++)
        if (registry[i]->scene_lights)
            snprintf(which + strlen(which), sizeof which - strlen(which), "%s%s", which[0] ? ", " : "",
                     registry[i]->name);
    return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                    "lights: method '%s' does not render extra lights (sun, point, spot); %s do", m->name, which);
}

vsd_status vsd_method_parse_options(const vsd_method *m, const vsd_scene *scene, void **options, char *err,
                                    size_t errlen)
{
    /* at least one byte, so a method without options still gets a pointer to free */
    void *o = calloc(1, m->options.struct_size ? m->options.struct_size : 1);
    vsd_status st;
    *options = NULL;
    if (!o) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    st = vsd_options_parse(&m->options, m->name, scene->render.options_json, o, err, errlen);
    if (st) {
        free(o);
        return st;
    }
    *options = o;
    return VSD_OK;
}

char *vsd_method_options_json(void)
{
    cJSON *root = cJSON_CreateObject();
    char *text;
    size_t i;
    for (i = 0; root && i < REGISTRY_COUNT; i++)
        cJSON_AddItemToObject(root, registry[i]->name, (cJSON *)vsd_options_table_json(&registry[i]->options));
    text = root ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    return text;
}

static void fill_job(vsd_tile_job *job, const vsd_frame_ctx *ctx, int width, int height,
                     void (*fn)(void *, int, int, int, int), void *user, const char *stage)
{
    memset(job, 0, sizeof *job);
    job->width = width;
    job->height = height;
    job->threads = ctx->threads;
    job->fn = fn;
    job->user = user;
    job->stage = stage;
    job->progress = ctx->progress;
    job->progress_user = ctx->user;
    job->progress_span = 1.0f;
    job->cancel = ctx->cancel;
}

void vsd_method_tile_job(vsd_tile_job *job, const vsd_frame_ctx *ctx, const vsd_framebuffer *fb,
                         void (*fn)(void *, int, int, int, int), void *user, const char *stage)
{
    fill_job(job, ctx, fb->width, fb->height, fn, user, stage);
    job->spread = 1;   /* the progress follows the work (cpu_tiles.h) */
}

void vsd_method_item_job(vsd_tile_job *job, const vsd_frame_ctx *ctx, int count,
                         void (*fn)(void *, int, int, int, int), void *user, const char *stage)
{
    fill_job(job, ctx, count, 1, fn, user, stage);
}
