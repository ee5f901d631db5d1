/* Farm options out, render options kept (farm_args.h). */
#include "farm_args.h"
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* `vsd render` arguments that stand alone. Every other "--name" (and "-o") takes the next
 * argument as its value, as in `vsd render`; "+W640", "-D" (POV-Ray switches) and
 * "--name=value" are single arguments. Knowing this keeps a render value that happens to
 * look like a farm option ("--set" "--chunk=...") with its render option. */
static int render_flag_alone(const char *arg)
{
    static const char *const alone[] = {"--quiet", "-q", "--continue", "--help", "-h", "--remote"};
    size_t k;
    for (k = 0; k < sizeof alone / sizeof alone[0]; k++)
        if (strcmp(arg, alone[k]) == 0) return 1;
    if (arg[0] != '-' || strchr(arg, '=')) return 1;
    if (arg[1] != '-') return strcmp(arg, "-o") != 0; /* POV-Ray "-X" switches */
    return 0;
}

/* "--name" matches "--name" (value in the next argument) or "--name=value". */
static int farm_option(const char *arg, const char *name, const char **inline_value)
{
    size_t n = strlen(name);
    if (strncmp(arg, name, n) != 0) return 0;
    if (arg[n] == '\0') { *inline_value = NULL; return 1; }
    if (arg[n] == '=') { *inline_value = arg + n + 1; return 1; }
    return 0;
}

static int positive_int(const char *name, const char *text, const char *what, int *out, char *err,
                        size_t errlen)
{
    char *end;
    long v;
    errno = 0;
    v = strtol(text, &end, 10);
    if (!text[0] || *end || errno || v < 1 || v > INT_MAX / 2) {
        snprintf(err, errlen, "%s: expected a whole number of %s >= 1, got '%s'", name, what, text);
        return -1;
    }
    *out = (int)v;
    return 0;
}

/* An #SBATCH line carries one option; a newline would smuggle in a second (or a command). */
static int sbatch_line_ok(const char *name, const char *v, char *err, size_t errlen)
{
    if (!v[0] || strpbrk(v, "\n\r")) {
        snprintf(err, errlen, "%s: expected one non-empty line, got '%s'", name, v);
        return -1;
    }
    return 0;
}

int vsd_farm_args_split(int argc, char **argv, vsd_farm_args *fa, char *err, size_t errlen)
{
    static const char *const valued[] = {"--frames", "--chunk", "--partition", "--cpus",
                                         "--log-dir", "--sbatch"};
    int i;
    memset(fa, 0, sizeof *fa);
    fa->render_argv[fa->render_argc++] = "render";
    for (i = 1; i < argc; i++) {
        const char *arg = argv[i], *val = NULL;
        size_t k;
        int which = -1;
        if (strcmp(arg, "--submit") == 0) { fa->submit = 1; continue; }
        if (strcmp(arg, "--help") == 0 || strcmp(arg, "-h") == 0) { fa->help = 1; continue; }
        for (k = 0; k < sizeof valued / sizeof valued[0] && which < 0; k++)
            if (farm_option(arg, valued[k], &val)) which = (int)k;
        if (which < 0) {
            /* A render argument, with its value when it takes one. */
            int n = render_flag_alone(arg) || i + 1 >= argc ? 1 : 2;
            if (fa->render_argc + n > VSD_FARM_MAX_ARGS) {
                snprintf(err, errlen, "too many arguments (at most %d)", VSD_FARM_MAX_ARGS - 1);
                return -1;
            }
            while (n--) fa->render_argv[fa->render_argc++] = argv[i++];
            i--;
            continue;
        }
        if (!val) {
            if (i + 1 >= argc) {
                snprintf(err, errlen, "%s needs a value", valued[which]);
                return -1;
            }
            val = argv[++i];
        }
        switch (which) {
        case 0: fa->frames = val; break;
        case 1: if (positive_int("--chunk", val, "frames", &fa->chunk, err, errlen)) return -1; break;
        case 2:
            if (!val[0] || strpbrk(val, " \t\n\r'\"\\")) {
                snprintf(err, errlen, "--partition: expected a partition name, got '%s'", val);
                return -1;
            }
            fa->partition = val;
            break;
        case 3: if (positive_int("--cpus", val, "CPUs", &fa->cpus, err, errlen)) return -1; break;
        case 4: fa->log_dir = val; break;
        case 5:
            if (sbatch_line_ok("--sbatch", val, err, errlen)) return -1;
            if (val[0] != '-') {
                snprintf(err, errlen, "--sbatch: expected an sbatch option such as --time=2:00:00, got '%s'", val);
                return -1;
            }
            if (fa->sbatch_count >= VSD_FARM_MAX_SBATCH) {
                snprintf(err, errlen, "--sbatch: at most %d", VSD_FARM_MAX_SBATCH);
                return -1;
            }
            fa->sbatch[fa->sbatch_count++] = val;
            break;
        }
    }
    return 0;
}
