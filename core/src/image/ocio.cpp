// OpenColorIO shim: the two transforms vsd needs (scene_linear -> display/view for the
// preview PNG, a named colour space -> scene_linear for environment maps) behind the C
// functions of imageio_internal.h. The caller chooses the config (ocio_config.c), so both
// uses agree on it. No exception leaves this file.
#include "src/image/imageio_internal.h"

#include <OpenColorIO/OpenColorIO.h>

#include <cstdio>
#include <exception>
#include <sstream>
#include <string>

namespace OCIO = OCIO_NAMESPACE;

namespace {

// "a, b, c" of up to `max` names, then ", ..." — enough to show the user what exists.
template <typename Count, typename Name>
std::string name_list(Count count, Name name, int max)
{
    std::string s;
    int n = count();
    for (int i = 0; i < n && i < max; i++)
        s += (i ? ", " : "") + std::string(name(i));
    if (n > max)
        s += ", ...";
    return s;
}

const char *config_name(const char *config_path)
{
    return config_path ? config_path : "(vsd's built-in linear spaces)";
}

void copy_name(char *dst, size_t len, const char *src)
{
    if (dst && len)
        std::snprintf(dst, len, "%s", src);
}

vsd_status display_view(const char *config_path, float *rgba, int w, int h, const char *display,
                        const char *view, char *used_display, size_t udlen, char *used_view,
                        size_t uvlen, char *err, size_t errlen)
{
    OCIO::ConstConfigRcPtr config = OCIO::Config::CreateFromFile(config_path);
    std::string d = display && *display ? display : config->getDefaultDisplay();
    int nd = config->getNumDisplays();
    bool known = false;
    for (int i = 0; i < nd && !known; i++)
        known = d == config->getDisplay(i);
    if (!known)
        return vsd_fail(VSD_ERR_NOT_FOUND, err, errlen,
                        "display '%s' is not in OpenColorIO config %s; displays: %s", d.c_str(),
                        config_path,
                        name_list([&] { return nd; }, [&](int i) { return config->getDisplay(i); }, 20)
                            .c_str());
    std::string v = view && *view ? view : config->getDefaultView(d.c_str());
    int nv = config->getNumViews(d.c_str());
    known = false;
    for (int i = 0; i < nv && !known; i++)
        known = v == config->getView(d.c_str(), i);
    if (!known)
        return vsd_fail(VSD_ERR_NOT_FOUND, err, errlen,
                        "view '%s' is not a view of display '%s' in OpenColorIO config %s; "
                        "views: %s",
                        v.c_str(), d.c_str(), config_path,
                        name_list([&] { return nv; },
                                  [&](int i) { return config->getView(d.c_str(), i); }, 20)
                            .c_str());

    OCIO::DisplayViewTransformRcPtr t = OCIO::DisplayViewTransform::Create();
    t->setSrc(OCIO::ROLE_SCENE_LINEAR);
    t->setDisplay(d.c_str());
    t->setView(v.c_str());
    OCIO::ConstCPUProcessorRcPtr cpu = config->getProcessor(t)->getDefaultCPUProcessor();
    OCIO::PackedImageDesc img(rgba, w, h, 4);
    cpu->apply(img);
    copy_name(used_display, udlen, d.c_str());
    copy_name(used_view, uvlen, v.c_str());
    return VSD_OK;
}

// NULL = vsd's built-in config (ocio_builtin_config.cpp), else the file.
OCIO::ConstConfigRcPtr open_config(const char *config_path)
{
    if (config_path)
        return OCIO::Config::CreateFromFile(config_path);
    std::istringstream text(vsd_ocio_builtin_config);
    return OCIO::Config::CreateFromStream(text);
}

vsd_status convert(const char *config_path, const char *from, const char *to, float *rgb, size_t n,
                   char *err, size_t errlen)
{
    OCIO::ConstConfigRcPtr config = open_config(config_path);
    const char *names[2] = {from, to && *to ? to : OCIO::ROLE_SCENE_LINEAR};
    // getColorSpace also resolves role names ("scene_linear", "default_byte", ...) and aliases.
    for (const char *name : names)
        if (!config->getColorSpace(name))
            return vsd_fail(VSD_ERR_NOT_FOUND, err, errlen,
                            "colour space '%s' is not in OpenColorIO config %s; some valid names: %s",
                            name, config_name(config_path),
                            name_list([&] { return config->getNumColorSpaces(); },
                                      [&](int i) { return config->getColorSpaceNameByIndex(i); }, 12)
                                .c_str());
    OCIO::ConstCPUProcessorRcPtr cpu =
        config->getProcessor(names[0], names[1])->getDefaultCPUProcessor();
    OCIO::PackedImageDesc img(rgb, (long)n, 1, 3);
    cpu->apply(img);
    return VSD_OK;
}

// OCIO reports a bad config, a missing LUT file, etc. by exception; all of it is the config's
// fault, not the image's, so it is VSD_ERR_FORMAT naming the config.
vsd_status ocio_failure(const char *config_path, const char *what, char *err, size_t errlen)
{
    return vsd_fail(VSD_ERR_FORMAT, err, errlen, "OpenColorIO config %s: %s", config_name(config_path), what);
}

} // namespace

extern "C" vsd_status vsd_ocio_display_view(const char *config_path, float *rgba, int w, int h,
                                            const char *display, const char *view,
                                            char *used_display, size_t udlen, char *used_view,
                                            size_t uvlen, char *err, size_t errlen)
{
    try {
        return display_view(config_path, rgba, w, h, display, view, used_display, udlen,
                            used_view, uvlen, err, errlen);
    } catch (const std::exception &e) {
        return ocio_failure(config_path, e.what(), err, errlen);
    } catch (...) {
        return ocio_failure(config_path, "unknown error", err, errlen);
    }
}

extern "C" vsd_status vsd_ocio_convert(const char *config_path, const char *from, const char *to,
                                       float *rgb, size_t n, char *err, size_t errlen)
{
    try {
        return convert(config_path, from, to, rgb, n, err, errlen);
    } catch (const std::exception &e) {
        return ocio_failure(config_path, e.what(), err, errlen);
    } catch (...) {
        return ocio_failure(config_path, "unknown error", err, errlen);
    }
}
