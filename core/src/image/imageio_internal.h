/* Internal helpers of the vsd_imageio module (core/src/image + core/src/env), shared so that
 * each idea has one implementation: one file sniffer, one temp-file + rename commit, one
 * OpenColorIO config chooser, one OCIO shim. Not a public header: nothing outside
 * vsd_imageio (and its tests) includes it. */
#ifndef VSD_IMAGEIO_INTERNAL_H
#define VSD_IMAGEIO_INTERNAL_H
#include <stddef.h>
#include "vsd/image.h"
#ifdef __cplusplus
extern "C" {
#endif

/* Channel letters of a pass in Blender's order: "RGBA", "RGB" or "Z". */
const char *vsd_pass_chan_ids(vsd_pass p);

/* ---- files -------------------------------------------------------------------------- */

/* Read the first `n` bytes of `path` into `buf` (*got = bytes read, may be < n for a short
 * file). VSD_ERR_IO naming the path and the OS reason when it cannot be opened or read. */
vsd_status vsd_io_read_head(const char *path, unsigned char *buf, size_t n, size_t *got,
                            char *err, size_t errlen);

/* An output written through a temporary file "<path>.tmp-<pid>" in the destination folder,
 * so that a crash or a failed write never leaves a half-written file under the real name. */
typedef struct vsd_io_tmpfile {
    char path[4096];      /* the final name */
    char tmp[4200];       /* the temporary name */
    int fd;               /* open for writing, -1 when closed */
} vsd_io_tmpfile;

/* Create the temporary file (exclusively; never follows or truncates someone else's file).
 * VSD_ERR_IO naming `path` (e.g. its folder does not exist). */
vsd_status vsd_io_tmp_open(vsd_io_tmpfile *t, const char *path, char *err, size_t errlen);
/* fsync + close + rename onto the final name; on any failure the temporary is removed. */
vsd_status vsd_io_tmp_commit(vsd_io_tmpfile *t, char *err, size_t errlen);
/* Close (when open) and remove the temporary: the failure path. */
void vsd_io_tmp_abort(vsd_io_tmpfile *t);

/* ---- OpenEXR ------------------------------------------------------------------------ */

/* The four bytes every OpenEXR file starts with. */
#define VSD_EXR_MAGIC "\x76\x2f\x31\x01"

/* ---- OpenColorIO -------------------------------------------------------------------- */

/* Where the config came from, for notes and messages. */
typedef enum vsd_ocio_origin {
    VSD_OCIO_NONE = 0,   /* no config: callers fall back (preview) or refuse (colour spaces) */
    VSD_OCIO_ENV,        /* $OCIO */
    VSD_OCIO_BLENDER     /* Blender's installed config */
} vsd_ocio_origin;

/* NULL-terminated list of glob patterns tried for Blender's config when $OCIO is unset.
 * Tests point it elsewhere to exercise the no-config fallback; nothing else writes it. */
extern const char *const *vsd_ocio_blender_candidates;

/* The one config chooser: $OCIO when set and non-empty (a missing file there is an error —
 * the user asked for it, silently using another config would hide the mistake), else the
 * first existing Blender config, else none (*origin = VSD_OCIO_NONE, path = ""). */
vsd_status vsd_ocio_choose_config(char *path, size_t pathlen, vsd_ocio_origin *origin,
                                  char *err, size_t errlen);
/* "$OCIO" / "Blender's" / "none". */
const char *vsd_ocio_origin_str(vsd_ocio_origin o);

/* OCIO shim (ocio.cpp). Apply the display/view transform from the scene_linear role to
 * `rgba` (w*h pixels, 4 floats each, alpha left as is) in place. `display`/`view` NULL or
 * "" = the config's defaults; the names actually used are copied into used_display/used_view.
 * Unknown display or view: VSD_ERR_NOT_FOUND listing the valid ones. */
vsd_status vsd_ocio_display_view(const char *config_path, float *rgba, int w, int h,
                                 const char *display, const char *view,
                                 char *used_display, size_t udlen, char *used_view, size_t uvlen,
                                 char *err, size_t errlen);
/* Convert `rgb` (n pixels, 3 floats each) in place from colour space `from` to `to` (NULL or
 * "" = the scene_linear role) in the config at `config_path`, or in vsd's built-in config of
 * Blender's linear spaces when config_path is NULL. A name the config lacks:
 * VSD_ERR_NOT_FOUND naming it and some valid names; an unreadable config: VSD_ERR_FORMAT. */
vsd_status vsd_ocio_convert(const char *config_path, const char *from, const char *to,
                            float *rgb, size_t n, char *err, size_t errlen);
/* The text of vsd's built-in config (ocio_builtin_config.cpp). */
extern const char vsd_ocio_builtin_config[];

#ifdef __cplusplus
}
#endif
#endif
