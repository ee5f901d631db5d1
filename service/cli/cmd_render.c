/* `vsd render`: scene file + overrides in, one EXR (+ optional PNG) per frame out,
 * rendered in-process through the library's vsd_renderer (the daemon uses the same). */
#define _POSIX_C_SOURCE 200809L
#include "commands.h"
#include "vsd/render.h"
#include "render_remote.h"
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_OVERRIDES 256

typedef struct render_args {
    const char *scene_path;
    const char *overrides[MAX_OVERRIDES];
    char owned[MAX_OVERRIDES][VSD_PATH_LEN + 64];
    int override_count;
    int quiet;
    int threads;
    int remote;                  /* --remote[=SOCKET|HOST:PORT] */
    const char *remote_address;  /* "" = default socket */
    const char *token_file;
    const char *cache_dir;       /* --cache-dir; NULL = the default below */
} render_args;

typedef struct progress_state {
    int tty, quiet, frame;
    int last_percent;
    char last_stage[64];
} progress_state;

static volatile int g_cancel = 0;

static void on_sigint(int sig)
{
    (void)sig;
    g_cancel = 1;
}

static void render_usage(FILE *f)
{
    fprintf(f,
            "usage: vsd render SCENE.json [options]\n"
            "  --method NAME        render.method (%s", vsd_method_names()[0]);
    {
        const char *const *n = vsd_method_names() + 1;
        for (; *n; n++) fprintf(f, ", %s", *n);
    }
    fprintf(f, ")\n"
            "  --width N, --height N film size in pixels\n"
            "  --frames A-B | N     frame range (inclusive)\n"
            "  --samples N          samples per pixel\n"
            "  --seed N             random seed\n"
            "  --device auto|cpu|cuda\n"
            "  --threads N          CPU threads (default: all cores)\n"
            "  --output PATH        output.exr (#### = frame number), relative to the current folder\n"
            "  --preview PATH       also write a display PNG (#### = frame number)\n"
            "  --set KEY=VALUE      any scene field, e.g. --set medium.density=20\n"
            "  --remote[=ADDR]      render through a running `vsd serve` (default socket, a socket path,\n"
            "                       or HOST:PORT); uploads only the VDB frames and map it lacks\n"
            "  --token-file FILE    token for --remote=HOST:PORT (else $VSD_TOKEN)\n"
            "  --cache-dir DIR      where methods keep per-frame work between runs (crm's RBF fits;\n"
            "                       default $VSD_CACHE_DIR, else $XDG_CACHE_HOME/vsd or ~/.cache/vsd;\n"
            "                       'none' = no cache)\n"
            "  --quiet              print nothing but errors\n");
}

static int add_override(render_args *a, const char *fmt, const char *v1, const char *v2)
{
    char *slot;
    if (a->override_count >= MAX_OVERRIDES) {
        fprintf(stderr, "vsd render: too many overrides (at most %d)\n", MAX_OVERRIDES);
        return 0;
    }
    slot = a->owned[a->override_count];
    snprintf(slot, sizeof a->owned[0], fmt, v1, v2 ? v2 : "");
    a->overrides[a->override_count++] = slot;
    return 1;
}

/* Command-line paths are relative to the current folder, scene-file paths to the scene:
 * make the former absolute, and JSON-quote it. */
static int add_path_override(render_args *a, const char *key, const char *path)
{
    char abs[VSD_PATH_LEN];
    if (path[0] == '/') snprintf(abs, sizeof abs, "%s", path);
    else {
        char cwd[VSD_PATH_LEN / 2];
        if (!getcwd(cwd, sizeof cwd)) cwd[0] = '\0';
        snprintf(abs, sizeof abs, "%s/%s", cwd, path);
    }
    if (strchr(abs, '"') || strchr(abs, '\\')) {
        fprintf(stderr, "vsd render: %s: quotes and backslashes are not supported in paths\n", path);
        return 0;
    }
    return add_override(a, "%s=\"%s\"", key, abs);
}

static int parse_frames(render_args *a, const char *v)
{
    char start[32], end[32];
    const char *dash = strchr(v + 1, '-'); /* skip a leading minus sign */
    char *e1, *e2;
    if (!dash) {
        snprintf(start, sizeof start, "%s", v);
        snprintf(end, sizeof end, "%s", v);
    } else {
        snprintf(start, sizeof start, "%.*s", (int)(dash - v), v);
        snprintf(end, sizeof end, "%s", dash + 1);
    }
    strtol(start, &e1, 10);
    strtol(end, &e2, 10);
    if (!start[0] || !end[0] || *e1 || *e2) {
        fprintf(stderr, "vsd render: --frames: expected A-B or N, got '%s'\n", v);
        return 0;
    }
    return add_override(a, "frames.start=%s%s", start, NULL) && add_override(a, "frames.end=%s%s", end, NULL);
}

/* Returns -1 to continue, else an exit code. */
static int parse_args(int argc, char **argv, render_args *a)
{
    static const struct { const char *flag, *key; } simple[] = {
        {"--method", "render.method"}, {"--width", "film.width"}, {"--height", "film.height"},
        {"--samples", "render.samples"}, {"--seed", "render.seed"}, {"--device", "render.device"},
        {"--threads", "render.threads"},
    };
    int i;
    size_t k;
    memset(a, 0, sizeof *a);
    for (i = 1; i < argc; i++) {
        const char *arg = argv[i];
        const char *val = i + 1 < argc ? argv[i + 1] : NULL;
        int matched = 0;
        if (strcmp(arg, "--help") == 0 || strcmp(arg, "-h") == 0) {
            render_usage(stdout);
            return VSD_EXIT_OK;
        }
        if (strcmp(arg, "--quiet") == 0 || strcmp(arg, "-q") == 0) { a->quiet = 1; continue; }
        if (strcmp(arg, "--remote") == 0 || strncmp(arg, "--remote=", 9) == 0) {
            a->remote = 1;
            a->remote_address = arg[8] == '=' ? arg + 9 : "";
            continue;
        }
        if (arg[0] != '-') {
            if (a->scene_path) {
                fprintf(stderr, "vsd render: more than one scene file ('%s', '%s')\n", a->scene_path, arg);
                return VSD_EXIT_USAGE;
            }
            a->scene_path = arg;
            continue;
        }
        if (!val) {
            fprintf(stderr, "vsd render: %s needs a value\n", arg);
            return VSD_EXIT_USAGE;
        }
        for (k = 0; k < sizeof simple / sizeof simple[0]; k++)
            if (strcmp(arg, simple[k].flag) == 0) {
                matched = add_override(a, "%s=%s", simple[k].key, val);
                if (!matched) return VSD_EXIT_USAGE;
            }
        if (!matched) {
            int ok;
            if (strcmp(arg, "--set") == 0) ok = add_override(a, "%s%s", val, NULL);
            else if (strcmp(arg, "--frames") == 0) ok = parse_frames(a, val);
            else if (strcmp(arg, "--output") == 0 || strcmp(arg, "-o") == 0) ok = add_path_override(a, "output.exr", val);
            else if (strcmp(arg, "--preview") == 0) ok = add_path_override(a, "output.preview_png", val);
            else if (strcmp(arg, "--token-file") == 0) ok = (a->token_file = val) != NULL;
            else if (strcmp(arg, "--cache-dir") == 0) ok = (a->cache_dir = val) != NULL;
            else {
                fprintf(stderr, "vsd render: unknown option '%s' (see vsd render --help)\n", arg);
                return VSD_EXIT_USAGE;
            }
            if (!ok) return VSD_EXIT_USAGE;
        }
        i++;
    }
    if (!a->scene_path) {
        render_usage(stderr);
        return VSD_EXIT_USAGE;
    }
    return -1;
}

static void on_progress(void *user, const char *stage, float fraction)
{
    progress_state *p = user;
    int percent = (int)(fraction * 100.0f + 0.5f);
    if (p->quiet) return;
    if (percent == p->last_percent && strcmp(stage, p->last_stage) == 0) return;
    if (p->tty) {
        int bar = percent * 30 / 100, i;
        fprintf(stderr, "\rframe %d %-13s [", p->frame, stage);
        for (i = 0; i < 30; i++) fputc(i < bar ? '#' : '.', stderr);
        fprintf(stderr, "] %3d%%", percent);
        fflush(stderr);
    } else if (percent / 10 != p->last_percent / 10 || strcmp(stage, p->last_stage) != 0) {
        fprintf(stderr, "frame %d %s %d%%\n", p->frame, stage, percent);
    }
    p->last_percent = percent;
    snprintf(p->last_stage, sizeof p->last_stage, "%s", stage);
}

/* Reading failures (a missing VDB or map) are bad input; writing failures are failed renders. */
static int exit_code_for(vsd_status st, int writing)
{
    if (st == VSD_ERR_IO && !writing) return VSD_EXIT_INPUT;
    switch (st) {
    case VSD_OK: return VSD_EXIT_OK;
    case VSD_ERR_CANCELLED: return VSD_EXIT_CANCELLED;
    case VSD_ERR_FORMAT: case VSD_ERR_NOT_FOUND: case VSD_ERR_TYPE: case VSD_ERR_INVALID:
    case VSD_ERR_UNSUPPORTED: return VSD_EXIT_INPUT;
    default: return VSD_EXIT_RENDER_FAILED;
    }
}

static void begin_frame(void *user, int frame)
{
    progress_state *p = user;
    p->frame = frame;
    p->last_percent = -1;
    p->last_stage[0] = '\0';
}

/* The same frames through a daemon (render_remote.c); files written where render_frames
 * writes them. */
static int render_frames_remote(const vsd_scene *scene, const render_args *a)
{
    progress_state prog = {0};
    vsd_remote_options ro = {0};
    prog.tty = isatty(STDERR_FILENO);
    prog.quiet = a->quiet;
    ro.address = a->remote_address;
    ro.token_file = a->token_file;
    ro.quiet = a->quiet;
    ro.progress = on_progress;
    ro.user = &prog;
    ro.begin_frame = begin_frame;
    ro.cancel = &g_cancel;
    return vsd_render_remote(a->scene_path, scene, a->overrides, a->override_count, &ro);
}

/* --cache-dir, or the per-user default (vsd_default_cache_dir); "none" = no cache. */
static const char *cache_dir(const render_args *a, char *buf, size_t len)
{
    if (a->cache_dir) return strcmp(a->cache_dir, "none") == 0 || !a->cache_dir[0] ? NULL : a->cache_dir;
    return vsd_default_cache_dir(buf, len);
}

static int render_frames(const vsd_scene *scene, const render_args *a)
{
    char cache[VSD_PATH_LEN];
    progress_state prog = {0};
    vsd_render_options ro = {0};
    vsd_renderer *r = NULL;
    vsd_framebuffer *fb = NULL;
    char err[2048];
    vsd_status st;
    int frame, rc = VSD_EXIT_OK;
    prog.tty = isatty(STDERR_FILENO);
    prog.quiet = a->quiet;
    ro.progress = on_progress;
    ro.user = &prog;
    ro.cancel = &g_cancel;
    ro.cache_dir = cache_dir(a, cache, sizeof cache);
    st = vsd_renderer_create(scene, &ro, &r, err, sizeof err);
    if (st) {
        fprintf(stderr, "vsd render: %s\n", err);
        return exit_code_for(st, 0);
    }
    for (frame = scene->frames.start; frame <= scene->frames.end && !st; frame++) {
        int writing = 0;
        vsd_render_stats stats;
        char path[VSD_PATH_LEN], note[512];
        prog.frame = frame;
        prog.last_percent = -1;
        prog.last_stage[0] = '\0';
        st = vsd_renderer_render(r, frame, &fb, &stats, err, sizeof err);
        if (prog.tty && !a->quiet) fputc('\n', stderr);
        if (!st) {
            writing = 1;
            st = vsd_write_frame_outputs(scene, frame, fb, &stats, path, sizeof path, note, sizeof note, err, sizeof err);
        }
        if (st) {
            fprintf(stderr, "vsd render: frame %d: %s\n", frame, err);
            rc = exit_code_for(st, writing);
            break;
        }
        if (!a->quiet) {
            printf("frame %d: %s  (%s, %d spp, load %.2fs, prepare %.2fs, render %.2fs, %d threads)\n", frame,
                   path, stats.method, stats.samples, stats.load_seconds, stats.prepare_seconds,
                   stats.render_seconds, stats.threads);
            if (note[0]) printf("  preview: %s\n", note);
            if (stats.method_info[0]) printf("  %s: %s\n", stats.method, stats.method_info);
            fflush(stdout);
        }
        if (stats.warnings[0]) fprintf(stderr, "vsd render: frame %d: warning: %s\n", frame, stats.warnings);
    }
    vsd_framebuffer_destroy(fb);
    vsd_renderer_destroy(r);
    return rc;
}

int vsd_cmd_render(int argc, char **argv)
{
    render_args a;
    vsd_scene scene;
    char err[2048];
    vsd_status st;
    int rc = parse_args(argc, argv, &a);
    if (rc >= 0) return rc;
    st = vsd_scene_load(a.scene_path, a.overrides, a.override_count, &scene, err, sizeof err);
    if (st) {
        fprintf(stderr, "vsd render: %s\n", err);
        return exit_code_for(st, 0);
    }
    signal(SIGINT, on_sigint);
    if (a.remote) return render_frames_remote(&scene, &a);
    return render_frames(&scene, &a);
}
