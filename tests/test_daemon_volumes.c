/* Scenes of several volumes through `vsd serve` (issue 30): real daemon processes on Unix
 * sockets, driven by the C client and by `vsd render --remote`. Usage:
 * test_daemon_volumes VSD_EXECUTABLE
 *
 * Proves: a two-volume RENDER through blobs gives the in-process renderer's image bit for
 * bit (reference, same seed), and so does `vsd render --remote` with a scene file whose
 * second volume reads another frame (frame_offset); missing_blob lists every volume's
 * missing blob at once (a file two volumes share once); RESULT.cache reports each volume
 * (a change of volumes[1]'s frame reloads volumes[1] only); --max-voxels bounds the volumes'
 * voxels together; a method that renders one volume refuses with the renderer's message; a
 * bad blob or blob name names the volume's index; a scene of VSD_MAX_VOLUMES volumes from
 * server-side paths renders as in-process and finds its renderer again. */
#define _GNU_SOURCE
#include "test_common.h"
#include "test_render_util.h"
#include "test_daemon_proc.h"
#include "vsd_client.h"
#include "vsd_proto.h"
#include "vsd/render.h"
#include "vsd/vdbio.h"
#include <cjson/cJSON.h>
#include <stdlib.h>
#include <unistd.h>

static const char *g_vsd;
static char g_dir[1024], g_env[1024];

static const char *frame_file(int frame)
{
    static char path[4][1200];
    static int turn;
    char rel[64];
    turn = (turn + 1) % 4;
    snprintf(rel, sizeof rel, "smoke64/fluid_data_%04d.vdb", frame);
    snprintf(path[turn], sizeof path[turn], "%s", test_data(rel));
    return path[turn];
}

/* The two volumes: smoke64 as it is, and a second copy moved by its matrix with its own
 * material and its temperature grid as emission (smoke64's flame is empty); they overlap.
 * file0/file1: blob names or paths; method: "reference", "lbl". */
static void scene2(char *out, size_t len, const char *file0, const char *file1, const char *env, const char *method)
{
    snprintf(out, len,
             "{\"version\":1,\"volumes\":["
             "{\"file\":\"%s\",\"grid\":\"density\",\"medium\":{\"density\":8}},"
             "{\"file\":\"%s\",\"emission_grid\":\"temperature\",\"matrix\":[1,0,0,0.6, 0,1,0,0, 0,0,1,0.3, 0,0,0,1],"
             "\"medium\":{\"density\":4,\"albedo\":[0.9,0.5,0.3],\"anisotropy\":0.3,\"emission_strength\":3}}],"
             "\"environment\":{\"file\":\"%s\"},"
             "\"camera\":{\"position\":[1,-3.9745,1.8771],\"look_at\":[1,1,1],\"up\":[0,0,1],\"fov\":0.7},"
             "\"film\":{\"width\":32,\"height\":18},\"render\":{\"method\":\"%s\",\"samples\":4,\"seed\":3}}",
             file0, file1, env, method);
}

/* The first volume alone (to see that the second one changes the picture). */
static void scene1(char *out, size_t len, const char *file0, const char *env)
{
    snprintf(out, len,
             "{\"version\":1,\"volume\":{\"file\":\"%s\",\"grid\":\"density\"},\"medium\":{\"density\":8},"
             "\"environment\":{\"file\":\"%s\"},"
             "\"camera\":{\"position\":[1,-3.9745,1.8771],\"look_at\":[1,1,1],\"up\":[0,0,1],\"fov\":0.7},"
             "\"film\":{\"width\":32,\"height\":18},\"render\":{\"method\":\"reference\",\"samples\":4,\"seed\":3}}",
             file0, env);
}

/* VSD_MAX_VOLUMES volumes of one sequence under dir, volume v reading frame + v, side by
 * side; each volume's entry is long enough that the daemon's renderer key is kept by its
 * hash (cache_slots.c). */
static void scene_max(char *out, size_t len, const char *dir)
{
    int v, n = snprintf(out, len, "{\"version\":1,\"volumes\":[");
    for (v = 0; v < VSD_MAX_VOLUMES && n > 0 && (size_t)n < len; v++)
        n += snprintf(out + n, len - (size_t)n,
                      "%s{\"file\":\"%s/fluid_data_####.vdb\",\"frame_offset\":%d,"
                      "\"matrix\":[0.5,0,0,%g, 0,0.5,0,%g, 0,0,0.5,0.5, 0,0,0,1],\"medium\":{\"density\":%d}}",
                      v ? "," : "", dir, v, (v % 4) * 0.5, (v / 4) * 0.5, 2 + v % 3);
    if (n > 0 && (size_t)n < len)
        snprintf(out + n, len - (size_t)n,
                 "],\"camera\":{\"position\":[1,-3.9745,1.8771],\"look_at\":[1,1,1],\"up\":[0,0,1],\"fov\":0.7},"
                 "\"film\":{\"width\":32,\"height\":18},\"render\":{\"method\":\"reference\",\"samples\":4,"
                 "\"seed\":5}}");
}

static vsd_framebuffer *render_local(const char *json)
{
    vsd_scene sc;
    return test_parse_scene(json, NULL, 0, &sc) ? test_render_fresh(&sc, NULL, NULL, NULL, 1, NULL) : NULL;
}


static long compare_fb(const vsd_framebuffer *a, const vsd_framebuffer *b)
{
    long diff = 0, i, n;
    int p;
    if (!a || !b || a->width != b->width || a->height != b->height) return -1;
    n = (long)a->width * a->height;
    for (p = 0; p < VSD_PASS_COUNT; p++)
        for (i = 0; i < n * vsd_pass_channels((vsd_pass)p); i++)
            if (memcmp(&a->pass[p][i], &b->pass[p][i], sizeof(float)) != 0) diff++;
    return diff;
}

static int render_remote(vsdc *c, const char *scene, vsdc_result *res, cJSON **info, char *err, size_t errlen)
{
    vsdc_render_request rq;
    int rc;
    memset(&rq, 0, sizeof rq);
    memset(res, 0, sizeof *res);
    rq.scene_json = scene;
    *info = NULL;
    rc = vsdc_render(c, &rq, res, err, errlen);
    if (rc == 0) *info = cJSON_Parse(res->json ? res->json : "{}");
    return rc;
}

/* RESULT.cache.<name>, or cache.volumes[v].<name> when v >= 0: 1 true, 0 false, -1 null,
 * -2 absent. */
static int cache_flag(const cJSON *info, int v, const char *name)
{
    const cJSON *cache = cJSON_GetObjectItemCaseSensitive(info, "cache"), *x;
    if (v >= 0) cache = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(cache, "volumes"), v);
    x = cJSON_GetObjectItemCaseSensitive(cache, name);
    return cJSON_IsTrue(x) ? 1 : cJSON_IsFalse(x) ? 0 : cJSON_IsNull(x) ? -1 : -2;
}

/* Print "<what> <JSON of o.<key>>" (for the log). */
static void print_field(const char *what, const cJSON *o, const char *key)
{
    char *text = cJSON_PrintUnformatted(cJSON_GetObjectItemCaseSensitive(o, key));
    printf("%s %s\n", what, text ? text : "?");
    free(text);
}

static int cache_volume_count(const cJSON *info)
{
    const cJSON *l = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(info, "cache"), "volumes");
    return cJSON_IsArray(l) ? cJSON_GetArraySize(l) : -1;
}

static uint64_t density_voxels(const char *path)
{
    vsd_grid_info *g = NULL;
    int n = 0, i;
    uint64_t v = 0;
    char err[512];
    if (vsd_vdb_list(path, &g, &n, err, sizeof err)) return 0;
    for (i = 0; i < n; i++)
        if (strcmp(g[i].name, "density") == 0) v = g[i].active_voxels;
    vsd_vdb_list_free(g);
    return v;
}

static int upload(vsdc *c, const char *path, char *blob, size_t len)
{
    char err[1024];
    if (vsdc_upload_file(c, path, blob, len, NULL, err, sizeof err) == 0) return 0;
    CHECK_MSG(0, "upload %s: %s", path, err);
    return -1;
}

/* The hashes listed in the last ERROR's "missing". */
static int listed_missing(const vsdc *c, const char *hash)
{
    cJSON *m = cJSON_Parse(vsdc_error_json(c) ? vsdc_error_json(c) : "{}");
    const cJSON *it;
    int n = 0;
    cJSON_ArrayForEach(it, cJSON_GetObjectItemCaseSensitive(m, "missing"))
    {
        if (cJSON_IsString(it) && strcmp(it->valuestring, hash) == 0) n++;
    }
    cJSON_Delete(m);
    return n;
}

static int missing_count(const vsdc *c)
{
    cJSON *m = cJSON_Parse(vsdc_error_json(c) ? vsdc_error_json(c) : "{}");
    int n = cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(m, "missing"));
    cJSON_Delete(m);
    return n;
}

/* a, b: EXR files; every channel equal bit for bit, and the same vsd/scene_hash. */
static void check_same_exr(const char *a, const char *b)
{
    vsd_exr_image *ia = NULL, *ib = NULL;
    char err[1024], ha[80] = "", hb[80] = "";
    if (vsd_exr_read(a, &ia, err, sizeof err) == 0 && vsd_exr_read(b, &ib, err, sizeof err) == 0) {
        int k, same = ia->channel_count == ib->channel_count && ia->width == ib->width && ia->height == ib->height;
        for (k = 0; same && k < ia->channel_count; k++) {
            const float *pb = vsd_exr_channel(ib, ia->channel_names[k]);
            same = pb && memcmp(pb, ia->channels[k], sizeof(float) * ia->width * ia->height) == 0;
        }
        CHECK_MSG(same, "%s: vsd render --remote differs from vsd render (%s)", b, a);
    } else {
        CHECK_MSG(0, "reading the CLI outputs: %s", err);
    }
    vsd_exr_image_destroy(ia);
    vsd_exr_image_destroy(ib);
    CHECK(vsd_exr_read_attr(a, "vsd/scene_hash", ha, sizeof ha, err, sizeof err) == 0);
    CHECK(vsd_exr_read_attr(b, "vsd/scene_hash", hb, sizeof hb, err, sizeof err) == 0);
    CHECK_MSG(ha[0] && strcmp(ha, hb) == 0, "vsd/scene_hash: local %s, remote %s", ha, hb);
}

int main(int argc, char **argv)
{
    test_daemon d = {0}, dl = {0};
    vsdc *c = NULL;
    vsdc_result res;
    cJSON *info = NULL;
    char err[2048], scene[8192], local[8192], b10[128], b15[128], b16[128], eb[128];
    char h20[80], h21[80], longdir[1400], big[16384];
    vsd_framebuffer *fb2 = NULL, *fb1 = NULL, *fb16 = NULL, *fbmax = NULL;
    long diff;
    if (argc < 2) {
        fprintf(stderr, "usage: test_daemon_volumes VSD\n");
        return 2;
    }
    g_vsd = argv[1];
    snprintf(g_dir, sizeof g_dir, "%s", test_tmp("daemon_volumes"));
    {
        char cmd[2300];
        snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", g_dir, g_dir);
        if (system(cmd) != 0) return 1;
    }
    snprintf(g_env, sizeof g_env, "%s", test_data("env/sunset.exr"));
    if (access(frame_file(10), R_OK) != 0 || access(g_env, R_OK) != 0) {
        fprintf(stderr, "no shared data (%s): skipped\n", frame_file(10));
        return 77;
    }
    /* in-process: the two volumes (frames 10 and 15), volumes[1] at frame 16, the first alone */
    scene2(local, sizeof local, frame_file(10), frame_file(15), g_env, "reference");
    fb2 = render_local(local);
    scene2(local, sizeof local, frame_file(10), frame_file(16), g_env, "reference");
    fb16 = render_local(local);
    scene1(local, sizeof local, frame_file(10), g_env);
    fb1 = render_local(local);
    CHECK(fb2 && fb16 && fb1);
    diff = compare_fb(fb2, fb1);
    CHECK_MSG(diff > 0, "the second volume does not change the picture (%ld values differ)", diff);
    {
        /* and its emission shows */
        long i, lit = 0;
        for (i = 0; fb2 && i < (long)fb2->width * fb2->height * 3; i++) lit += fb2->pass[VSD_PASS_EMIT][i] > 0;
        CHECK_MSG(lit > 0, "volumes[1]'s emission left the Emit pass black");
    }

    /* server-side files for the scene of VSD_MAX_VOLUMES volumes, under a long folder name */
    snprintf(longdir, sizeof longdir, "%s/a-folder-with-a-long-name-so-that-sixteen-volumes-make-a-renderer-key-"
             "longer-than-a-cache-entry-holds", g_dir);
    {
        char cmd[4000];
        int fr;
        snprintf(cmd, sizeof cmd, "mkdir -p '%s'", longdir);
        CHECK(system(cmd) == 0);
        for (fr = 1; fr <= VSD_MAX_VOLUMES; fr++) {
            snprintf(cmd, sizeof cmd, "cp '%s' '%s/'", frame_file(fr), longdir);
            CHECK(system(cmd) == 0);
        }
    }
    scene_max(big, sizeof big, longdir);
    fbmax = render_local(big);
    CHECK(fbmax != NULL);
    {
        const char *extra[] = {"--allow-path", longdir, NULL};
        if (test_daemon_start(&d, g_vsd, g_dir, "dv", NULL, NULL, extra)) return 1;
    }
    if (vsdc_connect(d.sock, NULL, &c, err, sizeof err)) {
        CHECK_MSG(0, "connect: %s", err);
        test_daemon_stop(&d);
        return test_finish("test_daemon_volumes");
    }

    /* (b) missing_blob lists the blobs of both volumes at once (and the map's), each once */
    vsd_hash_file(VSD_HASH_XXH3_128, frame_file(20), h20, NULL, err, sizeof err);
    vsd_hash_file(VSD_HASH_XXH3_128, frame_file(21), h21, NULL, err, sizeof err);
    {
        char f20[100], f21[100], ehash[80], fe[100];
        vsd_hash_file(VSD_HASH_XXH3_128, g_env, ehash, NULL, err, sizeof err);
        snprintf(f20, sizeof f20, "blob:%s", h20);
        snprintf(f21, sizeof f21, "blob:%s", h21);
        snprintf(fe, sizeof fe, "blob:%s", ehash);
        scene2(scene, sizeof scene, f20, f21, fe, "reference");
        CHECK(render_remote(c, scene, &res, &info, err, sizeof err) == VSDC_ERR_SERVER);
        CHECK_MSG(strcmp(vsdc_error_code(c), "missing_blob") == 0, "code %s: %s", vsdc_error_code(c), err);
        CHECK_MSG(listed_missing(c, h20) == 1 && listed_missing(c, h21) == 1 && listed_missing(c, ehash) == 1 &&
                      missing_count(c) == 3,
                  "missing_blob must list both volumes' blobs and the map's: %s", vsdc_error_json(c));
        printf("missing_blob of two volumes and the map: %s\n", vsdc_error_json(c) ? vsdc_error_json(c) : "(none)");
        vsdc_result_free(&res);
        cJSON_Delete(info);
        /* one file for both volumes: listed once; the uploaded map not at all */
        upload(c, g_env, eb, sizeof eb);
        scene2(scene, sizeof scene, f20, f20, eb, "reference");
        CHECK(render_remote(c, scene, &res, &info, err, sizeof err) == VSDC_ERR_SERVER);
        CHECK_MSG(listed_missing(c, h20) == 1 && missing_count(c) == 1, "a blob two volumes share: %s",
                  vsdc_error_json(c));
        vsdc_result_free(&res);
        cJSON_Delete(info);
    }

    /* (a) a two-volume RENDER through blobs == the in-process renderer, bit for bit */
    upload(c, frame_file(10), b10, sizeof b10);
    upload(c, frame_file(15), b15, sizeof b15);
    upload(c, frame_file(16), b16, sizeof b16);
    scene2(scene, sizeof scene, b10, b15, eb, "reference");
    if (render_remote(c, scene, &res, &info, err, sizeof err) == 0) {
        diff = test_exr_bytes_diff(res.exr, res.exr_len, fb2, g_dir, "volumes");
        CHECK_MSG(diff == 0, "two volumes: the daemon's image and the in-process one differ in %ld values", diff);
        CHECK_MSG(cache_volume_count(info) == 2, "cache.volumes: %s", res.json);
        CHECK(cache_flag(info, 0, "volume") == 0 && cache_flag(info, 1, "volume") == 0);
        CHECK(cache_flag(info, 0, "emission") == -1 && cache_flag(info, 1, "emission") == 0 &&
              cache_flag(info, 1, "ior") == -1);
        CHECK(cache_flag(info, -1, "volume") == 0 && cache_flag(info, -1, "emission") == -1 &&
              cache_flag(info, -1, "ior") == -1 && cache_flag(info, -1, "renderer") == 0);
        printf("two volumes through the daemon: %ld values differ from in-process;", diff);
        print_field(" cache", info, "cache");
    } else {
        CHECK_MSG(0, "two-volume render: %s", err);
    }
    vsdc_result_free(&res);
    cJSON_Delete(info);
    /* the same again: every input and the renderer from the cache, the same image */
    if (render_remote(c, scene, &res, &info, err, sizeof err) == 0) {
        CHECK(test_exr_bytes_diff(res.exr, res.exr_len, fb2, g_dir, "volumes") == 0);
        CHECK_MSG(cache_flag(info, 0, "volume") == 1 && cache_flag(info, 1, "volume") == 1 &&
                      cache_flag(info, 1, "emission") == 1 && cache_flag(info, -1, "renderer") == 1 &&
                      cache_flag(info, -1, "preparation") == 1,
                  "the same two-volume scene again: %s", res.json);
    } else {
        CHECK_MSG(0, "two-volume render again: %s", err);
    }
    vsdc_result_free(&res);
    cJSON_Delete(info);
    /* a material change of volumes[1] only: the same renderer, a new preparation */
    {
        const char *ov[] = {"volumes.1.medium.density=2"};
        vsdc_render_request rq;
        memset(&rq, 0, sizeof rq);
        rq.scene_json = scene;
        rq.overrides = ov;
        rq.override_count = 1;
        if (vsdc_render(c, &rq, &res, err, sizeof err) == 0) {
            info = cJSON_Parse(res.json);
            CHECK_MSG(cache_flag(info, -1, "renderer") == 1 && cache_flag(info, -1, "preparation") == 0,
                      "volumes[1]'s density changed: %s", res.json);
            cJSON_Delete(info);
        } else {
            CHECK_MSG(0, "render with volumes.1.medium.density: %s", err);
        }
        vsdc_result_free(&res);
    }

    /* (c) only volumes[1]'s file changes (frame 16's blob): volumes[0] comes from the cache */
    scene2(scene, sizeof scene, b10, b16, eb, "reference");
    if (render_remote(c, scene, &res, &info, err, sizeof err) == 0) {
        /* the renderer of frames 10 + 15 is taken over (docs/protocol.md): volumes[0] stays */
        CHECK_MSG(cache_flag(info, 0, "volume") == 1 && cache_flag(info, 1, "volume") == 0 &&
                      cache_flag(info, 1, "emission") == 0 && cache_flag(info, -1, "volume") == 1 &&
                      cache_flag(info, -1, "environment") == 1 && cache_flag(info, -1, "renderer") == 0 &&
                      cache_flag(info, -1, "renderer_taken_over") == 1 && cache_flag(info, -1, "preparation") == 0,
                  "volumes[1] to another frame: %s", res.json);
        diff = test_exr_bytes_diff(res.exr, res.exr_len, fb16, g_dir, "volumes");
        CHECK_MSG(diff == 0, "volumes[1] at frame 16: %ld values differ from in-process", diff);
        print_field("volumes[1] to another frame: cache", info, "cache");
    } else {
        CHECK_MSG(0, "render with volumes[1] at frame 16: %s", err);
    }
    vsdc_result_free(&res);
    cJSON_Delete(info);

    /* (d) the same with constellation, whose part per volume builds its frame stage from its
     * own volume alone: taking over the frames-10 + 15 renderer prepares volumes[1]'s part
     * only ("reframed=1"), and the image is a fresh in-process renderer's, bit for bit */
    {
        vsd_framebuffer *fresh;
        scene2(scene, sizeof scene, b10, b15, eb, "constellation");
        if (render_remote(c, scene, &res, &info, err, sizeof err) == 0)
            CHECK_MSG(cache_flag(info, -1, "renderer") == 0 && cache_flag(info, -1, "renderer_taken_over") == 0,
                      "constellation's first two-volume render: %s", res.json);
        else
            CHECK_MSG(0, "constellation, frames 10 + 15: %s", err);
        vsdc_result_free(&res);
        cJSON_Delete(info);
        scene2(local, sizeof local, frame_file(10), frame_file(16), g_env, "constellation");
        fresh = render_local(local);
        scene2(scene, sizeof scene, b10, b16, eb, "constellation");
        if (fresh && render_remote(c, scene, &res, &info, err, sizeof err) == 0) {
            const cJSON *mi = cJSON_GetObjectItemCaseSensitive(info, "method_info");
            CHECK_MSG(cache_flag(info, -1, "renderer_taken_over") == 1, "constellation, volumes[1] to frame 16: %s",
                      res.json);
            CHECK_MSG(cJSON_IsString(mi) && strstr(mi->valuestring, "reframed=1") &&
                          strstr(mi->valuestring, "relit=2"),
                      "constellation, volumes[1] to frame 16: method_info %s", res.json);
            diff = test_exr_bytes_diff(res.exr, res.exr_len, fresh, g_dir, "volumes_cst");
            CHECK_MSG(diff == 0, "constellation, a renderer taken over: %ld values differ from in-process", diff);
            printf("constellation, volumes[1] to frame 16 in a renderer taken over: %s; %ld values differ from "
                   "in-process\n",
                   cJSON_IsString(mi) ? mi->valuestring : "?", diff);
        } else {
            CHECK_MSG(0, "constellation, frames 10 + 16: %s", err);
        }
        vsdc_result_free(&res);
        cJSON_Delete(info);
        vsd_framebuffer_destroy(fresh);
    }

    /* (e) a form that renders one volume (crm's paper form: one volume's RBF fit): the
     * daemon's error with the renderer's message */
    {
        char plain[sizeof scene];
        const char *at;
        scene2(plain, sizeof plain, b10, b15, eb, "crm");
        at = strstr(plain, "\"method\":\"crm\"");
        CHECK(at != NULL);
        snprintf(scene, sizeof scene, "%.*s\"method\":\"crm\",\"options\":{\"view_density\":\"compensated\"}%s",
                 at ? (int)(at - plain) : 0, plain, at ? at + strlen("\"method\":\"crm\"") : "");
    }
    CHECK(render_remote(c, scene, &res, &info, err, sizeof err) == VSDC_ERR_SERVER);
    CHECK_MSG(strcmp(vsdc_error_code(c), "invalid_scene") == 0, "crm compensated with two volumes: %s: %s",
              vsdc_error_code(c), err);
    CHECK_CONTAINS(err, "volumes: the scene has 2 volumes; crm's fitted forms");
    printf("crm compensated with two volumes: %s: %s\n", vsdc_error_code(c), err);
    vsdc_result_free(&res);
    cJSON_Delete(info);

    /* (f) lbl and crm render the two volumes (a part per volume): the daemon's image is
     * in-process's */
    for (int m = 0; m < 2; m++) {
        const char *method = m ? "crm" : "lbl";
        vsd_framebuffer *fbl;
        scene2(local, sizeof local, frame_file(10), frame_file(15), g_env, method);
        fbl = render_local(local);
        scene2(scene, sizeof scene, b10, b15, eb, method);
        CHECK(fbl != NULL);
        if (fbl && render_remote(c, scene, &res, &info, err, sizeof err) == 0) {
            diff = test_exr_bytes_diff(res.exr, res.exr_len, fbl, g_dir, m ? "volumes_crm" : "volumes_lbl");
            CHECK_MSG(diff == 0, "%s with two volumes: %ld values differ from in-process", method, diff);
            printf("%s with two volumes through the daemon: %ld values differ from in-process\n", method, diff);
        } else {
            CHECK_MSG(0, "%s with two volumes through the daemon: %s", method, err);
        }
        vsdc_result_free(&res);
        cJSON_Delete(info);
        vsd_framebuffer_destroy(fbl);
    }

    /* a bad blob, a bad blob name: the error names the volume */
    {
        static const char junk[] = "this is not a VDB file, nor any other kind of grid";
        char jhash[80], jblob[100];
        vsd_hash_buffer(VSD_HASH_XXH3_128, junk, sizeof junk, jhash);
        snprintf(jblob, sizeof jblob, "blob:%s", jhash);
        CHECK(vsdc_put(c, jhash, junk, sizeof junk, err, sizeof err) == 0);
        scene2(scene, sizeof scene, b10, jblob, eb, "reference");
        CHECK(render_remote(c, scene, &res, &info, err, sizeof err) == VSDC_ERR_SERVER);
        CHECK_MSG(strcmp(vsdc_error_code(c), "bad_input") == 0, "a bad blob: %s", err);
        CHECK_CONTAINS(err, "volumes[1]: ");
        printf("a bad blob as volumes[1]: %s\n", err);
        vsdc_result_free(&res);
        cJSON_Delete(info);
        scene2(scene, sizeof scene, b10, "blob:nothex", eb, "reference");
        CHECK(render_remote(c, scene, &res, &info, err, sizeof err) == VSDC_ERR_SERVER);
        CHECK_MSG(strcmp(vsdc_error_code(c), "bad_hash") == 0, "a bad blob name: %s", err);
        CHECK_CONTAINS(err, "volumes[1].file");
        vsdc_result_free(&res);
        cJSON_Delete(info);
    }

    /* the most volumes a scene holds, as server-side paths (each volume its own frame):
     * the in-process image, and the same renderer found again (its key, longer than an
     * entry's, kept by its hash) */
    {
        int pass;
        for (pass = 0; pass < 2; pass++) {
            if (render_remote(c, big, &res, &info, err, sizeof err) == 0) {
                diff = test_exr_bytes_diff(res.exr, res.exr_len, fbmax, g_dir, "volumes");
                CHECK_MSG(diff == 0, "%d volumes: %ld values differ from in-process", VSD_MAX_VOLUMES, diff);
                CHECK(cache_volume_count(info) == VSD_MAX_VOLUMES);
                CHECK_MSG(cache_flag(info, -1, "renderer") == pass && cache_flag(info, VSD_MAX_VOLUMES - 1, "volume") == pass,
                          "%d volumes, render %d: %s", VSD_MAX_VOLUMES, pass + 1, res.json);
                if (pass) printf("%d volumes from server paths: %ld values differ from in-process, renderer reused\n",
                                 VSD_MAX_VOLUMES, diff);
            } else {
                CHECK_MSG(0, "%d volumes: %s", VSD_MAX_VOLUMES, err);
            }
            vsdc_result_free(&res);
            cJSON_Delete(info);
        }
    }

    /* `vsd render --remote` with a two-volume scene file (volumes[1] reads frame + 5) writes
     * what `vsd render` writes, bit for bit */
    {
        char path[1200], cmd[6000], a[1200], b[1200], pattern[1200];
        FILE *f;
        int fr;
        snprintf(pattern, sizeof pattern, "%s/fluid_data_####.vdb", test_data("smoke64"));
        snprintf(path, sizeof path, "%s/two.json", g_dir);
        scene2(scene, sizeof scene, pattern, pattern, g_env, "reference");
        {
            /* volumes[1] a few frames ahead */
            char *at = strstr(scene, "{\"file\":\"");
            at = at ? strstr(at + 1, "{\"file\":\"") : NULL;
            f = fopen(path, "w");
            if (at && f) fprintf(f, "%.*s{\"frame_offset\":5,%s", (int)(at - scene), scene, at + 1);
            if (f) fclose(f);
        }
        snprintf(a, sizeof a, "%s/cli_local_####.exr", g_dir);
        snprintf(b, sizeof b, "%s/cli_remote_####.exr", g_dir);
        snprintf(cmd, sizeof cmd,
                 "'%s' render '%s' --frames 10-11 --output '%s' --quiet && "
                 "'%s' render '%s' --frames 10-11 --output '%s' --quiet --remote='%s'",
                 g_vsd, path, a, g_vsd, path, b, d.sock);
        CHECK_MSG(system(cmd) == 0, "%s", cmd);
        for (fr = 10; fr <= 11; fr++) {
            snprintf(a, sizeof a, "%s/cli_local_%04d.exr", g_dir, fr);
            snprintf(b, sizeof b, "%s/cli_remote_%04d.exr", g_dir, fr);
            check_same_exr(a, b);
        }
        /* for the log: the volumes the daemon holds now (frames 10, 11 of volumes[0], 15, 16 of
         * volumes[1] by the CLI; 10, 15, 16 were there from the renders above) */
        {
            char *json = NULL;
            cJSON *st = NULL;
            if (vsdc_stats(c, &json, err, sizeof err) == 0) st = cJSON_Parse(json);
            print_field("after the CLI: STATS cache.volumes", cJSON_GetObjectItemCaseSensitive(st, "cache"), "volumes");
            cJSON_Delete(st);
            free(json);
        }
    }
    vsdc_close(c);
    c = NULL;
    CHECK(test_daemon_stop(&d) == 0);

    /* (d) --max-voxels bounds the voxels of the scene's volumes together: each of the two
     * grids fits, both do not */
    {
        uint64_t v10 = density_voxels(frame_file(10)), v15 = density_voxels(frame_file(15));
        uint64_t limit = (v10 > v15 ? v10 : v15) + (v10 < v15 ? v10 : v15) / 2;
        char lim[32], expect[200];
        snprintf(lim, sizeof lim, "%llu", (unsigned long long)limit);
        CHECK(v10 > 0 && v15 > 0);
        {
            const char *extra[] = {"--max-voxels", lim, NULL};
            if (test_daemon_start(&dl, g_vsd, g_dir, "dl", NULL, NULL, extra)) return test_finish("test_daemon_volumes");
        }
        if (vsdc_connect(dl.sock, NULL, &c, err, sizeof err) == 0) {
            upload(c, frame_file(10), b10, sizeof b10);
            upload(c, frame_file(15), b15, sizeof b15);
            upload(c, g_env, eb, sizeof eb);
            scene2(scene, sizeof scene, b10, b15, eb, "reference");
            CHECK(render_remote(c, scene, &res, &info, err, sizeof err) == VSDC_ERR_SERVER);
            CHECK_MSG(strcmp(vsdc_error_code(c), "limit") == 0, "two volumes above --max-voxels: %s: %s",
                      vsdc_error_code(c), err);
            snprintf(expect, sizeof expect, "volumes: 2 volumes hold %llu active voxels together, above the daemon's "
                     "limit of %llu", (unsigned long long)(v10 + v15), (unsigned long long)limit);
            CHECK_CONTAINS(err, expect);
            printf("--max-voxels %s: %s\n", lim, err);
            vsdc_result_free(&res);
            cJSON_Delete(info);
            /* each alone is within it */
            scene1(scene, sizeof scene, b15, eb);
            CHECK_MSG(render_remote(c, scene, &res, &info, err, sizeof err) == 0, "one volume under --max-voxels: %s",
                      err);
            vsdc_result_free(&res);
            cJSON_Delete(info);
            vsdc_close(c);
        } else {
            CHECK_MSG(0, "connect: %s", err);
        }
        CHECK(test_daemon_stop(&dl) == 0);
    }

    vsd_framebuffer_destroy(fb2);
    vsd_framebuffer_destroy(fb16);
    vsd_framebuffer_destroy(fb1);
    vsd_framebuffer_destroy(fbmax);
    return test_finish("test_daemon_volumes");
}
