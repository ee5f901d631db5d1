/* Multilayer EXR writer on OpenEXR's C API (openexr.h): one scanline part, ZIP, RLE or no
 * compression (the chunks encoded on several threads, exr_chunks.c),
 * channels "<layer>.<Pass>.<chan>" as Blender writes them, through a temporary file that is
 * renamed into place only once the whole file is on disk (docs/architecture.md §6). */
#define _POSIX_C_SOURCE 200809L
#include "src/image/imageio_internal.h"
#include "src/image/exr_chunks.h"
#include <errno.h>
#include <openexr.h>
#include <Imath/half.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Per-write state reachable from OpenEXR's callbacks through the context's user data:
 * a temporary file (vsd_exr_write) or a growing buffer (vsd_exr_encode). */
typedef struct exr_writer {
    vsd_io_tmpfile file;
    unsigned char *bytes;             /* memory: the file's bytes so far */
    size_t len, cap;
    char msg[512];                    /* first error OpenEXR reported */
    int write_errno;                  /* errno of a failed pwrite, 0 if none */
} exr_writer;

/* OpenEXR reports errors through this callback instead of returning text; keep the first
 * message (later ones are usually consequences) instead of letting it print to stderr. */
static void on_exr_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    void *ud = NULL;
    exr_writer *w = (ctxt && exr_get_user_data(ctxt, &ud) == EXR_ERR_SUCCESS) ? ud : NULL;
    if (w && !w->msg[0])
        snprintf(w->msg, sizeof w->msg, "%s", msg ? msg : exr_get_default_error_message(code));
}

/* Our own write callback on the already-open temporary file: pwrite at the offsets the
 * library asks for (it writes the chunk table last, back near the start of the file). */
static int64_t write_fn(exr_const_context_t ctxt, void *userdata, const void *buffer,
                        uint64_t sz, uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    exr_writer *w = userdata;
    const char *p = buffer;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t n = pwrite(w->file.fd, p + done, (size_t)(sz - done), (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            w->write_errno = n < 0 ? errno : EIO;
            error_cb(ctxt, EXR_ERR_WRITE_IO, "%s", strerror(w->write_errno));
            return -1;
        }
        done += (uint64_t)n;
    }
    return (int64_t)sz;
}

/* The same into memory: the library writes at increasing offsets but for the chunk table,
 * which it writes last, back near the start. */
static int64_t memory_write_fn(exr_const_context_t ctxt, void *userdata, const void *buffer, uint64_t sz,
                               uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    exr_writer *w = userdata;
    uint64_t end = offset + sz;
    if (end < offset || end > (uint64_t)SIZE_MAX / 2) {
        error_cb(ctxt, EXR_ERR_WRITE_IO, "EXR larger than memory can hold");
        return -1;
    }
    if (end > w->cap) {
        size_t cap = w->cap ? w->cap : 1 << 16;
        unsigned char *b;
        while (cap < end) cap *= 2;
        if (!(b = realloc(w->bytes, cap))) {
            error_cb(ctxt, EXR_ERR_OUT_OF_MEMORY, "no memory for %llu bytes of EXR", (unsigned long long)end);
            return -1;
        }
        w->bytes = b;
        w->cap = cap;
    }
    if (offset > w->len) memset(w->bytes + w->len, 0, (size_t)(offset - w->len));
    memcpy(w->bytes + offset, buffer, (size_t)sz);
    if (end > w->len) w->len = (size_t)end;
    return (int64_t)sz;
}

/* The pass part of each channel name: opt->pass_names where given (a Blender version that
 * renames its passes, e.g. 5.0's "Volume Direct"), else vsd's own, checked by the rules
 * scene files follow too (vsd_pass_name_problem, vsd_pass_names_clash). */
static vsd_status pass_names(const vsd_exr_write_options *opt, unsigned mask,
                             const char *names[VSD_PASS_COUNT], char *err, size_t errlen)
{
    char why[160];
    int p, q;
    for (p = 0; p < VSD_PASS_COUNT; p++) {
        const char *given = opt && opt->pass_names ? opt->pass_names[p] : NULL;
        names[p] = given && *given ? given : vsd_pass_name((vsd_pass)p);
        if (vsd_pass_name_problem(names[p], why, sizeof why))
            return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR pass name for %s: %s", vsd_pass_name((vsd_pass)p), why);
    }
    if (vsd_pass_names_clash(names, mask, &p, &q))
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR passes %s and %s both named \"%s\"",
                        vsd_pass_name((vsd_pass)p), vsd_pass_name((vsd_pass)q), names[p]);
    return VSD_OK;
}

/* The channel list for the selected passes. Depth stays float32 even when half is asked
 * for, as Blender does for its non-colour passes: the 1e10 "empty" marker and distances
 * beyond 2048 units do not survive half precision. Channel or attribute names beyond 31
 * characters set *long_names (the EXR 2.0 flag every current reader understands). */
static vsd_status build_channels(const vsd_exr_write_options *opt, exr_chan *chans, int *count,
                                 int *long_names, char *err, size_t errlen)
{
    const char *layer = opt && opt->layer && *opt->layer ? opt->layer : "ViewLayer";
    unsigned mask = opt && opt->pass_mask ? opt->pass_mask : VSD_PASS_ALL;
    if (strlen(layer) > LAYER_MAX)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR layer name longer than %d characters",
                        LAYER_MAX);
    if (mask & ~VSD_PASS_ALL)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR pass mask 0x%x has unknown bits", mask);
    const char *names[VSD_PASS_COUNT];
    vsd_status st = pass_names(opt, mask, names, err, errlen);
    if (st)
        return st;
    int n = 0;
    *long_names = 0;
    for (int p = 0; p < VSD_PASS_COUNT; p++) {
        if (!(mask & VSD_PASS_BIT(p)))
            continue;
        const char *ids = vsd_pass_chan_ids((vsd_pass)p);
        for (int c = 0; ids[c]; c++, n++) {
            snprintf(chans[n].name, sizeof chans[n].name, "%s.%s.%c", layer, names[p], ids[c]);
            chans[n].pass = (vsd_pass)p;
            chans[n].comp = c;
            chans[n].half = opt && opt->half && p != VSD_PASS_DEPTH;
            if (strlen(chans[n].name) > EXR_SHORT_NAME_MAX)
                *long_names = 1;
        }
    }
    for (int i = 0; opt && i < opt->attr_count; i++)
        if (strlen(opt->attrs[i].name) > EXR_SHORT_NAME_MAX)
            *long_names = 1;
    *count = n;
    return VSD_OK;
}

/* OpenEXR's code for each of vsd's compressions */
static const exr_compression_t k_exr_compression[VSD_EXR_COMPRESSION_COUNT] = {
    [VSD_EXR_ZIP] = EXR_COMPRESSION_ZIP,
    [VSD_EXR_NONE] = EXR_COMPRESSION_NONE,
    [VSD_EXR_RLE] = EXR_COMPRESSION_RLE,
};

/* (check_inputs refused any other value) */
static exr_compression_t exr_compression_of(const vsd_exr_write_options *opt)
{
    return k_exr_compression[opt ? opt->compression : VSD_EXR_ZIP];
}

/* Everything that goes before the pixels: size, compression, channels, attributes. The
 * library sorts the channel list by name, as the EXR format requires; write_chunks therefore
 * matches channels by name, never by position. */
static exr_result_t define_header(exr_context_t ctxt, const vsd_framebuffer *fb,
                                  const exr_chan *chans, int n, int long_names,
                                  const vsd_exr_write_options *opt)
{
    int part = 0;
    exr_result_t rv = exr_add_part(ctxt, NULL, EXR_STORAGE_SCANLINE, &part);
    if (!rv && long_names)
        rv = exr_set_longname_support(ctxt, 1);
    if (!rv)
        rv = exr_initialize_required_attr_simple(ctxt, part, fb->width, fb->height,
                                                 exr_compression_of(opt));
    for (int i = 0; !rv && i < n; i++)
        rv = exr_add_channel(ctxt, part, chans[i].name,
                             chans[i].half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                             EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (!rv)
        rv = exr_attr_set_string(ctxt, part, "vsd/version", VSD_VERSION_STRING);
    for (int i = 0; !rv && opt && i < opt->attr_count; i++)
        rv = exr_attr_set_string(ctxt, part, opt->attrs[i].name, opt->attrs[i].value);
    if (!rv)
        rv = exr_write_header(ctxt);
    return rv;
}

/* Map an OpenEXR failure to a vsd status with a message naming the file. */
static vsd_status exr_failure(exr_result_t rv, const exr_writer *w, const char *path,
                              char *err, size_t errlen)
{
    const char *why = w->msg[0] ? w->msg : exr_get_default_error_message(rv);
    vsd_status s = VSD_ERR_INTERNAL;
    if (w->write_errno || rv == EXR_ERR_FILE_ACCESS || rv == EXR_ERR_WRITE_IO)
        s = VSD_ERR_IO;
    else if (rv == EXR_ERR_OUT_OF_MEMORY)
        s = VSD_ERR_NOMEM;
    else if (rv == EXR_ERR_NAME_TOO_LONG || rv == EXR_ERR_INVALID_ATTR ||
             rv == EXR_ERR_INVALID_ARGUMENT || rv == EXR_ERR_ATTR_TYPE_MISMATCH)
        s = VSD_ERR_INVALID;
    return vsd_fail(s, err, errlen, "cannot write EXR '%s': %s", path, why);
}

static vsd_status check_inputs(const char *path, const vsd_framebuffer *fb,
                               const vsd_exr_write_options *opt, char *err, size_t errlen)
{
    if (!path || !*path)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR write: no file name given");
    if (!fb || fb->width <= 0 || fb->height <= 0)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR write '%s': empty framebuffer", path);
    if (opt && (unsigned)opt->compression >= VSD_EXR_COMPRESSION_COUNT)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR write '%s': unknown compression %d", path,
                        (int)opt->compression);
    for (int i = 0; opt && i < opt->attr_count; i++)
        if (!opt->attrs || !opt->attrs[i].name || !*opt->attrs[i].name || !opt->attrs[i].value)
            return vsd_fail(VSD_ERR_INVALID, err, errlen,
                            "EXR write '%s': attribute %d has no name or no value", path, i);
    return VSD_OK;
}

/* The EXR of fb through w (its write_fn), named `name` in OpenEXR's messages. */
static exr_result_t encode_exr(exr_writer *w, exr_write_func_ptr_t write, const char *name,
                               const vsd_framebuffer *fb, const exr_chan *chans, int n, int long_names,
                               const vsd_exr_write_options *opt)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = on_exr_error;
    init.user_data = w;
    init.write_fn = write;
    exr_context_t ctxt = NULL;
    exr_result_t rv = exr_start_write(&ctxt, name, EXR_WRITE_FILE_DIRECTLY, &init);
    if (!rv)
        rv = define_header(ctxt, fb, chans, n, long_names, opt);
    if (!rv)
        rv = vsd_exr_write_chunks(ctxt, fb, chans, n, opt ? opt->threads : 0);
    if (ctxt) {
        exr_result_t fin = exr_finish(&ctxt); /* writes the chunk offset table */
        if (!rv)
            rv = fin;
    }
    return rv;
}

vsd_status vsd_exr_write(const char *path, const vsd_framebuffer *fb,
                         const vsd_exr_write_options *opt, char *err, size_t errlen)
{
    vsd_status s = check_inputs(path, fb, opt, err, errlen);
    exr_chan chans[4 * VSD_PASS_COUNT];
    int n = 0, long_names = 0;
    if (s == VSD_OK)
        s = build_channels(opt, chans, &n, &long_names, err, errlen);
    exr_writer w;
    memset(&w, 0, sizeof w);
    if (s == VSD_OK)
        s = vsd_io_tmp_open(&w.file, path, err, errlen);
    if (s != VSD_OK)
        return s;
    exr_result_t rv = encode_exr(&w, write_fn, w.file.tmp, fb, chans, n, long_names, opt);
    if (rv) {
        vsd_io_tmp_abort(&w.file);
        return exr_failure(rv, &w, path, err, errlen);
    }
    return vsd_io_tmp_commit(&w.file, err, errlen);
}

vsd_status vsd_exr_encode(const vsd_framebuffer *fb, const vsd_exr_write_options *opt, unsigned char **bytes,
                          size_t *len, char *err, size_t errlen)
{
    static const char name[] = "(in memory)";
    vsd_status s = check_inputs(name, fb, opt, err, errlen);
    exr_chan chans[4 * VSD_PASS_COUNT];
    int n = 0, long_names = 0;
    exr_writer w;
    *bytes = NULL;
    *len = 0;
    if (s == VSD_OK)
        s = build_channels(opt, chans, &n, &long_names, err, errlen);
    if (s != VSD_OK)
        return s;
    memset(&w, 0, sizeof w);
    /* room for the uncompressed file at once (pages a smaller ZIP file leaves untouched
     * cost no memory): no copies while it grows */
    w.cap = (size_t)fb->width * (size_t)fb->height * (size_t)n * sizeof(float) + ((size_t)1 << 16) +
            (size_t)fb->height * sizeof(uint64_t);
    if (!(w.bytes = malloc(w.cap))) w.cap = 0;
    exr_result_t rv = encode_exr(&w, memory_write_fn, name, fb, chans, n, long_names, opt);
    if (rv) {
        free(w.bytes);
        return exr_failure(rv, &w, name, err, errlen);
    }
    *bytes = w.bytes;
    *len = w.len;
    return VSD_OK;
}
