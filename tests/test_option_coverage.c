/* test_option_coverage.c — every option is exercised (issue 29 item 7).
 *
 * For every method of the registry (vsd_method_catalog_json(), never a list of our own),
 * for every BOOL option's non-default value and every CHOICE option's non-default choices:
 *   - render a tiny scene with that value, plus the prerequisites its "applies_when" rule
 *     needs, and the same scene with only the prerequisites (the value's baseline);
 *   - require the two images to differ by more than float noise (DIFF_TOL), unless the value
 *     is declared below (declared[]) as a no-op for this scene, with its reason — a declared
 *     value must then give the same image to float rounding (SAME_TOL): for options that
 *     promise "the same result, only faster" that equality IS the check, and for the others
 *     it keeps the declaration honest (a declaration that stops being true fails, naming it).
 * A value added to any table is rendered here without any change to this file: if it does
 * nothing on this scene the test fails naming method, option and value.
 *
 * Then every option with an "applies_when" rule is set where one condition of its rule does
 * not hold (the others made to hold): the renderer must refuse it with the checker's
 * "render.options.X does not apply with render.options.Y = ..." naming both options.
 *
 * The scene: smoke64 frame 11 (a 280 kB VDB, fast to load) under the sunset map, 24x16
 * pixels, anisotropy 0.5 (the shipped scene has 0: the phase options — lbl lattice_phase /
 * readout, shgrid form — only change anything when the phase is not isotropic). The renders are deterministic (CPU device, render.seed fixed); the test checks
 * it once per method: the baseline rendered twice by fresh renderers is bit-identical, so a
 * difference above DIFF_TOL is the option's and not noise. */
#include "test_common.h"
#include "test_render_util.h"
#include "vsd/clock.h"
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SCENE "scenes/smoke64_sunset.json"
/* Frame 11, and 10 before it where a sequence is needed (sequence[]): both have the same
 * bounding box of bricks (4x4x5 from index 16,16,0), which crm's coherent fit requires (a
 * sequence whose box changes starts over: frames 9 -> 10 would make `coherent` a no-op). */
#define FRAME 11

/* Two images differ when some pass has a pixel channel that moved by more than DIFF_TOL
 * times the pass's largest value (max |a - b| / max |b|, test_max_rel_diff). The renders are
 * deterministic (checked), so a value that does nothing gives 0 exactly; a value that takes
 * another but equivalent path moves floats by their rounding: crm's former decode "view"
 * (the same D~ + R decoded in the kernel instead of once per frame) measured 1.3e-7 here,
 * float's epsilon. SAME_TOL, "the same image", is 15x that; DIFF_TOL another 10x above, so float
 * noise can never pass for an effect. The smallest effect measured is 1.9e-4 (lbl view_bake
 * false: the phase per ray instead of per record at the camera-to-record direction); the
 * others are 5e-3 (constellation shadows "rays") and up. */
#define DIFF_TOL 2e-5
#define SAME_TOL 2e-6

/* Cheap overrides, present in the baseline and the value's render alike (dropped where their
 * own rule does not hold with the value tested). Each says why it is there; none is tested
 * itself (a tested option is always at its default in the baseline). */
static const struct {
    const char *method, *key, *json, *why;
} cheap[] = {
    /* 64 median-cut lights at 24x16 pixels: 8 are enough to show every option's effect */
    {"constellation", "lights", "8", "fewer lights: a fraction of the shadow work"},
    {"constellation", "shadow_grid", "16", "shadows grid: 16^3 records instead of the automatic grid"},
    {"lbl", "lights", "8", "fewer lights: an eighth of the marching"},
    {"lbl", "tolerance", "1e-6",
     "the diffusion solved to 1e-6, not the default 3e-3: the lattice's two orders then agree to float rounding (at "
     "1e-3 they differ by 1.8e-5, their distances from the steady state); a few more steps on 16^3 cells"},
    {"lbl", "cells", "16", "16^3 lattice cells instead of 64^3: the diffusion in milliseconds"},
    {"shgrid", "grid", "8", "8^3 records instead of a cell per 4 voxels"},
    {"shgrid", "directions", "48", "48 HEALPix directions per record instead of 192"},
    {"crm", "rbf_count", "16", "16 RBFs (the fewest the automatic count picks): a quick fit"},
    {"crm", "fit_iterations", "40", "the fit stops early: its quality is not under test"},
    {"crm", "orders", "4", "multiple orders: 4 orders before the tail instead of 12"},
    {"crm", "order_directions", "12", "multiple orders: 12 directions per cell instead of 48"},
    {"crm", "directions", "12", "single grid: 12 transmittance directions per node instead of 108"},
    {"crm", "node_spacing", "2", "source nodes 2 voxels apart instead of 1 (automatic at 40 voxels): 1/8 the nodes"},
    {"raymarch", "lights", "8", "8 shadow directions per step instead of 256"},
};

/* More settings an option is exercised under, besides the defaults: each a case of its own
 * (the baseline has the same settings). For options that work in a mode no "applies_when"
 * rule names. */
static const struct {
    const char *method, *key, *with, *why;
} contexts[] = {
    {"constellation", "distance_map", "{\"shadows\":\"rays\"}",
     "the map leaps the view and shadow rays' samples with shadows \"rays\", the records' shadow rays with \"grid\""},
    {"crm", "coherent", "{\"view_density\":\"compensated\"}",
     "the RBF fit runs only where something reads it: here the view's D~ + R"},
};

/* Values declared to leave this scene's image as it is (to float rounding, SAME_TOL), under
 * the defaults ("" in `with`) or a context above. "BUG:" would mark a value whose doc says
 * it should change the image here (none found). */
static const struct {
    const char *method, *key, *value, *with, *why;
} declared[] = {
    {"lbl", "leaps", "false", "",
     "the same result by design, only faster (\"the same result; 0 = march every step\"): equality IS the check"},
    {"lbl", "lattice_order", "jacobi", "",
     "the same steady state reached by another iteration (lbl_lattice.h): with both solves run to the tolerance "
     "above, equality IS the check; test_lbl_lattice [14] counts the steps each takes"},
    {"lbl", "exchange", "false", "",
     "light between near groups of volumes (lbl_exchange.h): this scene has one volume, so nothing is sent and "
     "nothing may change; test_volumes renders its effect on three volumes and a cloud beside a smoke"},
    {"constellation", "distance_map", "false", "",
     "the map only leaps samples of zero density (density_threshold 0): bit-identical by design "
     "(docs/methods/constellation.md, \"Exactness of the accelerations\"): equality IS the check"},
    {"constellation", "distance_map", "false", "{\"shadows\":\"rays\"}",
     "as above, with the per-sample shadow rays and the view rays leaping"},
    {"constellation", "shadow_density", "full", "",
     "this scene's shadow cells are under a voxel (64 along its 40-voxel longest axis), where \"auto\" reads the "
     "source voxels too (src/method/density_levels.h): equality IS the check that small volumes keep their image; "
     "test_density_levels checks the levels, bench/crm/scale.py their effect on a large volume"},
    {"constellation", "validity_mask", "false", "",
     "the mask only skips shells before a ray's first non-empty sample (its rule sets shadows \"rays\", where "
     "it runs): bit-identical by design, only faster"},
    {"crm", "coherent", "false", "",
     "the default path (view_density voxels, single grid, multiple orders) fits nothing, so no fit option can "
     "change its image: equality IS the check that it fits nothing (issue 31)"},
    {"shgrid", "record_density", "full", "",
     "this scene's record cells are about a voxel (32 per axis over 32 x 32 x 40 voxels), where \"auto\" reads the "
     "source voxels too (src/method/density_levels.h): equality IS the check that small volumes keep their image; "
     "test_density_levels checks the levels, bench/crm/scale.py their effect on a large volume"},
    {"shgrid", "form", "product", "",
     "the default \"auto\" picks product for an anisotropic medium (this scene's 0.5): equality is the check "
     "that auto does (factored, the other form, must and does change the image)"},
};

/* Options whose effect shows only across frames: rendered as a two-frame sequence by one
 * renderer (FRAME - 1, then FRAME), the second image compared. */
static const struct {
    const char *method, *key, *why;
} sequence[] = {
    {"crm", "coherent", "a fit started from the previous frame's RBFs needs a previous frame"},
};

typedef struct cov {
    vsd_scene scene;
    int cases, differ, same, refusals;
    /* baselines by "method options", each rendered once */
    struct { char *key; vsd_framebuffer *fb; } cache[64];
    int cached;
} cov;

/* ---- the rows of the catalog ---- */

static const cJSON *row_find(const cJSON *rows, const char *key)
{
    const cJSON *r;
    cJSON_ArrayForEach(r, rows) {
        const cJSON *k = cJSON_GetObjectItemCaseSensitive(r, "key");
        if (cJSON_IsString(k) && !strcmp(k->valuestring, key)) return r;
    }
    return NULL;
}

static const char *row_str(const cJSON *row, const char *field)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(row, field);
    return cJSON_IsString(v) ? v->valuestring : "";
}

static const cJSON *row_default(const cJSON *row) { return cJSON_GetObjectItemCaseSensitive(row, "default"); }

/* The row's "applies_when" conditions (NULL: always applies, or no such row). */
static const cJSON *row_rule(const cJSON *row)
{
    return row ? cJSON_GetObjectItemCaseSensitive(row, "applies_when") : NULL;
}

/* The option's value with `set` (a JSON object): the one set, else the table's default. */
static const cJSON *effective(const cJSON *rows, const cJSON *set, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(set, key);
    const cJSON *row = row_find(rows, key);
    return v ? v : row ? row_default(row) : NULL;
}

static int same_value(const cJSON *a, const cJSON *b) { return a && b && cJSON_Compare(a, b, 1); }

/* A valid value of row that differs from v (choice: the first other choice; bool: the other
 * one; int / number: the default, else the minimum, else the maximum). */
static cJSON *other_value(const cJSON *row, const cJSON *v)
{
    const char *type = row_str(row, "type");
    if (!strcmp(type, "choice")) {
        const cJSON *c;
        cJSON_ArrayForEach(c, cJSON_GetObjectItemCaseSensitive(row, "choices"))
            if (!same_value(c, v)) return cJSON_Duplicate(c, 1);
        return NULL;
    }
    if (!strcmp(type, "bool")) return cJSON_CreateBool(!cJSON_IsTrue(v));
    {
        const cJSON *cand[3];
        int i;
        cand[0] = row_default(row);
        cand[1] = cJSON_GetObjectItemCaseSensitive(row, "min");
        cand[2] = cJSON_GetObjectItemCaseSensitive(row, "max");
        for (i = 0; i < 3; i++)
            if (cand[i] && !same_value(cand[i], v)) return cJSON_Duplicate(cand[i], 1);
    }
    return NULL;
}

/* Condition c ({"key", "equals" | "differs"}) with the values of `set`. */
static int condition_holds(const cJSON *rows, const cJSON *set, const cJSON *c)
{
    const char *key = row_str(c, "key");
    const cJSON *eq = cJSON_GetObjectItemCaseSensitive(c, "equals");
    const cJSON *df = cJSON_GetObjectItemCaseSensitive(c, "differs");
    const cJSON *v = effective(rows, set, key);
    return eq ? same_value(v, eq) : !same_value(v, df);
}

/* A value of c's option that makes c hold (hold = 1) or fail (hold = 0); NULL if none. */
static cJSON *condition_value(const cJSON *rows, const cJSON *c, int hold)
{
    const cJSON *row = row_find(rows, row_str(c, "key"));
    const cJSON *eq = cJSON_GetObjectItemCaseSensitive(c, "equals");
    const cJSON *df = cJSON_GetObjectItemCaseSensitive(c, "differs");
    if (!row) return NULL;
    if (eq) return hold ? cJSON_Duplicate(eq, 1) : other_value(row, eq);
    return hold ? other_value(row, df) : cJSON_Duplicate(df, 1);
}

static void put(cJSON *obj, const char *key, cJSON *v)
{
    if (cJSON_GetObjectItemCaseSensitive(obj, key)) cJSON_ReplaceItemInObjectCaseSensitive(obj, key, v);
    else cJSON_AddItemToObject(obj, key, v);
}

static cJSON *merged(const cJSON *required, const cJSON *optional)
{
    cJSON *m = cJSON_Duplicate(optional, 1);
    const cJSON *it;
    cJSON_ArrayForEach(it, required) put(m, it->string, cJSON_Duplicate(it, 1));
    return m;
}

/* Makes every rule hold: a required key's unmet condition sets the condition's option
 * (required too: a prerequisite); an optional key (a cheap override) whose rule does not
 * hold is dropped. `fixed`, when given, names a key of `required` no prerequisite may change
 * (the one whose rule is under test). 0 when the rules cannot all be met. */
static int settle(const cJSON *rows, cJSON *required, cJSON *optional, const char *fixed)
{
    int round;
    for (round = 0; round < 16; round++) {
        int changed = 0;
        cJSON *all = merged(required, optional), *it, *next;
        cJSON_ArrayForEach(it, required) {
            const cJSON *row = row_find(rows, it->string), *c;
            cJSON_ArrayForEach(c, row_rule(row)) {
                const char *ck = row_str(c, "key");
                cJSON *v;
                if (condition_holds(rows, all, c)) continue;
                if ((fixed && !strcmp(ck, fixed)) || cJSON_GetObjectItemCaseSensitive(required, ck) ||
                    !(v = condition_value(rows, c, 1))) {
                    cJSON_Delete(all);
                    return 0;
                }
                put(required, ck, v);
                cJSON_DeleteItemFromObjectCaseSensitive(optional, ck);
                changed = 1;
                break;
            }
            if (changed) break;
        }
        cJSON_Delete(all);
        if (changed) continue;
        all = merged(required, optional);
        for (it = optional->child; it; it = next) {
            const cJSON *row = row_find(rows, it->string), *c;
            next = it->next;
            cJSON_ArrayForEach(c, row_rule(row))
                if (!condition_holds(rows, all, c)) {
                    cJSON_DeleteItemFromObjectCaseSensitive(optional, it->string);
                    changed = 1;
                    break;
                }
            if (changed) break;
        }
        cJSON_Delete(all);
        if (!changed) return 1;
    }
    return 0;
}

/* ---- renders ---- */

static cJSON *cheap_overrides(const char *method, const cJSON *rows)
{
    cJSON *o = cJSON_CreateObject();
    size_t i;
    for (i = 0; i < sizeof cheap / sizeof cheap[0]; i++) {
        if (strcmp(cheap[i].method, method)) continue;
        /* an entry naming no option is a failed CHECK in main */
        if (row_find(rows, cheap[i].key)) cJSON_AddItemToObject(o, cheap[i].key, cJSON_Parse(cheap[i].json));
    }
    return o;
}

static int is_sequence(const char *method, const char *key)
{
    size_t i;
    for (i = 0; i < sizeof sequence / sizeof sequence[0]; i++)
        if (!strcmp(sequence[i].method, method) && !strcmp(sequence[i].key, key)) return 1;
    return 0;
}

/* The image of `method` with options `opts` (FRAME; with seq, FRAME - 1 then FRAME by one
 * renderer, the second image); NULL (and a failed CHECK) on failure. */
static vsd_framebuffer *render(cov *t, const char *method, const cJSON *opts, int seq)
{
    vsd_scene sc = t->scene;
    char *json = cJSON_PrintUnformatted(opts);
    vsd_renderer *r;
    vsd_framebuffer *fb = NULL;
    snprintf(sc.render.method, sizeof sc.render.method, "%s", method);
    snprintf(sc.render.options_json, sizeof sc.render.options_json, "%s", json);
    r = test_make_renderer(&sc, NULL);
    CHECK_MSG(r != NULL, "%s %s: the renderer refuses the options", method, json);
    if (!r || (seq && !test_render(r, FRAME - 1, &fb, NULL)) || !test_render(r, FRAME, &fb, NULL)) {
        vsd_framebuffer_destroy(fb);
        fb = NULL;
    }
    vsd_renderer_destroy(r);
    free(json);
    return fb;
}

static const vsd_framebuffer *baseline(cov *t, const char *method, const cJSON *opts, int seq)
{
    char *json = cJSON_PrintUnformatted(opts), key[4600];
    int i;
    snprintf(key, sizeof key, "%s%s %s", method, seq ? " seq" : "", json);
    free(json);
    for (i = 0; i < t->cached; i++)
        if (!strcmp(t->cache[i].key, key)) return t->cache[i].fb;
    if (t->cached == (int)(sizeof t->cache / sizeof t->cache[0])) {
        CHECK_MSG(0, "more baselines than the cache holds: enlarge cov.cache");
        return NULL;
    }
    t->cache[t->cached].key = strdup(key);
    t->cache[t->cached].fb = render(t, method, opts, seq);
    return t->cache[t->cached++].fb;
}

/* The largest change over every pass: max |a - b| / max |b| (test_max_rel_diff). */
static double image_diff(const vsd_framebuffer *a, const vsd_framebuffer *b, const char **pass)
{
    double d = 0;
    int p;
    *pass = "";
    for (p = 0; p < VSD_PASS_COUNT; p++) {
        double dp = test_max_rel_diff(a, b, (vsd_pass)p);
        if (dp > d) {
            d = dp;
            *pass = vsd_pass_name((vsd_pass)p);
        }
    }
    return d;
}

static int declared_index(const char *method, const char *key, const char *value, const char *with)
{
    size_t i;
    for (i = 0; i < sizeof declared / sizeof declared[0]; i++)
        if (!strcmp(declared[i].method, method) && !strcmp(declared[i].key, key) &&
            !strcmp(declared[i].value, value) && !strcmp(declared[i].with, with))
            return (int)i;
    return -1;
}

/* ---- the cases ---- */

/* Value `value` of option `row` under the settings `ctx` (a JSON object, "" = none). */
static void one_case(cov *t, const char *method, const cJSON *rows, const cJSON *row, const cJSON *value,
                     const char *ctx, int *declared_seen)
{
    const char *key = row_str(row, "key");
    char vtext[160], *pre;
    cJSON *required = ctx[0] ? cJSON_Parse(ctx) : cJSON_CreateObject(), *optional = cheap_overrides(method, rows);
    cJSON *with, *base;
    int seq = is_sequence(method, key), d;
    double t0 = vsd_clock_seconds();
    if (cJSON_IsString(value)) snprintf(vtext, sizeof vtext, "%s", value->valuestring);
    else snprintf(vtext, sizeof vtext, "%s", cJSON_IsTrue(value) ? "true" : "false");
    d = declared_index(method, key, vtext, ctx);
    if (d >= 0) declared_seen[d] = 1;
    t->cases++;
    CHECK_MSG(required != NULL, "%s.%s: the context %s is not JSON", method, key, ctx);
    if (!required) required = cJSON_CreateObject();
    cJSON_DeleteItemFromObjectCaseSensitive(optional, key);
    put(required, key, cJSON_Duplicate(value, 1));
    if (!settle(rows, required, optional, NULL)) {
        CHECK_MSG(0, "%s.%s = %s: its rule's prerequisites cannot all be met", method, key, vtext);
        goto done;
    }
    with = merged(required, optional);
    /* the baseline: the prerequisites and overrides without the value (an override that
     * applies only with the value goes too) */
    cJSON_DeleteItemFromObjectCaseSensitive(required, key);
    base = cJSON_Duplicate(with, 1);
    cJSON_DeleteItemFromObjectCaseSensitive(base, key);
    {
        cJSON *none = cJSON_CreateObject();
        settle(rows, none, base, NULL);
        cJSON_Delete(none);
    }
    pre = cJSON_PrintUnformatted(base);
    {
        const vsd_framebuffer *b = baseline(t, method, base, seq);
        vsd_framebuffer *fb = render(t, method, with, seq);
        if (b && fb) {
            const char *pass;
            double diff = image_diff(fb, b, &pass);
            printf("  %-13s %-16s = %-10s against %s%s: max rel diff %.3g (%s), Combined %.3g%s, %.2f s\n", method,
                   key, vtext, pre, seq ? " (2-frame sequence)" : "", diff, pass[0] ? pass : "-",
                   test_max_rel_diff(fb, b, VSD_PASS_COMBINED),
                   d >= 0 ? (diff <= SAME_TOL ? " declared no-op: same image" : " declared no-op: DIFFERS")
                          : (diff > DIFF_TOL ? " changes the image" : " NO CHANGE"),
                   vsd_clock_seconds() - t0);
            if (d >= 0) {
                CHECK_MSG(diff <= SAME_TOL,
                          "%s.%s = %s is declared a no-op for this scene (%s) but changes the image by %.3g (%s): "
                          "remove it from declared[]", method, key, vtext, declared[d].why, diff, pass);
                t->same++;
            } else {
                CHECK_MSG(diff > DIFF_TOL,
                          "%s.%s = %s does not change the image of the test scene (max rel diff %.3g against %s): "
                          "make the scene show it, or declare it in declared[] with a reason", method, key, vtext,
                          diff, pre);
                t->differ++;
            }
        }
        vsd_framebuffer_destroy(fb);
    }
    free(pre);
    cJSON_Delete(with);
    cJSON_Delete(base);
done:
    cJSON_Delete(required);
    cJSON_Delete(optional);
}

/* Every non-default value of option `row`: under the defaults, and under each context. */
static void one_value(cov *t, const char *method, const cJSON *rows, const cJSON *row, const cJSON *value,
                      int *declared_seen, int *contexts_seen)
{
    size_t i;
    one_case(t, method, rows, row, value, "", declared_seen);
    for (i = 0; i < sizeof contexts / sizeof contexts[0]; i++)
        if (!strcmp(contexts[i].method, method) && !strcmp(contexts[i].key, row_str(row, "key"))) {
            contexts_seen[i] = 1;
            one_case(t, method, rows, row, value, contexts[i].with, declared_seen);
        }
}

/* The baseline rendered twice by fresh renderers is bit-identical: differences are the
 * options', not noise. */
static void check_deterministic(cov *t, const char *method, const cJSON *rows)
{
    cJSON *o = cheap_overrides(method, rows), *none = cJSON_CreateObject();
    const vsd_framebuffer *a;
    vsd_framebuffer *b;
    settle(rows, none, o, NULL);
    a = baseline(t, method, o, 0);
    b = render(t, method, o, 0);
    CHECK_MSG(a && b && test_identical(a, b), "%s: two renders of the same options differ: the comparison needs "
              "deterministic renders", method);
    vsd_framebuffer_destroy(b);
    cJSON_Delete(o);
    cJSON_Delete(none);
}

/* Options `opts` of `method` given to vsd_renderer_create: its status, the error in err. */
static vsd_status create_with(const cov *t, const char *method, const cJSON *opts, char *err, size_t errlen)
{
    vsd_scene sc = t->scene;
    vsd_renderer *r = NULL;
    char *json = cJSON_PrintUnformatted(opts);
    vsd_status st;
    snprintf(sc.render.method, sizeof sc.render.method, "%s", method);
    snprintf(sc.render.options_json, sizeof sc.render.options_json, "%s", json);
    err[0] = '\0';
    st = vsd_renderer_create(&sc, NULL, &r, err, errlen);
    CHECK_MSG(st != VSD_OK || r != NULL, "%s %s: VSD_OK without a renderer", method, json);
    vsd_renderer_destroy(r);
    free(json);
    return st;
}

/* Every rule: one condition broken, the others holding. The option at a value away from
 * its default is refused, the error naming it and the option that rules it out; at its
 * default written out it is accepted (the checker's rule: a default changes nothing, so
 * `vsd methods`' defaults copied into a scene stay valid). */
static void check_refusals(cov *t, const char *method, const cJSON *rows)
{
    const cJSON *row;
    cJSON_ArrayForEach(row, rows) {
        const char *key = row_str(row, "key");
        const cJSON *rule = cJSON_GetObjectItemCaseSensitive(row, "applies_when"), *c;
        cJSON_ArrayForEach(c, rule) {
            const char *ck = row_str(c, "key");
            cJSON *opts = cJSON_CreateObject(), *none = cJSON_CreateObject(), *bad, *away, *o;
            char err[1024], expect[256], *json;
            vsd_status st;
            bad = condition_value(rows, c, 0);
            away = other_value(row, row_default(row));
            CHECK_MSG(bad != NULL, "%s.%s: no value of %s breaks its rule", method, key, ck);
            CHECK_MSG(away != NULL, "%s.%s: no value but its default", method, key);
            if (!bad || !away) {
                cJSON_Delete(bad);
                cJSON_Delete(away);
                cJSON_Delete(opts);
                cJSON_Delete(none);
                continue;
            }
            /* the value that breaks the rule, with its own prerequisites */
            put(opts, ck, bad);
            CHECK_MSG(settle(rows, opts, none, NULL), "%s: %s's prerequisites", method, ck);
            /* the rule's other conditions made to hold, c's option left as it is */
            cJSON_ArrayForEach(o, rule) {
                cJSON *v;
                if (o == c || condition_holds(rows, opts, o)) continue;
                if ((v = condition_value(rows, o, 1))) put(opts, row_str(o, "key"), v);
            }
            CHECK_MSG(!condition_holds(rows, opts, c), "%s.%s: the rule's condition on %s still holds", method, key,
                      ck);
            /* the default written out: accepted */
            put(opts, key, cJSON_Duplicate(row_default(row), 1));
            json = cJSON_PrintUnformatted(opts);
            st = create_with(t, method, opts, err, sizeof err);
            CHECK_MSG(st == VSD_OK, "%s %s: the default written out is refused: %s", method, json, err);
            free(json);
            /* away from the default: refused, naming both */
            put(opts, key, away);
            json = cJSON_PrintUnformatted(opts);
            st = create_with(t, method, opts, err, sizeof err);
            snprintf(expect, sizeof expect, "render.options.%s does not apply with render.options.%s = ", key, ck);
            printf("  %-13s %-16s %s: %s\n", method, key, json, err);
            CHECK_MSG(st == VSD_ERR_INVALID, "%s %s: accepted (status %d)", method, json, (int)st);
            CHECK_CONTAINS(err, expect);
            t->refusals++;
            free(json);
            cJSON_Delete(opts);
            cJSON_Delete(none);
        }
    }
}

int main(void)
{
    static const char *const ov[] = {
        /* tiny: a few hundred pixels show every option and keep ~50 renders quick */
        "film.width=24", "film.height=16",
        /* the shipped scene is isotropic; the phase options need a phase that is not */
        "medium.anisotropy=0.5",
        /* the path tracer's samples (the fast methods take their own pixel_samples) */
        "render.samples=4", "render.seed=7",
        /* the CPU view, deterministic, and the only one view_bake and view_spacing act on
         * ("CPU view: ..."): a CUDA build on a machine with a GPU would otherwise pick it */
        "render.device=cpu"};
    static cov t;
    char *text = vsd_method_catalog_json();
    cJSON *catalog = text ? cJSON_Parse(text) : NULL;
    const cJSON *m;
    const char *const *name;
    int methods = 0, *declared_seen = calloc(sizeof declared / sizeof declared[0] + 1, sizeof(int));
    int *contexts_seen = calloc(sizeof contexts / sizeof contexts[0] + 1, sizeof(int));
    size_t i;
    double t0 = vsd_clock_seconds();
    setvbuf(stdout, NULL, _IOLBF, 0);
    CHECK(catalog != NULL && cJSON_IsArray(catalog));
    if (!catalog || !test_load_scene(SCENE, ov, (int)(sizeof ov / sizeof ov[0]), &t.scene))
        return test_finish("test_option_coverage");
    /* the catalog and vsd_method_names() are the same list */
    for (name = vsd_method_names(); *name; name++) {
        int found = 0;
        cJSON_ArrayForEach(m, catalog) found |= !strcmp(row_str(m, "name"), *name);
        CHECK_MSG(found, "%s is not in the method catalog", *name);
    }
    cJSON_ArrayForEach(m, catalog) {
        const char *method = row_str(m, "name");
        const cJSON *rows = cJSON_GetObjectItemCaseSensitive(m, "options"), *row;
        int before = t.cases;
        double tm = vsd_clock_seconds();
        methods++;
        printf("%s\n", method);
        cJSON_ArrayForEach(row, rows) {
            const char *key = row_str(row, "key"), *type = row_str(row, "type");
            const cJSON *def = row_default(row);
            if (!strcmp(type, "bool")) {
                cJSON *v = cJSON_CreateBool(!cJSON_IsTrue(def));
                CHECK_MSG(cJSON_IsBool(def), "%s.%s: a bool without a bool default", method, key);
                one_value(&t, method, rows, row, v, declared_seen, contexts_seen);
                cJSON_Delete(v);
            } else if (!strcmp(type, "choice")) {
                const cJSON *c;
                int n = 0;
                cJSON_ArrayForEach(c, cJSON_GetObjectItemCaseSensitive(row, "choices")) {
                    n++;
                    if (!same_value(c, def)) one_value(&t, method, rows, row, c, declared_seen, contexts_seen);
                }
                CHECK_MSG(n >= 2, "%s.%s: a choice of %d values", method, key, n);
            } else {
                /* int and number are ranges, not values to enumerate; anything else is a type
                 * this test does not know how to exercise yet */
                CHECK_MSG(!strcmp(type, "int") || !strcmp(type, "number"),
                          "%s.%s has type \"%s\", which this test does not exercise: extend it", method, key, type);
            }
        }
        if (t.cases > before) check_deterministic(&t, method, rows);
        check_refusals(&t, method, rows);
        printf("  %s: %d values, %.1f s\n", method, t.cases - before, vsd_clock_seconds() - tm);
    }
    for (i = 0; i < sizeof declared / sizeof declared[0]; i++)
        CHECK_MSG(declared_seen[i], "declared[] names %s.%s = %s (with %s), which is no case: remove it",
                  declared[i].method, declared[i].key, declared[i].value, declared[i].with);
    for (i = 0; i < sizeof contexts / sizeof contexts[0]; i++)
        CHECK_MSG(contexts_seen[i], "contexts[] names %s.%s, which is no BOOL or CHOICE option: remove it",
                  contexts[i].method, contexts[i].key);
    for (i = 0; i < sizeof cheap / sizeof cheap[0]; i++) {
        int found = 0;
        cJSON_ArrayForEach(m, catalog)
            if (!strcmp(row_str(m, "name"), cheap[i].method))
                found = row_find(cJSON_GetObjectItemCaseSensitive(m, "options"), cheap[i].key) != NULL;
        CHECK_MSG(found, "cheap[] names %s.%s, which is no option: update it", cheap[i].method, cheap[i].key);
    }
    for (i = 0; i < sizeof sequence / sizeof sequence[0]; i++) {
        int found = 0;
        cJSON_ArrayForEach(m, catalog)
            if (!strcmp(row_str(m, "name"), sequence[i].method))
                found = row_find(cJSON_GetObjectItemCaseSensitive(m, "options"), sequence[i].key) != NULL;
        CHECK_MSG(found, "sequence[] names %s.%s, which is no option: remove it", sequence[i].method, sequence[i].key);
    }
    CHECK(methods >= 1);
    printf("%d methods, %d (method, option, value) cases: %d change the image, %d declared no-ops the same; "
           "%d rule refusals; %.1f s\n", methods, t.cases, t.differ, t.same, t.refusals, vsd_clock_seconds() - t0);
    for (i = 0; i < (size_t)t.cached; i++) {
        free(t.cache[i].key);
        vsd_framebuffer_destroy(t.cache[i].fb);
    }
    free(declared_seen);
    free(contexts_seen);
    cJSON_Delete(catalog);
    free(text);
    return test_finish("test_option_coverage");
}
