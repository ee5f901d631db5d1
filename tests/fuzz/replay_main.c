/* Corpus replay without libFuzzer: a main() that feeds every file named on the command line
 * (folders: every file in them, in name order) to the harness's LLVMFuzzerTestOneInput once.
 * The plain (gcc) build uses it so CI replays the committed corpora, and the sanitizer build
 * replays them under ASan/UBSan; libFuzzer builds link the harness with -fsanitize=fuzzer
 * instead. Exit status 0 = every input handled; a crash or sanitizer report fails the test. */
#define _GNU_SOURCE
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int run_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    unsigned char *buf = NULL;
    size_t len = 0, cap = 0, n;
    if (!f) {
        fprintf(stderr, "replay: cannot open %s\n", path);
        return -1;
    }
    do {
        if (cap - len < 65536) {
            unsigned char *b = realloc(buf, cap = cap ? cap * 2 : 65536);
            if (!b) {
                free(buf);
                fclose(f);
                return -1;
            }
            buf = b;
        }
        n = fread(buf + len, 1, cap - len, f);
        len += n;
    } while (n > 0);
    fclose(f);
    LLVMFuzzerTestOneInput(buf, len);
    free(buf);
    return 0;
}

static int by_name(const struct dirent **a, const struct dirent **b) { return strcmp((*a)->d_name, (*b)->d_name); }

int main(int argc, char **argv)
{
    int count = 0, failed = 0;
    for (int i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) != 0) {
            fprintf(stderr, "replay: %s: no such file or folder\n", argv[i]);
            failed = 1;
        } else if (S_ISDIR(st.st_mode)) {
            struct dirent **list = NULL;
            int n = scandir(argv[i], &list, NULL, by_name);
            for (int k = 0; k < n; k++) {
                char path[4096];
                struct stat fs;
                snprintf(path, sizeof path, "%s/%s", argv[i], list[k]->d_name);
                if (stat(path, &fs) == 0 && S_ISREG(fs.st_mode)) {
                    if (run_file(path)) failed = 1;
                    else count++;
                }
                free(list[k]);
            }
            free(list);
            if (n < 0) failed = 1;
        } else {
            if (run_file(argv[i])) failed = 1;
            else count++;
        }
    }
    printf("replay: %d inputs\n", count);
    if (count == 0) {
        fprintf(stderr, "replay: no inputs\n");
        return 1;
    }
    return failed;
}
