/* The method registry (core/methods/registry.h) as a table, so the CLI, the daemon's HELLO,
 * the option checks and the tests all list the same methods, with what each can render. */
#include "method.h"
#include "device/cpu/cpu_tiles.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>

#define VSD_METHOD_ADDRESS(name) &vsd_method_##name,
static const vsd_method *const registry[] = { VSD_METHOD_REGISTRY(VSD_METHOD_ADDRESS) };
#undef VSD_METHOD_ADDRESS
#define REGISTRY_COUNT (sizeof registry / sizeof registry[0])

/* The catalog's name of each capability bit (vsd/render.h), in bit order. */
static const char *const cap_names[] = { "multiple_scattering", "refraction", "scene_lights", "emission_scattering",
                                         "cuda_view", "several_volumes" };
static const char *const role_names[] = { "final_default", "viewport_default" };

const char *const *vsd_method_names(void)
{
    /* built at compile time from the same list, so concurrent callers (HELLOs on the
     * daemon's threads) read it without a race */
#define VSD_METHOD_NAME(name) #name,
    static const char *const names[] = { VSD_METHOD_REGISTRY(VSD_METHOD_NAME) NULL };
#undef VSD_METHOD_NAME
    return names;
}

const vsd_method *vsd_method_find(const char *name)
{
    size_t i;
    for (i = 0; i < REGISTRY_COUNT; i++)
        if (strcmp(registry[i]->name, name) == 0) return registry[i];
    return NULL;
}

/* The methods with capability `cap`, comma separated, into which[n]. */
static const char *methods_with(unsigned cap, char *which, size_t n)
{
    which[0] = '\0';
    for (size_t i = 0; i < REGISTRY_COUNT; i++)
        if (registry[i]->caps & cap)
            snprintf(which + strlen(which), n - strlen(which), "%s%s", which[0] ? ", " : "", registry[i]->name);
    return which;
}

vsd_status vsd_method_check_volumes(const vsd_method *m, const vsd_scene *sc, char *err, size_t errlen)
{
    char which[256];
    int refracting = -1;
    if (sc->volume_count <= 1) return VSD_OK;
    for (int i = 0; i < sc->volume_count; i++) {
        if (!vsd_scene_volume_refracts(&sc->volumes[i])) continue;
        if (refracting >= 0)
            return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                            "volumes[%d] and volumes[%d] both refract (medium.ior, ior_grid): one refracting volume "
                            "per scene so far (its index field is one volume's)",
                            refracting, i);
        refracting = i;
        if (!m->refraction_among_volumes)
            return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                            "volumes[%d].medium: refraction (ior, ior_grid) in a scene with several volumes: method "
                            "'%s' bends rays through one volume alone so far (reference renders a refracting volume "
                            "among others)",
                            i, m->name);
    }
    if (m->caps & VSD_METHOD_CAP_SEVERAL_VOLUMES) return VSD_OK;
    return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                    "volumes: the scene has %d volumes; method '%s' renders one volume so far (%s render several)",
                    sc->volume_count, m->name, methods_with(VSD_METHOD_CAP_SEVERAL_VOLUMES, which, sizeof which));
}

vsd_status vsd_method_check_lights(const vsd_method *m, const vsd_scene *sc, char *err, size_t errlen)
{
    char which[256] = "";
    size_t i;
    if (sc->light_count == 0) return VSD_OK;
    if (vsd_scene_refracting_volume(sc) >= 0)
        return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                        "lights: extra lights through a refracting medium (medium.ior, volume.ior_grid) are not "
                        "supported yet: a bent ray cannot be aimed at a point or a sun");
    if (m->caps & VSD_METHOD_CAP_SCENE_LIGHTS) return VSD_OK;
    for (i = 0; i < REGISTRY_COUNT; i++)
        if (registry[i]->caps & VSD_METHOD_CAP_SCENE_LIGHTS)
            snprintf(which + strlen(which), sizeof which - strlen(which), "%s%s", which[0] ? ", " : "",
                     registry[i]->name);
    return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                    "lights: method '%s' does not render extra lights (sun, point, spot); %s do", m->name, which);
}

vsd_status vsd_method_parse_options(const vsd_method *m, const vsd_scene *scene, void **options, char *err,
                                    size_t errlen)
{
    return vsd_method_options_from_json(m, scene->render.options_json, options, err, errlen);
}

vsd_status vsd_method_options_from_json(const vsd_method *m, const char *options_json, void **options, char *err,
                                        size_t errlen)
{
    /* at least one byte, so a method without options still gets a pointer to free */
    void *o = calloc(1, m->options.struct_size ? m->options.struct_size : 1);
    vsd_status st;
    *options = NULL;
    if (!o) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory");
    st = vsd_options_parse(&m->options, m->name, options_json, o, err, errlen);
    if (st) {
        free(o);
        return st;
    }
    *options = o;
    return VSD_OK;
}

const vsd_option_when vsd_option_on_sparse_view[] = {{"view_spacing", 1, 1, NULL}, {NULL, 0, 0, NULL}};

unsigned vsd_method_capabilities(const char *name)
{
    const vsd_method *m = vsd_method_find(name);
    return m ? m->caps : 0u;
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

static cJSON *method_json(const vsd_method *m)
{
    cJSON *o = cJSON_CreateObject(), *caps, *roles;
    size_t b;
    if (!o) return NULL;
    cJSON_AddStringToObject(o, "name", m->name);
    cJSON_AddStringToObject(o, "label", m->label);
    cJSON_AddStringToObject(o, "summary", m->summary);
    caps = cJSON_AddObjectToObject(o, "capabilities");
    for (b = 0; caps && b < sizeof cap_names / sizeof cap_names[0]; b++)
        cJSON_AddBoolToObject(caps, cap_names[b], (m->caps >> b) & 1u);
    roles = cJSON_AddArrayToObject(o, "roles");
    for (b = 0; roles && b < sizeof role_names / sizeof role_names[0]; b++)
        if ((m->roles >> b) & 1u) cJSON_AddItemToArray(roles, cJSON_CreateString(role_names[b]));
    cJSON_AddItemToObject(o, "options", (cJSON *)vsd_options_table_json(&m->options));
    cJSON_AddItemToObject(o, "preview_options",
                          m->preview_options ? cJSON_Parse(m->preview_options) : cJSON_CreateObject());
    return o;
}

char *vsd_method_catalog_json(void)
{
    cJSON *root = cJSON_CreateArray();
    char *text;
    size_t i;
    for (i = 0; root && i < REGISTRY_COUNT; i++) cJSON_AddItemToArray(root, method_json(registry[i]));
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
