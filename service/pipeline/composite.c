/* vsd's volume passes over a background plate (composite.h). */
#include "composite.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void vsd_composite_over(const vsd_framebuffer *vol, unsigned present, const vsd_plate *pl, vsd_framebuffer *out,
                        long *plate_wins)
{
    size_t n = (size_t)vol->width * vol->height, i;
    int depth = (present & VSD_PASS_BIT(VSD_PASS_DEPTH)) && pl->depth;
    long wins = 0;
    vsd_framebuffer_clear(out);
    for (i = 0; i < n; i++) {
        const float *v = vol->pass[VSD_PASS_COMBINED] + 4 * i;
        float plate[4] = {pl->r[i], pl->g[i], pl->b[i], pl->a ? pl->a[i] : 1.0f};
        float *o = out->pass[VSD_PASS_COMBINED] + 4 * i;
        float vd = vol->pass[VSD_PASS_DEPTH][i];
        int c, p;
        if (depth && pl->depth[i] < vd) {
            /* the plate's surface is nearer than the volume's first interaction */
            wins++;
            memcpy(o, plate, sizeof plate);
            for (c = 0; c < 3; c++) out->pass[VSD_PASS_TRANSMITTANCE][3 * i + c] = 1.0f;
            out->pass[VSD_PASS_DEPTH][i] = pl->depth[i];
            continue;
        }
        for (c = 0; c < 4; c++) o[c] = v[c] + (1.0f - v[3]) * plate[c];
        for (p = VSD_PASS_VOLUME_DIR; p <= VSD_PASS_TRANSMITTANCE; p++)
            if (present & VSD_PASS_BIT(p))
                for (c = 0; c < 3; c++) out->pass[p][3 * i + c] = vol->pass[p][3 * i + c];
        if (present & VSD_PASS_BIT(VSD_PASS_DEPTH)) out->pass[VSD_PASS_DEPTH][i] = vd;
        if (pl->depth && pl->depth[i] < out->pass[VSD_PASS_DEPTH][i]) out->pass[VSD_PASS_DEPTH][i] = pl->depth[i];
    }
    if (plate_wins) *plate_wins = wins;
}

/* Pass names a reader may meet for each vsd pass: vsd's own, then Blender 5.0's. */
static const char *const aliases[VSD_PASS_COUNT][3] = {
    {"Combined", NULL, NULL},          {"VolumeDir", "Volume Direct", NULL},
    {"VolumeInd", "Volume Indirect", NULL}, {"Emit", "Emission", NULL},
    {"Transmittance", NULL, NULL},     {"Depth", NULL, NULL},
};
static const char *const letters[VSD_PASS_COUNT] = {"RGBA", "RGB", "RGB", "RGB", "RGB", "Z"};

static void list_channels(const vsd_exr_image *img, char *buf, size_t len)
{
    size_t used = 0;
    int i;
    buf[0] = '\0';
    for (i = 0; i < img->channel_count && used + 1 < len; i++)
        used += (size_t)snprintf(buf + used, len - used, "%s%s", i ? ", " : "", img->channel_names[i]);
    if (!img->channel_count) snprintf(buf, len, "none");
}

/* The layer of the first channel "<layer>.Combined.R" ("" when the channel is plain
 * "Combined.R"); -1 when none. */
static int find_layer(const vsd_exr_image *img, char *layer, size_t len)
{
    int i;
    for (i = 0; i < img->channel_count; i++) {
        const char *n = img->channel_names[i];
        size_t l = strlen(n);
        if (l >= 10 && strcmp(n + l - 10, "Combined.R") == 0 && (l == 10 || n[l - 11] == '.')) {
            size_t pl = l == 10 ? 0 : l - 11;
            if (pl >= len) pl = len - 1;
            memcpy(layer, n, pl);
            layer[pl] = '\0';
            return 0;
        }
    }
    return -1;
}

static const float *channel(const vsd_exr_image *img, const char *layer, const char *pass, char letter)
{
    char name[512];
    snprintf(name, sizeof name, "%s%s%s.%c", layer, layer[0] ? "." : "", pass, letter);
    return vsd_exr_channel(img, name);
}

/* Copies the passes img holds under `layer` into fb; returns the vsd_pass bits found and
 * the name each was found under. */
static unsigned read_passes(const vsd_exr_image *img, const char *layer, vsd_framebuffer *fb,
                            const char *names[VSD_PASS_COUNT])
{
    unsigned found = 0;
    size_t n = (size_t)img->width * img->height;
    int p, a, c;
    for (p = 0; p < VSD_PASS_COUNT; p++) {
        for (a = 0; a < 3 && aliases[p][a]; a++) {
            int nc = (int)strlen(letters[p]);
            const float *pl[4] = {NULL, NULL, NULL, NULL};
            for (c = 0; c < nc; c++)
                if (!(pl[c] = channel(img, layer, aliases[p][a], letters[p][c]))) break;
            if (c < nc) continue;
            for (size_t i = 0; i < n; i++)
                for (c = 0; c < nc; c++) fb->pass[p][(size_t)nc * i + c] = pl[c][i];
            found |= VSD_PASS_BIT(p);
            names[p] = aliases[p][a];
            break;
        }
    }
    return found;
}

/* A depth plane of img: "Z", else a channel ending ".Z", else (allow_r) "R"; NULL when none. */
static const float *depth_channel(const vsd_exr_image *img, int allow_r, const char **which)
{
    const float *z = vsd_exr_channel(img, "Z");
    int i;
    *which = "Z";
    for (i = 0; !z && i < img->channel_count; i++) {
        size_t l = strlen(img->channel_names[i]);
        if (l > 2 && strcmp(img->channel_names[i] + l - 2, ".Z") == 0) {
            z = img->channels[i];
            *which = img->channel_names[i];
        }
    }
    if (!z && allow_r) {
        z = vsd_exr_channel(img, "R");
        *which = "R";
    }
    return z;
}

vsd_status vsd_composite_files(const char *volume_exr, const char *plate_exr, const char *out_exr,
                               const vsd_composite_options *opt, vsd_composite_report *rep, char *err,
                               size_t errlen)
{
    static const vsd_composite_options none = {NULL, 0};
    vsd_exr_image *vi = NULL, *pi = NULL, *di = NULL;
    vsd_framebuffer *vol = NULL, *out = NULL;
    const char *names[VSD_PASS_COUNT] = {0};
    float *depth_buf = NULL;
    char list[1024], player[128];
    vsd_plate plate;
    unsigned present;
    vsd_status st;
    int p;
    if (!opt) opt = &none;
    memset(rep, 0, sizeof *rep);
    memset(&plate, 0, sizeof plate);
    if ((st = vsd_exr_read(volume_exr, &vi, err, errlen))) goto done;
    if ((st = vsd_exr_read(plate_exr, &pi, err, errlen))) goto done;
    if (find_layer(vi, rep->layer, sizeof rep->layer) != 0) {
        list_channels(vi, list, sizeof list);
        st = vsd_fail(VSD_ERR_FORMAT, err, errlen,
                      "%s: no Combined pass (no channel <layer>.Combined.R; channels: %.600s): not a vsd render?",
                      volume_exr, list);
        goto done;
    }
    if (vi->width != pi->width || vi->height != pi->height) {
        st = vsd_fail(VSD_ERR_INVALID, err, errlen, "image sizes differ: %s is %dx%d, %s is %dx%d", volume_exr,
                      vi->width, vi->height, plate_exr, pi->width, pi->height);
        goto done;
    }
    rep->width = vi->width;
    rep->height = vi->height;
    if ((st = vsd_framebuffer_create(vi->width, vi->height, &vol, err, errlen)) ||
        (st = vsd_framebuffer_create(vi->width, vi->height, &out, err, errlen)))
        goto done;
    present = read_passes(vi, rep->layer, vol, names);
    if (!(present & VSD_PASS_BIT(VSD_PASS_COMBINED))) {
        st = vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: layer '%s' lacks one of Combined.R/G/B/A", volume_exr,
                      rep->layer);
        goto done;
    }

    /* the plate: plain R, G, B[, A] (POV-Ray, most tools), else a render's Combined */
    plate.r = vsd_exr_channel(pi, "R");
    plate.g = vsd_exr_channel(pi, "G");
    plate.b = vsd_exr_channel(pi, "B");
    plate.a = vsd_exr_channel(pi, "A");
    snprintf(rep->plate_channels, sizeof rep->plate_channels, "R, G, B%s", plate.a ? ", A" : " (opaque: no A)");
    if (!(plate.r && plate.g && plate.b) && find_layer(pi, player, sizeof player) == 0) {
        plate.r = channel(pi, player, "Combined", 'R');
        plate.g = channel(pi, player, "Combined", 'G');
        plate.b = channel(pi, player, "Combined", 'B');
        plate.a = channel(pi, player, "Combined", 'A');
        snprintf(rep->plate_channels, sizeof rep->plate_channels, "%.100s%sCombined", player, player[0] ? "." : "");
    }
    if (!(plate.r && plate.g && plate.b)) {
        list_channels(pi, list, sizeof list);
        st = vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: no R, G, B channels (nor <layer>.Combined); channels: %.600s",
                      plate_exr, list);
        goto done;
    }
    if (!opt->no_depth) {
        const char *which = NULL;
        if (opt->plate_depth) {
            const float *z, *a;
            size_t i, n = (size_t)pi->width * pi->height;
            if ((st = vsd_exr_read(opt->plate_depth, &di, err, errlen))) goto done;
            if (di->width != pi->width || di->height != pi->height) {
                st = vsd_fail(VSD_ERR_INVALID, err, errlen, "image sizes differ: %s is %dx%d, %s is %dx%d",
                              opt->plate_depth, di->width, di->height, plate_exr, pi->width, pi->height);
                goto done;
            }
            if (!(z = depth_channel(di, 1, &which))) {
                list_channels(di, list, sizeof list);
                st = vsd_fail(VSD_ERR_FORMAT, err, errlen, "%s: no Z or R channel for the depth; channels: %.600s",
                              opt->plate_depth, list);
                goto done;
            }
            /* a depth render's transparent background (A = 0) is "nothing there" */
            a = vsd_exr_channel(di, "A");
            if (!(depth_buf = malloc(n * sizeof(float)))) {
                st = vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for the depth plate");
                goto done;
            }
            for (i = 0; i < n; i++) depth_buf[i] = a && a[i] <= 0.0f ? VSD_DEPTH_EMPTY : z[i];
            plate.depth = depth_buf;
        } else {
            plate.depth = depth_channel(pi, 0, &which);
        }
        if (plate.depth) {
            size_t l = strlen(rep->plate_channels);
            snprintf(rep->plate_channels + l, sizeof rep->plate_channels - l, "; depth %.40s%s%.60s", which,
                     opt->plate_depth ? " of " : "", opt->plate_depth ? opt->plate_depth : "");
        }
    }
    rep->by_depth = plate.depth && (present & VSD_PASS_BIT(VSD_PASS_DEPTH));
    vsd_composite_over(vol, present, &plate, out, &rep->plate_wins);
    if (plate.depth) {
        present |= VSD_PASS_BIT(VSD_PASS_DEPTH);
        if (!names[VSD_PASS_DEPTH]) names[VSD_PASS_DEPTH] = "Depth";
    }
    {
        vsd_exr_write_options wo;
        vsd_exr_attr attr[1] = {{"vsd/composite", plate_exr}};
        size_t used = 0;
        memset(&wo, 0, sizeof wo);
        wo.layer = rep->layer[0] ? rep->layer : "ViewLayer";
        if (!rep->layer[0]) snprintf(rep->layer, sizeof rep->layer, "ViewLayer");
        wo.pass_names = names;
        wo.pass_mask = present;
        wo.attrs = attr;
        wo.attr_count = 1;
        for (p = 0; p < VSD_PASS_COUNT; p++)
            if (present & VSD_PASS_BIT(p))
                used += (size_t)snprintf(rep->passes + used, sizeof rep->passes - used, "%s%s", used ? ", " : "",
                                         names[p]);
        st = vsd_exr_write(out_exr, out, &wo, err, errlen);
        rep->output_error = st != VSD_OK;
    }
done:
    free(depth_buf);
    vsd_framebuffer_destroy(vol);
    vsd_framebuffer_destroy(out);
    vsd_exr_image_destroy(vi);
    vsd_exr_image_destroy(pi);
    vsd_exr_image_destroy(di);
    return st;
}
