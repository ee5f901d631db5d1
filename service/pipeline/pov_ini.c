/* Reading POV-Ray INI files (pov_ini.h). */
#include "pov_ini.h"
#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#define LINE_MAX_LEN 4096

int vsd_pov_is_ini(const char *arg)
{
    const char *end = strchr(arg, '[');
    size_t n = end ? (size_t)(end - arg) : strlen(arg);
    if (end && arg[strlen(arg) - 1] != ']') return 0;
    return n > 4 && strncasecmp(arg + n - 4, ".ini", 4) == 0;
}

void vsd_pov_ini_path(const char *spec, char *out, size_t outlen)
{
    const char *end = strchr(spec, '[');
    snprintf(out, outlen, "%.*s", end ? (int)(end - spec) : (int)strlen(spec), spec);
}

static char *trim(char *s)
{
    char *e;
    while (isspace((unsigned char)*s)) s++;
    e = s + strlen(s);
    while (e > s && isspace((unsigned char)e[-1])) *--e = '\0';
    return s;
}

/* "Key = "va lue"" -> "Key=va lue"; a line without '=' is returned as it is. */
static void normalise_item(char *line, char *out, size_t outlen)
{
    char *eq = strchr(line, '=');
    char *key, *value;
    size_t vn;
    if (!eq) {
        snprintf(out, outlen, "%s", line);
        return;
    }
    *eq = '\0';
    key = trim(line);
    value = trim(eq + 1);
    vn = strlen(value);
    if (vn >= 2 && (value[0] == '"' || value[0] == '\'') && value[vn - 1] == value[0]) {
        value[vn - 1] = '\0';
        value++;
    }
    snprintf(out, outlen, "%s=%s", key, value);
}

/* Strip a ';' comment that is not inside quotes. */
static void strip_comment(char *line)
{
    char quote = 0;
    for (char *p = line; *p; p++) {
        if (quote) {
            if (*p == quote) quote = 0;
        } else if (*p == '"' || *p == '\'') {
            quote = *p;
        } else if (*p == ';') {
            *p = '\0';
            return;
        }
    }
}

/* Splits a switch line ("+W640 +H360 -D") at blanks and hands each switch on. */
static int each_switch(char *line, int lineno, vsd_pov_item_fn fn, void *user, char *err, size_t errlen)
{
    char *save = NULL;
    for (char *tok = strtok_r(line, " \t", &save); tok; tok = strtok_r(NULL, " \t", &save))
        if (fn(user, tok, lineno, err, errlen)) return -1;
    return 0;
}

int vsd_pov_ini_read(const char *spec, vsd_pov_item_fn fn, void *user, char *err, size_t errlen)
{
    char path[4096], want[256] = "", buf[LINE_MAX_LEN + 2], item[LINE_MAX_LEN + 2], inner[512];
    const char *open = strchr(spec, '[');
    int lineno = 0, in_wanted = 1, found = 0;
    FILE *f;
    vsd_pov_ini_path(spec, path, sizeof path);
    if (open) snprintf(want, sizeof want, "%.*s", (int)strlen(open + 1) - 1, open + 1);
    f = fopen(path, "r");
    if (!f) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    while (fgets(buf, sizeof buf, f)) {
        char *line;
        lineno++;
        if (!strchr(buf, '\n') && !feof(f)) {
            snprintf(err, errlen, "%s:%d: line longer than %d characters", path, lineno, LINE_MAX_LEN);
            fclose(f);
            return -1;
        }
        strip_comment(buf);
        line = trim(buf);
        if (!*line) continue;
        if (line[0] == '[') {
            char *close = strchr(line, ']');
            if (!close || close[1]) {
                snprintf(err, errlen, "%s:%d: a section label is [Name], got '%s'", path, lineno, line);
                fclose(f);
                return -1;
            }
            snprintf(inner, sizeof inner, "%.*s", (int)(close - line - 1), line + 1);
            in_wanted = want[0] && strcasecmp(trim(inner), want) == 0;
            found |= in_wanted;
            continue;
        }
        if (!in_wanted) continue;
        {
            char where[4200];
            int rc;
            snprintf(where, sizeof where, "%s:%d: ", path, lineno);
            if (line[0] == '+' || line[0] == '-') {
                rc = each_switch(line, lineno, fn, user, err, errlen);
            } else {
                normalise_item(line, item, sizeof item);
                rc = fn(user, item, lineno, err, errlen);
            }
            if (rc) {
                /* Put the file and line in front of the handler's message. */
                char msg[2048];
                snprintf(msg, sizeof msg, "%s", err);
                snprintf(err, errlen, "%s%s", where, msg);
                fclose(f);
                return -1;
            }
        }
    }
    fclose(f);
    if (want[0] && !found) {
        snprintf(err, errlen, "%s: no section [%s] in the file", path, want);
        return -1;
    }
    return 0;
}
