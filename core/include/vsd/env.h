/* vsd/env.h — equirectangular environment maps (docs/architecture.md §3).
 *
 * Pixels are scene-linear RGB floats, row 0 = top of the image = straight up (+Z), mapped
 * exactly as Cycles' Environment Texture: direction d -> u = 0.5 - atan2(d.y,d.x)/(2 pi),
 * v = 1 - acos(d.z)/pi (v = 1 at row 0). Strength and Z rotation are applied at lookup time
 * (see kernel/kernel_env.h), not baked into the pixels, so changing them costs nothing.
 *
 * Ownership: vsd_env_load/vsd_env_create_uniform return an env freed by vsd_env_destroy. */
#ifndef VSD_ENV_H
#define VSD_ENV_H
#include "vsd/status.h"

#include <stdio.h>
#ifdef __cplusplus
extern "C" {
#endif

typedef struct vsd_env {
    int width, height;
    float *rgb;          /* [width*height*3] */
    char file[1024];
} vsd_env;

/* A map's colour conversion as one string, the form that cache keys and the daemon's
 * isolated loader carry: "" = none; "FROM" = from OpenColorIO colour space FROM to the
 * config's scene_linear role; "FROM" VSD_ENV_SPACE_SEP "TO" = from FROM to the named working
 * space TO (Blender 5.0's per-file Linear Rec.2020 or ACEScg, or Rec.709 named as 4.x+ name
 * it). An empty `from` gives "" whatever `to` is: a map in the working space is not touched. */
#define VSD_ENV_NAME_LEN 128   /* a colour space name, as the scene's */
#define VSD_ENV_SPACE_SEP '\x1f'
static inline void vsd_env_conversion(const char *from, const char *to, char *buf, size_t len)
{
    if (!from || !*from) snprintf(buf, len, "%s", "");
    else if (!to || !*to) snprintf(buf, len, "%s", from);
    else snprintf(buf, len, "%s%c%s", from, VSD_ENV_SPACE_SEP, to);
}

/* Load .exr (any compression Blender writes, via OpenEXR's C++ API) or Radiance .hdr/.pic
 * (RGBE, flat or run-length encoded), chosen by file content, not extension. When
 * `conversion` (vsd_env_conversion) is non-NULL and non-empty the pixels are converted with
 * OpenColorIO: in the config that $OCIO names, else Blender's installed one, else (or when
 * that config lacks either name, as Blender 3.4's lacks 4.x's "Linear Rec.709", "Linear
 * Rec.2020" and "ACEScg") vsd's built-in config of the linear spaces Blender 4.x and 5.x
 * offer (ocio_builtin_config.cpp). A name in neither config: VSD_ERR_NOT_FOUND naming it. */
vsd_status vsd_env_load(const char *path, const char *conversion, vsd_env **out,
                        char *err, size_t errlen);

/* A constant-colour map (width x height) — the "world colour" case and the furnace test. */
vsd_status vsd_env_create_uniform(const float rgb[3], int width, int height, vsd_env **out,
                                  char *err, size_t errlen);

void vsd_env_destroy(vsd_env *env);

/* Solid angle of one texel of row `row` of a width x height map (every texel of a row has
 * the same): (2 pi / width) (cos theta0 - cos theta1), theta = pi row / height. The one
 * quadrature weight every integral over a map uses (projections, light constellations). */
double vsd_env_texel_solid_angle(int width, int height, int row);

#ifdef __cplusplus
}
#endif
#endif
