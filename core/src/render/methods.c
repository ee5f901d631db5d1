/* The method registry: one table, so the CLI, the daemon's HELLO and the option checks
 * all list the same methods. */
#include "method.h"
#include "device/cpu/cpu_tiles.h"
#include <string.h>
#include <cjson/cJSON.h>

static const vsd_method *const registry[] = { &vsd_method_reference, &vsd_method_raymarch, &vsd_method_shgrid,
                                                &vsd_method_constellation };
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

static int option_known(const vsd_method *m, const char *key)
{
    const char *const *o;
    for (o = m->options; o && *o; o++)
        if (strcmp(*o, key) == 0) return 1;
    return 0;
}

vsd_status vsd_method_check_options(const vsd_method *m, const vsd_scene *scene, char *err, size_t errlen)
{
    cJSON *root = cJSON_Parse(scene->render.options_json[0] ? scene->render.options_json : "{}");
    cJSON *item;
    vsd_status st = VSD_OK;
    if (!root) return vsd_fail(VSD_ERR_FORMAT, err, errlen, "render.options: not a JSON object");
    cJSON_ArrayForEach(item, root) {
        if (!option_known(m, item->string)) {
            char known[512] = "";
            const char *const *o;
            for (o = m->options; o && *o; o++) {
                if (known[0]) strncat(known, ", ", sizeof known - strlen(known) - 1);
                strncat(known, *o, sizeof known - strlen(known) - 1);
            }
            st = vsd_fail(VSD_ERR_INVALID, err, errlen,
                          "render.options.%s: unknown option for method %s (known: %s)",
                          item->string, m->name, known[0] ? known : "none");
            break;
        }
    }
    cJSON_Delete(root);
    return st;
}

void vsd_method_tile_job(vsd_tile_job *job, const vsd_frame_ctx *ctx, const vsd_framebuffer *fb,
                         void (*fn)(void *, int, int, int, int), void *user, const char *stage)
{
    memset(job, 0, sizeof *job);
    job->width = fb->width;
    job->height = fb->height;
    job->threads = ctx->threads;
    job->fn = fn;
    job->user = user;
    job->stage = stage;
    job->progress = ctx->progress;
    job->progress_user = ctx->user;
    job->progress_span = 1.0f;
    job->cancel = ctx->cancel;
}
