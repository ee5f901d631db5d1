/* The one checker of method options (method_options.h). */
#include "method_options.h"
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

static void put_int(void *out, size_t off, int v) { memcpy((char *)out + off, &v, sizeof v); }
static void put_double(void *out, size_t off, double v) { memcpy((char *)out + off, &v, sizeof v); }

static void put_default(const vsd_option_spec *s, void *out)
{
    if (s->type == VSD_OPT_NUMBER) put_double(out, s->offset, s->def);
    else put_int(out, s->offset, (int)s->def);
}

/* "a", "b", "c" for error messages */
static void list_choices(const vsd_option_spec *s, char *buf, size_t len)
{
    const char *const *c;
    buf[0] = '\0';
    for (c = s->choices; c && *c; c++) {
        size_t used = strlen(buf);
        snprintf(buf + used, len - used, "%s\"%s\"", c == s->choices ? "" : ", ", *c);
    }
}

static void list_keys(const vsd_option_table *t, char *buf, size_t len)
{
    size_t i;
    buf[0] = '\0';
    for (i = 0; i < t->count; i++) {
        size_t used = strlen(buf);
        snprintf(buf + used, len - used, "%s%s", i ? ", " : "", t->rows[i].key);
    }
}

static const vsd_option_spec *find_row(const vsd_option_table *t, const char *key)
{
    size_t i;
    for (i = 0; i < t->count; i++)
        if (strcmp(t->rows[i].key, key) == 0) return &t->rows[i];
    return NULL;
}

static vsd_status read_number(const vsd_option_spec *s, const cJSON *it, double *v, char *err, size_t errlen)
{
    if (!cJSON_IsNumber(it) || !isfinite(it->valuedouble))
        return vsd_fail(VSD_ERR_TYPE, err, errlen, "render.options.%s: expected %s", s->key,
                        s->type == VSD_OPT_INT ? "integer" : "a finite number");
    *v = it->valuedouble;
    if (s->type == VSD_OPT_INT && *v != floor(*v))
        return vsd_fail(VSD_ERR_TYPE, err, errlen, "render.options.%s: expected integer, got %g", s->key, *v);
    if ((s->flags & VSD_OPT_ZERO_AUTO) && *v == 0.0) return VSD_OK;
    if ((s->flags & VSD_OPT_ZERO_AUTO) && !(*v > s->min && *v <= s->max))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "render.options.%s: %g is out of range (%g, %g] (0 = automatic)",
                        s->key, *v, s->min, s->max);
    if (!(*v >= s->min && *v <= s->max))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "render.options.%s: %g is out of range %g..%g", s->key, *v, s->min,
                        s->max);
    if (s->check) {
        const char *why = s->check(*v);
        if (why) return vsd_fail(VSD_ERR_INVALID, err, errlen, "render.options.%s: %g %s", s->key, *v, why);
    }
    return VSD_OK;
}

static vsd_status read_value(const vsd_option_spec *s, const cJSON *it, void *out, char *err, size_t errlen)
{
    char list[256];
    double v = 0.0;
    vsd_status st;
    int i;
    switch (s->type) {
    case VSD_OPT_BOOL:
        if (!cJSON_IsBool(it))
            return vsd_fail(VSD_ERR_TYPE, err, errlen, "render.options.%s: expected boolean (true or false)", s->key);
        put_int(out, s->offset, cJSON_IsTrue(it) ? 1 : 0);
        return VSD_OK;
    case VSD_OPT_CHOICE:
        list_choices(s, list, sizeof list);
        if (!cJSON_IsString(it))
            return vsd_fail(VSD_ERR_TYPE, err, errlen, "render.options.%s: expected a string, one of %s", s->key, list);
        for (i = 0; s->choices[i]; i++)
            if (strcmp(s->choices[i], it->valuestring) == 0) {
                put_int(out, s->offset, i);
                return VSD_OK;
            }
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "render.options.%s: \"%.64s\" is not one of %s", s->key,
                        it->valuestring, list);
    case VSD_OPT_INT:
    case VSD_OPT_NUMBER:
        if ((st = read_number(s, it, &v, err, errlen))) return st;
        if (s->type == VSD_OPT_INT) put_int(out, s->offset, (int)v);
        else put_double(out, s->offset, v);
        return VSD_OK;
    }
    return vsd_fail(VSD_ERR_INTERNAL, err, errlen, "render.options.%s: bad option type", s->key);
}

static double get_value(const vsd_option_spec *s, const void *out)
{
    double d;
    int i;
    if (s->type == VSD_OPT_NUMBER) {
        memcpy(&d, (const char *)out + s->offset, sizeof d);
        return d;
    }
    memcpy(&i, (const char *)out + s->offset, sizeof i);
    return i;
}

/* The index of choice `name` in row s, -1 when it is none of them. */
static int choice_index(const vsd_option_spec *s, const char *name)
{
    int i;
    for (i = 0; s->choices && s->choices[i]; i++)
        if (strcmp(s->choices[i], name) == 0) return i;
    return -1;
}

static int condition_holds(const vsd_option_spec *other, const vsd_option_when *w, const void *out)
{
    double want = other->type == VSD_OPT_CHOICE ? choice_index(other, w->choice) : w->number;
    return (get_value(other, out) == want) != (w->differs != 0);
}

/* "block_steps = 4" / "lattice = \"d3q18\"": the value an option has in out. */
static void value_text(const vsd_option_spec *s, const void *out, char *buf, size_t len)
{
    double v = get_value(s, out);
    if (s->type == VSD_OPT_CHOICE) snprintf(buf, len, "%s = \"%s\"", s->key, s->choices[(int)v]);
    else if (s->type == VSD_OPT_BOOL) snprintf(buf, len, "%s = %s", s->key, v != 0.0 ? "true" : "false");
    else snprintf(buf, len, "%s = %g", s->key, v);
}

static void condition_text(const vsd_option_spec *other, const vsd_option_when *w, char *buf, size_t len)
{
    const char *op = w->differs ? "!=" : "=";
    if (other && other->type == VSD_OPT_CHOICE) snprintf(buf, len, "%s %s \"%s\"", w->key, op, w->choice);
    else if (other && other->type == VSD_OPT_BOOL) snprintf(buf, len, "%s %s %s", w->key, op, w->number != 0.0 ? "true" : "false");
    else snprintf(buf, len, "%s %s %g", w->key, op, w->number);
}

void vsd_option_rule_text(const vsd_option_table *t, const vsd_option_spec *s, char *buf, size_t len)
{
    const vsd_option_when *w;
    buf[0] = '\0';
    for (w = s->when; w && w->key; w++) {
        char one[160];
        size_t used = strlen(buf);
        condition_text(find_row(t, w->key), w, one, sizeof one);
        snprintf(buf + used, len - used, "%s%s", w == s->when ? "" : " and ", one);
    }
}

int vsd_option_rules_invalid(const vsd_option_table *t, char *why, size_t len)
{
    size_t i;
    for (i = 0; i < t->count; i++) {
        const vsd_option_when *w;
        for (w = t->rows[i].when; w && w->key; w++) {
            const vsd_option_spec *o = find_row(t, w->key);
            if (!o || o == &t->rows[i]) {
                snprintf(why, len, "%s: its rule names %s option '%s'", t->rows[i].key, o ? "itself as" : "no",
                         w->key);
                return 1;
            }
            if ((o->type == VSD_OPT_CHOICE) != (w->choice != NULL) ||
                (o->type == VSD_OPT_CHOICE && choice_index(o, w->choice) < 0)) {
                snprintf(why, len, "%s: its rule's value for '%s' is not one of that option's", t->rows[i].key,
                         w->key);
                return 1;
            }
        }
    }
    return 0;
}

/* Every key set in root away from its default whose rule does not hold with the values in
 * out: an error naming it, the option that rules it out and that option's value. (A default
 * written out changes nothing, so it is no lie: `vsd methods`' defaults copied into a
 * scene file stay valid.) */
static vsd_status check_rules(const vsd_option_table *t, const cJSON *root, const void *out, char *err,
                              size_t errlen)
{
    const cJSON *it;
    cJSON_ArrayForEach(it, root) {
        const vsd_option_spec *s = find_row(t, it->string);
        const vsd_option_when *w;
        if (get_value(s, out) == s->def) continue;
        for (w = s->when; w && w->key; w++) {
            const vsd_option_spec *other = find_row(t, w->key);
            char have[160], rule[480];
            if (!other || condition_holds(other, w, out)) continue;
            value_text(other, out, have, sizeof have);
            vsd_option_rule_text(t, s, rule, sizeof rule);
            return vsd_fail(VSD_ERR_INVALID, err, errlen,
                            "render.options.%s does not apply with render.options.%s%s (it applies only when %s)",
                            s->key, have, cJSON_GetObjectItemCaseSensitive(root, other->key) ? "" : " (the default)",
                            rule);
        }
    }
    return VSD_OK;
}

vsd_status vsd_options_parse(const vsd_option_table *t, const char *method, const char *options_json, void *out,
                             char *err, size_t errlen)
{
    cJSON *root = cJSON_Parse(options_json && options_json[0] ? options_json : "{}");
    const cJSON *it;
    vsd_status st = VSD_OK;
    size_t i;
    memset(out, 0, t->struct_size);
    for (i = 0; i < t->count; i++) put_default(&t->rows[i], out);
    if (!root || !cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "render.options: not a JSON object");
    }
    cJSON_ArrayForEach(it, root) {
        const vsd_option_spec *s = find_row(t, it->string);
        if (!s) {
            char known[1024];
            list_keys(t, known, sizeof known);
            st = vsd_fail(VSD_ERR_INVALID, err, errlen, "render.options.%s: unknown option for method %s (known: %s)",
                          it->string, method, known[0] ? known : "none");
            break;
        }
        if ((st = read_value(s, it, out, err, errlen))) break;
    }
    if (!st) st = check_rules(t, root, out, err, errlen);
    cJSON_Delete(root);
    return st;
}

static const char *type_name(vsd_option_type t)
{
    switch (t) {
    case VSD_OPT_INT: return "int";
    case VSD_OPT_NUMBER: return "number";
    case VSD_OPT_BOOL: return "bool";
    case VSD_OPT_CHOICE: return "choice";
    }
    return "?";
}

/* [{"key": other, "equals" | "differs": value}, ...]: the value as its option's JSON type. */
static void add_rule_json(const vsd_option_table *t, const vsd_option_spec *s, cJSON *arr)
{
    const vsd_option_when *w;
    for (w = s->when; arr && w->key; w++) {
        const vsd_option_spec *other = find_row(t, w->key);
        cJSON *c = cJSON_CreateObject();
        const char *op = w->differs ? "differs" : "equals";
        cJSON_AddStringToObject(c, "key", w->key);
        if (w->choice) cJSON_AddStringToObject(c, op, w->choice);
        else if (other && other->type == VSD_OPT_BOOL) cJSON_AddBoolToObject(c, op, w->number != 0.0);
        else cJSON_AddNumberToObject(c, op, w->number);
        cJSON_AddItemToArray(arr, c);
    }
}

void *vsd_options_table_json(const vsd_option_table *t)
{
    cJSON *arr = cJSON_CreateArray();
    size_t i;
    for (i = 0; arr && i < t->count; i++) {
        const vsd_option_spec *s = &t->rows[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "key", s->key);
        cJSON_AddStringToObject(o, "type", type_name(s->type));
        if (s->type == VSD_OPT_INT || s->type == VSD_OPT_NUMBER) {
            cJSON_AddNumberToObject(o, "min", s->min);
            cJSON_AddNumberToObject(o, "max", s->max);
            cJSON_AddNumberToObject(o, "default", s->def);
        } else if (s->type == VSD_OPT_BOOL) {
            cJSON_AddBoolToObject(o, "default", s->def != 0.0);
        } else {
            cJSON *c = cJSON_AddArrayToObject(o, "choices");
            const char *const *ch;
            for (ch = s->choices; ch && *ch; ch++) cJSON_AddItemToArray(c, cJSON_CreateString(*ch));
            cJSON_AddStringToObject(o, "default", s->choices[(int)s->def]);
        }
        if (s->flags & VSD_OPT_ZERO_AUTO) cJSON_AddBoolToObject(o, "auto_zero", 1);
        if (s->flags & VSD_OPT_LENGTH) cJSON_AddStringToObject(o, "unit", "length");
        if (s->when) add_rule_json(t, s, cJSON_AddArrayToObject(o, "applies_when"));
        cJSON_AddStringToObject(o, "doc", s->doc);
        cJSON_AddItemToArray(arr, o);
    }
    return arr;
}
