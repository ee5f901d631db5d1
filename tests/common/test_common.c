#include "test_common.h"
#include <stdlib.h>

int vsd_test_failures = 0;

/* $VSD_SHARED_DATA overrides the build's path, so a test binary carried to another machine
 * (scripts/gpu-bundle.sh) reads the data files that travel with it. */
const char *test_data(const char *rel)
{
    static char buf[2048];
    const char *dir = getenv("VSD_SHARED_DATA");
    snprintf(buf, sizeof buf, "%s/%s", dir && *dir ? dir : VSD_SHARED_DATA, rel);
    return buf;
}

const char *test_tmp(const char *rel)
{
    static char buf[2048];
    snprintf(buf, sizeof buf, "%s/%s", VSD_TEST_TMP, rel);
    return buf;
}

const char *test_tmp_in(const char *folder, const char *name)
{
    static char buf[2][2048];
    static int k;
    k ^= 1;
    snprintf(buf[k], sizeof buf[k], "%s/%s/%s", VSD_TEST_TMP, folder, name);
    return buf[k];
}

void test_copy_prefix(const char *src, const char *dst, size_t keep)
{
    FILE *in = fopen(src, "rb"), *out = fopen(dst, "wb");
    char buf[65536];
    size_t n;
    while (in && out && keep && (n = fread(buf, 1, keep < sizeof buf ? keep : sizeof buf, in)) > 0) {
        fwrite(buf, 1, n, out);
        keep -= n;
    }
    if (in)
        fclose(in);
    if (out)
        fclose(out);
}

double test_urand(unsigned long long *state)
{
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*state >> 11) * (1.0 / 9007199254740992.0);
}

void test_random_dir(unsigned long long *state, double d[3])
{
    double z = 2 * test_urand(state) - 1, phi = 2 * 3.14159265358979323846 * test_urand(state), s = sqrt(1 - z * z);
    d[0] = s * cos(phi);
    d[1] = s * sin(phi);
    d[2] = z;
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

unsigned char *test_read_file(const char *path, long *size)
{
    FILE *f = fopen(path, "rb");
    unsigned char *buf = NULL;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (*size = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0 &&
        (buf = malloc((size_t)*size)) && fread(buf, 1, (size_t)*size, f) != (size_t)*size) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    return buf;
}
