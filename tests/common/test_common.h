/* Minimal test harness: CHECK macros that report file:line and keep going, a failure
 * count that becomes the exit status, and helpers for data paths and temp files. */
#ifndef VSD_TEST_COMMON_H
#define VSD_TEST_COMMON_H
#include <stdio.h>
#include <string.h>
#include <math.h>

extern int vsd_test_failures;

#define CHECK(cond) do { if (!(cond)) { vsd_test_failures++; \
    fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); } } while (0)
#define CHECK_MSG(cond, ...) do { if (!(cond)) { vsd_test_failures++; \
    fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond); \
    fprintf(stderr, __VA_ARGS__); fputc('\n', stderr); } } while (0)
#define CHECK_NEAR(a, b, tol) do { double va_ = (a), vb_ = (b); \
    if (!(fabs(va_ - vb_) <= (tol))) { vsd_test_failures++; \
    fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.9g, %s = %.9g, tol %.3g\n", \
            __FILE__, __LINE__, #a, va_, #b, vb_, (double)(tol)); } } while (0)
/* err must contain needle (case-sensitive). */
#define CHECK_CONTAINS(hay, needle) do { const char *h_ = (hay); \
    if (!h_ || !strstr(h_, (needle))) { vsd_test_failures++; \
    fprintf(stderr, "%s:%d: expected \"%s\" in \"%s\"\n", __FILE__, __LINE__, (needle), h_ ? h_ : "(null)"); } } while (0)

/* Path under ../shared/data (static buffer, valid until the next call). */
const char *test_data(const char *rel);
/* Path under the build's test-tmp folder (static buffer, valid until the next call). */
const char *test_tmp(const char *rel);
/* Path folder/name under the build's test-tmp folder; two buffers used in turn, so two such
 * paths can be arguments of one call (each valid until the second call after it). */
const char *test_tmp_in(const char *folder, const char *name);
/* Copy the first `keep` bytes of src to dst ((size_t)-1: all of it), as a truncated file for
 * the readers' error paths; nothing happens when either file cannot be opened. */
void test_copy_prefix(const char *src, const char *dst, size_t keep);
/* Reproducible randomness for tests: a uniform number in [0, 1) from a 64-bit LCG whose
 * state the caller keeps (and seeds), and a uniformly distributed unit direction. */
double test_urand(unsigned long long *state);
void test_random_dir(unsigned long long *state, double d[3]);

/* Return the exit status: 0 when no CHECK failed. Prints a summary. */
int test_finish(const char *name);
/* A whole file into a malloc'd buffer (*size bytes), or NULL when it cannot be read or is
 * empty. */
unsigned char *test_read_file(const char *path, long *size);

#endif
