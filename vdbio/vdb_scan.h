// vdb_scan.h — what the two halves of vdbio's structural scan share (internal to vdbio/),
// and what vdbio.cpp and vdb_load.cpp use of it: vdb_file_scan.cpp scans a file's header,
// metadata and grid descriptors; vdb_tree_scan.cpp walks the tree of the one grid OpenVDB is
// about to read. Both check every length they meet against the bytes really there, so that
// OpenVDB, which trusts them, never sees one that is not.
#ifndef VSD_VDBIO_VDB_SCAN_H
#define VSD_VDBIO_VDB_SCAN_H

#include "vsd/status.h"

#include <cstdint>
#include <string>
#include <vector>

namespace vsd_vdbio {

// A refusal: the status and the message (naming the file) that the C API returns.
struct ScanError {
    vsd_status status;
    std::string message;
};

// "<path>: truncated or corrupt OpenVDB file (<what> runs past the end of the N-byte file)"
std::string truncated(const std::string &path, const std::string &what, int64_t size);
// "<path>: truncated or corrupt OpenVDB file (<what>)"
std::string corrupt(const std::string &path, const std::string &what);

// Bounds-checked little-endian reader over a file descriptor, through a small window so that
// the many short reads and skips of a tree walk cost a memcpy, not a system call. Every read
// and seek is checked against the file size: false means "not there".
class ByteReader {
public:
    ByteReader(int fd, int64_t size);
    int64_t pos() const { return pos_; }
    int64_t size() const { return size_; }
    int64_t left() const { return size_ - pos_; }
    bool read(void *dst, int64_t n);
    bool seek(int64_t p);
    bool skip(int64_t n) { return n >= 0 && n <= left() && seek(pos_ + n); }
    // io::readString: a uint32 length, then that many bytes.
    bool read_string(std::string &s);

private:
    bool fill(int64_t at);   // load the window starting at `at`

    int fd_;
    int64_t size_;
    int64_t pos_ = 0;
    std::vector<char> window_;
    int64_t window_pos_ = 0, window_len_ = 0;
};

// One grid as its descriptor describes it, in file order.
struct GridEntry {
    std::string unique;          // unique name: name, or name + "\x1e" + n for duplicates
    std::string name;            // the grid's name
    std::string grid_type;       // e.g. "Tree_float_5_4_3" (half-float suffix removed)
    std::string parent;          // unique name of the grid whose tree an instance shares
    bool half = false;           // the type name has the "_HalfFloat" suffix
    bool instance = false;       // shares another grid's tree
    int64_t grid_pos = 0, block_pos = 0, end_pos = 0;
    bool has_compression = false;
    uint32_t compression = 0;    // per-grid io::COMPRESS_* flags (file version >= 222)
    // Where the topology starts (after the compression flags, metadata and transform), and
    // whether OpenVDB will read the tree as 16-bit halves: Grid::readTopology/readBuffers
    // pass GridBase::saveFloatAsHalf(), which is the "is_saved_as_half_float" metadata entry
    // as read from the file (MetaMap::readMeta replaces what the type-name suffix set).
    int64_t topo_pos = -1;
    bool half_meta = false;
};

struct FileScan {
    uint32_t version = 0;
    int64_t size = 0;
    bool file_zip = false;       // the file-wide "compressed" flag of versions 220 and 221
    std::vector<GridEntry> grids;
};

// The descriptor io::File::findDescriptor picks for `name` ("name" or "name[N]"): what
// io::File::readGrid(name) will read. nullptr when there is none.
const GridEntry *find_descriptor(const FileScan &scan, const std::string &name);

// The name io::File looks a grid up by: "name[n]" picks exactly this descriptor even when
// several grids share the name (io::File::findDescriptor).
std::string lookup_name(const GridEntry &g);

// Stat + scan of header, file metadata, grid descriptors and each grid's metadata and
// transform. Throws ScanError; returns a complete, offset-checked FileScan. Implemented, with
// everything above, in vdb_file_scan.cpp.
FileScan scan_file(const std::string &path);

// Walk the tree that io::File::readGrid(read_name) is about to read (the grid's own, or for an
// instance its parent's) and check every count, mask-dependent length and compressed-chunk
// size in it against the bytes of that grid; throws ScanError when anything is inconsistent.
// Returns without a walk when OpenVDB will read no tree (no such grid, an unregistered type:
// OpenVDB itself refuses those before reading). Implemented in vdb_tree_scan.cpp.
void scan_grid_tree(const std::string &path, const FileScan &scan, const std::string &read_name);

} // namespace vsd_vdbio

#endif
