/* The daemon's caches under two budgets: blobs (files in the private cache folder,
 * content-addressed, written temp+rename) under the disk budget (--blob-mb), and parsed
 * volumes, environment maps and renderers (each holding a method's prepared state) under
 * the memory budget (--cache-mb). Apart, because in one budget the memory pressure of
 * renderers evicted uploads between their PUT and their RENDER (docs/soak.md). One LRU
 * list; an entry with refs > 0 is in use (a running job, or a renderer pinning its
 * volumes) and never evicted; eviction for one budget takes only that budget's entries.
 * Renderer slots (admission, sizes learned per method) are in cache_slots.c. */
#define _GNU_SOURCE
#include "cache_internal.h"
#include "loader.h"
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <malloc.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static const char *const kind_names[ENT_KINDS] = {"blobs", "volumes", "envs", "renderers"};

static void lru_unlink(vsdd_cache *k, vsdd_entry *e)
{
    if (e->prev) e->prev->next = e->next;
    else k->head = e->next;
    if (e->next) e->next->prev = e->prev;
    else k->tail = e->prev;
    e->prev = e->next = NULL;
}

void vsdd_cache_lru_push(vsdd_cache *k, vsdd_entry *e)
{
    e->prev = NULL;
    e->next = k->head;
    if (k->head) k->head->prev = e;
    k->head = e;
    if (!k->tail) k->tail = e;
}

void vsdd_cache_touch(vsdd_cache *k, vsdd_entry *e)
{
    lru_unlink(k, e);
    vsdd_cache_lru_push(k, e);
}

/* The counter e's bytes go to: the disk budget, the memory budget, or outside it. */
static uint64_t *counter_of(vsdd_cache *k, const vsdd_entry *e)
{
    return e->kind == ENT_BLOB ? &k->disk_used : e->uncached ? &k->uncached : &k->used;
}

void vsdd_cache_note_peaks(vsdd_cache *k)
{
    if (k->used + k->reserved > k->peak) k->peak = k->used + k->reserved;
    if (k->disk_used + k->disk_reserved > k->disk_peak) k->disk_peak = k->disk_used + k->disk_reserved;
}

void vsdd_cache_account(vsdd_cache *k, vsdd_entry *e, int add)
{
    if (add) {
        *counter_of(k, e) += e->bytes;
        k->count[e->kind]++;
        vsdd_cache_note_peaks(k);
    } else {
        *counter_of(k, e) -= e->bytes;
        k->count[e->kind]--;
        pthread_cond_broadcast(&k->room);
    }
}

static void free_entry(vsdd_cache *k, vsdd_entry *e);

/* Lock held. Remove and free e (refs == 0). */
void vsdd_cache_evict(vsdd_cache *k, vsdd_entry *e)
{
    lru_unlink(k, e);
    vsdd_cache_account(k, e, 0);
    k->evictions++;
    if (e->kind != ENT_BLOB) k->trim = 1;
    vsdd_log(VSDD_LOG_DEBUG, "cache: evict %s %.80s (%llu bytes)", kind_names[e->kind], e->key,
             (unsigned long long)e->bytes);
    free_entry(k, e);
}

void vsdd_cache_unpin_locked(vsdd_cache *k, vsdd_entry *e)
{
    if (e && e->refs > 0 && --e->refs == 0) pthread_cond_broadcast(&k->room);
}

static void free_entry(vsdd_cache *k, vsdd_entry *e)
{
    int i;
    switch (e->kind) {
    case ENT_BLOB: unlink(e->path); break;
    case ENT_VOLUME: vsd_volume_destroy(e->vol); break;
    case ENT_ENV: vsd_env_destroy(e->env); break;
    case ENT_SLOT:
        vsd_renderer_destroy(e->slot->r);
        vsd_framebuffer_destroy(e->slot->film);
        for (i = 0; i < VSDD_SLOT_PINS; i++) vsdd_cache_unpin_locked(k, e->slot->pins[i]);
        free(e->slot);
        break;
    }
    free(e);
}

/* Lock held. Evict least recently used idle entries of one budget (blobs: the disk one,
 * else the memory one) until `need` more bytes fit in it. */
static int make_room_in(vsdd_cache *k, int blobs, uint64_t need)
{
    uint64_t budget = blobs ? k->cfg->blob_bytes : k->cfg->cache_bytes;
    const uint64_t *used = blobs ? &k->disk_used : &k->used, *reserved = blobs ? &k->disk_reserved : &k->reserved;
    while (*used + *reserved + need > budget) {
        vsdd_entry *e;
        for (e = k->tail; e && (e->refs > 0 || (e->kind == ENT_BLOB) != blobs); e = e->prev) {}
        if (!e) return -1;
        vsdd_cache_evict(k, e);
    }
    return 0;
}

int vsdd_cache_make_room(vsdd_cache *k, uint64_t need) { return make_room_in(k, 0, need); }

/* Lock not held. Give the heap freed by evictions back to the system. glibc keeps freed
 * chunks in its arenas, so an evicted renderer's tens of MB stayed resident and the next
 * one's grew RSS beside them; the budget is about resident memory. */
void vsdd_cache_trim_after_evictions(vsdd_cache *k)
{
    int trim;
    vsdd_lock(&k->lock);
    trim = k->trim;
    k->trim = 0;
    vsdd_unlock(&k->lock);
    if (trim) malloc_trim(0);
}

vsdd_entry *vsdd_cache_find(vsdd_cache *k, int kind, const char *key, int idle_only)
{
    vsdd_entry *e;
    for (e = k->head; e; e = e->next)
        if (e->kind == kind && strcmp(e->key, key) == 0 && (!idle_only || e->refs == 0)) return e;
    return NULL;
}

static void remove_dir(const char *dir);

/* Remove the private cache folders (vsd-cache-*) of daemons that died without cleaning up
 * (kill -9, a crash, a power cut): a live daemon holds an exclusive flock on its folder's
 * "owner" file, which the kernel drops when the process dies, so a folder whose owner can
 * be locked is an orphan. Folders without the file (other programs, older versions) stay. */
static void remove_orphan_folders(const char *parent, const char *mine)
{
    DIR *d = opendir(parent);
    struct dirent *de;
    if (!d) return;
    while ((de = readdir(d))) {
        char dir[VSD_PATH_LEN + 300], owner[VSD_PATH_LEN + 320];
        int fd;
        if (strncmp(de->d_name, "vsd-cache-", 10) != 0) continue;
        snprintf(dir, sizeof dir, "%s/%s", parent, de->d_name);
        if (strcmp(dir, mine) == 0) continue;
        snprintf(owner, sizeof owner, "%s/owner", dir);
        fd = open(owner, O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
        if (fd < 0) continue;
        if (flock(fd, LOCK_EX | LOCK_NB) == 0) {
            vsdd_log(VSDD_LOG_INFO, "removing %s, left by a daemon that did not exit cleanly", dir);
            remove_dir(dir);
        }
        close(fd);
    }
    closedir(d);
}

vsdd_cache *vsdd_cache_new(const vsdd_config *cfg, vsdd_loader *loader, char *err, size_t errlen)
{
    vsdd_cache *k = calloc(1, sizeof *k);
    char tmpl[VSD_PATH_LEN];
    if (!k) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    k->cfg = cfg;
    k->loader = loader;
    k->owner_fd = -1;
    vsdd_mutex_init(&k->lock, VSDD_RANK_CACHE);
    pthread_cond_init(&k->room, NULL);
    snprintf(tmpl, sizeof tmpl, "%.900s/vsd-cache-XXXXXX", cfg->cache_parent);
    if (!mkdtemp(tmpl)) {
        snprintf(err, errlen, "cannot create a cache folder in %s: %s", cfg->cache_parent, strerror(errno));
        vsdd_cache_free(k);
        return NULL;
    }
    chmod(tmpl, 0700);
    snprintf(k->dir, sizeof k->dir, "%s", tmpl);
    snprintf(k->blob_dir, sizeof k->blob_dir, "%.940s/blobs", tmpl);
    if (mkdir(k->blob_dir, 0700) != 0) {
        snprintf(err, errlen, "cannot create %s: %s", k->blob_dir, strerror(errno));
        vsdd_cache_shutdown(k);
        vsdd_cache_free(k);
        return NULL;
    }
    {
        char owner[VSD_PATH_LEN + 16];
        snprintf(owner, sizeof owner, "%.1000s/owner", tmpl);
        k->owner_fd = open(owner, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
        if (k->owner_fd < 0 || flock(k->owner_fd, LOCK_EX | LOCK_NB) != 0) {
            snprintf(err, errlen, "cannot create and lock %s: %s", owner, strerror(errno));
            vsdd_cache_shutdown(k);
            vsdd_cache_free(k);
            return NULL;
        }
    }
    remove_orphan_folders(cfg->cache_parent, tmpl);
    return k;
}

const char *vsdd_cache_dir(const vsdd_cache *k) { return k->dir; }

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

void vsdd_cache_shutdown(vsdd_cache *k)
{
    vsdd_lock(&k->lock);
    /* renderers first: they pin volumes */
    for (;;) {
        vsdd_entry *e;
        for (e = k->head; e && e->kind != ENT_SLOT; e = e->next) {}
        if (!e) break;
        lru_unlink(k, e);
        vsdd_cache_account(k, e, 0);
        free_entry(k, e);
    }
    while (k->head) {
        vsdd_entry *e = k->head;
        lru_unlink(k, e);
        vsdd_cache_account(k, e, 0);
        free_entry(k, e);
    }
    vsdd_unlock(&k->lock);
    if (k->dir[0]) remove_dir(k->dir);
    k->dir[0] = '\0';
    if (k->owner_fd >= 0) close(k->owner_fd);
    k->owner_fd = -1;
}

void vsdd_cache_free(vsdd_cache *k)
{
    if (!k) return;
    pthread_cond_destroy(&k->room);
    vsdd_mutex_destroy(&k->lock);
    free(k);
}

int vsdd_cache_has_blob(vsdd_cache *k, const char *hash)
{
    char key[128];
    vsdd_entry *e;
    snprintf(key, sizeof key, "blob:%s", hash);
    vsdd_lock(&k->lock);
    e = vsdd_cache_find(k, ENT_BLOB, key, 0);
    if (e) vsdd_cache_touch(k, e);
    vsdd_unlock(&k->lock);
    return e != NULL;
}

int vsdd_cache_put_blob(vsdd_cache *k, int fd, const char *hash, uint64_t len, vsdd_err *e, int *fatal)
{
    char key[128], tmp[VSD_PATH_LEN + 32], final_path[VSD_PATH_LEN + 80], got[VSD_HASH_HEX_MAX];
    vsd_hash_kind kind = vsd_hash_kind_of(hash);
    unsigned char *buf = NULL;
    vsd_hasher *h = NULL;
    uint64_t left = len;
    int tfd = -1, rc = -1, reserved = 0;
    *fatal = 0;
    snprintf(key, sizeof key, "blob:%s", hash);
    if (vsdd_cache_has_blob(k, hash)) {
        if (vsd_proto_skip(fd, len, 30000)) *fatal = 1;
        return *fatal ? vsdd_fail(e, VSD_E_BAD_FRAME, "blob data truncated or too slow") : 0;
    }
    if (len > k->cfg->blob_bytes) {
        vsdd_fail(e, VSD_E_LIMIT, "blob of %llu bytes is larger than the whole blob store (%llu bytes, --blob-mb)",
                  (unsigned long long)len, (unsigned long long)k->cfg->blob_bytes);
        *fatal = vsd_proto_skip(fd, len, 30000) != 0;
        return -1;
    }
    vsdd_lock(&k->lock);
    if (make_room_in(k, 1, len) == 0) {
        k->disk_reserved += len;
        reserved = 1;
        vsdd_cache_note_peaks(k);
    }
    vsdd_unlock(&k->lock);
    if (!reserved) {
        vsdd_fail(e, VSD_E_CACHE_FULL, "the blob store is full of data in use by running jobs; retry later");
        *fatal = vsd_proto_skip(fd, len, 30000) != 0;
        return -1;
    }
    snprintf(tmp, sizeof tmp, "%s/.put-XXXXXX", k->blob_dir);
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
    snprintf(final_path, sizeof final_path, "%.950s/%s", k->blob_dir, hash);
    vsdd_lock(&k->lock);
    k->disk_reserved -= len;
    reserved = 0;
    if (!vsdd_cache_find(k, ENT_BLOB, key, 0)) {
        vsdd_entry *b = calloc(1, sizeof *b);
        if (b && rename(tmp, final_path) == 0) {
            b->kind = ENT_BLOB;
            snprintf(b->key, sizeof b->key, "%s", key);
            snprintf(b->path, sizeof b->path, "%.1000s", final_path);
            b->bytes = len;
            make_room_in(k, 1, len); /* the reservation was released: normally a no-op */
            vsdd_cache_lru_push(k, b);
            vsdd_cache_account(k, b, 1);
            tmp[0] = '\0';
            rc = 0;
        } else {
            free(b);
            vsdd_fail(e, VSD_E_INTERNAL, "cannot store the blob");
        }
    } else {
        rc = 0;
    }
    vsdd_unlock(&k->lock);
done:
    if (h) vsd_hasher_final(h, got);
    if (tfd >= 0) close(tfd);
    if (tmp[0]) unlink(tmp);
    free(buf);
    if (reserved) {
        vsdd_lock(&k->lock);
        k->disk_reserved -= len;
        vsdd_unlock(&k->lock);
    }
    return rc;
}

/* Lock held. The file behind src ("blob:<hash>" pinned into *blob, or a path). */
static int source_path(vsdd_cache *k, const char *src, char *path, size_t len, vsdd_entry **blob, vsdd_err *e)
{
    *blob = NULL;
    if (strncmp(src, "blob:", 5) == 0) {
        vsdd_entry *b = vsdd_cache_find(k, ENT_BLOB, src, 0);
        if (!b) return vsdd_fail(e, VSD_E_MISSING_BLOB, "%s is not in the daemon's cache (send it with PUT)", src);
        b->refs++;
        vsdd_cache_touch(k, b);
        *blob = b;
        snprintf(path, len, "%s", b->path);
    } else {
        snprintf(path, len, "%s", src);
    }
    return 0;
}

int vsdd_cache_pin_file(vsdd_cache *k, const char *src, char *path, size_t len, vsdd_entry **blob, vsdd_err *e)
{
    int rc;
    vsdd_lock(&k->lock);
    rc = source_path(k, src, path, len, blob, e);
    vsdd_unlock(&k->lock);
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
static int insert_loaded(vsdd_cache *k, vsdd_entry *e, vsdd_entry **out, vsdd_err *err)
{
    vsdd_entry *other = vsdd_cache_find(k, e->kind, e->key, 0);
    if (other) {
        free_entry(k, e);
        other->refs++;
        vsdd_cache_touch(k, other);
        *out = other;
        return 0;
    }
    if (vsdd_cache_make_room(k, e->bytes)) {
        vsdd_fail(err, VSD_E_CACHE_FULL, "the cache (%llu MiB) cannot hold %.80s (%llu bytes) beside the data in use",
                  (unsigned long long)(k->cfg->cache_bytes >> 20), e->key, (unsigned long long)e->bytes);
        free_entry(k, e);
        return -1;
    }
    e->refs = 1;
    vsdd_cache_lru_push(k, e);
    vsdd_cache_account(k, e, 1);
    *out = e;
    return 0;
}

/* Lock held: a cached entry for key, pinned, or NULL (counted as a hit or a miss). */
static vsdd_entry *lookup(vsdd_cache *k, int kind, const char *key)
{
    vsdd_entry *e = vsdd_cache_find(k, kind, key, 0);
    if (!e) {
        k->misses[kind]++;
        return NULL;
    }
    e->refs++;
    vsdd_cache_touch(k, e);
    k->hits[kind]++;
    return e;
}

/* Keep a freshly decoded volume or map (one of vol/env set) under key, pinned. */
static int keep_loaded(vsdd_cache *k, int kind, const char *key, vsd_volume *vol, vsd_env *env, vsdd_entry *blob,
                       vsdd_entry **out, vsdd_err *err)
{
    vsdd_entry *e = calloc(1, sizeof *e);
    int rc;
    if (!e) {
        vsd_volume_destroy(vol);
        vsd_env_destroy(env);
        vsdd_cache_unpin(k, blob);
        return vsdd_fail(err, VSD_E_INTERNAL, "out of memory");
    }
    e->kind = kind;
    snprintf(e->key, sizeof e->key, "%s", key);
    e->vol = vol;
    e->env = env;
    e->bytes = vol ? volume_bytes(vol) : sizeof *env + (uint64_t)env->width * env->height * 3 * sizeof(float);
    vsdd_lock(&k->lock);
    vsdd_cache_unpin_locked(k, blob);
    rc = insert_loaded(k, e, out, err);
    vsdd_unlock(&k->lock);
    vsdd_cache_trim_after_evictions(k);
    return rc;
}
/* The cached entry of `key` (*out, *hit = 1: returns 0), or the source's file pinned for a
 * load (*blob, path: returns 1), under the cache lock; -1 when the source is unknown. */
static int find_or_pin_source(vsdd_cache *k, int kind, const char *key, const char *src, char *path, size_t pathlen,
                              vsdd_entry **blob, vsdd_entry **out, int *hit, vsdd_err *err)
{
    int rc;
    vsdd_lock(&k->lock);
    *out = lookup(k, kind, key);
    rc = *out ? 0 : source_path(k, src, path, pathlen, blob, err);
    vsdd_unlock(&k->lock);
    if (*out) {
        *hit = 1;
        return 0;
    }
    return rc ? -1 : 1;
}


int vsdd_cache_get_volume(vsdd_cache *k, const char *src, const char *grid, int grid_index, vsdd_entry **out, int *hit,
                          vsdd_err *err)
{
    char key[1400], path[VSD_PATH_LEN], stamp[64];
    vsdd_entry *blob = NULL;
    vsd_volume *vol = NULL;
    int rc;
    *hit = 0;
    source_stamp(src, stamp, sizeof stamp);
    snprintf(key, sizeof key, "vol|%s%s|%s|%d", src, stamp, grid, grid_index);
    if ((rc = find_or_pin_source(k, ENT_VOLUME, key, src, path, sizeof path, &blob, out, hit, err)) <= 0) return rc;
    /* decoded without the cache lock: other jobs go on meanwhile (the blob stays pinned) */
    if (vsdd_load_volume(k->loader, src, path, grid, grid_index, &vol, err)) {
        vsdd_cache_unpin(k, blob);
        return -1;
    }
    return keep_loaded(k, ENT_VOLUME, key, vol, NULL, blob, out, err);
}

int vsdd_cache_get_env(vsdd_cache *k, const char *src, const char *conversion, vsdd_entry **out, int *hit,
                       vsdd_err *err)
{
    char key[1400], path[VSD_PATH_LEN], stamp[64];
    vsdd_entry *blob = NULL;
    vsd_env *env = NULL;
    int rc;
    *hit = 0;
    source_stamp(src, stamp, sizeof stamp);
    snprintf(key, sizeof key, "env|%s%s|%s", src, stamp, conversion);
    if ((rc = find_or_pin_source(k, ENT_ENV, key, src, path, sizeof path, &blob, out, hit, err)) <= 0) return rc;
    if (vsdd_load_env(k->loader, src, path, conversion, &env, err)) {
        vsdd_cache_unpin(k, blob);
        return -1;
    }
    return keep_loaded(k, ENT_ENV, key, NULL, env, blob, out, err);
}

const vsd_volume *vsdd_entry_volume(const vsdd_entry *e) { return e ? e->vol : NULL; }
const vsd_env *vsdd_entry_env(const vsdd_entry *e) { return e ? e->env : NULL; }
vsdd_slot_use *vsdd_slot_use_of(vsdd_slot *s) { return &s->use; }
vsd_renderer *vsdd_slot_renderer(vsdd_slot *s) { return s->r; }

void vsdd_cache_unpin(vsdd_cache *k, vsdd_entry *e)
{
    if (!e) return;
    vsdd_lock(&k->lock);
    vsdd_cache_unpin_locked(k, e);
    vsdd_unlock(&k->lock);
}

cJSON *vsdd_cache_stats(vsdd_cache *k)
{
    cJSON *o = cJSON_CreateObject(), *kind;
    int i;
    vsdd_lock(&k->lock);
    cJSON_AddNumberToObject(o, "budget_bytes", (double)k->cfg->cache_bytes);
    cJSON_AddNumberToObject(o, "used_bytes", (double)(k->used + k->reserved));
    cJSON_AddNumberToObject(o, "peak_bytes", (double)k->peak);
    cJSON_AddNumberToObject(o, "uncached_bytes", (double)k->uncached);
    cJSON_AddNumberToObject(o, "admission_waits", (double)k->admission_waits);
    cJSON_AddNumberToObject(o, "blob_budget_bytes", (double)k->cfg->blob_bytes);
    cJSON_AddNumberToObject(o, "blob_used_bytes", (double)(k->disk_used + k->disk_reserved));
    cJSON_AddNumberToObject(o, "blob_peak_bytes", (double)k->disk_peak);
    cJSON_AddNumberToObject(o, "evictions", (double)k->evictions);
    cJSON_AddNumberToObject(o, "renderers_taken_over", (double)k->taken_over);
    for (i = 0; i < ENT_KINDS; i++) {
        kind = cJSON_AddObjectToObject(o, kind_names[i]);
        cJSON_AddNumberToObject(kind, "entries", (double)k->count[i]);
        cJSON_AddNumberToObject(kind, "hits", (double)k->hits[i]);
        cJSON_AddNumberToObject(kind, "misses", (double)k->misses[i]);
    }
    {
        uint64_t by[ENT_KINDS] = {0};
        vsdd_entry *e;
        for (e = k->head; e; e = e->next) by[e->kind] += e->bytes;
        for (i = 0; i < ENT_KINDS; i++)
            cJSON_AddNumberToObject(cJSON_GetObjectItem(o, kind_names[i]), "bytes", (double)by[i]);
    }
    vsdd_unlock(&k->lock);
    return o;
}
