/* The daemon's caches under one memory budget (--cache-mb): blobs (files in the private
 * cache folder, content-addressed, written temp+rename), parsed volumes, environment maps
 * and renderers (each holding a method's prepared state). One LRU list; an entry with
 * refs > 0 is in use (a running job, or a renderer pinning its volumes) and never evicted. */
#define _GNU_SOURCE
#include "cache.h"
#include "loader.h"
#include <dirent.h>
#include <errno.h>
#include <malloc.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

enum { ENT_BLOB, ENT_VOLUME, ENT_ENV, ENT_SLOT, ENT_KINDS };
static const char *const kind_names[ENT_KINDS] = {"blobs", "volumes", "envs", "renderers"};

struct vsdd_entry {
    int kind;
    char key[1400];
    uint64_t bytes;
    int refs;
    struct vsdd_entry *prev, *next;   /* head = most recently used */
    char path[VSD_PATH_LEN];          /* blob file */
    vsd_volume *vol;
    vsd_env *env;
    vsdd_slot *slot;
};

static struct {
    pthread_mutex_t lock;
    vsdd_entry *head, *tail;
    uint64_t used, reserved, peak;
    uint64_t hits[ENT_KINDS], misses[ENT_KINDS], evictions, count[ENT_KINDS];
    char blob_dir[VSD_PATH_LEN];
} C = {.lock = PTHREAD_MUTEX_INITIALIZER};

static void lru_unlink(vsdd_entry *e)
{
    if (e->prev) e->prev->next = e->next;
    else C.head = e->next;
    if (e->next) e->next->prev = e->prev;
    else C.tail = e->prev;
    e->prev = e->next = NULL;
}

static void lru_push(vsdd_entry *e)
{
    e->prev = NULL;
    e->next = C.head;
    if (C.head) C.head->prev = e;
    C.head = e;
    if (!C.tail) C.tail = e;
}

static void touch(vsdd_entry *e)
{
    lru_unlink(e);
    lru_push(e);
}

static void account(vsdd_entry *e, int add)
{
    if (add) {
        C.used += e->bytes;
        C.count[e->kind]++;
        if (C.used + C.reserved > C.peak) C.peak = C.used + C.reserved;
    } else {
        C.used -= e->bytes;
        C.count[e->kind]--;
    }
}

static void free_entry(vsdd_entry *e);

/* Lock held. Remove and free e (refs == 0). */
static void evict(vsdd_entry *e)
{
    lru_unlink(e);
    account(e, 0);
    C.evictions++;
    vsdd_log(VSDD_LOG_DEBUG, "cache: evict %s %.80s (%llu bytes)", kind_names[e->kind], e->key,
             (unsigned long long)e->bytes);
    free_entry(e);
}

static void unpin_locked(vsdd_entry *e)
{
    if (e && e->refs > 0) e->refs--;
}

static void free_entry(vsdd_entry *e)
{
    int i;
    switch (e->kind) {
    case ENT_BLOB: unlink(e->path); break;
    case ENT_VOLUME: vsd_volume_destroy(e->vol); break;
    case ENT_ENV: vsd_env_destroy(e->env); break;
    case ENT_SLOT:
        vsd_renderer_destroy(e->slot->r);
        for (i = 0; i < VSDD_SLOT_PINS; i++) unpin_locked(e->slot->pins[i]);
        free(e->slot);
        break;
    }
    free(e);
}

/* Lock held. Evict least recently used idle entries until `need` more bytes fit. */
static int make_room(uint64_t need)
{
    uint64_t budget = g_daemon.cfg.cache_bytes;
    while (C.used + C.reserved + need > budget) {
        vsdd_entry *e;
        for (e = C.tail; e && e->refs > 0; e = e->prev) {}
        if (!e) return -1;
        evict(e);
    }
    return 0;
}

static vsdd_entry *find(int kind, const char *key, int idle_only)
{
    vsdd_entry *e;
    for (e = C.head; e; e = e->next)
        if (e->kind == kind && strcmp(e->key, key) == 0 && (!idle_only || e->refs == 0)) return e;
    return NULL;
}

int vsdd_cache_init(char *err, size_t errlen)
{
    vsdd_config *cfg = &g_daemon.cfg;
    char tmpl[VSD_PATH_LEN];
    snprintf(tmpl, sizeof tmpl, "%.900s/vsd-cache-XXXXXX", cfg->cache_parent);
    if (!mkdtemp(tmpl)) {
        snprintf(err, errlen, "cannot create a cache folder in %s: %s", cfg->cache_parent, strerror(errno));
        return -1;
    }
    chmod(tmpl, 0700);
    snprintf(cfg->cache_dir, sizeof cfg->cache_dir, "%s", tmpl);
    snprintf(C.blob_dir, sizeof C.blob_dir, "%.940s/blobs", tmpl);
    if (mkdir(C.blob_dir, 0700) != 0) {
        snprintf(err, errlen, "cannot create %s: %s", C.blob_dir, strerror(errno));
        return -1;
    }
    return 0;
}

static void remove_dir(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *de;
    char p[VSD_PATH_LEN + 300];
    if (!d) return;
    while ((de = readdir(d))) {
        struct stat st;
        if (!strcmp(de->d_name, ".") || !strcmp(de->d_name, "..")) continue;
        snprintf(p, sizeof p, "%s/%s", dir, de->d_name);
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode)) remove_dir(p);
        else unlink(p);
    }
    closedir(d);
    rmdir(dir);
}

void vsdd_cache_shutdown(void)
{
    pthread_mutex_lock(&C.lock);
    /* renderers first: they pin volumes */
    for (;;) {
        vsdd_entry *e;
        for (e = C.head; e && e->kind != ENT_SLOT; e = e->next) {}
        if (!e) break;
        lru_unlink(e);
        account(e, 0);
        free_entry(e);
    }
    while (C.head) {
        vsdd_entry *e = C.head;
        lru_unlink(e);
        account(e, 0);
        free_entry(e);
    }
    pthread_mutex_unlock(&C.lock);
    if (g_daemon.cfg.cache_dir[0]) remove_dir(g_daemon.cfg.cache_dir);
}

int vsdd_cache_has_blob(const char *hash)
{
    char key[128];
    vsdd_entry *e;
    snprintf(key, sizeof key, "blob:%s", hash);
    pthread_mutex_lock(&C.lock);
    e = find(ENT_BLOB, key, 0);
    if (e) touch(e);
    pthread_mutex_unlock(&C.lock);
    return e != NULL;
}

int vsdd_cache_put_blob(int fd, const char *hash, uint64_t len, vsdd_err *e, int *fatal)
{
    char key[128], tmp[VSD_PATH_LEN + 32], final_path[VSD_PATH_LEN + 80], got[VSD_HASH_HEX_MAX];
    vsd_hash_kind kind = vsd_hash_kind_of(hash);
    unsigned char *buf = NULL;
    vsd_hasher *h = NULL;
    uint64_t left = len;
    int tfd = -1, rc = -1, reserved = 0;
    *fatal = 0;
    snprintf(key, sizeof key, "blob:%s", hash);
    if (vsdd_cache_has_blob(hash)) {
        if (vsd_proto_skip(fd, len, 30000)) *fatal = 1;
        return *fatal ? vsdd_fail(e, VSD_E_BAD_FRAME, "blob data truncated or too slow") : 0;
    }
    if (len > g_daemon.cfg.cache_bytes) {
        vsdd_fail(e, VSD_E_LIMIT, "blob of %llu bytes is larger than the whole cache (%llu bytes, --cache-mb)",
                  (unsigned long long)len, (unsigned long long)g_daemon.cfg.cache_bytes);
        *fatal = vsd_proto_skip(fd, len, 30000) != 0;
        return -1;
    }
    pthread_mutex_lock(&C.lock);
    if (make_room(len) == 0) {
        C.reserved += len;
        reserved = 1;
        if (C.used + C.reserved > C.peak) C.peak = C.used + C.reserved;
    }
    pthread_mutex_unlock(&C.lock);
    if (!reserved) {
        vsdd_fail(e, VSD_E_CACHE_FULL, "the cache is full of data in use by running jobs; retry later");
        *fatal = vsd_proto_skip(fd, len, 30000) != 0;
        return -1;
    }
    snprintf(tmp, sizeof tmp, "%s/.put-XXXXXX", C.blob_dir);
    tfd = mkstemp(tmp);
    buf = malloc(1 << 20);
    h = vsd_hasher_new(kind);
    if (tfd < 0 || !buf || !h) {
        vsdd_fail(e, VSD_E_INTERNAL, "cannot store the blob: %s", tfd < 0 ? strerror(errno) : "out of memory");
        *fatal = vsd_proto_skip(fd, len, 30000) != 0;
        goto done;
    }
    while (left > 0) {
        size_t chunk = left > (1u << 20) ? (1u << 20) : (size_t)left;
        if (vsd_proto_read_full(fd, buf, chunk, 30000)) {
            vsdd_fail(e, VSD_E_BAD_FRAME, "blob data truncated or too slow");
            *fatal = 1;
            goto done;
        }
        vsd_hasher_update(h, buf, chunk);
        if (vsd_proto_write_full(tfd, buf, chunk)) {
            vsdd_fail(e, VSD_E_INTERNAL, "cannot write the blob: %s", strerror(errno));
            *fatal = vsd_proto_skip(fd, left - chunk, 30000) != 0;
            goto done;
        }
        left -= chunk;
    }
    vsd_hasher_final(h, got);
    h = NULL;
    if (strcmp(got, hash) != 0) {
        vsdd_fail(e, VSD_E_HASH_MISMATCH, "blob %s: the data hashes to %s (%s)", hash, got, vsd_hash_kind_name(kind));
        goto done;
    }
    close(tfd);
    tfd = -1;
    snprintf(final_path, sizeof final_path, "%.950s/%s", C.blob_dir, hash);
    pthread_mutex_lock(&C.lock);
    C.reserved -= len;
    reserved = 0;
    if (!find(ENT_BLOB, key, 0)) {
        vsdd_entry *b = calloc(1, sizeof *b);
        if (b && rename(tmp, final_path) == 0) {
            b->kind = ENT_BLOB;
            snprintf(b->key, sizeof b->key, "%s", key);
            snprintf(b->path, sizeof b->path, "%.1000s", final_path);
            b->bytes = len;
            make_room(len); /* the reservation was released: normally a no-op */
            lru_push(b);
            account(b, 1);
            tmp[0] = '\0';
            rc = 0;
        } else {
            free(b);
            vsdd_fail(e, VSD_E_INTERNAL, "cannot store the blob");
        }
    } else {
        rc = 0;
    }
    pthread_mutex_unlock(&C.lock);
done:
    if (h) vsd_hasher_final(h, got);
    if (tfd >= 0) close(tfd);
    if (tmp[0]) unlink(tmp);
    free(buf);
    if (reserved) {
        pthread_mutex_lock(&C.lock);
        C.reserved -= len;
        pthread_mutex_unlock(&C.lock);
    }
    return rc;
}

/* Lock held. The file behind src ("blob:<hash>" pinned into *blob, or a path). */
static int source_path(const char *src, char *path, size_t len, vsdd_entry **blob, vsdd_err *e)
{
    *blob = NULL;
    if (strncmp(src, "blob:", 5) == 0) {
        vsdd_entry *b = find(ENT_BLOB, src, 0);
        if (!b) return vsdd_fail(e, VSD_E_MISSING_BLOB, "%s is not in the daemon's cache (send it with PUT)", src);
        b->refs++;
        touch(b);
        *blob = b;
        snprintf(path, len, "%s", b->path);
    } else {
        snprintf(path, len, "%s", src);
    }
    return 0;
}

int vsdd_cache_pin_file(const char *src, char *path, size_t len, vsdd_entry **blob, vsdd_err *e)
{
    int rc;
    pthread_mutex_lock(&C.lock);
    rc = source_path(src, path, len, blob, e);
    pthread_mutex_unlock(&C.lock);
    return rc;
}

/* Server-side files are keyed with their modification time and size, so a file rewritten
 * in place (a re-simulated cache) is loaded again. */
static void source_stamp(const char *src, char *stamp, size_t len)
{
    struct stat st;
    stamp[0] = '\0';
    if (strncmp(src, "blob:", 5) != 0 && stat(src, &st) == 0)
        snprintf(stamp, len, "@%lld.%09ld:%lld", (long long)st.st_mtim.tv_sec, (long)st.st_mtim.tv_nsec,
                 (long long)st.st_size);
}

static uint64_t volume_bytes(const vsd_volume *v)
{
    uint64_t cells = (uint64_t)v->brick_dims[0] * v->brick_dims[1] * v->brick_dims[2];
    return sizeof *v + (uint64_t)v->brick_count * VSD_BRICK_VOXELS * sizeof(float) + cells * 12;
}

/* Insert a freshly loaded entry (lock held), or adopt one another thread inserted meanwhile. */
static int insert_loaded(vsdd_entry *e, vsdd_entry **out, vsdd_err *err)
{
    vsdd_entry *other = find(e->kind, e->key, 0);
    if (other) {
        free_entry(e);
        other->refs++;
        touch(other);
        *out = other;
        return 0;
    }
    if (make_room(e->bytes)) {
        vsdd_fail(err, VSD_E_CACHE_FULL, "the cache (%llu MiB) cannot hold %.80s (%llu bytes) beside the data in use",
                  (unsigned long long)(g_daemon.cfg.cache_bytes >> 20), e->key, (unsigned long long)e->bytes);
        free_entry(e);
        return -1;
    }
    e->refs = 1;
    lru_push(e);
    account(e, 1);
    *out = e;
    return 0;
}

/* Lock held: a cached entry for key, pinned, or NULL (counted as a hit or a miss). */
static vsdd_entry *lookup(int kind, const char *key)
{
    vsdd_entry *e = find(kind, key, 0);
    if (!e) {
        C.misses[kind]++;
        return NULL;
    }
    e->refs++;
    touch(e);
    C.hits[kind]++;
    return e;
}

/* Keep a freshly decoded volume or map (one of vol/env set) under key, pinned. */
static int keep_loaded(int kind, const char *key, vsd_volume *vol, vsd_env *env, vsdd_entry *blob, vsdd_entry **out,
                       vsdd_err *err)
{
    vsdd_entry *e = calloc(1, sizeof *e);
    int rc;
    if (!e) {
        vsd_volume_destroy(vol);
        vsd_env_destroy(env);
        vsdd_cache_unpin(blob);
        return vsdd_fail(err, VSD_E_INTERNAL, "out of memory");
    }
    e->kind = kind;
    snprintf(e->key, sizeof e->key, "%s", key);
    e->vol = vol;
    e->env = env;
    e->bytes = vol ? volume_bytes(vol) : sizeof *env + (uint64_t)env->width * env->height * 3 * sizeof(float);
    pthread_mutex_lock(&C.lock);
    unpin_locked(blob);
    rc = insert_loaded(e, out, err);
    pthread_mutex_unlock(&C.lock);
    return rc;
}

int vsdd_cache_get_volume(const char *src, const char *grid, int grid_index, vsdd_entry **out, int *hit, vsdd_err *err)
{
    char key[1400], path[VSD_PATH_LEN], stamp[64];
    vsdd_entry *blob = NULL;
    vsd_volume *vol = NULL;
    int rc;
    *hit = 0;
    source_stamp(src, stamp, sizeof stamp);
    snprintf(key, sizeof key, "vol|%s%s|%s|%d", src, stamp, grid, grid_index);
    pthread_mutex_lock(&C.lock);
    *out = lookup(ENT_VOLUME, key);
    rc = *out ? 0 : source_path(src, path, sizeof path, &blob, err);
    pthread_mutex_unlock(&C.lock);
    if (*out) {
        *hit = 1;
        return 0;
    }
    if (rc) return -1;
    /* decoded without the cache lock: other jobs go on meanwhile (the blob stays pinned) */
    if (vsdd_load_volume(src, path, grid, grid_index, &vol, err)) {
        vsdd_cache_unpin(blob);
        return -1;
    }
    return keep_loaded(ENT_VOLUME, key, vol, NULL, blob, out, err);
}

int vsdd_cache_get_env(const char *src, const char *colorspace, vsdd_entry **out, int *hit, vsdd_err *err)
{
    char key[1400], path[VSD_PATH_LEN], stamp[64];
    vsdd_entry *blob = NULL;
    vsd_env *env = NULL;
    int rc;
    *hit = 0;
    source_stamp(src, stamp, sizeof stamp);
    snprintf(key, sizeof key, "env|%s%s|%s", src, stamp, colorspace);
    pthread_mutex_lock(&C.lock);
    *out = lookup(ENT_ENV, key);
    rc = *out ? 0 : source_path(src, path, sizeof path, &blob, err);
    pthread_mutex_unlock(&C.lock);
    if (*out) {
        *hit = 1;
        return 0;
    }
    if (rc) return -1;
    if (vsdd_load_env(src, path, colorspace, &env, err)) {
        vsdd_cache_unpin(blob);
        return -1;
    }
    return keep_loaded(ENT_ENV, key, NULL, env, blob, out, err);
}

const vsd_volume *vsdd_entry_volume(const vsdd_entry *e) { return e ? e->vol : NULL; }
const vsd_env *vsdd_entry_env(const vsdd_entry *e) { return e ? e->env : NULL; }

void vsdd_cache_unpin(vsdd_entry *e)
{
    if (!e) return;
    pthread_mutex_lock(&C.lock);
    unpin_locked(e);
    pthread_mutex_unlock(&C.lock);
}

/* What each method's renderers were last seen to hold (vsdd_cache_slot_grew), the first
 * estimate of a new one; lock held. */
static struct { char method[32]; uint64_t bytes; } learned[16];

static uint64_t *learned_bytes(const char *method)
{
    size_t i;
    for (i = 0; i < sizeof learned / sizeof learned[0] && learned[i].method[0]; i++)
        if (strcmp(learned[i].method, method) == 0) return &learned[i].bytes;
    if (i == sizeof learned / sizeof learned[0]) return NULL;
    snprintf(learned[i].method, sizeof learned[i].method, "%s", method);
    learned[i].bytes = 0;
    return &learned[i].bytes;
}

/* A renderer's first estimate, before it is measured: the sampling tables of the map plus
 * as much again as the density grid, or what the method's last renderer held if more. */
static uint64_t slot_bytes(vsdd_entry *pins[VSDD_SLOT_PINS], const char *method)
{
    uint64_t b = 256 * 1024, *l = learned_bytes(method);
    if (pins[0]) b += pins[0]->bytes;
    if (pins[2] && pins[2]->env) b += (uint64_t)pins[2]->env->width * pins[2]->env->height * 8;
    else b += 64 * 32 * 8;
    return l && *l > b ? *l : b;
}

uint64_t vsdd_heap_in_use(void)
{
    struct mallinfo2 mi = mallinfo2();
    return (uint64_t)mi.uordblks + (uint64_t)mi.hblkhd;
}

void vsdd_cache_slot_grew(vsdd_slot *s, int64_t grown)
{
    vsdd_entry *e = s->self;
    uint64_t held, *l;
    pthread_mutex_lock(&C.lock);
    s->held += grown;
    held = s->held > 0 ? (uint64_t)s->held : 0;
    l = learned_bytes(s->method);
    if (l) *l = held;
    if (held > e->bytes && strcmp(e->key, "(uncached)") != 0) {
        account(e, 0);
        e->bytes = held;
        /* this slot is in use (refs > 0), so only other idle entries go */
        if (make_room(e->bytes)) {
            e->bytes = 0;
            snprintf(e->key, sizeof e->key, "(uncached)");
        }
        account(e, 1);
    }
    pthread_mutex_unlock(&C.lock);
}

int vsdd_cache_get_slot(const char *key, const vsd_scene *scene, vsdd_entry *pins[VSDD_SLOT_PINS],
                        vsdd_slot_progress_fn progress, vsdd_slot **out, int *hit, char *msg, size_t msglen)
{
    vsdd_entry *e;
    vsdd_slot *s;
    vsd_render_options ro;
    vsd_status st;
    int i;
    *out = NULL;
    *hit = 0;
    pthread_mutex_lock(&C.lock);
    e = find(ENT_SLOT, key, 1);
    if (e) {
        e->refs = 1;
        touch(e);
        C.hits[ENT_SLOT]++;
        for (i = 0; i < VSDD_SLOT_PINS; i++) unpin_locked(pins[i]); /* the slot pins the same entries */
        pthread_mutex_unlock(&C.lock);
        st = vsd_renderer_set_scene(e->slot->r, scene, msg, msglen);
        if (st) {
            vsdd_cache_release_slot(e->slot, 0);
            return -(int)st;
        }
        *out = e->slot;
        *hit = 1;
        return 0;
    }
    C.misses[ENT_SLOT]++;
    pthread_mutex_unlock(&C.lock);
    s = calloc(1, sizeof *s);
    e = calloc(1, sizeof *e);
    if (!s || !e) {
        free(s);
        free(e);
        for (i = 0; i < VSDD_SLOT_PINS; i++) vsdd_cache_unpin(pins[i]);
        snprintf(msg, msglen, "out of memory");
        return -(int)VSD_ERR_NOMEM;
    }
    memset(&ro, 0, sizeof ro);
    ro.threads = g_daemon.cfg.threads;
    ro.progress = progress;
    ro.user = s;
    ro.cancel = &s->cancel;
    ro.cache_dir = g_daemon.cfg.method_cache[0] ? g_daemon.cfg.method_cache : NULL;
    {
        uint64_t before = vsdd_heap_in_use();
        st = vsd_renderer_create(scene, &ro, &s->r, msg, msglen);
        s->held = (int64_t)vsdd_heap_in_use() - (int64_t)before;
    }
    snprintf(s->method, sizeof s->method, "%.31s", scene->render.method);
    if (st) {
        free(s);
        free(e);
        for (i = 0; i < VSDD_SLOT_PINS; i++) vsdd_cache_unpin(pins[i]);
        return -(int)st;
    }
    vsd_renderer_use_volumes(s->r, vsdd_entry_volume(pins[0]), vsdd_entry_volume(pins[1]));
    vsd_renderer_use_ior_volume(s->r, vsdd_entry_volume(pins[3]));
    if (pins[2]) vsd_renderer_use_env(s->r, pins[2]->env);
    for (i = 0; i < VSDD_SLOT_PINS; i++) s->pins[i] = pins[i];
    s->self = e;
    e->kind = ENT_SLOT;
    snprintf(e->key, sizeof e->key, "%s", key);
    e->slot = s;
    pthread_mutex_lock(&C.lock);
    e->bytes = slot_bytes(pins, s->method);
    if (make_room(e->bytes)) {
        /* still render (the job's data is in memory already), but do not keep it */
        e->bytes = 0;
        snprintf(e->key, sizeof e->key, "(uncached)");
    }
    e->refs = 1;
    lru_push(e);
    account(e, 1);
    pthread_mutex_unlock(&C.lock);
    *out = s;
    return 0;
}

void vsdd_cache_release_slot(vsdd_slot *s, int keep)
{
    vsdd_entry *e = s->self;
    pthread_mutex_lock(&C.lock);
    if (e->refs > 0) e->refs--;
    if ((!keep || strcmp(e->key, "(uncached)") == 0) && e->refs == 0) evict(e);
    pthread_mutex_unlock(&C.lock);
}

cJSON *vsdd_cache_stats(void)
{
    cJSON *o = cJSON_CreateObject(), *k;
    int i;
    pthread_mutex_lock(&C.lock);
    cJSON_AddNumberToObject(o, "budget_bytes", (double)g_daemon.cfg.cache_bytes);
    cJSON_AddNumberToObject(o, "used_bytes", (double)(C.used + C.reserved));
    cJSON_AddNumberToObject(o, "peak_bytes", (double)C.peak);
    cJSON_AddNumberToObject(o, "evictions", (double)C.evictions);
    for (i = 0; i < ENT_KINDS; i++) {
        k = cJSON_AddObjectToObject(o, kind_names[i]);
        cJSON_AddNumberToObject(k, "entries", (double)C.count[i]);
        cJSON_AddNumberToObject(k, "hits", (double)C.hits[i]);
        cJSON_AddNumberToObject(k, "misses", (double)C.misses[i]);
    }
    {
        uint64_t by[ENT_KINDS] = {0};
        vsdd_entry *e;
        for (e = C.head; e; e = e->next) by[e->kind] += e->bytes;
        for (i = 0; i < ENT_KINDS; i++)
            cJSON_AddNumberToObject(cJSON_GetObjectItem(o, kind_names[i]), "bytes", (double)by[i]);
    }
    pthread_mutex_unlock(&C.lock);
    return o;
}
