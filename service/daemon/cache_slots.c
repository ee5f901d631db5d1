/* Renderer slots of the daemon's cache: a renderer kept per (method, options, inputs),
 * counted in the memory budget at the heap it was seen to use. A new one is admitted when
 * the budget can hold its method's last working size, or when no other renderer is busy
 * (then it renders alone outside the budget and is not kept). Without the wait, renderers that did not fit rendered
 * uncached beside a full cache, two at once with two workers, and RSS reached 1.8x the
 * budget (docs/soak.md: why each of these was needed). */
#define _GNU_SOURCE
#include "cache_internal.h"
#include <malloc.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* What each method's renderers were last seen to use at most within a job
 * (vsdd_cache_render_end), the first estimate of a new one (k->learned); lock held. */
static uint64_t *learned_bytes(vsdd_cache *k, const char *method)
{
    size_t i, n = sizeof k->learned / sizeof k->learned[0];
    for (i = 0; i < n && k->learned[i].method[0]; i++)
        if (strcmp(k->learned[i].method, method) == 0) return &k->learned[i].bytes;
    if (i == n) return NULL;
    snprintf(k->learned[i].method, sizeof k->learned[i].method, "%s", method);
    k->learned[i].bytes = 0;
    return &k->learned[i].bytes;
}

/* A renderer's first estimate, before it is measured: the sampling tables of the map plus
 * as much again as the density grids of its volumes, or its method's last working size if
 * more. */
static uint64_t slot_bytes(vsdd_cache *k, vsdd_entry *pins[VSDD_SLOT_PINS], const char *method)
{
    uint64_t b = 256 * 1024, *l = learned_bytes(k, method);
    const vsdd_entry *env = pins[VSDD_PIN_ENV];
    int v;
    for (v = 0; v < VSD_MAX_VOLUMES; v++)
        if (pins[VSDD_PIN(v, VSDD_PIN_DENSITY)]) b += pins[VSDD_PIN(v, VSDD_PIN_DENSITY)]->bytes;
    if (env && env->env) b += (uint64_t)env->env->width * env->env->height * 8;
    else b += 64 * 32 * 8;
    return l && *l > b ? *l : b;
}

/* The entry key of a slot (and a slot's preparation key): the caller's key, or, when it is
 * too long (a scene with many volumes, long options), its head and the XXH3-128 of the whole
 * of it, so two different inputs never share a renderer and the same inputs always find
 * theirs. */
void vsdd_key_fit(const char *key, char *out, size_t len)
{
    char hex[VSD_HASH_HEX_MAX];
    size_t n = strlen(key);
    if (n < len) {
        memcpy(out, key, n + 1);
        return;
    }
    vsd_hash_buffer(VSD_HASH_XXH3_128, key, n, hex);
    snprintf(out, len, "%.*s...#%s", (int)(len - sizeof hex - 8), key, hex);
}

uint64_t vsdd_heap_in_use(void)
{
    struct mallinfo2 mi = mallinfo2();
    return (uint64_t)mi.uordblks + (uint64_t)mi.hblkhd;
}

/* Lock held. Count the busy slot of entry e at `working` bytes when that is more than
 * now: idle entries are evicted to make room (e is in use, so it stays); one that still
 * does not fit is counted outside the budget until its job ends and is not kept, so that
 * no other renderer is admitted beside it meanwhile. */
static void grow_entry(vsdd_cache *k, vsdd_entry *e, uint64_t working)
{
    if (working <= e->bytes) return;
    vsdd_cache_account(k, e, 0);
    e->bytes = working;
    if (!e->uncached && vsdd_cache_make_room(k, e->bytes)) {
        e->uncached = 1;
        snprintf(e->key, sizeof e->key, "(uncached)");
    }
    vsdd_cache_account(k, e, 1);
}

void vsdd_cache_render_begin(vsdd_cache *k, vsdd_slot *s)
{
    uint64_t heap = vsdd_heap_in_use();
    vsdd_lock(&k->lock);
    s->heap_start = heap;
    vsdd_unlock(&k->lock);
}

void vsdd_cache_render_end(vsdd_cache *k, vsdd_slot *s, int64_t framebuffer_bytes, int ok)
{
    uint64_t heap = vsdd_heap_in_use(), *l, size;
    int64_t before;
    vsdd_lock(&k->lock);
    before = s->held;
    if (ok) {
        /* what it keeps: the growth over the render, less the framebuffer it made */
        s->held += (int64_t)heap - (int64_t)s->heap_start - framebuffer_bytes;
        if (s->held < 0) s->held = 0;
    }
    /* its size for this job: the more of what it held before and after */
    size = (uint64_t)(s->held > before ? s->held : before > 0 ? before : 0);
    if (ok) {
        /* the next new renderer of this method is first estimated at this size: a rise
         * taken at once, a fall slowly */
        l = learned_bytes(k, s->method);
        if (l) *l = size >= *l ? size : (*l * 3 + size) / 4;
    }
    grow_entry(k, s->self, size);
    vsdd_unlock(&k->lock);
}

int64_t vsdd_film_bytes(const vsd_framebuffer *film)
{
    int64_t channels = 0;
    int p;
    if (!film) return 0;
    for (p = 0; p < VSD_PASS_COUNT; p++) channels += vsd_pass_channels((vsd_pass)p);
    return (int64_t)film->width * film->height * channels * (int64_t)sizeof(float);
}

vsd_framebuffer *vsdd_cache_take_film(vsdd_cache *k, vsdd_slot *s)
{
    vsd_framebuffer *fb;
    vsdd_lock(&k->lock);
    fb = s->film;
    s->film = NULL;
    /* the job's now, as a film it made would be (vsdd_cache_render_end leaves it out) */
    s->held -= vsdd_film_bytes(fb);
    if (s->held < 0) s->held = 0;
    vsdd_unlock(&k->lock);
    return fb;
}

void vsdd_cache_keep_film(vsdd_cache *k, vsdd_slot *s, vsd_framebuffer **film)
{
    vsdd_lock(&k->lock);
    if (*film && !s->film && !s->self->uncached) {
        const uint64_t after = (uint64_t)s->held + (uint64_t)vsdd_film_bytes(*film);
        const uint64_t more = after > s->self->bytes ? after - s->self->bytes : 0;
        /* only into room the budget has free: a film saves its first touch, a few hundredths
         * of a second, and is not worth evicting an idle renderer, volume or map for */
        if (k->used + k->reserved + more <= k->cfg->cache_bytes) {
            s->film = *film;
            *film = NULL;
            s->held = (int64_t)after;
            grow_entry(k, s->self, after);
        }
    }
    vsdd_unlock(&k->lock);
}

/* Lock held. Wait until a new renderer of `est` bytes is admitted: room in the memory
 * budget (reserved, *cached = 1), or no other renderer busy (it renders alone outside the
 * budget, *cached = 0). The jobs waiting here hold only their inputs' pins, and busy
 * renderers end (max_job_seconds at worst), so the wait ends. -1 if *cancel is raised. */
static int admit_renderer(vsdd_cache *k, uint64_t est, volatile int *cancel, int *cached)
{
    int waited = 0;
    for (;;) {
        /* a renderer running outside the budget counts here, or a second one would be
         * admitted beside it into a cache that is full once it ends */
        if (vsdd_cache_make_room(k, est + k->uncached) == 0) {
            k->reserved += est;
            *cached = 1;
            break;
        }
        if (k->busy_slots == 0) {
            /* make_room above evicted every idle entry it could: a renderer larger than
             * the budget renders beside nothing but the inputs of waiting jobs */
            k->uncached += est;
            *cached = 0;
            break;
        }
        if (cancel && *cancel) return -1;
        if (!waited) {
            k->admission_waits++;
            vsdd_log(VSDD_LOG_DEBUG, "cache: a new renderer (%llu bytes) waits for memory",
                     (unsigned long long)est);
            waited = 1;
        }
        {
            struct timespec until = vsdd_deadline_ms(200); /* the cancel flag has no condition variable */
            vsdd_cond_timedwait(&k->room, &k->lock, &until);
        }
    }
    k->busy_slots++;
    vsdd_cache_note_peaks(k);
    return 0;
}

/* Lock held. Undo admit_renderer's reservation once the slot's entry is created or failed. */
static void end_admission(vsdd_cache *k, uint64_t est, int cached)
{
    if (cached) k->reserved -= est;
    else k->uncached -= est;
}

/* Whether slot s holds volume v as `pins` has it (density, emission and ior grid entries). */
static int holds_volume(const vsdd_slot *s, vsdd_entry *pins[VSDD_SLOT_PINS], int v)
{
    int w, equal = 1;
    for (w = 0; w < VSDD_PINS_PER_VOLUME; w++) equal &= s->pins[VSDD_PIN(v, w)] == pins[VSDD_PIN(v, w)];
    return equal;
}

/* Lock held. The idle kept renderer of `family` holding the most of the scene's volumes as
 * `pins` has them (at least one), or NULL. Only with several volumes: one volume's new frame
 * leaves its renderer nothing to keep but the map's, and a renderer kept per frame makes
 * scrubbing back free. */
static vsdd_entry *renderer_to_take_over(vsdd_cache *k, const char *family, const vsd_scene *scene,
                                         vsdd_entry *pins[VSDD_SLOT_PINS])
{
    vsdd_entry *e, *best = NULL;
    int v, most = 0;
    if (scene->volume_count < 2) return NULL;
    for (e = k->head; e; e = e->next) {
        int same = 0;
        if (e->kind != ENT_SLOT || e->refs > 0 || e->uncached || strcmp(e->slot->family, family) != 0) continue;
        for (v = 0; v < scene->volume_count; v++) same += holds_volume(e->slot, pins, v);
        if (same > most) {
            most = same;
            best = e;
        }
    }
    return best;
}

/* Lock held. e (idle, found above) is keyed for `ekey` and takes the caller's pins of the
 * volumes it holds otherwise (releasing its own; pins[] of those become NULL) and is handed
 * those volumes; the volumes that stay keep their key in the renderer, so their parts are
 * not prepared again. */
static void take_over(vsdd_cache *k, vsdd_entry *e, const char *ekey, const vsd_scene *scene,
                      vsdd_entry *pins[VSDD_SLOT_PINS])
{
    vsdd_slot *s = e->slot;
    int v, w, i;
    k->taken_over++;
    snprintf(e->key, sizeof e->key, "%s", ekey);
    for (v = 0; v < scene->volume_count; v++) {
        if (holds_volume(s, pins, v)) continue;
        for (w = 0; w < VSDD_PINS_PER_VOLUME; w++) {
            i = VSDD_PIN(v, w);
            vsdd_cache_unpin_locked(k, s->pins[i]);
            s->pins[i] = pins[i];
            pins[i] = NULL;   /* the slot's now */
        }
        vsd_renderer_use_volume(s->r, v, vsdd_entry_volume(s->pins[VSDD_PIN(v, VSDD_PIN_DENSITY)]),
                                vsdd_entry_volume(s->pins[VSDD_PIN(v, VSDD_PIN_EMISSION)]),
                                vsdd_entry_volume(s->pins[VSDD_PIN(v, VSDD_PIN_IOR)]));
    }
}

int vsdd_cache_get_slot(vsdd_cache *k, const char *key, const char *family, const vsd_scene *scene,
                        vsdd_entry *pins[VSDD_SLOT_PINS], vsdd_slot_progress_fn progress, volatile int *cancel,
                        vsdd_slot **out, int *hit, char *msg, size_t msglen)
{
    vsdd_entry *e;
    vsdd_slot *s;
    vsd_render_options ro;
    vsd_status st;
    uint64_t est;
    int i, cached = 0;
    char ekey[sizeof e->key];
    char efamily[sizeof e->key];
    *out = NULL;
    *hit = VSDD_SLOT_NEW;
    vsdd_key_fit(key, ekey, sizeof ekey);
    vsdd_key_fit(family, efamily, sizeof efamily);
    vsdd_lock(&k->lock);
    e = vsdd_cache_find(k, ENT_SLOT, ekey, 1);
    if (e) {
        k->hits[ENT_SLOT]++;
        *hit = VSDD_SLOT_HIT;
    } else if ((e = renderer_to_take_over(k, efamily, scene, pins))) {
        k->misses[ENT_SLOT]++;
        take_over(k, e, ekey, scene, pins);
        *hit = VSDD_SLOT_TAKEN_OVER;
    }
    if (e) {
        e->refs = 1;
        k->busy_slots++;
        vsdd_cache_touch(k, e);
        /* the slot pins the same entries (a take-over moved the others into it) */
        for (i = 0; i < VSDD_SLOT_PINS; i++) vsdd_cache_unpin_locked(k, pins[i]);
        vsdd_unlock(&k->lock);
        st = vsd_renderer_set_scene(e->slot->r, scene, msg, msglen);
        if (st) {
            *hit = VSDD_SLOT_NEW;
            vsdd_cache_release_slot(k, e->slot, 0);
            return -(int)st;
        }
        *out = e->slot;
        return 0;
    }
    k->misses[ENT_SLOT]++;
    est = slot_bytes(k, pins, scene->render.method);
    if (admit_renderer(k, est, cancel, &cached)) {
        for (i = 0; i < VSDD_SLOT_PINS; i++) vsdd_cache_unpin_locked(k, pins[i]);
        vsdd_unlock(&k->lock);
        snprintf(msg, msglen, "cancelled while waiting for memory");
        return -(int)VSD_ERR_CANCELLED;
    }
    vsdd_unlock(&k->lock);
    vsdd_cache_trim_after_evictions(k); /* before the new renderer allocates beside what was evicted */
    s = calloc(1, sizeof *s);
    e = calloc(1, sizeof *e);
    if (!s || !e) {
        free(s);
        free(e);
        st = VSD_ERR_NOMEM;
        snprintf(msg, msglen, "out of memory");
        goto failed;
    }
    memset(&ro, 0, sizeof ro);
    ro.threads = k->cfg->threads;
    ro.progress = progress;
    ro.user = &s->use;
    ro.cancel = &s->use.cancel;
    ro.cache_dir = k->cfg->method_cache[0] ? k->cfg->method_cache : NULL;
    ro.max_voxels = k->cfg->max_voxels;   /* the daemon checked its volumes against it already */
    {
        uint64_t before = vsdd_heap_in_use();
        st = vsd_renderer_create(scene, &ro, &s->r, msg, msglen);
        s->held = (int64_t)vsdd_heap_in_use() - (int64_t)before;
    }
    snprintf(s->method, sizeof s->method, "%.31s", scene->render.method);
    snprintf(s->family, sizeof s->family, "%s", efamily);
    if (st) {
        free(s);
        free(e);
        goto failed;
    }
    /* each volume of the scene from its pinned grids (the slot keeps the pins) */
    for (i = 0; i < scene->volume_count && i < VSD_MAX_VOLUMES; i++)
        vsd_renderer_use_volume(s->r, i, vsdd_entry_volume(pins[VSDD_PIN(i, VSDD_PIN_DENSITY)]),
                                vsdd_entry_volume(pins[VSDD_PIN(i, VSDD_PIN_EMISSION)]),
                                vsdd_entry_volume(pins[VSDD_PIN(i, VSDD_PIN_IOR)]));
    if (pins[VSDD_PIN_ENV]) vsd_renderer_use_env(s->r, pins[VSDD_PIN_ENV]->env);
    for (i = 0; i < VSDD_SLOT_PINS; i++) s->pins[i] = pins[i];
    s->self = e;
    e->kind = ENT_SLOT;
    snprintf(e->key, sizeof e->key, "%s", ekey);
    e->slot = s;
    vsdd_lock(&k->lock);
    end_admission(k, est, cached);
    e->bytes = est;
    if (!cached) {
        /* rendered alone beside nothing else busy, counted outside the budget, not kept */
        e->uncached = 1;
        snprintf(e->key, sizeof e->key, "(uncached)");
    }
    e->refs = 1;
    vsdd_cache_lru_push(k, e);
    vsdd_cache_account(k, e, 1);
    vsdd_unlock(&k->lock);
    *out = s;
    return 0;
failed:
    vsdd_lock(&k->lock);
    end_admission(k, est, cached);
    k->busy_slots--;
    for (i = 0; i < VSDD_SLOT_PINS; i++) vsdd_cache_unpin_locked(k, pins[i]);
    pthread_cond_broadcast(&k->room);
    vsdd_unlock(&k->lock);
    return -(int)st;
}

void vsdd_cache_release_slot(vsdd_cache *k, vsdd_slot *s, int keep)
{
    vsdd_entry *e = s->self;
    vsdd_lock(&k->lock);
    if (e->refs > 0) e->refs--;
    k->busy_slots--;
    if ((!keep || e->uncached) && e->refs == 0) {
        vsdd_cache_evict(k, e);
    } else if (e->refs == 0 && (uint64_t)s->held < e->bytes) {
        /* kept: counted at what it holds between jobs, no longer at its working size */
        vsdd_cache_account(k, e, 0);
        e->bytes = (uint64_t)s->held;
        vsdd_cache_account(k, e, 1);
    }
    pthread_cond_broadcast(&k->room);
    vsdd_unlock(&k->lock);
    vsdd_cache_trim_after_evictions(k);
}
