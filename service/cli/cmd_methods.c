/* `vsd methods [--json]`: every method and its render.options (key, type, range, default,
 * one line of doc), from the same tables the renderer checks options against and the
 * daemon's HELLO sends. --json prints vsd_method_options_json() as it is. */
#include "commands.h"
#include "vsd/render.h"
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void print_range(const cJSON *o)
{
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(o, "type");
    const cJSON *def = cJSON_GetObjectItemCaseSensitive(o, "default");
    if (!strcmp(type->valuestring, "choice")) {
        const cJSON *c;
        int first = 1;
        printf("one of ");
        cJSON_ArrayForEach(c, cJSON_GetObjectItemCaseSensitive(o, "choices")) {
            printf("%s%s", first ? "" : "|", c->valuestring);
            first = 0;
        }
        printf(", default %s", def->valuestring);
    } else if (!strcmp(type->valuestring, "bool")) {
        printf("true|false, default %s", cJSON_IsTrue(def) ? "true" : "false");
    } else {
        printf("%s %g..%g, default %g", type->valuestring, cJSON_GetObjectItemCaseSensitive(o, "min")->valuedouble,
               cJSON_GetObjectItemCaseSensitive(o, "max")->valuedouble, def->valuedouble);
        if (cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(o, "auto_zero"))) printf(" (automatic)");
    }
}

int vsd_cmd_methods(int argc, char **argv)
{
    int json = 0, i;
    char *text;
    cJSON *root, *method, *opt;
    for (i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--json")) json = 1;
        else if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            printf("usage: vsd methods [--json]\n"
                   "Lists every rendering method and its render.options: type, range, default, meaning.\n");
            return VSD_EXIT_OK;
        } else {
            fprintf(stderr, "vsd methods: unknown option '%s'\n", argv[i]);
            return VSD_EXIT_USAGE;
        }
    }
    text = vsd_method_options_json();
    if (!text) {
        fprintf(stderr, "vsd methods: out of memory\n");
        return VSD_EXIT_RENDER_FAILED;
    }
    if (json) {
        printf("%s\n", text);
        free(text);
        return VSD_EXIT_OK;
    }
    root = cJSON_Parse(text);
    free(text);
    cJSON_ArrayForEach(method, root) {
        printf("%s\n", method->string);
        if (cJSON_GetArraySize(method) == 0) printf("  (no options)\n");
        cJSON_ArrayForEach(opt, method) {
            printf("  %-18s ", cJSON_GetObjectItemCaseSensitive(opt, "key")->valuestring);
            print_range(opt);
            printf("\n  %-18s %s\n", "", cJSON_GetObjectItemCaseSensitive(opt, "doc")->valuestring);
        }
    }
    cJSON_Delete(root);
    return VSD_EXIT_OK;
}
