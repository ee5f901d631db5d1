#include "test_common.h"
#include <stdlib.h>

int vsd_test_failures = 0;

const char *test_data(const char *rel)
{
    static char buf[2048];
    snprintf(buf, sizeof buf, "%s/%s", VSD_SHARED_DATA, rel);
    return buf;
}

const char *test_tmp(const char *rel)
{
    static char buf[2048];
    snprintf(buf, sizeof buf, "%s/%s", VSD_TEST_TMP, rel);
    return buf;
}

int test_finish(const char *name)
{
    if (vsd_test_failures) {
        fprintf(stderr, "%s: %d check(s) failed\n", name, vsd_test_failures);
        return 1;
    }
    printf("%s: all checks passed\n", name);
    return 0;
}
