/* Method options (render.options): a free-form JSON object that each method reads with
 * its own keys and defaults. The scene keeps it as text (vsd_scene owns no heap memory),
 * so each lookup parses it again; methods read their options once per prepare, not per
 * pixel, so that costs nothing that matters. */
#include "vsd/scene.h"

#include <cjson/cJSON.h>
#include <string.h>

/* Numbers as they are, booleans as 1/0; anything else (absent, string, object) gives
 * `fallback`, so a method always gets a usable value. */
double vsd_scene_option_number(const vsd_scene *scene, const char *key, double fallback)
{
    if (!scene || !key)
        return fallback;
    cJSON *root = cJSON_Parse(scene->render.options_json);
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(root, key);
    double v = fallback;
    if (cJSON_IsNumber(item))
        v = item->valuedouble;
    else if (cJSON_IsBool(item))
        v = cJSON_IsTrue(item) ? 1.0 : 0.0;
    cJSON_Delete(root);
    return v;
}

/* Returns 1 and copies the string when `key` holds a string that fits in `out`; returns 0
 * (absent or not a string) or -1 (too long for `out`) and leaves `out` unchanged, so a
 * caller can put the default in `out` first. */
int vsd_scene_option_string(const vsd_scene *scene, const char *key, char *out, size_t outlen)
{
    if (!scene || !key || !out || !outlen)
        return 0;
    cJSON *root = cJSON_Parse(scene->render.options_json);
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(root, key);
    int found = 0;
    if (cJSON_IsString(item)) {
        size_t n = strlen(item->valuestring);
        found = n < outlen ? 1 : -1;
        if (found == 1)
            memcpy(out, item->valuestring, n + 1);
    }
    cJSON_Delete(root);
    return found;
}
