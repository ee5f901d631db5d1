// EXR reading through OpenEXR's C++ API (Imf::InputFile), behind the C functions of
// vsd/image.h. C++ because Debian's OpenEXR 3.1 C API cannot decode DWAA/DWAB, the
// compression of Blender's bundled HDRIs. This is the module's only EXR reader: environment
// maps (core/src/env) come through vsd_exr_read too. No exception leaves this file.
#include "src/image/imageio_internal.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>

namespace {

// The most pixels an EXR may have: vsd's own largest image is 16384 x 16384 (the daemon's
// --max-size); a larger data window is taken as corrupt.
constexpr int64_t VSD_EXR_MAX_PIXELS = int64_t(1) << 28;

// A data window's sides each reach 2^32 from int32 corners, so their product can overflow
// int64 (found by tests/fuzz/fuzz_env): the area is bounded by a division, not a product.
static bool window_fits(int64_t w, int64_t h)
{
    return w > 0 && h > 0 && w <= VSD_EXR_MAX_PIXELS && h <= VSD_EXR_MAX_PIXELS / w;
}

// OpenEXR allocates each header attribute at the size its length field states before
// reading it, so a corrupt length in a 1 KB file asked for 1.9 GB (found by
// tests/fuzz/fuzz_env). Walk the header(s) first: after the magic and version, attributes
// "name\0type\0" + int32 size + value, an empty name ending a header; multi-part files
// (version bit 12) hold several headers and end with an empty one. Every size must fit in
// what is left of the file.
vsd_status check_exr_headers(const char *path, char *err, size_t errlen)
{
    std::FILE *f = std::fopen(path, "rb");
    if (!f)
        return vsd_fail(VSD_ERR_IO, err, errlen, "cannot open '%s'", path);
    long size = -1;
    unsigned char version[4] = {0, 0, 0, 0};
    if (std::fseek(f, 0, SEEK_END) == 0)
        size = std::ftell(f);
    bool ok = size >= 8 && std::fseek(f, 4, SEEK_SET) == 0 && std::fread(version, 1, 4, f) == 4;
    const bool multipart = (version[1] & 0x10) != 0;
    char name[256] = "", type[256] = "";
    for (int header = 0; ok; header++) {
        int attrs = 0;
        for (;; attrs++) {
            int n = 0, c = 0;
            for (int part = 0; part < 2 && ok; part++) {   // name, then type
                char *dst = part == 0 ? name : type;
                n = 0;
                while ((c = std::fgetc(f)) > 0 && n < 255)
                    dst[n++] = char(c);
                dst[n] = '\0';
                ok = c == 0 && !(part == 1 && n == 0);
                if (part == 0 && ok && n == 0)
                    break;
            }
            if (!ok || n == 0)
                break;   // an error, or the empty name that ends this header
            unsigned char b[4] = {0, 0, 0, 0};
            ok = std::fread(b, 1, 4, f) == 4;
            const int32_t len = int32_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 |
                                        uint32_t(b[3]) << 24);
            const long at = ok ? std::ftell(f) : -1;
            ok = ok && len >= 0 && at >= 0 && len <= size - at;
            if (ok && len == 16 && std::strcmp(name, "dataWindow") == 0 && std::strcmp(type, "box2i") == 0) {
                // OpenEXR sizes its line-offset table from this before any check of ours:
                // the same bound as read_all's, applied before OpenEXR sees the file
                unsigned char v[16];
                int32_t box[4];
                ok = std::fread(v, 1, 16, f) == 16;
                for (int k = 0; ok && k < 4; k++)
                    box[k] = int32_t(uint32_t(v[4 * k]) | uint32_t(v[4 * k + 1]) << 8 |
                                     uint32_t(v[4 * k + 2]) << 16 | uint32_t(v[4 * k + 3]) << 24);
                const int64_t w = ok ? int64_t(box[2]) - box[0] + 1 : 0, h = ok ? int64_t(box[3]) - box[1] + 1 : 0;
                ok = ok && window_fits(w, h);
            } else {
                ok = ok && std::fseek(f, len, SEEK_CUR) == 0;
            }
        }
        // single-part: one header; multi-part: until an empty header
        if (!ok || !multipart || (header > 0 && attrs == 0))
            break;
    }
    std::fclose(f);
    if (!ok)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                        "EXR '%s' is truncated or corrupt: its header runs past the end of the file "
                        "(at attribute '%.64s')",
                        path, name);
    return VSD_OK;
}

// Distinguish "missing/unreadable" (VSD_ERR_IO) and "not an EXR" (VSD_ERR_FORMAT) before
// OpenEXR sees the file: its exceptions do not say which of the two happened.
vsd_status check_exr_file(const char *path, char *err, size_t errlen)
{
    unsigned char head[4];
    size_t got = 0;
    vsd_status s = vsd_io_read_head(path, head, sizeof head, &got, err, errlen);
    if (s != VSD_OK)
        return s;
    if (got < 4 || std::memcmp(head, VSD_EXR_MAGIC, 4) != 0)
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "'%s' is not an OpenEXR file", path);
    return check_exr_headers(path, err, errlen);
}

vsd_exr_image *alloc_image(int w, int h, int count)
{
    auto *img = static_cast<vsd_exr_image *>(std::calloc(1, sizeof(vsd_exr_image)));
    if (!img)
        return nullptr;
    img->width = w;
    img->height = h;
    img->channel_count = count;
    img->channel_names = static_cast<char **>(std::calloc((size_t)count + 1, sizeof(char *)));
    img->channels = static_cast<float **>(std::calloc((size_t)count + 1, sizeof(float *)));
    if (!img->channel_names || !img->channels) {
        vsd_exr_image_destroy(img);
        return nullptr;
    }
    return img;
}

// Allocate the planes and describe them to OpenEXR as float slices; OpenEXR converts half
// and uint channels to float while reading. Slice::Make maps the data window's origin to
// the start of each plane, so row 0 of a plane is the top row of the data window.
vsd_status bind_planes(const Imf::Header &hdr, vsd_exr_image *img, Imf::FrameBuffer &fb,
                       const char *path, char *err, size_t errlen)
{
    const Imath::Box2i dw = hdr.dataWindow();
    size_t npix = (size_t)img->width * (size_t)img->height;
    int i = 0;
    for (auto it = hdr.channels().begin(); it != hdr.channels().end(); ++it, ++i) {
        if (it.channel().xSampling != 1 || it.channel().ySampling != 1)
            return vsd_fail(VSD_ERR_UNSUPPORTED, err, errlen,
                            "'%s': channel '%s' is subsampled, which vsd does not read", path,
                            it.name());
        img->channel_names[i] = strdup(it.name());
        img->channels[i] = static_cast<float *>(std::calloc(npix ? npix : 1, sizeof(float)));
        if (!img->channel_names[i] || !img->channels[i])
            return vsd_fail(VSD_ERR_NOMEM, err, errlen, "'%s': out of memory", path);
        fb.insert(it.name(), Imf::Slice::Make(Imf::FLOAT, img->channels[i], dw, sizeof(float),
                                              sizeof(float) * (size_t)img->width));
    }
    return VSD_OK;
}

vsd_status read_all(const char *path, vsd_exr_image **out, char *err, size_t errlen)
{
    Imf::InputFile file(path);
    const Imf::Header &hdr = file.header();
    const Imath::Box2i dw = hdr.dataWindow();
    int count = 0;
    for (auto it = hdr.channels().begin(); it != hdr.channels().end(); ++it)
        count++;
    // The planes are sized from the header's data window: a corrupt window in a 1 KB file
    // asked for 18 GB (found by tests/fuzz/fuzz_env), and its width can overflow an int.
    const int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
    if (!window_fits(w, h))
        return vsd_fail(VSD_ERR_FORMAT, err, errlen,
                        "EXR '%s' is corrupt: data window of %lld x %lld pixels", path, (long long)w,
                        (long long)h);
    vsd_exr_image *img = alloc_image(int(w), int(h), count);
    if (!img)
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "'%s': out of memory", path);
    Imf::FrameBuffer fb;
    vsd_status s = bind_planes(hdr, img, fb, path, err, errlen);
    if (s == VSD_OK) {
        try {
            file.setFrameBuffer(fb);
            file.readPixels(dw.min.y, dw.max.y);
        } catch (...) {
            vsd_exr_image_destroy(img);
            throw;
        }
        *out = img;
    } else {
        vsd_exr_image_destroy(img);
    }
    return s;
}

} // namespace

extern "C" vsd_status vsd_exr_read(const char *path, vsd_exr_image **out, char *err,
                                   size_t errlen)
{
    if (!out)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR read: no output pointer");
    *out = nullptr;
    vsd_status s = check_exr_file(path, err, errlen);
    if (s != VSD_OK)
        return s;
    try {
        return read_all(path, out, err, errlen);
    } catch (const std::bad_alloc &) {
        return vsd_fail(VSD_ERR_NOMEM, err, errlen, "'%s': out of memory", path);
    } catch (const std::exception &e) {
        // A file that starts like an EXR but fails to decode is truncated or corrupt.
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "EXR '%s' is truncated or corrupt: %s", path,
                        e.what());
    } catch (...) {
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "cannot read EXR '%s'", path);
    }
}

namespace {

vsd_status read_attr(const char *path, const char *attr, char *value, size_t len, char *err,
                     size_t errlen)
{
    Imf::InputFile file(path);
    const Imf::Header &hdr = file.header();
    Imf::Header::ConstIterator it = hdr.find(attr);
    if (it == hdr.end())
        return vsd_fail(VSD_ERR_NOT_FOUND, err, errlen, "'%s' has no attribute '%s'", path, attr);
    auto *sa = dynamic_cast<const Imf::StringAttribute *>(&it.attribute());
    if (!sa)
        return vsd_fail(VSD_ERR_TYPE, err, errlen, "'%s': attribute '%s' is a %s, not a string",
                        path, attr, it.attribute().typeName());
    const std::string &v = sa->value();
    if (v.size() >= len)
        return vsd_fail(VSD_ERR_INVALID, err, errlen,
                        "'%s': attribute '%s' (%zu bytes) does not fit a %zu-byte buffer", path,
                        attr, v.size(), len);
    std::memcpy(value, v.c_str(), v.size() + 1);
    return VSD_OK;
}

} // namespace

extern "C" vsd_status vsd_exr_read_attr(const char *path, const char *attr, char *value,
                                        size_t len, char *err, size_t errlen)
{
    if (!attr || !value || len == 0)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "EXR attribute read: bad arguments");
    value[0] = '\0';
    vsd_status s = check_exr_file(path, err, errlen);
    if (s != VSD_OK)
        return s;
    try {
        return read_attr(path, attr, value, len, err, errlen);
    } catch (const std::exception &e) {
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "cannot read EXR '%s': %s", path, e.what());
    } catch (...) {
        return vsd_fail(VSD_ERR_FORMAT, err, errlen, "cannot read EXR '%s'", path);
    }
}
