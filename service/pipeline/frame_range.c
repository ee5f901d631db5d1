/* "A-B" / "N" frame ranges (frame_range.h). */
#include "frame_range.h"
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int parse_int(const char *s, size_t len, int *out)
{
    char buf[32], *end;
    long v;
    if (len == 0 || len >= sizeof buf) return -1;
    memcpy(buf, s, len);
    buf[len] = '\0';
    errno = 0;
    v = strtol(buf, &end, 10);
    if (*end || errno || v < INT_MIN / 2 || v > INT_MAX / 2) return -1;
    *out = (int)v;
    return 0;
}

int vsd_parse_frame_range(const char *text, int *first, int *last, char *err, size_t errlen)
{
    /* The dash that separates is the first one after the first character (a leading
     * minus belongs to the number). */
    const char *dash = text[0] ? strchr(text + 1, '-') : NULL;
    int a, b;
    if (dash ? parse_int(text, (size_t)(dash - text), &a) || parse_int(dash + 1, strlen(dash + 1), &b)
             : parse_int(text, strlen(text), &a)) {
        snprintf(err, errlen, "expected A-B or N, got '%s'", text);
        return -1;
    }
    if (!dash) b = a;
    if (b < a) {
        snprintf(err, errlen, "'%s': end %d before start %d", text, b, a);
        return -1;
    }
    *first = a;
    *last = b;
    return 0;
}
