/* Method option tables (core/src/method/method_options.h): the checker against a table of
 * its own, its "applies when" rules, every registered method's published table
 * (vsd_method_options_json) round-tripped through the checker the renderer uses, and the
 * registry's catalog (vsd_method_catalog_json, what `vsd methods --json` and HELLO send):
 * one entry per method, capabilities as the descriptors declare them, one default per role,
 * and rules that name real options. */
#include "test_common.h"
#include "vsd/render.h"
#include "vsd/scene.h"
#include "src/method/method.h"
#include "src/method/method_options.h"
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
    {"count", VSD_OPT_INT, 1, 99, 7, NULL, "a count", offsetof(toy_options, count), 0, odd_problem, NULL},
    {"flag", VSD_OPT_BOOL, 0, 1, 1, NULL, "a switch", offsetof(toy_options, flag), 0, NULL, NULL},
    {"mode", VSD_OPT_CHOICE, 0, 0, 1, toy_modes, "a mode", offsetof(toy_options, mode), 0, NULL, NULL},
    {"step", VSD_OPT_NUMBER, 0, 10, 0, NULL, "a length", offsetof(toy_options, step), VSD_OPT_ZERO_AUTO | VSD_OPT_LENGTH,
     NULL, NULL},
    {"gain", VSD_OPT_NUMBER, -1, 1, 0.25, NULL, "a gain", offsetof(toy_options, gain), 0, NULL, NULL},
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

/* A toy table with rules: "gain" applies only when mode is "exact" and flag is on; "step"
 * only when count differs from 7. */
static const vsd_option_when toy_on_exact[] = {{"mode", 0, 0, "exact"}, {"flag", 0, 1, NULL}, {NULL, 0, 0, NULL}};
static const vsd_option_when toy_on_count[] = {{"count", 1, 7, NULL}, {NULL, 0, 0, NULL}};
static const vsd_option_spec ruled_rows[] = {
    {"count", VSD_OPT_INT, 1, 99, 7, NULL, "a count", offsetof(toy_options, count), 0, NULL, NULL},
    {"flag", VSD_OPT_BOOL, 0, 1, 1, NULL, "a switch", offsetof(toy_options, flag), 0, NULL, NULL},
    {"mode", VSD_OPT_CHOICE, 0, 0, 1, toy_modes, "a mode", offsetof(toy_options, mode), 0, NULL, NULL},
    {"step", VSD_OPT_NUMBER, 0, 10, 0, NULL, "a length", offsetof(toy_options, step), 0, NULL, toy_on_count},
    {"gain", VSD_OPT_NUMBER, -1, 1, 0.25, NULL, "a gain", offsetof(toy_options, gain), 0, NULL, toy_on_exact},
};
static const vsd_option_table ruled = VSD_OPTION_TABLE(ruled_rows, toy_options);

static void test_rules(void)
{
    static const struct {
        const char *json, *message; /* message NULL: accepted */
    } cases[] = {
        {"{\"gain\": 0.5}", NULL},                          /* mode "exact" and flag on by default */
        {"{\"gain\": 0.5, \"mode\": \"exact\", \"flag\": true}", NULL},
        {"{\"gain\": 0.5, \"mode\": \"fast\"}",
         "render.options.gain does not apply with render.options.mode = \"fast\" (it applies only when mode = "
         "\"exact\" and flag = true)"},
        {"{\"flag\": false, \"gain\": -0.5}",
         "render.options.gain does not apply with render.options.flag = false (it applies only when mode = "
         "\"exact\" and flag = true)"},
        /* a default written out is no lie: accepted where the rule does not hold */
        {"{\"gain\": 0.25, \"mode\": \"fast\"}", NULL},
        {"{\"step\": 2}",
         "render.options.step does not apply with render.options.count = 7 (the default) (it applies only when "
         "count != 7)"},
        {"{\"step\": 2, \"count\": 9}", NULL},
    };
    toy_options o;
    char err[512], rule[256], why[256];
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        vsd_status st = vsd_options_parse(&ruled, "toy", cases[i].json, &o, err, sizeof err);
        if (!cases[i].message) CHECK_MSG(st == VSD_OK, "%s refused: %s", cases[i].json, err);
        else {
            CHECK_MSG(st == VSD_ERR_INVALID, "%s accepted", cases[i].json);
            CHECK_MSG(strcmp(err, cases[i].message) == 0, "%s gave \"%s\"", cases[i].json, err);
        }
    }
    vsd_option_rule_text(&ruled, &ruled_rows[4], rule, sizeof rule);
    CHECK_MSG(strcmp(rule, "mode = \"exact\" and flag = true") == 0, "rule text \"%s\"", rule);
    CHECK(vsd_option_rules_invalid(&ruled, why, sizeof why) == 0);
    {
        /* the published row carries the rule as data */
        cJSON *arr = (cJSON *)vsd_options_table_json(&ruled);
        char *text = cJSON_PrintUnformatted(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(arr, 4), "applies_when"));
        CHECK_MSG(text && strcmp(text, "[{\"key\":\"mode\",\"equals\":\"exact\"},{\"key\":\"flag\",\"equals\":true}]") == 0,
                  "applies_when %s", text ? text : "(none)");
        free(text);
        cJSON_Delete(arr);
    }
    {
        /* a rule naming an option the table lacks, or a choice the option lacks, is caught */
        static const vsd_option_when bad_key[] = {{"nonesuch", 0, 1, NULL}, {NULL, 0, 0, NULL}};
        static const vsd_option_when bad_choice[] = {{"mode", 0, 0, "slow"}, {NULL, 0, 0, NULL}};
        vsd_option_spec rows[sizeof ruled_rows / sizeof ruled_rows[0]];
        vsd_option_table t = ruled;
        memcpy(rows, ruled_rows, sizeof rows);
        t.rows = rows;
        rows[3].when = bad_key;
        CHECK(vsd_option_rules_invalid(&t, why, sizeof why) == 1);
        CHECK_CONTAINS(why, "nonesuch");
        rows[3].when = bad_choice;
        CHECK(vsd_option_rules_invalid(&t, why, sizeof why) == 1);
        CHECK_CONTAINS(why, "mode");
    }
}

static const cJSON *item(const cJSON *o, const char *key) { return cJSON_GetObjectItemCaseSensitive(o, key); }

/* A method's preview_options in the catalog: an object, the descriptor's own; render.options
 * its table accepts (vsd_options_parse, as a scene's), each set away from its default (an
 * override that changes nothing would only cost the viewport a second renderer). */
static void check_preview_options(const cJSON *m, const vsd_method *desc)
{
    const cJSON *p = item(m, "preview_options"), *o, *row;
    void *parsed;
    char err[512];
    CHECK_MSG(cJSON_IsObject(p), "%s: preview_options is not an object", desc->name);
    if (!cJSON_IsObject(p)) return;
    CHECK_MSG(!desc->preview_options == !p->child, "%s: preview_options {} against the descriptor's", desc->name);
    if (!desc->preview_options) return;
    parsed = calloc(1, desc->options.struct_size);
    CHECK(parsed != NULL);
    CHECK_MSG(parsed && vsd_options_parse(&desc->options, desc->name, desc->preview_options, parsed, err, sizeof err) ==
                            VSD_OK,
              "%s: preview_options refused: %s", desc->name, err);
    free(parsed);
    cJSON_ArrayForEach(o, p) {
        int found = 0;
        cJSON_ArrayForEach(row, item(m, "options")) {
            if (strcmp(item(row, "key")->valuestring, o->string) != 0) continue;
            found = 1;
            CHECK_MSG(!cJSON_Compare(item(row, "default"), o, 1), "%s: preview option %s is its default", desc->name,
                      o->string);
        }
        CHECK_MSG(found, "%s: preview option %s is not in its table", desc->name, o->string);
    }
}

/* The catalog: every registered method once, in the registry's order, with a label, a
 * summary, its capabilities as its descriptor declares them, and the same option table as
 * vsd_method_options_json; one method per role, the final default being the scene file's
 * default method; each rule names real options (that each rule refuses a value set where it
 * does not hold, through the renderer, is test_option_coverage's). */
static void test_catalog(void)
{
    static const char *const caps[] = {"multiple_scattering", "refraction", "scene_lights", "emission_scattering",
                                       "cuda_view"};
    char *text = vsd_method_catalog_json(), *tables_text = vsd_method_options_json();
    cJSON *cat = text ? cJSON_Parse(text) : NULL, *tables = tables_text ? cJSON_Parse(tables_text) : NULL;
    const char *const *name = vsd_method_names();
    const cJSON *m;
    int finals = 0, viewports = 0;
    vsd_scene sc;
    CHECK(cat != NULL && cJSON_IsArray(cat) && tables != NULL);
    vsd_scene_defaults(&sc);
    cJSON_ArrayForEach(m, cat) {
        const char *mname = item(m, "name")->valuestring;
        const vsd_method *desc = vsd_method_find(mname);
        const cJSON *role;
        char why[256];
        size_t b;
        CHECK_MSG(*name && strcmp(*name, mname) == 0, "catalog entry %s out of the registry's order", mname);
        if (*name) name++;
        CHECK(desc != NULL);
        if (!desc) continue;
        CHECK_MSG(strlen(item(m, "label")->valuestring) > 0 && strlen(item(m, "summary")->valuestring) > 10,
                  "%s: no label or summary", mname);
        for (b = 0; b < sizeof caps / sizeof caps[0]; b++)
            CHECK_MSG(cJSON_IsBool(item(item(m, "capabilities"), caps[b])) &&
                          cJSON_IsTrue(item(item(m, "capabilities"), caps[b])) == !!(desc->caps & (1u << b)) &&
                          !!(vsd_method_capabilities(mname) & (1u << b)) == !!(desc->caps & (1u << b)),
                      "%s: capability %s", mname, caps[b]);
        cJSON_ArrayForEach(role, item(m, "roles")) {
            if (!strcmp(role->valuestring, "final_default")) {
                finals++;
                CHECK_MSG(strcmp(mname, sc.render.method) == 0, "final default %s, scene default %s", mname,
                          sc.render.method);
            } else if (!strcmp(role->valuestring, "viewport_default")) {
                viewports++;
                /* the viewport is to look like the final render: more than single scattering;
                 * and a material edit is to show soon (issue 32): a quick first look */
                CHECK(desc->caps & VSD_METHOD_CAP_MULTIPLE_SCATTERING);
                CHECK_MSG(desc->preview_options != NULL, "viewport default %s has no preview_options", mname);
            } else CHECK_MSG(0, "%s: unknown role %s", mname, role->valuestring);
        }
        CHECK_MSG(cJSON_Compare(item(m, "options"), item(tables, mname), 1), "%s: catalog options differ", mname);
        CHECK_MSG(vsd_option_rules_invalid(&desc->options, why, sizeof why) == 0, "%s: %s", mname, why);
        check_preview_options(m, desc);
    }
    CHECK_MSG(*name == NULL, "the catalog lacks %s", *name ? *name : "");
    CHECK(finals == 1 && viewports == 1);
    cJSON_Delete(cat);
    cJSON_Delete(tables);
    free(text);
    free(tables_text);
}

/* The lights check names the methods that render lights, from their capabilities. */
static void test_lights_named_from_capabilities(void)
{
    vsd_scene sc;
    char err[512], expect[256] = "";
    const char *const *n;
    vsd_scene_defaults(&sc);
    sc.light_count = 1;
    for (n = vsd_method_names(); *n; n++)
        if (vsd_method_capabilities(*n) & VSD_METHOD_CAP_SCENE_LIGHTS)
            snprintf(expect + strlen(expect), sizeof expect - strlen(expect), "%s%s", expect[0] ? ", " : "", *n);
    CHECK(expect[0] != '\0');
    for (n = vsd_method_names(); *n; n++) {
        vsd_status st = vsd_method_check_lights(vsd_method_find(*n), &sc, err, sizeof err);
        if (vsd_method_capabilities(*n) & VSD_METHOD_CAP_SCENE_LIGHTS) CHECK_MSG(st == VSD_OK, "%s: %s", *n, err);
        else {
            CHECK_MSG(st == VSD_ERR_UNSUPPORTED, "%s accepted lights", *n);
            CHECK_CONTAINS(err, expect);
        }
    }
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
    test_rules();
    test_catalog();
    test_lights_named_from_capabilities();
    test_renderer_refuses();
    return test_finish("test_method_options");
}
