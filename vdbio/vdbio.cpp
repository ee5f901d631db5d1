// vdbio.cpp — OpenVDB files into vsd_volume, behind the extern "C" API of vsd/vdbio.h:
// which grid a caller asked for, what a file holds (vsd_vdb_list), and the order in which
// loading runs (vsd_vdb_load), with every failure mapped to a status and a message naming
// the file.
//
// Reading happens in two stages. First a structural scan of the file that checks every
// length, count and offset against the bytes really there: OpenVDB trusts the lengths it
// reads and can allocate or read garbage on a truncated, corrupt or foreign file, so nothing
// reaches OpenVDB until the scan has shown that what it will read is consistent.
// vdb_file_scan.cpp scans the header, the file metadata, the grid descriptors and each grid's
// metadata and transform; vdb_tree_scan.cpp walks the tree of the grid about to be read
// (vdb_scan.h is what they share with this file). Then OpenVDB reads the one grid asked for
// (delayed loading off, so all data is read now, inside our try block), and vdb_load.cpp
// copies its leaves into the brick pool of vsd/volume.h (vdb_load.h).
#include "vsd/vdbio.h"

#include "vdb_load.h"
#include "vdb_scan.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <cfloat>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <new>
#include <string>

namespace {

using openvdb::GridBase;

void init_openvdb()
{
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

vsd_status fail(char *err, size_t errlen, vsd_status st, const std::string &msg)
{
    return vsd_fail(st, err, errlen, "%s", msg.c_str());
}

using vsd_vdbio::copy_cstr;
using vsd_vdbio::FileScan;
using vsd_vdbio::get_meta;
using vsd_vdbio::GridEntry;
using vsd_vdbio::load_grid;
using vsd_vdbio::lookup_name;
using vsd_vdbio::scan_file;
using vsd_vdbio::ScanError;

// ---- names and types ---------------------------------------------------------------------

// "float", "vec3s", "int32"... from the registered grid type; unregistered tree types
// "Tree_<value>_5_4_3" still give their value type.
std::string value_type_of(const std::string &grid_type)
{
    if (GridBase::isRegistered(grid_type))
        return GridBase::createGrid(grid_type)->valueType();
    const std::string pre = "Tree_";
    if (grid_type.compare(0, pre.size(), pre) == 0) {
        const size_t end = grid_type.find('_', pre.size());
        return grid_type.substr(pre.size(), end == std::string::npos ? end : end - pre.size());
    }
    return grid_type;
}

bool is_scalar_real(const std::string &value_type)
{
    return value_type == "float" || value_type == "double" || value_type == "half";
}

std::string grid_listing(const FileScan &scan)
{
    if (scan.grids.empty())
        return "the file has no grids";
    std::string s = "grids present:";
    for (size_t i = 0; i < scan.grids.size(); ++i) {
        s += (i ? ", " : " ") + std::to_string(i) + " '" + scan.grids[i].name + "' (" +
             value_type_of(scan.grids[i].grid_type) + ")";
    }
    return s;
}

// Index into scan.grids for a selection, or a NOT_FOUND ScanError listing what is there.
size_t select_grid(const std::string &path, const FileScan &scan, const vsd_grid_select &sel)
{
    const std::string want = sel.name ? sel.name : "";
    if (sel.index >= 0) {
        if (size_t(sel.index) >= scan.grids.size())
            throw ScanError{VSD_ERR_NOT_FOUND, path + ": no grid at index " +
                                                   std::to_string(sel.index) + " (" +
                                                   grid_listing(scan) + ")"};
        const GridEntry &g = scan.grids[size_t(sel.index)];
        if (!want.empty() && want != g.name && want != lookup_name(g))
            throw ScanError{VSD_ERR_NOT_FOUND, path + ": grid " + std::to_string(sel.index) +
                                                   " is '" + g.name + "', not '" + want + "' (" +
                                                   grid_listing(scan) + ")"};
        return size_t(sel.index);
    }
    for (size_t i = 0; i < scan.grids.size(); ++i) {
        const GridEntry &g = scan.grids[i];
        if (want.empty() ? is_scalar_real(value_type_of(g.grid_type)) : want == g.name)
            return i;
    }
    for (size_t i = 0; !want.empty() && i < scan.grids.size(); ++i)
        if (want == lookup_name(scan.grids[i]))   // "density[1]" form
            return i;
    if (want.empty())
        throw ScanError{VSD_ERR_NOT_FOUND, path + ": no float grid (" + grid_listing(scan) + ")"};
    throw ScanError{VSD_ERR_NOT_FOUND,
                    path + ": no grid named '" + want + "' (" + grid_listing(scan) + ")"};
}

// ---- listing -----------------------------------------------------------------------------

std::string compression_string(uint32_t flags)
{
    if (flags == openvdb::io::COMPRESS_NONE)
        return "none";
    std::string s;
    auto add = [&s](const char *part) { s += (s.empty() ? "" : "+") + std::string(part); };
    if (flags & openvdb::io::COMPRESS_ZIP) add("zip");
    if (flags & openvdb::io::COMPRESS_BLOSC) add("blosc");
    if (flags & openvdb::io::COMPRESS_ACTIVE_MASK) add("active-mask");
    return s.empty() ? "unknown" : s;
}

// Active count and bbox from the statistics OpenVDB writes into each grid's metadata; only
// when a writer left them out is the whole grid read to compute them (its tree checked first).
void grid_stats(const std::string &path, const FileScan &scan, openvdb::io::File &file, const GridEntry &g,
                const GridBase &meta, uint64_t &active, openvdb::CoordBBox &bbox)
{
    openvdb::Vec3i lo, hi;
    int64_t count = 0;
    if (get_meta<openvdb::Vec3IMetadata>(meta, GridBase::META_FILE_BBOX_MIN, lo) &&
        get_meta<openvdb::Vec3IMetadata>(meta, GridBase::META_FILE_BBOX_MAX, hi) &&
        get_meta<openvdb::Int64Metadata>(meta, GridBase::META_FILE_VOXEL_COUNT, count)) {
        active = uint64_t(count);
        bbox = openvdb::CoordBBox(openvdb::Coord(lo), openvdb::Coord(hi));
        return;
    }
    GridBase::Ptr full = vsd_vdbio::read_checked_grid(file, path, scan, g);
    active = full->activeVoxelCount();
    bbox = full->evalActiveVoxelBoundingBox();
}

// World box of the active voxels' cells, index [min - 1/2, max + 1/2]: the box Blender and
// Houdini draw around a grid.
void world_box(const openvdb::math::Transform &xf, const openvdb::CoordBBox &b, vsd_grid_info &info)
{
    for (int a = 0; a < 3; ++a) {
        info.world_bbox_min[a] = DBL_MAX;
        info.world_bbox_max[a] = -DBL_MAX;
    }
    if (b.empty())
        return;
    for (int n = 0; n < 8; ++n) {
        const openvdb::Vec3d p((n & 1 ? b.max().x() + 0.5 : b.min().x() - 0.5),
                               (n & 2 ? b.max().y() + 0.5 : b.min().y() - 0.5),
                               (n & 4 ? b.max().z() + 0.5 : b.min().z() - 0.5));
        const openvdb::Vec3d w = xf.indexToWorld(p);
        for (int a = 0; a < 3; ++a) {
            info.world_bbox_min[a] = std::min(info.world_bbox_min[a], w[a]);
            info.world_bbox_max[a] = std::max(info.world_bbox_max[a], w[a]);
        }
    }
}

void describe_grid(const std::string &path, const FileScan &scan, openvdb::io::File &file, const GridEntry &g,
                   vsd_grid_info &info)
{
    GridBase::Ptr meta = file.readGridMetadata(lookup_name(g));
    copy_cstr(info.name, sizeof info.name, g.name);
    copy_cstr(info.type, sizeof info.type, value_type_of(g.grid_type));
    bool half = false;
    get_meta<openvdb::BoolMetadata>(*meta, GridBase::META_SAVE_HALF_FLOAT, half);
    info.half_float = g.half || half;
    std::string comp;
    if (g.has_compression)
        comp = compression_string(g.compression);
    else if (!get_meta<openvdb::StringMetadata>(*meta, GridBase::META_FILE_COMPRESSION, comp))
        comp = "unknown";
    copy_cstr(info.compression, sizeof info.compression, comp);
    const openvdb::Vec3d vs = meta->transform().voxelSize();
    openvdb::CoordBBox bbox;
    grid_stats(path, scan, file, g, *meta, info.active_voxels, bbox);
    for (int a = 0; a < 3; ++a) {
        info.voxel_size[a] = vs[a];
        info.index_bbox_min[a] = bbox.empty() ? 1 : bbox.min()[a];
        info.index_bbox_max[a] = bbox.empty() ? 0 : bbox.max()[a];
    }
    world_box(meta->transform(), bbox, info);
}

// Map any exception escaping OpenVDB to a status and a message that names the file.
vsd_status map_exception(const std::string &path, char *err, size_t errlen)
{
    try {
        throw;
    } catch (const ScanError &e) {
        return fail(err, errlen, e.status, e.message);
    } catch (const std::bad_alloc &) {
        return fail(err, errlen, VSD_ERR_NOMEM, path + ": out of memory while reading");
    } catch (const openvdb::LookupError &e) {
        // a grid type this OpenVDB build does not know (io::GridDescriptor::read)
        return fail(err, errlen, VSD_ERR_UNSUPPORTED,
                    path + ": cannot read OpenVDB file (" + e.what() + ")");
    } catch (const openvdb::Exception &e) {
        return fail(err, errlen, VSD_ERR_FORMAT,
                    path + ": truncated or corrupt OpenVDB file (" + e.what() + ")");
    } catch (const std::exception &e) {
        return fail(err, errlen, VSD_ERR_FORMAT,
                    path + ": cannot read OpenVDB file (" + e.what() + ")");
    } catch (...) {
        return fail(err, errlen, VSD_ERR_INTERNAL, path + ": unknown error while reading");
    }
}

} // namespace

extern "C" {

vsd_status vsd_vdb_load(const char *path, vsd_grid_select sel, vsd_volume **out, char *err,
                        size_t errlen)
{
    if (out)
        *out = nullptr;
    if (!path || !out)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "vsd_vdb_load: NULL path or out");
    const std::string p = path;
    try {
        init_openvdb();
        const FileScan scan = scan_file(p);
        const GridEntry &g = scan.grids[select_grid(p, scan, sel)];
        const std::string vt = value_type_of(g.grid_type);
        if (!is_scalar_real(vt))
            return fail(err, errlen, VSD_ERR_TYPE,
                        p + ": grid '" + g.name + "' has value type " + vt +
                            "; vsd loads scalar float grids (float, half or double)");
        vsd_volume *vol = load_grid(p, scan, g);
        const vsd_status st = vsd_volume_check_finite(vol, err, errlen);
        if (st != VSD_OK) {
            vsd_volume_destroy(vol);
            return st;
        }
        *out = vol;
        return VSD_OK;
    } catch (...) {
        return map_exception(p, err, errlen);
    }
}

vsd_status vsd_vdb_list(const char *path, vsd_grid_info **grids, int *count, char *err,
                        size_t errlen)
{
    if (grids)
        *grids = nullptr;
    if (count)
        *count = 0;
    if (!path || !grids || !count)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "vsd_vdb_list: NULL path, grids or count");
    const std::string p = path;
    vsd_grid_info *infos = nullptr;
    try {
        init_openvdb();
        const FileScan scan = scan_file(p);
        infos = static_cast<vsd_grid_info *>(std::calloc(std::max<size_t>(1, scan.grids.size()),
                                                         sizeof(vsd_grid_info)));
        if (!infos)
            throw std::bad_alloc();
        if (!scan.grids.empty()) {
            openvdb::io::File file(p);
            file.open(false);
            for (size_t i = 0; i < scan.grids.size(); ++i)
                describe_grid(p, scan, file, scan.grids[i], infos[i]);
            file.close();
        }
        *grids = infos;
        *count = int(scan.grids.size());
        return VSD_OK;
    } catch (...) {
        std::free(infos);
        return map_exception(p, err, errlen);
    }
}

void vsd_vdb_list_free(vsd_grid_info *grids)
{
    std::free(grids);
}

vsd_status vsd_vdb_select_info(const char *path, vsd_grid_select sel, vsd_grid_info *out, char *err, size_t errlen)
{
    if (!path || !out)
        return vsd_fail(VSD_ERR_INVALID, err, errlen, "vsd_vdb_select_info: NULL path or out");
    const std::string p = path;
    std::memset(out, 0, sizeof *out);
    try {
        init_openvdb();
        const FileScan scan = scan_file(p);
        const GridEntry &g = scan.grids[select_grid(p, scan, sel)];
        openvdb::io::File file(p);
        file.open(false);
        describe_grid(p, scan, file, g, *out);
        file.close();
        return VSD_OK;
    } catch (...) {
        return map_exception(p, err, errlen);
    }
}

} // extern "C"
