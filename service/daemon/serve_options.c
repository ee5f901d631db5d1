/* `vsd serve`'s command line: every option, its default and its range; a bad value is a
 * message naming the option and exit status 2. */
#define _GNU_SOURCE
#include "serve_options.h"
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static void serve_usage(FILE *f)
{
    fprintf(f,
            "usage: vsd serve [options]\n"
            "  --socket PATH          Unix socket (default $XDG_RUNTIME_DIR/vsd.sock, else /tmp/vsd-$UID.sock)\n"
            "  --tcp HOST:PORT        also listen on TCP (127.0.0.1 unless --listen-any; needs --token-file)\n"
            "  --listen-any           allow a non-loopback --tcp address\n"
            "  --token-file FILE      token TCP clients must send in HELLO\n"
            "  --allow-path DIR       RENDER may name files under DIR (repeatable; default: blobs only)\n"
            "  --cache-mb N           memory budget of the decoded volumes, maps and kept renderers\n"
            "                         (default 2048); a new renderer waits until it fits\n"
            "  --blob-mb N            disk budget of uploaded blob files (default 4 * cache-mb)\n"
            "  --cache-dir DIR        where blob files live (default $TMPDIR or /tmp)\n"
            "  --method-cache DIR     where methods keep work between runs, e.g. crm's RBF fits (default\n"
            "                         $VSD_CACHE_DIR, else $XDG_CACHE_HOME/vsd or ~/.cache/vsd; 'none' = off)\n"
            "  --workers N            jobs rendered at once (default 1)\n"
            "  --threads N            CPU threads per job (default: all cores / workers)\n"
            "  --queue N              jobs that may wait; more are refused with BUSY (default 16)\n"
            "  --max-connections N    (default 64)\n"
            "  --max-message-mb N     largest binary part (a PUT blob) (default 1024)\n"
            "  --max-json-kb N        largest JSON part (default 1024)\n"
            "  --max-size N           largest film width or height (default 16384)\n"
            "  --max-pixels N         largest film width*height (default 67108864)\n"
            "  --max-voxels N         most active voxels of one grid, and of a scene's volumes\n"
            "                         together (default 1000000000)\n"
            "  --max-job-seconds S    a job running longer is cancelled (default 3600, 0 = no limit)\n"
            "  --loader MODE          isolated (default): VDBs and maps are decoded in a child process;\n"
            "                         inprocess: on the worker thread (debugging only)\n"
            "  --loader-mb N          the decoder process's address space (default 2 * cache-mb + 1024)\n"
            "  --loader-seconds S     the decoder process is killed after S seconds (default 120)\n"
            "  --log-level L          error, warn, info (default) or debug\n"
            "  --lock-file PATH       pid/lock file (default SOCKET.lock)\n"
            "  --ready-file PATH      write {\"socket\",\"tcp\",\"pid\"} JSON here once listening\n");
}

static int parse_u64(const char *flag, const char *v, uint64_t lo, uint64_t hi, uint64_t *out)
{
    char *end;
    unsigned long long x;
    errno = 0;
    x = strtoull(v, &end, 10);
    if (errno || end == v || *end || v[0] == '-' || x < lo || x > hi) {
        fprintf(stderr, "vsd serve: %s: expected an integer in %llu..%llu, got '%s'\n", flag, (unsigned long long)lo,
                (unsigned long long)hi, v);
        return -1;
    }
    *out = x;
    return 0;
}

static int read_token(const char *path, char *out, size_t len)
{
    FILE *f = fopen(path, "r");
    struct stat st;
    size_t n;
    if (!f) {
        fprintf(stderr, "vsd serve: --token-file %s: %s\n", path, strerror(errno));
        return -1;
    }
    if (fstat(fileno(f), &st) == 0 && (st.st_mode & 077))
        fprintf(stderr, "vsd serve: warning: %s is readable by others (chmod 600 it)\n", path);
    n = fread(out, 1, len - 1, f);
    fclose(f);
    out[n] = '\0';
    while (n > 0 && (out[n - 1] == '\n' || out[n - 1] == '\r' || out[n - 1] == ' ' || out[n - 1] == '\t')) out[--n] = '\0';
    if (n < 8) {
        fprintf(stderr, "vsd serve: --token-file %s: the token must have at least 8 characters\n", path);
        return -1;
    }
    return 0;
}

/* Returns -1 to go on, else an exit code. */
int vsdd_serve_options(int argc, char **argv, vsdd_config *c, char *ready_file, size_t ready_len)
{
    const char *xdg = getenv("XDG_RUNTIME_DIR"), *tmp = getenv("TMPDIR");
    const char *token_file = NULL;
    uint64_t v;
    int i;
    memset(c, 0, sizeof *c);
    if (xdg && xdg[0]) snprintf(c->socket_path, sizeof c->socket_path, "%s/vsd.sock", xdg);
    else snprintf(c->socket_path, sizeof c->socket_path, "/tmp/vsd-%ld.sock", (long)getuid());
    snprintf(c->cache_parent, sizeof c->cache_parent, "%s", tmp && tmp[0] ? tmp : "/tmp");
    c->cache_bytes = 2048ull << 20;
    if (!vsd_default_cache_dir(c->method_cache, sizeof c->method_cache)) c->method_cache[0] = '\0';
    c->workers = 1;
    c->queue_max = 16;
    c->max_connections = 64;
    c->max_message = 1024ull << 20;
    c->max_json = 1024u << 10;
    c->max_dim = 16384;
    c->max_pixels = 67108864ull;
    c->max_voxels = 1000000000ull;
    c->max_job_seconds = 3600;
    c->log_level = VSDD_LOG_INFO;
    c->loader = VSDD_LOADER_ISOLATED;
    c->loader_seconds = 120;
    /* the running executable, even if its file was replaced since (an upgrade) */
    snprintf(c->loader_exe, sizeof c->loader_exe, "/proc/self/exe");
    ready_file[0] = '\0';
    for (i = 1; i < argc; i++) {
        const char *a = argv[i], *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            serve_usage(stdout);
            return 0;
        }
        if (!strcmp(a, "--listen-any")) {
            c->listen_any = 1;
            continue;
        }
        if (!val) {
            fprintf(stderr, "vsd serve: %s needs a value (see vsd serve --help)\n", a);
            return 2;
        }
        i++;
        if (!strcmp(a, "--socket")) {
            if (strlen(val) >= sizeof c->socket_path) {
                fprintf(stderr, "vsd serve: --socket: path too long\n");
                return 2;
            }
            snprintf(c->socket_path, sizeof c->socket_path, "%s", val);
        } else if (!strcmp(a, "--tcp")) snprintf(c->tcp, sizeof c->tcp, "%s", val);
        else if (!strcmp(a, "--token-file")) token_file = val;
        else if (!strcmp(a, "--allow-path")) {
            char real[PATH_MAX];
            struct stat st;
            if (c->allow_count >= VSDD_MAX_ALLOW || !realpath(val, real) || stat(real, &st) || !S_ISDIR(st.st_mode) ||
                strlen(real) >= VSD_PATH_LEN) {
                fprintf(stderr, "vsd serve: --allow-path %s: not an existing folder (or more than %d)\n", val,
                        VSDD_MAX_ALLOW);
                return 2;
            }
            memcpy(c->allow[c->allow_count++], real, strlen(real) + 1); /* length checked above */
        } else if (!strcmp(a, "--cache-mb")) {
            if (parse_u64(a, val, 1, 1ull << 24, &v)) return 2;
            c->cache_bytes = v << 20;
        } else if (!strcmp(a, "--blob-mb")) {
            if (parse_u64(a, val, 1, 1ull << 26, &v)) return 2;
            c->blob_bytes = v << 20;
        } else if (!strcmp(a, "--cache-dir")) snprintf(c->cache_parent, sizeof c->cache_parent, "%s", val);
        else if (!strcmp(a, "--method-cache"))
            snprintf(c->method_cache, sizeof c->method_cache, "%s", strcmp(val, "none") ? val : "");
        else if (!strcmp(a, "--workers")) {
            if (parse_u64(a, val, 1, 256, &v)) return 2;
            c->workers = (int)v;
        } else if (!strcmp(a, "--threads")) {
            if (parse_u64(a, val, 0, 4096, &v)) return 2;
            c->threads = (int)v;
        } else if (!strcmp(a, "--queue")) {
            if (parse_u64(a, val, 0, 100000, &v)) return 2;
            c->queue_max = (int)v;
        } else if (!strcmp(a, "--max-connections")) {
            if (parse_u64(a, val, 1, 100000, &v)) return 2;
            c->max_connections = (int)v;
        } else if (!strcmp(a, "--max-message-mb")) {
            if (parse_u64(a, val, 1, 1ull << 24, &v)) return 2;
            c->max_message = v << 20;
        } else if (!strcmp(a, "--max-json-kb")) {
            if (parse_u64(a, val, 1, 1u << 20, &v)) return 2;
            c->max_json = (uint32_t)(v << 10);
        } else if (!strcmp(a, "--max-size")) {
            if (parse_u64(a, val, 1, 16384, &v)) return 2;
            c->max_dim = (int)v;
        } else if (!strcmp(a, "--max-pixels")) {
            if (parse_u64(a, val, 1, 67108864ull, &v)) return 2;
            c->max_pixels = v;
        } else if (!strcmp(a, "--max-voxels")) {
            if (parse_u64(a, val, 1, UINT64_MAX >> 1, &v)) return 2;
            c->max_voxels = v;
        } else if (!strcmp(a, "--max-job-seconds")) {
            char *end;
            double s = strtod(val, &end);
            if (end == val || *end || !(s >= 0) || s > 1e7) {
                fprintf(stderr, "vsd serve: --max-job-seconds: expected seconds >= 0, got '%s'\n", val);
                return 2;
            }
            c->max_job_seconds = s;
        } else if (!strcmp(a, "--loader")) {
            if (strcmp(val, "isolated") && strcmp(val, "inprocess")) {
                fprintf(stderr, "vsd serve: --loader: expected isolated or inprocess, got '%s'\n", val);
                return 2;
            }
            c->loader = strcmp(val, "isolated") ? VSDD_LOADER_INPROCESS : VSDD_LOADER_ISOLATED;
        } else if (!strcmp(a, "--loader-mb")) {
            if (parse_u64(a, val, 64, 1ull << 24, &v)) return 2;
            c->loader_bytes = v << 20;
        } else if (!strcmp(a, "--loader-seconds")) {
            char *end;
            double s = strtod(val, &end);
            if (end == val || *end || !(s > 0) || s > 1e6) {
                fprintf(stderr, "vsd serve: --loader-seconds: expected seconds > 0, got '%s'\n", val);
                return 2;
            }
            c->loader_seconds = s;
        } else if (!strcmp(a, "--log-level")) {
            static const char *const levels[] = {"error", "warn", "info", "debug"};
            int k;
            for (k = 0; k < 4 && strcmp(val, levels[k]); k++) {}
            if (k == 4) {
                fprintf(stderr, "vsd serve: --log-level: expected error, warn, info or debug\n");
                return 2;
            }
            c->log_level = k;
        } else if (!strcmp(a, "--lock-file")) snprintf(c->lock_path, sizeof c->lock_path, "%s", val);
        else if (!strcmp(a, "--ready-file")) snprintf(ready_file, ready_len, "%s", val);
        else {
            fprintf(stderr, "vsd serve: unknown option '%s' (see vsd serve --help)\n", a);
            return 2;
        }
    }
    if (c->tcp[0] && !token_file) {
        fprintf(stderr, "vsd serve: --tcp needs --token-file (TCP clients must authenticate)\n");
        return 2;
    }
    if (token_file && read_token(token_file, c->token, sizeof c->token)) return 2;
    if (!c->lock_path[0]) snprintf(c->lock_path, sizeof c->lock_path, "%s.lock", c->socket_path);
    /* room for the largest grid the cache could keep, decoded beside OpenVDB's own tree,
     * plus the executable's libraries */
    if (!c->blob_bytes) c->blob_bytes = 4 * c->cache_bytes;
    if (!c->loader_bytes) c->loader_bytes = 2 * c->cache_bytes + (1024ull << 20);
    if (c->threads == 0 && c->workers > 1) {
        long cores = sysconf(_SC_NPROCESSORS_ONLN);
        c->threads = cores > c->workers ? (int)(cores / c->workers) : 1;
    }
    return -1;
}

