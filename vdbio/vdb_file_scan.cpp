// vdb_file_scan.cpp — the structural scan of an OpenVDB file, up to the trees.
//
// OpenVDB trusts the lengths it reads and can allocate or read garbage on a truncated,
// corrupt or foreign file, so nothing reaches OpenVDB until a scan has shown that what it
// will read is consistent. This file scans the header, the file metadata, the grid
// descriptors and each grid's metadata and transform, checking every length, count and
// offset against the bytes really there, and records what the rest of vdbio needs (FileScan).
// It also holds what vdb_scan.h declares for both halves of the scan: the error strings, the
// bounds-checked ByteReader, and the descriptor lookup that mirrors io::File's.
// vdb_tree_scan.cpp walks the tree of the one grid about to be read; vdbio.cpp selects,
// lists and loads (vdb_load.cpp) only what this scan has accepted.
#include "vdb_scan.h"

#include <openvdb/io/DelayedLoadMetadata.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/math/Maps.h>
#include <openvdb/openvdb.h>
#include <openvdb/points/StreamCompression.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace vsd_vdbio {

// ---- what vdb_scan.h declares ---------------------------------------------------------------

std::string truncated(const std::string &path, const std::string &what, int64_t size)
{
    return path + ": truncated or corrupt OpenVDB file (" + what + " runs past the end of the " +
           std::to_string(size) + "-byte file)";
}

std::string corrupt(const std::string &path, const std::string &what)
{
    return path + ": truncated or corrupt OpenVDB file (" + what + ")";
}

ByteReader::ByteReader(int fd, int64_t size) : fd_(fd), size_(size), window_(size_t(64) << 10) {}

bool ByteReader::fill(int64_t at)
{
    window_pos_ = at;
    window_len_ = 0;
    const int64_t want = std::min<int64_t>(int64_t(window_.size()), size_ - at);
    while (window_len_ < want) {
        const ssize_t got = pread(fd_, window_.data() + window_len_, size_t(want - window_len_),
                                  off_t(at + window_len_));
        if (got < 0 && errno == EINTR)
            continue;
        if (got <= 0)
            return false;
        window_len_ += got;
    }
    return true;
}

bool ByteReader::read(void *dst, int64_t n)
{
    if (n < 0 || n > left())
        return false;
    char *out = static_cast<char *>(dst);
    while (n > 0) {
        if (pos_ < window_pos_ || pos_ >= window_pos_ + window_len_) {
            if (!fill(pos_) || window_len_ == 0)
                return false;
        }
        const int64_t k = std::min(n, window_pos_ + window_len_ - pos_);
        std::memcpy(out, window_.data() + (pos_ - window_pos_), size_t(k));
        out += k;
        pos_ += k;
        n -= k;
    }
    return true;
}

bool ByteReader::seek(int64_t p)
{
    if (p < 0 || p > size_)
        return false;
    pos_ = p;
    return true;
}

bool ByteReader::read_string(std::string &s)
{
    uint32_t n = 0;
    if (!read(&n, sizeof n) || int64_t(n) > left())
        return false;
    s.assign(size_t(n), '\0');
    return read(&s[0], int64_t(n));
}

// io::File::findDescriptor: descriptors live in a multimap keyed by grid name (file order
// within a key); "name[N]" picks the one whose unique name matches, a plain name the first.
const GridEntry *find_descriptor(const FileScan &scan, const std::string &name)
{
    using openvdb::io::GridDescriptor;
    const std::string unique = GridDescriptor::stringAsUniqueName(name);
    auto matching = [&scan](const std::string &key) {
        std::vector<const GridEntry *> r;
        for (const GridEntry &g : scan.grids)
            if (g.name == key)
                r.push_back(&g);
        return r;
    };
    std::vector<const GridEntry *> range = matching(name);
    if (range.empty())
        range = matching(GridDescriptor::stripSuffix(unique));
    if (range.empty())
        return nullptr;
    if (name == unique)
        return range.front();
    for (const GridEntry *g : range)
        if (g->unique == unique || g->unique == name)
            return g;
    return nullptr;
}

// The name io::File looks a grid up by: "name[n]" picks exactly this descriptor even when
// several grids share the name (io::File::findDescriptor).
std::string lookup_name(const GridEntry &g)
{
    return openvdb::io::GridDescriptor::nameAsString(g.unique);
}

// ---- structural scan ----------------------------------------------------------------------

namespace {

// Header fields up to and including the UUID (io::Archive::readHeader, format >= 220).
void scan_header(const std::string &path, ByteReader &in, FileScan &out)
{
    int64_t magic = 0;
    if (in.size() < int64_t(sizeof magic)) {
        const int32_t m = openvdb::OPENVDB_MAGIC;
        char head[8] = {0};
        const int64_t n = in.size();
        in.read(head, n);
        if (n > 0 && std::memcmp(head, &m, size_t(std::min<int64_t>(n, 4))) == 0)
            throw ScanError{VSD_ERR_FORMAT, truncated(path, "the header", in.size())};
        throw ScanError{VSD_ERR_FORMAT, path + ": not an OpenVDB file (only " +
                                            std::to_string(n) + " bytes)"};
    }
    in.read(&magic, sizeof magic);
    if (magic != int64_t(openvdb::OPENVDB_MAGIC))
        throw ScanError{VSD_ERR_FORMAT, path + ": not an OpenVDB file (no VDB magic number)"};
    uint32_t lib[2] = {0, 0};
    char offsets = 0;
    if (!in.read(&out.version, sizeof out.version))
        throw ScanError{VSD_ERR_FORMAT, truncated(path, "the header", in.size())};
    if (out.version < openvdb::OPENVDB_FILE_VERSION_SELECTIVE_COMPRESSION)
        throw ScanError{VSD_ERR_UNSUPPORTED,
                        path + ": OpenVDB file format version " + std::to_string(out.version) +
                            " is older than the supported 220 (OpenVDB 2.0); re-save it"};
    if (out.version > openvdb::OPENVDB_FILE_VERSION)
        throw ScanError{VSD_ERR_UNSUPPORTED,
                        path + ": OpenVDB file format version " + std::to_string(out.version) +
                            " is newer than this OpenVDB " OPENVDB_LIBRARY_VERSION_STRING
                            " reads (" + std::to_string(openvdb::OPENVDB_FILE_VERSION) + ")"};
    bool ok = in.read(lib, sizeof lib) && in.read(&offsets, 1);
    if (ok && out.version < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) {
        // file-wide "is compressed" flag (zlib or nothing), per grid from 222 on
        char zip = 0;
        ok = in.read(&zip, 1);
        out.file_zip = zip != 0;
    }
    ok = ok && in.skip(36);   // UUID as 36 ASCII characters
    if (!ok)
        throw ScanError{VSD_ERR_FORMAT, truncated(path, "the header", in.size())};
    if (!offsets)
        throw ScanError{VSD_ERR_UNSUPPORTED,
                        path + ": OpenVDB file written as a non-seekable stream (no grid "
                               "offsets); re-save it as a file"};
}

// A Blosc buffer inside a "__delayedload" entry: OpenVDB allocates `bytes` for it, then (in
// points' bloscDecompress) room for the uncompressed size its header states, and Blosc takes
// the header's compressed size as the size of its input.
void scan_delayed_blosc(const std::string &path, ByteReader &in, const std::string &what, int64_t end,
                        uint32_t bytes, uint64_t expected)
{
    unsigned char h[16];
    if (bytes < sizeof h || int64_t(bytes) > end - in.pos() || !in.read(h, sizeof h))
        throw ScanError{VSD_ERR_FORMAT, corrupt(path, what + " holds a Blosc buffer of " + std::to_string(bytes) +
                                                          " bytes that does not fit in it")};
    const uint32_t nbytes = uint32_t(h[4]) | uint32_t(h[5]) << 8 | uint32_t(h[6]) << 16 | uint32_t(h[7]) << 24;
    const uint32_t cbytes = uint32_t(h[12]) | uint32_t(h[13]) << 8 | uint32_t(h[14]) << 16 | uint32_t(h[15]) << 24;
    // what OpenVDB accepts: the expected size, or the 128 bytes small arrays are padded to
    const uint64_t pad = uint64_t(openvdb::compression::BLOSC_PAD_BYTES);
    if (cbytes != bytes || !(nbytes == expected || (nbytes == pad && expected <= pad)))
        throw ScanError{VSD_ERR_FORMAT, corrupt(path, what + " holds a Blosc buffer whose header says " +
                                                          std::to_string(nbytes) + " bytes in " +
                                                          std::to_string(cbytes) + ", not " +
                                                          std::to_string(expected) + " in " + std::to_string(bytes))};
    in.skip(int64_t(bytes) - int64_t(sizeof h));
}

// io::DelayedLoadMetadata::readValue (every grid OpenVDB 6+ writes has one, "file_delayed_load"):
// a leaf count, then a per-leaf mask array and a per-leaf size array, each raw or as a Blosc
// buffer; OpenVDB sizes the arrays from the count and reads past the entry's byte count if
// the parts need more. Checked: the parts fit the entry, the count fits the file (a leaf
// takes at least its 64-byte value mask), the Blosc buffers are what their headers say.
void scan_delayed_load(const std::string &path, ByteReader &in, const std::string &what, uint32_t bytes)
{
    if (bytes == 0)
        return;   // OpenVDB reads nothing then
    const int64_t end = in.pos() + int64_t(bytes);
    auto bad = [&](const std::string &why) {
        return ScanError{VSD_ERR_FORMAT, corrupt(path, what + " " + why)};
    };
    uint32_t head[2] = {0, 0};   // leaf count, mask buffer bytes
    if (int64_t(bytes) < 12 || !in.read(head, 8))
        throw bad("is shorter than its header");
    const uint64_t count = head[0];
    if (count > uint64_t(in.size() / 64))
        throw bad("claims " + std::to_string(count) + " leaves, more than the file can hold");
    using openvdb::io::DelayedLoadMetadata;
    const uint64_t mask_bytes = count * sizeof(DelayedLoadMetadata::MaskType);
    const uint64_t size_bytes = count * sizeof(DelayedLoadMetadata::CompressedSizeType);
    if (head[1] > 0)
        scan_delayed_blosc(path, in, what, end, head[1], mask_bytes);
    else if (int64_t(mask_bytes) > end - in.pos() || !in.skip(int64_t(mask_bytes)))
        throw bad("has a mask of " + std::to_string(mask_bytes) + " bytes that does not fit in it");
    uint32_t sizes = 0;
    if (end - in.pos() < 4 || !in.read(&sizes, 4))
        throw bad("ends before its size table");
    if (sizes != std::numeric_limits<uint32_t>::max()) {
        if (sizes > 0)
            scan_delayed_blosc(path, in, what, end, sizes, size_bytes);
        else if (int64_t(size_bytes) > end - in.pos() || !in.skip(int64_t(size_bytes)))
            throw bad("has a size table of " + std::to_string(size_bytes) + " bytes that does not fit in it");
    }
    in.seek(end);
}

// io::MetaMap::readMeta: count, then (name, type name, byte count, value) per entry. OpenVDB
// reads the value of a registered fixed-size type as sizeof(T) bytes, whatever the byte count
// says: a count that differs would move OpenVDB's reading position away from the one this
// scan checks, so such an entry is corrupt (valid files always agree). A "bool" must be 0 or
// 1 (C++ reads it back as a bool), and "__delayedload" entries are walked (above). When
// `half` is given, it receives GridBase::saveFloatAsHalf() as OpenVDB will compute it.
void scan_metadata(const std::string &path, ByteReader &in, const std::string &what, bool *half = nullptr)
{
    using openvdb::Metadata;
    uint32_t count = 0;
    if (!in.read(&count, sizeof count) || int64_t(count) * 12 > in.left())
        throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
    for (uint32_t i = 0; i < count; ++i) {
        std::string name, type;
        uint32_t bytes = 0;
        if (!in.read_string(name) || !in.read_string(type) || !in.read(&bytes, sizeof bytes) ||
            int64_t(bytes) > in.left())
            throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
        const int64_t value_pos = in.pos();
        const std::string entry = what + ": entry '" + name + "' (" + type + ")";
        const bool registered = Metadata::isRegisteredType(type);
        if (type == openvdb::io::DelayedLoadMetadata::staticTypeName() && registered) {
            scan_delayed_load(path, in, entry, bytes);
        } else if (registered && type != openvdb::StringMetadata::staticTypeName()) {
            const uint32_t want = Metadata::createMetadata(type)->size();
            if (bytes != want)
                throw ScanError{VSD_ERR_FORMAT, corrupt(path, entry + " holds " + std::to_string(bytes) +
                                                                  " bytes, not " + std::to_string(want))};
            unsigned char b = 0;
            if (type == openvdb::BoolMetadata::staticTypeName() && (!in.read(&b, 1) || b > 1))
                throw ScanError{VSD_ERR_FORMAT, corrupt(path, entry + " is " + std::to_string(b) + ", not 0 or 1")};
        }
        if (half && name == openvdb::GridBase::META_SAVE_HALF_FLOAT) {
            // MetaMap::insertMeta: the last entry of a name wins; unregistered types whose
            // name starts with "__" are dropped; asBool() of the value OpenVDB builds
            std::string value(size_t(bytes), '\0');
            in.seek(value_pos);
            in.read(&value[0], int64_t(bytes));
            if (!registered) {
                if (type.compare(0, 2, "__") != 0)
                    *half = bytes > 0;
            } else if (type == openvdb::io::DelayedLoadMetadata::staticTypeName()) {
                *half = false;
            } else {
                Metadata::Ptr m = Metadata::createMetadata(type);
                std::istringstream is(std::string(reinterpret_cast<const char *>(&bytes), 4) + value);
                m->read(is);
                *half = m->asBool();
            }
        }
        if (!in.seek(value_pos + int64_t(bytes)))
            throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
    }
}

// Bytes a registered linear map's read() takes, measured by writing a default one; -1 for
// an unregistered type and for NonlinearFrustumMap (not of fixed size).
int64_t linear_map_bytes(const std::string &type)
{
    using openvdb::math::MapRegistry;
    if (type == openvdb::math::NonlinearFrustumMap::mapType() || !MapRegistry::isRegistered(type))
        return -1;
    std::ostringstream os;
    MapRegistry::createMap(type)->write(os);
    return int64_t(os.tellp());
}

// math::Transform::read (format >= 219): the map's type name, then the map. A frustum map
// holds a bounding box (int32 before version 221, double after), taper, depth and a second,
// linear map with its own type name (another length OpenVDB would trust). An unknown type
// leaves nothing after it checkable, so it is refused here (OpenVDB would throw KeyError).
void scan_transform(const std::string &path, ByteReader &in, uint32_t version, const std::string &label)
{
    const std::string what = "the transform of " + label;
    std::string type;
    if (!in.read_string(type))
        throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
    int64_t bytes = linear_map_bytes(type);
    if (bytes < 0 && type == openvdb::math::NonlinearFrustumMap::mapType()) {
        const int64_t bbox = version < openvdb::OPENVDB_FILE_VERSION_FLOAT_FRUSTUM_BBOX ? 6 * 4 : 6 * 8;
        std::string second;
        if (!in.skip(bbox + 2 * 8) || !in.read_string(second))
            throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
        bytes = linear_map_bytes(second);
        if (bytes < 0)
            throw ScanError{VSD_ERR_FORMAT, corrupt(path, label + " has a frustum transform whose second map "
                                                              "has an unknown type '" + second + "'")};
    } else if (bytes < 0) {
        throw ScanError{VSD_ERR_FORMAT, corrupt(path, label + " has an unknown transform type '" + type + "'")};
    }
    if (!in.skip(bytes))
        throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
}

// io::GridDescriptor::read, then the grid's compression flags at its start, metadata and
// transform, then a jump to the next descriptor at the grid's end, as io::File walks.
GridEntry scan_descriptor(const std::string &path, ByteReader &in, uint32_t version, int index)
{
    GridEntry g;
    const std::string what = "the descriptor of grid " + std::to_string(index);
    bool ok = in.read_string(g.unique) && in.read_string(g.grid_type);
    if (ok && version >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING)
        ok = in.read_string(g.parent);
    ok = ok && in.read(&g.grid_pos, 8) && in.read(&g.block_pos, 8) && in.read(&g.end_pos, 8);
    if (!ok)
        throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
    g.name = openvdb::io::GridDescriptor::stripSuffix(g.unique);
    g.instance = !g.parent.empty();
    static const std::string half_suffix = "_HalfFloat";
    if (g.grid_type.size() > half_suffix.size() &&
        g.grid_type.compare(g.grid_type.size() - half_suffix.size(), half_suffix.size(), half_suffix) == 0) {
        g.half = true;
        g.grid_type.resize(g.grid_type.size() - half_suffix.size());
    }
    const std::string label = "grid '" + g.name + "'";
    // An instance has no tree, and io::Archive::writeGridInstance leaves its block position 0:
    // its metadata and transform end where the grid does.
    if (g.instance && g.block_pos == 0)
        g.block_pos = g.end_pos;
    if (g.end_pos > in.size())
        throw ScanError{VSD_ERR_FORMAT, truncated(path, label, in.size())};
    if (g.grid_pos < in.pos() || g.block_pos < g.grid_pos || g.end_pos < g.block_pos)
        throw ScanError{VSD_ERR_FORMAT, path + ": truncated or corrupt OpenVDB file (" + label +
                                            " has inconsistent offsets)"};
    // The grid's compression flags (from version 222), own metadata and transform follow
    // (io::File::readGridPartial: compression, MetaMap::readMeta, Transform::read; the
    // transform precedes the topology in every version >= 216). OpenVDB sizes strings from
    // their length fields before reading them, so a corrupt length in a 10 KB file asked it
    // for 1.7 GB (found by tests/fuzz/fuzz_vdb): check them against the grid's bytes first.
    // OpenVDB reads them from grid_pos whatever end_pos says, so a grid too short for its
    // flags is refused rather than left unchecked.
    if (!in.seek(g.grid_pos))
        throw ScanError{VSD_ERR_FORMAT, truncated(path, label, in.size())};
    if (version >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) {
        if (g.grid_pos + 4 > g.block_pos || !in.read(&g.compression, 4))
            throw ScanError{VSD_ERR_FORMAT, corrupt(path, label + " is too short for its compression flags")};
        g.has_compression = true;
    }
    scan_metadata(path, in, "the metadata of " + label, &g.half_meta);
    scan_transform(path, in, version, label);
    if (in.pos() > g.block_pos)
        throw ScanError{VSD_ERR_FORMAT, truncated(path, "the transform of " + label, in.size())};
    g.topo_pos = in.pos();
    if (!in.seek(g.end_pos))
        throw ScanError{VSD_ERR_FORMAT, truncated(path, label, in.size())};
    return g;
}

void scan_grids(const std::string &path, ByteReader &in, FileScan &out)
{
    int32_t count = 0;
    if (!in.read(&count, sizeof count))
        throw ScanError{VSD_ERR_FORMAT, truncated(path, "the grid count", in.size())};
    // A descriptor takes at least 3 empty strings and 3 offsets: 36 bytes.
    if (count < 0 || int64_t(count) * 36 > in.left())
        throw ScanError{VSD_ERR_FORMAT, path + ": truncated or corrupt OpenVDB file (" +
                                            std::to_string(count) + " grids cannot fit in " +
                                            std::to_string(in.left()) + " bytes)"};
    for (int32_t i = 0; i < count; ++i)
        out.grids.push_back(scan_descriptor(path, in, out.version, int(i)));
}

} // namespace

// Stat + scan. Throws ScanError; returns a complete, offset-checked FileScan.
FileScan scan_file(const std::string &path)
{
    struct stat sb;
    if (stat(path.c_str(), &sb) != 0) {
        if (errno == ENOENT || errno == ENOTDIR)
            throw ScanError{VSD_ERR_IO, path + ": no such file"};
        throw ScanError{VSD_ERR_IO, path + ": " + std::strerror(errno)};
    }
    if (!S_ISREG(sb.st_mode))
        throw ScanError{VSD_ERR_IO, path + ": not a regular file"};
    const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        throw ScanError{VSD_ERR_IO, path + ": cannot open: " + std::strerror(errno)};
    FileScan out;
    out.size = int64_t(sb.st_size);
    try {
        ByteReader in(fd, out.size);
        scan_header(path, in, out);
        scan_metadata(path, in, "the file metadata");
        scan_grids(path, in, out);
    } catch (...) {
        close(fd);
        throw;
    }
    close(fd);
    return out;
}

} // namespace vsd_vdbio
