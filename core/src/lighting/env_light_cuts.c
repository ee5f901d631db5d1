/* Light constellations from equirectangular maps (vsd/lighting.h).
 *
 * Texel (col, row) covers azimuth 2 pi / W and polar angles [row pi/H, (row+1) pi/H], so
 * its exact solid angle is (2 pi / W)(cos theta0 - cos theta1); its energy for the cuts is
 * luminance * solid angle (Debevec's median cut weights by cos(latitude) for the same
 * reason). Median cut works on a summed-area table of that energy, so every cut is a
 * binary search; the lights' powers and centroids are summed once over their final
 * regions, which partition the map, so total power is exact. */
#include "vsd/lighting.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct env_geom {
    int w, h;
    double *row_omega;      /* [h] solid angle of one texel of the row */
    double *row_sin, *row_cos, *col_cos, *col_sin;
    double *energy;         /* [w*h] luminance * solid angle (>= 0) */
} env_geom;

typedef struct mc_region { int x0, y0, x1, y1, n; } mc_region;

static void geom_free(env_geom *g)
{
    free(g->row_omega); free(g->row_sin); free(g->row_cos); free(g->col_cos); free(g->col_sin);
    free(g->energy);
    memset(g, 0, sizeof *g);
}

static int geom_init(env_geom *g, const vsd_env *env)
{
    int x, y, w = env->width, h = env->height;
    memset(g, 0, sizeof *g);
    g->w = w;
    g->h = h;
    g->row_omega = malloc(sizeof(double) * (size_t)h);
    g->row_sin = malloc(sizeof(double) * (size_t)h);
    g->row_cos = malloc(sizeof(double) * (size_t)h);
    g->col_cos = malloc(sizeof(double) * (size_t)w);
    g->col_sin = malloc(sizeof(double) * (size_t)w);
    g->energy = malloc(sizeof(double) * (size_t)w * h);
    if (!g->row_omega || !g->row_sin || !g->row_cos || !g->col_cos || !g->col_sin || !g->energy) {
        geom_free(g);
        return 0;
    }
    for (y = 0; y < h; y++) {
        double tc = M_PI * (y + 0.5) / h;
        g->row_omega[y] = vsd_env_texel_solid_angle(w, h, y);
        g->row_sin[y] = sin(tc);
        g->row_cos[y] = cos(tc);
    }
    for (x = 0; x < w; x++) {
        double phi = (0.5 - (x + 0.5) / w) * 2.0 * M_PI;
        g->col_cos[x] = cos(phi);
        g->col_sin[x] = sin(phi);
    }
    for (y = 0; y < h; y++)
        for (x = 0; x < w; x++) {
            const float *p = env->rgb + 3 * ((size_t)y * w + x);
            double lum = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
            g->energy[(size_t)y * w + x] = (lum > 0 ? lum : 0.0) * g->row_omega[y];
        }
    return 1;
}

void vsd_env_texel_direction(const vsd_env *env, int col, int row, float dir[3])
{
    double theta = M_PI * (row + 0.5) / env->height, phi = (0.5 - (col + 0.5) / env->width) * 2.0 * M_PI;
    dir[0] = (float)(sin(theta) * cos(phi));
    dir[1] = (float)(sin(theta) * sin(phi));
    dir[2] = (float)cos(theta);
}

void vsd_env_integral(const vsd_env *env, double rgb[3])
{
    int x, y;
    rgb[0] = rgb[1] = rgb[2] = 0;
    for (y = 0; y < env->height; y++) {
        double om = vsd_env_texel_solid_angle(env->width, env->height, y), r[3] = {0, 0, 0};
        const float *p = env->rgb + (size_t)y * env->width * 3;
        for (x = 0; x < env->width; x++) {
            r[0] += p[3 * x];
            r[1] += p[3 * x + 1];
            r[2] += p[3 * x + 2];
        }
        rgb[0] += r[0] * om;
        rgb[1] += r[1] * om;
        rgb[2] += r[2] * om;
    }
}

/* Summed-area table S[(y)(w+1)+x] = energy over [0,x) x [0,y). */
static double *build_sat(const env_geom *g)
{
    int x, y, w = g->w, h = g->h;
    double *s = calloc((size_t)(w + 1) * (h + 1), sizeof(double));
    if (!s) return NULL;
    for (y = 0; y < h; y++) {
        double row = 0;
        for (x = 0; x < w; x++) {
            row += g->energy[(size_t)y * w + x];
            s[(size_t)(y + 1) * (w + 1) + x + 1] = s[(size_t)y * (w + 1) + x + 1] + row;
        }
    }
    return s;
}

static double sat_sum(const double *s, int w, int x0, int y0, int x1, int y1)
{
    size_t W = (size_t)w + 1;
    return s[y1 * W + x1] - s[y0 * W + x1] - s[y1 * W + x0] + s[y0 * W + x0];
}

/* Where to cut [lo, hi) so that the part below the cut holds `frac` of the energy: the
 * cut c in (lo, hi) whose energy below is closest to the target (ties: lower c). A region
 * with no energy is cut at its geometric middle. */
static int find_cut(const double *s, int w, const mc_region *r, int axis, double frac)
{
    double total = sat_sum(s, w, r->x0, r->y0, r->x1, r->y1), target = frac * total;
    int lo = axis == 0 ? r->x0 : r->y0, hi = axis == 0 ? r->x1 : r->y1, a = lo + 1, b = hi - 1, c;
    double best_err;
    int best;
    if (!(total > 0)) {
        c = (int)floor((double)lo + frac * (double)(hi - lo) + 0.5);
        return c < lo + 1 ? lo + 1 : (c > hi - 1 ? hi - 1 : c);
    }
    /* first cut with energy below >= target (energy below grows with c) */
    while (a < b) {
        int m = (a + b) >> 1;
        double e = axis == 0 ? sat_sum(s, w, r->x0, r->y0, m, r->y1) : sat_sum(s, w, r->x0, r->y0, r->x1, m);
        if (e >= target) b = m; else a = m + 1;
    }
    best = a;
    best_err = fabs((axis == 0 ? sat_sum(s, w, r->x0, r->y0, a, r->y1) : sat_sum(s, w, r->x0, r->y0, r->x1, a)) - target);
    c = a - 1;
    if (c >= lo + 1) {
        double e = axis == 0 ? sat_sum(s, w, r->x0, r->y0, c, r->y1) : sat_sum(s, w, r->x0, r->y0, r->x1, c);
        if (fabs(e - target) <= best_err) best = c;
    }
    return best;
}

/* Debevec's median cut generalised to any n: a region that must hold n lights is cut
 * across its longer angular side (width measured at its central latitude) so that the
 * two parts hold energy in the ratio floor(n/2) : ceil(n/2), then each part gets that many
 * lights. The leaves of region `whole` (whole->n lights) are written to `leaves` (at most
 * whole->n; single-texel regions cannot be cut further and keep all their lights in one). */
static int median_cut(const env_geom *g, const double *s, const mc_region *whole, mc_region *leaves)
{
    const int n = whole->n;
    mc_region *stack = malloc(sizeof(mc_region) * (size_t)(2 * n + 2));
    int sp = 0, nl = 0;
    if (!stack) return -1;
    stack[sp++] = *whole;
    while (sp > 0) {
        mc_region r = stack[--sp], a, b;
        int n1, axis, cut;
        double wd, hd;
        if (r.n <= 1 || (r.x1 - r.x0 < 2 && r.y1 - r.y0 < 2)) {
            leaves[nl++] = r;
            continue;
        }
        n1 = r.n / 2;
        wd = (r.x1 - r.x0) * (2.0 * M_PI / g->w) * sin(M_PI * 0.5 * (r.y0 + r.y1) / g->h);
        hd = (r.y1 - r.y0) * (M_PI / g->h);
        axis = wd >= hd ? 0 : 1;
        if (axis == 0 && r.x1 - r.x0 < 2) axis = 1;
        if (axis == 1 && r.y1 - r.y0 < 2) axis = 0;
        cut = find_cut(s, g->w, &r, axis, (double)n1 / r.n);
        a = b = r;
        if (axis == 0) { a.x1 = cut; b.x0 = cut; } else { a.y1 = cut; b.y0 = cut; }
        a.n = n1;
        b.n = r.n - n1;
        stack[sp++] = b;
        stack[sp++] = a;
    }
    free(stack);
    return nl;
}

/* Accumulators of one light: RGB power, solid angle, energy-weighted direction sum. */
typedef struct light_acc { double p[3], omega, d[3], e; } light_acc;

static void acc_texel(light_acc *a, const env_geom *g, const vsd_env *env, int x, int y)
{
    const float *px = env->rgb + 3 * ((size_t)y * g->w + x);
    double om = g->row_omega[y], e = g->energy[(size_t)y * g->w + x];
    a->p[0] += px[0] * om;
    a->p[1] += px[1] * om;
    a->p[2] += px[2] * om;
    a->omega += om;
    a->e += e;
    a->d[0] += e * g->row_sin[y] * g->col_cos[x];
    a->d[1] += e * g->row_sin[y] * g->col_sin[x];
    a->d[2] += e * g->row_cos[y];
}

/* Finish a light: direction = energy centroid on the sphere (normalised mean of unit
 * vectors; `fallback` when the region has no energy). Returns 0 for a black region. */
static int acc_finish(const light_acc *a, const float fallback[3], vsd_env_light *l)
{
    double len = sqrt(a->d[0] * a->d[0] + a->d[1] * a->d[1] + a->d[2] * a->d[2]);
    int c;
    for (c = 0; c < 3; c++) {
        l->power[c] = (float)a->p[c];
        l->dir[c] = len > 0 ? (float)(a->d[c] / len) : fallback[c];
    }
    l->solid_angle = (float)a->omega;
    return a->p[0] != 0 || a->p[1] != 0 || a->p[2] != 0;
}

static void region_centre(const env_geom *g, const mc_region *r, float dir[3])
{
    double theta = M_PI * 0.5 * (r->y0 + r->y1) / g->h, phi = (0.5 - 0.5 * (r->x0 + r->x1) / g->w) * 2.0 * M_PI;
    dir[0] = (float)(sin(theta) * cos(phi));
    dir[1] = (float)(sin(theta) * sin(phi));
    dir[2] = (float)cos(theta);
}

/* Lloyd's k-means on the sphere with energy weights, from the median-cut directions.
 * Iterations run on a block-downsampled copy (<= 64K points) so they stay fast on large
 * maps; the final assignment then runs on every texel, so powers still sum exactly. */
static int kmeans_refine(const env_geom *g, const vsd_env *env, vsd_env_light *lights, int k)
{
    int f = 1, dw, dh, it, i, x, y;
    double *pe, *pd, *cd;
    light_acc *acc;
    while ((size_t)(g->w / f) * (size_t)(g->h / f) > 65536 && f < g->w) f *= 2;
    dw = g->w / f;
    dh = g->h / f;
    if (dw < 1) dw = 1;
    if (dh < 1) dh = 1;
    pe = calloc((size_t)dw * dh, sizeof(double));
    pd = calloc((size_t)dw * dh * 3, sizeof(double));
    cd = malloc(sizeof(double) * 3 * (size_t)k);
    acc = malloc(sizeof(light_acc) * (size_t)k);
    if (!pe || !pd || !cd || !acc) {
        free(pe); free(pd); free(cd); free(acc);
        return 0;
    }
    /* downsampled points: block energy at the block's energy centroid */
    for (y = 0; y < dh * f; y++)
        for (x = 0; x < dw * f; x++) {
            size_t b = (size_t)(y / f) * dw + x / f;
            double e = g->energy[(size_t)y * g->w + x];
            pe[b] += e;
            pd[3 * b] += e * g->row_sin[y] * g->col_cos[x];
            pd[3 * b + 1] += e * g->row_sin[y] * g->col_sin[x];
            pd[3 * b + 2] += e * g->row_cos[y];
        }
    for (i = 0; i < dw * dh; i++) {
        double l = sqrt(pd[3 * i] * pd[3 * i] + pd[3 * i + 1] * pd[3 * i + 1] + pd[3 * i + 2] * pd[3 * i + 2]);
        if (l > 0) { pd[3 * i] /= l; pd[3 * i + 1] /= l; pd[3 * i + 2] /= l; }
    }
    for (i = 0; i < k; i++) {
        cd[3 * i] = lights[i].dir[0];
        cd[3 * i + 1] = lights[i].dir[1];
        cd[3 * i + 2] = lights[i].dir[2];
    }
    for (it = 0; it < 16; it++) {
        double moved = 0;
        memset(acc, 0, sizeof(light_acc) * (size_t)k);
        for (i = 0; i < dw * dh; i++) {
            int best = 0, c;
            double bd = -2;
            if (!(pe[i] > 0)) continue;
            for (c = 0; c < k; c++) {
                double dd = pd[3 * i] * cd[3 * c] + pd[3 * i + 1] * cd[3 * c + 1] + pd[3 * i + 2] * cd[3 * c + 2];
                if (dd > bd) { bd = dd; best = c; }
            }
            acc[best].e += pe[i];
            acc[best].d[0] += pe[i] * pd[3 * i];
            acc[best].d[1] += pe[i] * pd[3 * i + 1];
            acc[best].d[2] += pe[i] * pd[3 * i + 2];
        }
        for (i = 0; i < k; i++) {
            double l = sqrt(acc[i].d[0] * acc[i].d[0] + acc[i].d[1] * acc[i].d[1] + acc[i].d[2] * acc[i].d[2]);
            if (l > 0) {
                double n0 = acc[i].d[0] / l, n1 = acc[i].d[1] / l, n2 = acc[i].d[2] / l;
                moved = fmax(moved, 1.0 - (n0 * cd[3 * i] + n1 * cd[3 * i + 1] + n2 * cd[3 * i + 2]));
                cd[3 * i] = n0; cd[3 * i + 1] = n1; cd[3 * i + 2] = n2;
            }
        }
        if (moved < 1e-9) break;
    }
    /* final assignment of every texel (black ones too, for the solid angles) */
    memset(acc, 0, sizeof(light_acc) * (size_t)k);
    for (y = 0; y < g->h; y++)
        for (x = 0; x < g->w; x++) {
            double tx = g->row_sin[y] * g->col_cos[x], ty = g->row_sin[y] * g->col_sin[x], tz = g->row_cos[y];
            double bd = -2;
            int best = 0, c;
            for (c = 0; c < k; c++) {
                double dd = tx * cd[3 * c] + ty * cd[3 * c + 1] + tz * cd[3 * c + 2];
                if (dd > bd) { bd = dd; best = c; }
            }
            acc_texel(&acc[best], g, env, x, y);
        }
    for (i = 0; i < k; i++) {
        float fb[3] = {(float)cd[3 * i], (float)cd[3 * i + 1], (float)cd[3 * i + 2]};
        acc_finish(&acc[i], fb, &lights[i]);
    }
    free(pe); free(pd); free(cd); free(acc);
    return 1;
}

/* Drop lights with no power (black regions): they would only cost shadow rays. */
static int compact(vsd_env_light *l, int n)
{
    int i, m = 0;
    for (i = 0; i < n; i++)
        if (l[i].power[0] != 0 || l[i].power[1] != 0 || l[i].power[2] != 0) l[m++] = l[i];
    return m;
}

/* 64-bit FNV-1a-style mix over the size and the texel bits */
uint64_t vsd_env_content_hash(const vsd_env *env)
{
    uint64_t h = 1469598103934665603ull ^ ((uint64_t)env->width << 32 | (uint32_t)env->height);
    const uint32_t *p = (const uint32_t *)(const void *)env->rgb;
    size_t i, n = (size_t)env->width * env->height * 3;
    for (i = 0; i < n; i++) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

/* Each light's region cut again into per_group sub-lights (out->sub, the group = the
 * light's index once the black lights are dropped, as compact() will number them). */
static int split_groups(const env_geom *g, const vsd_env *env, const double *sat, const mc_region *leaves, int nl,
                        int per_group, vsd_light_constellation *out)
{
    mc_region *sub = malloc(sizeof *sub * (size_t)per_group);
    int i, kept = 0, ok = 1;
    out->sub = calloc((size_t)nl * (size_t)per_group, sizeof *out->sub);
    out->sub_group = calloc((size_t)nl * (size_t)per_group, sizeof *out->sub_group);
    out->sub_count = 0;
    if (!sub || !out->sub || !out->sub_group) ok = 0;
    for (i = 0; ok && i < nl; i++) {
        const vsd_env_light *l = &out->lights[i];
        mc_region whole = leaves[i];
        int ns, q, x, y;
        if (l->power[0] == 0 && l->power[1] == 0 && l->power[2] == 0) continue;   /* dropped by compact() */
        whole.n = per_group;
        if ((ns = median_cut(g, sat, &whole, sub)) < 0) {
            ok = 0;
            break;
        }
        for (q = 0; q < ns; q++) {
            light_acc a;
            vsd_env_light *sl = &out->sub[out->sub_count];
            memset(&a, 0, sizeof a);
            for (y = sub[q].y0; y < sub[q].y1; y++)
                for (x = sub[q].x0; x < sub[q].x1; x++) acc_texel(&a, g, env, x, y);
            if (!acc_finish(&a, l->dir, sl)) continue;
            out->sub_group[out->sub_count++] = kept;
        }
        kept++;
    }
    free(sub);
    return ok;
}

vsd_status vsd_constellation_build(const vsd_env *env, int n, vsd_lights_method method,
                                   vsd_light_constellation *out, char *err, size_t errlen)
{
    return vsd_constellation_build_grouped(env, n, 1, method, out, err, errlen);
}

vsd_status vsd_constellation_build_grouped(const vsd_env *env, int n, int per_group, vsd_lights_method method,
                                           vsd_light_constellation *out, char *err, size_t errlen)
{
    env_geom g;
    double *sat = NULL;
    mc_region *leaves = NULL;
    light_acc *acc = NULL;
    int nl, i, x, y;
    memset(out, 0, sizeof *out);
    if (!env || env->width < 1 || env->height < 1 || !env->rgb)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "light constellation: empty environment map");
    if (n < 1 || n > 65536)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "light constellation: %d lights is out of range 1..65536", n);
    if (per_group < 1 || per_group > 64)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "light constellation: %d sub-lights per light is out of range 1..64",
                        per_group);
    if (method != VSD_LIGHTS_MEDIAN_CUT && method != VSD_LIGHTS_KMEANS)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "light constellation: unknown method %d", (int)method);
    if (!geom_init(&g, env)) return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory for the median cut", env->file);
    sat = build_sat(&g);
    leaves = malloc(sizeof(mc_region) * (size_t)n);
    out->lights = calloc((size_t)n, sizeof(vsd_env_light));
    if (!sat || !leaves || !out->lights) goto nomem;
    {
        const mc_region map = {0, 0, g.w, g.h, n};
        nl = median_cut(&g, sat, &map, leaves);
    }
    if (nl < 0) goto nomem;
    acc = calloc((size_t)nl, sizeof(light_acc));
    if (!acc) goto nomem;
    for (i = 0; i < nl; i++)
        for (y = leaves[i].y0; y < leaves[i].y1; y++)
            for (x = leaves[i].x0; x < leaves[i].x1; x++) acc_texel(&acc[i], &g, env, x, y);
    for (i = 0; i < nl; i++) {
        float fb[3];
        region_centre(&g, &leaves[i], fb);
        acc_finish(&acc[i], fb, &out->lights[i]);
    }
    if (method == VSD_LIGHTS_MEDIAN_CUT && per_group > 1 && !split_groups(&g, env, sat, leaves, nl, per_group, out))
        goto nomem;
    out->count = compact(out->lights, nl);
    if (method == VSD_LIGHTS_KMEANS && out->count > 0) {
        if (!kmeans_refine(&g, env, out->lights, out->count)) goto nomem;
        out->count = compact(out->lights, out->count);
    }
    for (i = 0; i < out->count; i++) {
        out->total_power[0] += out->lights[i].power[0];
        out->total_power[1] += out->lights[i].power[1];
        out->total_power[2] += out->lights[i].power[2];
    }
    free(acc);
    free(leaves);
    free(sat);
    geom_free(&g);
    return VSD_OK;
nomem:
    free(acc);
    free(leaves);
    free(sat);
    geom_free(&g);
    vsd_constellation_free(out);
    return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory for %d lights", env->file, n);
}

void vsd_constellation_free(vsd_light_constellation *c)
{
    if (!c) return;
    free(c->lights);
    free(c->sub);
    free(c->sub_group);
    memset(c, 0, sizeof *c);
}

/* One light in the kernel layout: texture = Rz(rot) world, so world = Rz(-rot) texture
 * (kernel_env.h); `last` is the 8th float (a sub-light's light, else 0). */
static void kernel_light(const vsd_env_light *l, float cr, float sr, float strength, float last, float *o)
{
    o[0] = cr * l->dir[0] + sr * l->dir[1];
    o[1] = -sr * l->dir[0] + cr * l->dir[1];
    o[2] = l->dir[2];
    o[3] = 0.0f;
    o[4] = l->power[0] * strength;
    o[5] = l->power[1] * strength;
    o[6] = l->power[2] * strength;
    o[7] = last;
}

void vsd_constellation_kernel_lights(const vsd_light_constellation *c, float strength, float rotation_z,
                                     float *out)
{
    float cr = cosf(rotation_z), sr = sinf(rotation_z);
    int i;
    for (i = 0; i < c->count; i++) kernel_light(&c->lights[i], cr, sr, strength, 0.0f, out + 8 * (size_t)i);
    for (i = 0; i < c->sub_count; i++)
        kernel_light(&c->sub[i], cr, sr, strength, (float)c->sub_group[i], out + 8 * ((size_t)c->count + i));
}

vsd_status vsd_constellation_cache_update(vsd_constellation_cache *c, const vsd_env *env, int n,
                                          vsd_lights_method method, float strength, float rotation_z, char *err,
                                          size_t errlen)
{
    return vsd_constellation_cache_update_grouped(c, env, n, 1, method, strength, rotation_z, err, errlen);
}

vsd_status vsd_constellation_cache_update_grouped(vsd_constellation_cache *c, const vsd_env *env, int n, int per_group,
                                                  vsd_lights_method method, float strength, float rotation_z,
                                                  char *err, size_t errlen)
{
    uint64_t key = vsd_env_content_hash(env);
    if (!c->valid || key != c->key || n != c->n || per_group != c->per_group || (int)method != c->method) {
        vsd_status st;
        free(c->lights);   /* a failed rebuild leaves no lights of the old map behind */
        c->lights = NULL;
        c->count = 0;
        vsd_constellation_free(&c->cons);
        c->valid = 0;
        if ((st = vsd_constellation_build_grouped(env, n, per_group, method, &c->cons, err, errlen))) return st;
        c->key = key;
        c->n = n;
        c->per_group = per_group;
        c->method = (int)method;
        c->valid = 1;
    }
    free(c->lights);
    c->count = 0;
    if (!(c->lights = malloc(sizeof(float) * 8 * (size_t)(c->cons.count + c->cons.sub_count > 0 ? c->cons.count + c->cons.sub_count : 1))))
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for %d lights", c->cons.count);
    vsd_constellation_kernel_lights(&c->cons, strength, rotation_z, c->lights);
    c->count = c->cons.count;
    c->sub_count = c->cons.sub_count;
    return VSD_OK;
}

void vsd_constellation_cache_free(vsd_constellation_cache *c)
{
    vsd_constellation_free(&c->cons);
    free(c->lights);
    memset(c, 0, sizeof *c);
}
