/* Method option tables (core/src/render/method_options.h): the checker against a table of
 * its own, and every registered method's published table (vsd_method_options_json, what
 * `vsd methods --json` and HELLO send) round-tripped through the checker the renderer uses. */
#include "test_common.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "src/render/method.h"
#include "src/render/method_options.h"
#include <cjson/cJSON.h>
#include <stddef.h>
#include <stdlib.h>

typedef struct toy_options {
    int count, flag, mode;
    double step, gain;
} toy_options;

static const char *const toy_modes[] = {"fast", "exact", NULL};

static const char *odd_problem(double v) { return ((long)v % 2) ? NULL : "is not odd"; }

static const vsd_option_spec toy_rows[] = {
    {"count", VSD_OPT_INT, 1, 99, 7, NULL, "a count", offsetof(toy_options, count), 0, odd_problem},
    {"flag", VSD_OPT_BOOL, 0, 1, 1, NULL, "a switch", offsetof(toy_options, flag), 0, NULL},
    {"mode", VSD_OPT_CHOICE, 0, 0, 1, toy_modes, "a mode", offsetof(toy_options, mode), 0, NULL},
    {"step", VSD_OPT_NUMBER, 0, 10, 0, NULL, "a length", offsetof(toy_options, step), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH,
     NULL},
    {"gain", VSD_OPT_NUMBER, -1, 1, 0.25, NULL, "a gain", offsetof(toy_options, gain), 0, NULL},
};
static const vsd_option_table toy = VSD_OPTION_TABLE(toy_rows, toy_options);

static vsd_status parse_toy(const char *json, toy_options *o, char *err, size_t errlen)
{
    err[0] = '\0';
    return vsd_options_parse(&toy, "toy", json, o, err, errlen);
}

static void test_defaults_and_values(void)
{
    toy_options o;
    char err[512];
    CHECK(parse_toy("{}", &o, err, sizeof err) == VSD_OK);
    CHECK(o.count == 7 && o.flag == 1 && o.mode == 1 && o.step == 0.0 && o.gain == 0.25);
    CHECK(parse_toy("", &o, err, sizeof err) == VSD_OK && o.count == 7);
    CHECK(parse_toy("{\"count\": 99, \"flag\": false, \"mode\": \"fast\", \"step\": 2.5, \"gain\": -1}", &o, err,
                    sizeof err) == VSD_OK);
    CHECK(o.count == 99 && o.flag == 0 && o.mode == 0 && o.step == 2.5 && o.gain == -1.0);
}

static void test_errors(void)
{
    static const struct { const char *json, *message; vsd_status st; } bad[] = {
        {"{\"nope\": 1}", "render.options.nope: unknown option for method toy (known: count, flag, mode, step, gain)",
         VSD_ERR_INVALID},
        {"{\"count\": 0}", "render.options.count: 0 is out of range 1..99", VSD_ERR_INVALID},
        {"{\"count\": 100}", "render.options.count: 100 is out of range 1..99", VSD_ERR_INVALID},
        {"{\"count\": 2.5}", "render.options.count: expected integer, got 2.5", VSD_ERR_TYPE},
        {"{\"count\": \"3\"}", "render.options.count: expected integer", VSD_ERR_TYPE},
        {"{\"count\": 4}", "render.options.count: 4 is not odd", VSD_ERR_INVALID},
        {"{\"flag\": 1}", "render.options.flag: expected boolean (true or false)", VSD_ERR_TYPE},
        {"{\"mode\": \"slow\"}", "render.options.mode: \"slow\" is not one of \"fast\", \"exact\"", VSD_ERR_INVALID},
        {"{\"mode\": 1}", "render.options.mode: expected a string, one of \"fast\", \"exact\"", VSD_ERR_TYPE},
        {"{\"step\": -1}", "render.options.step: -1 is out of range (0, 10] (0 = automatic)", VSD_ERR_INVALID},
        {"{\"gain\": 1.5}", "render.options.gain: 1.5 is out of range -1..1", VSD_ERR_INVALID},
        {"{\"gain\": null}", "render.options.gain: expected a finite number", VSD_ERR_TYPE},
        {"[1, 2]", "render.options: not a JSON object", VSD_ERR_FORMAT},
        {"{\"count\": ", "render.options: not a JSON object", VSD_ERR_FORMAT},
    };
    size_t i;
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        toy_options o;
        char err[512];
        vsd_status st = parse_toy(bad[i].json, &o, err, sizeof err);
        CHECK_MSG(st == bad[i].st, "%s gave status %d", bad[i].json, (int)st);
        CHECK_MSG(strcmp(err, bad[i].message) == 0, "%s gave \"%s\"", bad[i].json, err);
    }
}

/* Every registered method: its published table's defaults, written back as an options
 * object, pass the renderer's checker; each numeric row's bounds pass and a value just
 * outside fails with the key and the range; every choice passes; rows have docs. */
static void test_registered_tables(void)
{
    char *text = vsd_method_options_json();
    cJSON *root = text ? cJSON_Parse(text) : NULL, *method, *row;
    const char *const *name;
    int methods = 0;
    CHECK(root != NULL);
    for (name = vsd_method_names(); *name; name++)
        CHECK_MSG(cJSON_GetObjectItemCaseSensitive(root, *name) != NULL, "no table for %s", *name);
    cJSON_ArrayForEach(method, root) {
        const vsd_method *m = vsd_method_find(method->string);
        cJSON *defaults = cJSON_CreateObject();
        vsd_scene sc;
        void *opts = NULL;
        char err[1024], *json;
        methods++;
        CHECK(m != NULL);
        if (!m) continue;
        vsd_scene_defaults(&sc);
        cJSON_ArrayForEach(row, method) {
            const char *key = cJSON_GetObjectItemCaseSensitive(row, "key")->valuestring;
            const char *type = cJSON_GetObjectItemCaseSensitive(row, "type")->valuestring;
            const cJSON *doc = cJSON_GetObjectItemCaseSensitive(row, "doc");
            CHECK_MSG(cJSON_IsString(doc) && strlen(doc->valuestring) > 8, "%s.%s has no doc", method->string, key);
            cJSON_AddItemToObject(defaults, key, cJSON_Duplicate(cJSON_GetObjectItemCaseSensitive(row, "default"), 1));
            if (!strcmp(type, "int") || !strcmp(type, "number")) {
                double lo = cJSON_GetObjectItemCaseSensitive(row, "min")->valuedouble;
                double hi = cJSON_GetObjectItemCaseSensitive(row, "max")->valuedouble;
                int auto_zero = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(row, "auto_zero"));
                /* below the range; for "0 = automatic" rows 0 itself is accepted, so -1 */
                double below = auto_zero ? -1.0 : !strcmp(type, "int") ? lo - 1 : lo - 0.5;
                char expect[256];
                snprintf(sc.render.options_json, sizeof sc.render.options_json, "{\"%s\": %.17g}", key, below);
                CHECK_MSG(vsd_method_parse_options(m, &sc, &opts, err, sizeof err) == VSD_ERR_INVALID,
                          "%s.%s = %g accepted", method->string, key, below);
                snprintf(expect, sizeof expect, "render.options.%s: %g is out of range ", key, below);
                CHECK_CONTAINS(err, expect);
                free(opts);
                opts = NULL;
                /* the upper bound is accepted unless an extra rule (HEALPix counts) refuses it */
                snprintf(sc.render.options_json, sizeof sc.render.options_json, "{\"%s\": %.17g}", key, hi);
                if (vsd_method_parse_options(m, &sc, &opts, err, sizeof err) != VSD_OK)
                    CHECK_CONTAINS(err, key);
                free(opts);
                opts = NULL;
                if (auto_zero) {
                    snprintf(sc.render.options_json, sizeof sc.render.options_json, "{\"%s\": 0}", key);
                    CHECK_MSG(vsd_method_parse_options(m, &sc, &opts, err, sizeof err) == VSD_OK, "%s.%s = 0 (automatic): %s",
                              method->string, key, err);
                    free(opts);
                    opts = NULL;
                }
            } else if (!strcmp(type, "choice")) {
                const cJSON *c;
                cJSON_ArrayForEach(c, cJSON_GetObjectItemCaseSensitive(row, "choices")) {
                    snprintf(sc.render.options_json, sizeof sc.render.options_json, "{\"%s\": \"%s\"}", key,
                             c->valuestring);
                    CHECK_MSG(vsd_method_parse_options(m, &sc, &opts, err, sizeof err) == VSD_OK, "%s.%s=%s: %s",
                              method->string, key, c->valuestring, err);
                    free(opts);
                    opts = NULL;
                }
            }
        }
        json = cJSON_PrintUnformatted(defaults);
        snprintf(sc.render.options_json, sizeof sc.render.options_json, "%s", json);
        CHECK_MSG(vsd_method_parse_options(m, &sc, &opts, err, sizeof err) == VSD_OK, "%s defaults %s: %s",
                  method->string, json, err);
        free(opts);
        opts = NULL;
        /* the defaults written out give the same struct as no options at all */
        if (m->options.struct_size) {
            void *none = NULL;
            sc.render.options_json[0] = '\0';
            CHECK(vsd_method_parse_options(m, &sc, &none, err, sizeof err) == VSD_OK);
            snprintf(sc.render.options_json, sizeof sc.render.options_json, "%s", json);
            CHECK(vsd_method_parse_options(m, &sc, &opts, err, sizeof err) == VSD_OK);
            CHECK_MSG(opts && none && memcmp(opts, none, m->options.struct_size) == 0, "%s: defaults differ",
                      method->string);
            free(none);
            free(opts);
            opts = NULL;
        }
        free(json);
        cJSON_Delete(defaults);
    }
    CHECK(methods >= 4);
    cJSON_Delete(root);
    free(text);
}

/* The renderer refuses a bad option before any work, naming it and its range. */
static void test_renderer_refuses(void)
{
    vsd_scene sc;
    vsd_renderer *r = NULL;
    char err[1024] = "";
    vsd_scene_defaults(&sc);
    snprintf(sc.render.method, sizeof sc.render.method, "raymarch");
    snprintf(sc.render.options_json, sizeof sc.render.options_json, "{\"pixel_samples\": 17}");
    CHECK(vsd_renderer_create(&sc, NULL, &r, err, sizeof err) == VSD_ERR_INVALID && r == NULL);
    CHECK_CONTAINS(err, "render.options.pixel_samples: 17 is out of range 1..16");
}

int main(void)
{
    test_defaults_and_values();
    test_errors();
    test_registered_tables();
    test_renderer_refuses();
    return test_finish("test_method_options");
}
