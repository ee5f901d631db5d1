/* method_options.h — each method declares its render.options as one table of
 * vsd_option_spec rows (key, type, range, default, choices, a one-line doc, and where the
 * value goes in the method's option struct). One checker reads scene->render.options_json
 * against the table and fills the struct; the same table is what `vsd methods`, the
 * daemon's HELLO and the Blender add-on's panel show. Adding an option is one row. */
#ifndef VSD_METHOD_OPTIONS_H
#define VSD_METHOD_OPTIONS_H
#include "vsd/status.h"
#include <stddef.h>

typedef enum vsd_option_type {
    VSD_OPT_INT,     /* an int in the struct; JSON number without a fraction */
    VSD_OPT_NUMBER,  /* a double in the struct; finite JSON number */
    VSD_OPT_BOOL,    /* an int (0/1) in the struct; JSON true/false */
    VSD_OPT_CHOICE   /* an int in the struct: the index into choices; JSON string */
} vsd_option_type;

enum {
    VSD_OPT_ZERO_AUTO = 1u << 0, /* INT, NUMBER: 0 (the default) means "chosen from the
                                    volume"; otherwise the value must be > min */
    VSD_OPT_LENGTH = 1u << 1     /* NUMBER: a length in world units (the add-on shows metres) */
};

/* One condition of an option's "applies when" rule: the option `key` of the same table
 * equals (or, with `differs`, does not equal) a value: `choice` for a CHOICE option, else
 * `number` (BOOL: 0/1). A rule is an array of conditions ended by {NULL}; all must hold. */
typedef struct vsd_option_when {
    const char *key;
    int differs;
    double number;
    const char *choice;
} vsd_option_when;

typedef struct vsd_option_spec {
    const char *key;
    vsd_option_type type;
    double min, max;                      /* INT, NUMBER: accepted range, inclusive */
    double def;                           /* INT, NUMBER, BOOL (0/1); CHOICE: index into choices */
    const char *const *choices;           /* CHOICE: NULL-terminated */
    const char *doc;                      /* one line: what it does, and its unit */
    size_t offset;                        /* offsetof(the method's option struct, field) */
    unsigned flags;
    /* an extra rule on a valid-range number: NULL when v is fine, else what is wrong */
    const char *(*check)(double v);
    /* NULL: always applies. Else the option only means something when every condition
     * holds (with the values set or defaulted); setting it away from its default otherwise
     * is an error naming both options, as a value silently ignored would be a lie. */
    const vsd_option_when *when;
} vsd_option_spec;

/* A method's table: rows, their count, and the size of the struct they fill. */
typedef struct vsd_option_table {
    const vsd_option_spec *rows;
    size_t count;
    size_t struct_size;
} vsd_option_table;

#define VSD_OPTION_TABLE(rows, type) { rows, sizeof rows / sizeof rows[0], sizeof(type) }

/* Rows every method on the shared view march (kernel/kernel_march.h) declares the same way. */
#define VSD_OPTION_PIXEL_SAMPLES(type) \
    {"pixel_samples", VSD_OPT_INT, 1, 16, 1, NULL, "n: n x n stratified view rays per pixel", \
     offsetof(type, pixel_samples), 0, NULL, NULL}
#define VSD_OPTION_EARLY_TERMINATION(type, what) \
    {"early_termination", VSD_OPT_NUMBER, 0, 1, 1e-3, NULL, \
     "stop a " what " once its transmittance is below this (0 = never; bound in kernel_march.h)", \
     offsetof(type, early_termination), 0, NULL, NULL}

/* Fills out (struct_size bytes) with every default, then with the values options_json
 * sets. An unknown key, a wrong type, a value out of range or not among the choices is an
 * error naming render.options.<key> and what it accepts; a key set away from its default
 * where its `when` rule does not hold is an error naming it and the option that rules it
 * out. */
vsd_status vsd_options_parse(const vsd_option_table *t, const char *method, const char *options_json, void *out,
                             char *err, size_t errlen);

/* The table as a JSON array (cJSON *, returned as void * so this header needs no cJSON):
 * [{"key", "type", "min", "max", "default", "choices", "doc", "auto_zero", "unit",
 * "applies_when": [{"key", "equals" | "differs": value}, ...]}, ...]. */
void *vsd_options_table_json(const vsd_option_table *t);

/* "lattice = \"d3q6\" and block_steps = 0": row s's rule in words, into buf ("" when
 * it has none), for `vsd methods` and error messages. */
void vsd_option_rule_text(const vsd_option_table *t, const vsd_option_spec *s, char *buf, size_t len);

/* A rule naming an option its table lacks, or a condition's value of the wrong kind: the
 * first such problem in words into why, 1; else 0. For the tests over the registry. */
int vsd_option_rules_invalid(const vsd_option_table *t, char *why, size_t len);

#endif
