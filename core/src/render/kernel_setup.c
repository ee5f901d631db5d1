#include "kernel_setup.h"
#include "kernel/kernel_lights.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

void vsd_mat4_mul(const double a[16], const double b[16], double c[16])
{
    double r[16];
    int i, j, k;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) {
            double s = 0;
            for (k = 0; k < 4; k++) s += a[i * 4 + k] * b[k * 4 + j];
            r[i * 4 + j] = s;
        }
    memcpy(c, r, sizeof r);
}

/* Gauss-Jordan with partial pivoting: the matrices are small and well scaled. */
int vsd_mat4_invert(const double m[16], double inv[16])
{
    double a[4][8];
    int i, j, k;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 8; j++) a[i][j] = j < 4 ? m[i * 4 + j] : (j - 4 == i ? 1.0 : 0.0);
    for (i = 0; i < 4; i++) {
        int p = i;
        for (k = i + 1; k < 4; k++)
            if (fabs(a[k][i]) > fabs(a[p][i])) p = k;
        if (fabs(a[p][i]) < 1e-300) return 0;
        if (p != i)
            for (j = 0; j < 8; j++) { double s = a[i][j]; a[i][j] = a[p][j]; a[p][j] = s; }
        for (j = 7; j >= i; j--) a[i][j] /= a[i][i];
        for (k = 0; k < 4; k++)
            if (k != i) {
                double f = a[k][i];
                for (j = i; j < 8; j++) a[k][j] -= f * a[i][j];
            }
    }
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) inv[i * 4 + j] = a[i][j + 4];
    return 1;
}

static void affine_from_mat4(vsd_affine *a, const double m[16])
{
    int i;
    for (i = 0; i < 12; i++) a->m[i] = (float)m[i];
}

vsd_status vsd_kvolume_setup(vsd_kvolume *kv, const vsd_volume *vol, const double object_matrix[16],
                             float scale, char *err, size_t errlen)
{
    double to_world[16], to_index[16];
    double min_step = 1e30;
    int a;
    memset(kv, 0, sizeof *kv);
    kv->scale = scale;
    if (!vol || vol->brick_dims[0] == 0) return VSD_OK;
    vsd_mat4_mul(object_matrix, vol->index_to_world, to_world);
    if (!vsd_mat4_invert(to_world, to_index))
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "%s: volume.matrix times the grid transform is singular", vol->file);
    affine_from_mat4(&kv->world_to_index, to_index);
    for (a = 0; a < 3; a++) {
        /* world length of one index step along axis a */
        double l = sqrt(to_world[a] * to_world[a] + to_world[4 + a] * to_world[4 + a] +
                        to_world[8 + a] * to_world[8 + a]);
        if (l < min_step) min_step = l;
        kv->origin[a] = vol->origin[a];
        kv->dims[a] = vol->brick_dims[a];
    }
    kv->brick_slots = vol->brick_slots;
    kv->voxels = vol->voxels;
    kv->brick_max = vol->brick_max;
    kv->step = (float)(0.5 * min_step);
    return VSD_OK;
}

static double texel_luminance(const vsd_env *env, int x, int y)
{
    const float *p = env->rgb + 3 * ((size_t)y * env->width + x);
    return fmax(0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2], 0.0);
}

/* The integral over texel (x, y) of the bilinear interpolant of the luminance, in texel
 * areas: each neighbour's value reaches 1/8 of the way into the texel along its axis. */
static double texel_weight(const vsd_env *env, int interpolation, int x, int y)
{
    static const double k[3] = {0.125, 0.75, 0.125};
    int w = env->width, h = env->height, i, j;
    double sum = 0;
    if (interpolation == VSD_ENV_CLOSEST) return texel_luminance(env, x, y);
    for (j = -1; j <= 1; j++) {
        int yy = y + j < 0 ? 0 : y + j >= h ? h - 1 : y + j;
        for (i = -1; i <= 1; i++) sum += k[i + 1] * k[j + 1] * texel_luminance(env, (x + i + w) % w, yy);
    }
    return sum;
}

vsd_status vsd_env_tables_build(const vsd_env *env, int interpolation, vsd_env_tables *t, char *err, size_t errlen)
{
    int w = env->width, h = env->height, x, y;
    double total = 0;
    t->cdf_rows = malloc(sizeof(float) * (size_t)(h + 1));
    t->cdf_cols = malloc(sizeof(float) * (size_t)h * (size_t)(w + 1));
    if (!t->cdf_rows || !t->cdf_cols) {
        vsd_env_tables_free(t);
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "%s: no memory for sampling tables", env->file);
    }
    t->cdf_rows[0] = 0;
    {
        double *row_sum = malloc(sizeof(double) * (size_t)h);
        if (!row_sum) {
            vsd_env_tables_free(t);
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "no memory for sampling tables");
        }
        for (y = 0; y < h; y++) {
            float *cc = t->cdf_cols + (size_t)y * (w + 1);
            double sin_t = sin(M_PI * (y + 0.5) / h), acc = 0;
            cc[0] = 0;
            for (x = 0; x < w; x++) {
                /* a small floor keeps every direction reachable, so MIS stays unbiased
                 * even where the map is black */
                acc += (texel_weight(env, interpolation, x, y) + 1e-6) * sin_t;
                cc[x + 1] = (float)acc;
            }
            for (x = 1; x <= w; x++) cc[x] = acc > 0 ? (float)(cc[x] / acc) : (float)x / w;
            cc[w] = 1.0f;
            row_sum[y] = acc;
            total += acc;
        }
        {
            double acc = 0;
            for (y = 0; y < h; y++) {
                acc += row_sum[y];
                t->cdf_rows[y + 1] = (float)(acc / total);
            }
            t->cdf_rows[h] = 1.0f;
        }
        free(row_sum);
    }
    return VSD_OK;
}

void vsd_env_tables_free(vsd_env_tables *t)
{
    free(t->cdf_rows);
    free(t->cdf_cols);
    t->cdf_rows = t->cdf_cols = NULL;
}

void vsd_kenv_setup(vsd_kenv *ke, const vsd_env *env, const vsd_env_tables *t, int interpolation, float strength,
                    float rotation_z)
{
    memset(ke, 0, sizeof *ke);
    ke->rgb = env->rgb;
    ke->cdf_rows = t->cdf_rows;
    ke->cdf_cols = t->cdf_cols;
    ke->width = env->width;
    ke->height = env->height;
    ke->strength = strength;
    ke->linear = interpolation == VSD_ENV_LINEAR;
    ke->cos_rot = cosf(rotation_z);
    ke->sin_rot = sinf(rotation_z);
}

void vsd_kcamera_setup(vsd_kcamera *kc, const vsd_scene *scene)
{
    memset(kc, 0, sizeof *kc);
    affine_from_mat4(&kc->cam_to_world, scene->camera.matrix);
    kc->orthographic = scene->camera.type == VSD_CAMERA_ORTHOGRAPHIC;
    kc->tan_half_fov = (float)tan(0.5 * scene->camera.fov);
    kc->ortho_half_width = (float)(0.5 * scene->camera.ortho_scale);
    kc->width = scene->film.width;
    kc->height = scene->film.height;
    kc->clip_start = (float)scene->camera.clip_start;
    kc->clip_end = (float)scene->camera.clip_end;
}

int vsd_kscene_lights_setup(float *out, const vsd_scene *scene)
{
    int i, c;
    memset(out, 0, (size_t)VSD_KLIGHT_FLOATS * VSD_MAX_LIGHTS * sizeof *out);
    for (i = 0; i < scene->light_count; i++) {
        const vsd_scene_light *s = &scene->lights[i];
        float *l = out + (size_t)VSD_KLIGHT_FLOATS * i;
        /* Cycles: a sun's strength is irradiance; a point's power P radiates P / 4pi per sr */
        float k = s->type == VSD_LIGHT_SUN ? s->strength : s->power / (4.0f * 3.14159265358979f);
        for (c = 0; c < 3; c++) {
            l[c] = (float)(s->type == VSD_LIGHT_SUN ? -s->direction[c] : s->position[c]);
            l[4 + c] = k * s->color[c];
            l[8 + c] = (float)s->direction[c];
        }
        l[3] = (float)s->type;
        l[7] = s->type == VSD_LIGHT_SUN ? cosf(0.5f * s->angle) : s->radius;
        l[11] = cosf(0.5f * s->spot_size);
        l[12] = (1.0f - l[11]) * s->spot_blend;
        l[13] = s->spot_cosine ? 1.0f : 0.0f;
    }
    return scene->light_count;
}

void vsd_kmedium_setup(vsd_kmedium *k, const vsd_scene_medium *m)
{
    const float *al = m->albedo, *ec = m->emission_color;
    float es = m->emission_strength;
    k->albedo = f3(al[0], al[1], al[2]);
    k->emission = f3(ec[0] * es, ec[1] * es, ec[2] * es);
    k->anisotropy = m->anisotropy;
}

void vsd_kernel_data_from_scene(vsd_kernel_data *kd, const vsd_scene *scene)
{
    vsd_kcamera_setup(&kd->camera, scene);
    vsd_kmedium_setup(&kd->medium, &scene->volumes[0].medium);
    kd->transparent = scene->film.transparent;
    kd->seed = scene->render.seed;
}
