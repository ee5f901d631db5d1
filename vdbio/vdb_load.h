// vdb_load.h — what vdbio.cpp and vdb_load.cpp share (internal to vdbio/): the loader that
// turns one scanned, selected grid into a vsd_volume, and two small helpers that both the
// loader and the listing in vdbio.cpp use to fill fixed C strings and read grid metadata.
#ifndef VSD_VDBIO_VDB_LOAD_H
#define VSD_VDBIO_VDB_LOAD_H

#include "vdb_scan.h"
#include "vsd/volume.h"

#include <openvdb/Grid.h>

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

// Read grid `g` through OpenVDB and convert it. Throws ScanError or OpenVDB/std exceptions.
// The caller has scanned the file (scan_file) and the grid's tree (scan_grid_tree) first.
// Implemented in vdb_load.cpp.
vsd_volume *load_grid(const std::string &path, const GridEntry &g);

} // namespace vsd_vdbio

#endif
