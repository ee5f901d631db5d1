/* `vsd methods [--json | --names]`: every method, what it can render, and its
 * render.options (key, type, range, default, when it applies, one line of doc), from the
 * registry the renderer checks options against and the daemon's HELLO sends. --json prints
 * vsd_method_catalog_json() as it is. */
#include "commands.h"
#include "vsd/render.h"
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const cJSON *field(const cJSON *o, const char *key) { return cJSON_GetObjectItemCaseSensitive(o, key); }

static void print_range(const cJSON *o)
{
    const cJSON *type = field(o, "type");
    const cJSON *def = field(o, "default");
    if (!strcmp(type->valuestring, "choice")) {
        const cJSON *c;
        int first = 1;
        printf("one of ");
        cJSON_ArrayForEach(c, field(o, "choices")) {
            printf("%s%s", first ? "" : "|", c->valuestring);
            first = 0;
        }
        printf(", default %s", def->valuestring);
    } else if (!strcmp(type->valuestring, "bool")) {
        printf("true|false, default %s", cJSON_IsTrue(def) ? "true" : "false");
    } else {
        printf("%s %g..%g, default %g", type->valuestring, field(o, "min")->valuedouble, field(o, "max")->valuedouble,
               def->valuedouble);
        if (cJSON_IsTrue(field(o, "auto_zero"))) printf(" (automatic)");
    }
}

/* "  applies when lattice = d3q6 and block_steps = 0" */
static void print_rule(const cJSON *o)
{
    const cJSON *c;
    int first = 1;
    if (!cJSON_GetArraySize(field(o, "applies_when"))) return;
    printf("\n  %-18s applies when ", "");
    cJSON_ArrayForEach(c, field(o, "applies_when")) {
        const cJSON *v = field(c, "equals") ? field(c, "equals") : field(c, "differs");
        printf("%s%s %s ", first ? "" : "and ", field(c, "key")->valuestring, field(c, "equals") ? "=" : "!=");
        if (cJSON_IsString(v)) printf("%s", v->valuestring);
        else if (cJSON_IsBool(v)) printf("%s", cJSON_IsTrue(v) ? "true" : "false");
        else printf("%g", v->valuedouble);
        first = 0;
    }
}

static void print_method(const cJSON *m)
{
    const cJSON *c, *opt;
    int any = 0;
    printf("%s  (%s) %s\n", field(m, "name")->valuestring, field(m, "label")->valuestring,
           field(m, "summary")->valuestring);
    printf("  renders:");
    cJSON_ArrayForEach(c, field(m, "capabilities")) if (cJSON_IsTrue(c)) {
            printf(" %s", c->string);
            any = 1;
        }
    printf("%s\n", any ? "" : " single scattering of the map only");
    cJSON_ArrayForEach(c, field(m, "roles")) printf("  default: %s\n", c->valuestring);
    if (cJSON_GetArraySize(field(m, "options")) == 0) printf("  (no options)\n");
    cJSON_ArrayForEach(opt, field(m, "options")) {
        printf("  %-18s ", field(opt, "key")->valuestring);
        print_range(opt);
        print_rule(opt);
        printf("\n  %-18s %s\n", "", field(opt, "doc")->valuestring);
    }
}

int vsd_cmd_methods(int argc, char **argv)
{
    int json = 0, names = 0, i;
    char *text;
    cJSON *root, *method;
    for (i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--json")) json = 1;
        else if (!strcmp(argv[i], "--names")) names = 1;
        else if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            printf("usage: vsd methods [--json | --names]\n"
                   "Lists every rendering method, what it renders, and its render.options: type, range, default,\n"
                   "when it applies, meaning. --json: the same as the daemon's HELLO.method_catalog; --names: the\n"
                   "method names, one per line.\n");
            return VSD_EXIT_OK;
        } else {
            fprintf(stderr, "vsd methods: unknown option '%s'\n", argv[i]);
            return VSD_EXIT_USAGE;
        }
    }
    if (names) {
        const char *const *n;
        for (n = vsd_method_names(); *n; n++) printf("%s\n", *n);
        return VSD_EXIT_OK;
    }
    text = vsd_method_catalog_json();
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
    cJSON_ArrayForEach(method, root) print_method(method);
    cJSON_Delete(root);
    return VSD_EXIT_OK;
}
