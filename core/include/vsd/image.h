/* vsd/image.h — render passes in memory and their files: multilayer EXR (OpenEXR C API),
 * EXR reading for tests/tools (C++ API behind a C shim), and the display preview PNG
 * through an OpenColorIO view transform (docs/architecture.md §6).
 *
 * Ownership: vsd_framebuffer_create/destroy; vsd_exr_read returns a vsd_exr_image freed
 * by vsd_exr_image_destroy. Writers never take ownership of their inputs. */
#ifndef VSD_IMAGE_H
#define VSD_IMAGE_H
#include <stddef.h>
#include "vsd/status.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef enum vsd_pass {
    VSD_PASS_COMBINED = 0,   /* RGBA, premultiplied, alpha = 1 - mean transmittance */
    VSD_PASS_VOLUME_DIR,     /* RGB: light scattered once toward the camera */
    VSD_PASS_VOLUME_IND,     /* RGB: light scattered more than once */
    VSD_PASS_EMIT,           /* RGB: emission reaching the camera */
    VSD_PASS_TRANSMITTANCE,  /* RGB: transmittance of the view ray through the volume */
    VSD_PASS_DEPTH,          /* Z: distance along the view ray to the first interaction estimate; 1e10 when empty */
    VSD_PASS_COUNT
} vsd_pass;

#define VSD_PASS_BIT(p) (1u << (p))
#define VSD_PASS_ALL ((1u << VSD_PASS_COUNT) - 1u)
#define VSD_DEPTH_EMPTY 1e10f

/* Blender pass name ("Combined", "VolumeDir", ...) and channel count (4, 3 or 1). */
const char *vsd_pass_name(vsd_pass p);
int vsd_pass_channels(vsd_pass p);
/* Parse a pass name; returns VSD_PASS_COUNT when unknown. */
vsd_pass vsd_pass_from_name(const char *name);

/* Longest EXR pass (layer) name: Blender's RenderPass.name holds 63 bytes. */
#define VSD_PASS_NAME_MAX 63
/* The rules for a pass's name in an EXR file (scene files and the EXR writer share them):
 * returns 0 when `name` may name a pass, else 1 with the reason in why ("empty name",
 * "longer than 63 characters ...", "\"a.b\" contains '.' ..."). Blender splits a channel
 * name "<layer>.<pass>.<channel>" at its dots, so a pass name holds none. */
int vsd_pass_name_problem(const char *name, char *why, size_t whylen);
/* Two passes p < q, both in mask, with the same name in names[VSD_PASS_COUNT] (they would
 * be one layer to every reader): returns 1 and sets *p, *q; 0 when all differ. */
int vsd_pass_names_clash(const char *const names[], unsigned mask, int *p, int *q);

/* All passes allocated, interleaved per pixel (Combined: RGBARGBA..., Depth: one float),
 * row 0 = top of the image, zero-filled (Depth filled with VSD_DEPTH_EMPTY). */
typedef struct vsd_framebuffer {
    int width, height;
    float *pass[VSD_PASS_COUNT];
} vsd_framebuffer;

vsd_status vsd_framebuffer_create(int width, int height, vsd_framebuffer **out,
                                  char *err, size_t errlen);
void vsd_framebuffer_clear(vsd_framebuffer *fb);
void vsd_framebuffer_destroy(vsd_framebuffer *fb);

typedef struct vsd_exr_attr {
    const char *name;   /* e.g. "vsd/method" */
    const char *value;  /* written as an EXR string attribute */
} vsd_exr_attr;

/* The EXR compressions vsd writes (the scene's output.compression). All are lossless.
 * Encoding a 1280x720 result's 17 float channels on the 2-core VM, two threads
 * (docs/daemon-bench.md): ZIP 0.34 s to 33% of the raw size, RLE 0.07 s to 48% (runs of
 * equal values: the empty background), none 0.05 s. ZIP for files kept, RLE for results
 * read at once. */
typedef enum vsd_exr_compression {
    VSD_EXR_ZIP = 0,
    VSD_EXR_NONE,
    VSD_EXR_RLE,
    VSD_EXR_COMPRESSION_COUNT
} vsd_exr_compression;

/* The scene file's name of each ("zip", "none", "rle"; the list NULL-terminated), and back
 * (VSD_EXR_COMPRESSION_COUNT when unknown). In their own object file: the scene parser,
 * which the light `vsd` front links, uses them without the EXR writer. */
extern const char *const vsd_exr_compression_names[VSD_EXR_COMPRESSION_COUNT + 1];
const char *vsd_exr_compression_name(vsd_exr_compression c);
vsd_exr_compression vsd_exr_compression_from_name(const char *name);

typedef struct vsd_exr_write_options {
    const char *layer;        /* 0 = "ViewLayer" */
    /* [VSD_PASS_COUNT] EXR pass names, e.g. Blender 5.0's "Volume Direct" for VolumeDir;
     * 0, or a 0 / "" entry = vsd_pass_name(). */
    const char *const *pass_names;
    unsigned pass_mask;       /* 0 = all passes */
    int half;                 /* 0 = float32 channels, 1 = half */
    vsd_exr_compression compression; /* 0 = ZIP */
    int threads;              /* threads encoding its chunks; 0 = one per online CPU (the bytes
                                 written do not depend on it) */
    const vsd_exr_attr *attrs;/* extra header attributes */
    int attr_count;
} vsd_exr_write_options;

/* Write a multilayer EXR with channels "<layer>.<Pass>.<R|G|B|A|Z>" (Blender's names, or
 * opt->pass_names: each at most 63 bytes, no '.', all distinct, else VSD_ERR_INVALID), ZIP
 * compressed unless opt->uncompressed, to `path` via a temporary file in the same folder that is renamed on success
 * (a crash never leaves a half-written frame). Creates no folders. */
vsd_status vsd_exr_write(const char *path, const vsd_framebuffer *fb,
                         const vsd_exr_write_options *opt, char *err, size_t errlen);
/* The same file's bytes in memory (*bytes malloc'd, free() them): a result sent at once
 * (the daemon), which no disk write, fsync or read-back needs to delay. */
vsd_status vsd_exr_encode(const vsd_framebuffer *fb, const vsd_exr_write_options *opt, unsigned char **bytes,
                          size_t *len, char *err, size_t errlen);

/* Any EXR (any compression), all channels as float planes, row 0 = top. */
typedef struct vsd_exr_image {
    int width, height, channel_count;
    char **channel_names;   /* [channel_count] */
    float **channels;       /* [channel_count][width*height] */
} vsd_exr_image;

vsd_status vsd_exr_read(const char *path, vsd_exr_image **out, char *err, size_t errlen);
/* Plane of the named channel, or NULL. */
const float *vsd_exr_channel(const vsd_exr_image *img, const char *name);
/* Header string attribute value (caller buffer), VSD_ERR_NOT_FOUND if absent. */
vsd_status vsd_exr_read_attr(const char *path, const char *attr, char *value, size_t len,
                             char *err, size_t errlen);
void vsd_exr_image_destroy(vsd_exr_image *img);

typedef struct vsd_preview_options {
    const char *view;        /* 0 = config's default view ("Standard"/"Filmic" in Blender's) */
    const char *display;     /* 0 = config's default display */
    float exposure;          /* stops, 0 = none */
} vsd_preview_options;

/* Display-referred 8-bit RGBA PNG of the Combined pass through an OpenColorIO
 * display/view transform. Config: $OCIO, else Blender's installed config, else a plain
 * sRGB transfer — `note` (may be NULL) then says which was used, for the CLI to print.
 * Written via a temporary name and renamed, like EXR. */
vsd_status vsd_preview_write_png(const char *path, const vsd_framebuffer *fb,
                                 const vsd_preview_options *opt, char *note, size_t notelen,
                                 char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
