// vdb_load.h — what vdbio.cpp and vdb_load.cpp share (internal to vdbio/): the loader that
// turns one scanned, selected grid into a vsd_volume, and two small helpers that both the
// loader and the listing in vdbio.cpp use to fill fixed C strings and read grid metadata.
#ifndef VSD_VDBIO_VDB_LOAD_H
#define VSD_VDBIO_VDB_LOAD_H

#include "vdb_scan.h"
#include "vsd/volume.h"

#include <openvdb/Grid.h>
#include <openvdb/io/File.h>

#include <cstddef>
#include <cstdio>
#include <string>

namespace vsd_vdbio {

inline void copy_cstr(char *dst, size_t cap, const std::string &s)
{
    std::snprintf(dst, cap, "%s", s.c_str());
}

template <typename MetaT, typename ValueT>
bool get_meta(const openvdb::GridBase &grid, const char *key, ValueT &out)
{
    auto m = grid.getMetadata<MetaT>(key);
    if (!m)
        return false;
    out = m->value();
    return true;
}

// The one way vdbio reads a grid's tree through OpenVDB: first the walk of that tree
// (scan_grid_tree), since OpenVDB trusts the sizes inside it, then io::File::readGrid. `scan`
// is the file's structural scan (scan_file). Implemented in vdb_load.cpp.
openvdb::GridBase::Ptr read_checked_grid(openvdb::io::File &file, const std::string &path, const FileScan &scan,
                                         const GridEntry &g);

// Read grid `g` (read_checked_grid) and convert it. Throws ScanError or OpenVDB/std
// exceptions. Implemented in vdb_load.cpp.
vsd_volume *load_grid(const std::string &path, const FileScan &scan, const GridEntry &g);

} // namespace vsd_vdbio

#endif
