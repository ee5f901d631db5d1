// vdbio.cpp — OpenVDB files into vsd_volume, behind the extern "C" API of vsd/vdbio.h.
//
// Reading happens in two stages. First a small structural scan of the file (header, file
// metadata, grid descriptors and their byte offsets) that checks every length and offset
// against the real file size: OpenVDB trusts the lengths it reads and can allocate or read
// garbage on a truncated or foreign file, so nothing reaches OpenVDB until the scan has shown
// that every grid's bytes are present. Then OpenVDB reads the one grid asked for (delayed
// loading off, so all data is read now, inside our try block), and its leaves are copied into
// the brick pool of vsd/volume.h.
#include "vsd/vdbio.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <sys/stat.h>

#include <cerrno>
#include <cfloat>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <mutex>
#include <new>
#include <string>
#include <vector>

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

// ---- structural scan ---------------------------------------------------------------------

// One grid as its descriptor describes it, in file order.
struct GridEntry {
    std::string unique;          // unique name: name, or name + "\x1e" + n for duplicates
    std::string name;            // the grid's name
    std::string grid_type;       // e.g. "Tree_float_5_4_3" (half-float suffix removed)
    bool half = false;           // stored as 16-bit floats
    bool instance = false;       // shares another grid's tree
    int64_t grid_pos = 0, block_pos = 0, end_pos = 0;
    bool has_compression = false;
    uint32_t compression = 0;    // per-grid io::COMPRESS_* flags (file version >= 222)
};

struct FileScan {
    uint32_t version = 0;
    std::vector<GridEntry> grids;
};

// Bounds-checked little reader over a FILE*: every read states what it was reading, so a
// short file yields "truncated" with the part that is missing.
class ByteReader {
public:
    ByteReader(FILE *f, int64_t size) : f_(f), size_(size) {}
    int64_t pos() const { return pos_; }
    int64_t size() const { return size_; }
    int64_t left() const { return size_ - pos_; }
    bool read(void *dst, int64_t n)
    {
        if (n < 0 || n > left())
            return false;
        if (n > 0 && std::fread(dst, 1, size_t(n), f_) != size_t(n))
            return false;
        pos_ += n;
        return true;
    }
    bool seek(int64_t p)
    {
        if (p < 0 || p > size_ || fseeko(f_, off_t(p), SEEK_SET) != 0)
            return false;
        pos_ = p;
        return true;
    }
    bool skip(int64_t n) { return n >= 0 && n <= left() && seek(pos_ + n); }
    bool read_string(std::string &s)
    {
        uint32_t n = 0;
        if (!read(&n, sizeof n) || int64_t(n) > left())
            return false;
        s.assign(size_t(n), '\0');
        return read(&s[0], int64_t(n));
    }

private:
    FILE *f_;
    int64_t size_;
    int64_t pos_ = 0;
};

struct ScanError {
    vsd_status status;
    std::string message;
};

std::string truncated(const std::string &path, const std::string &what, int64_t size)
{
    return path + ": truncated or corrupt OpenVDB file (" + what + " runs past the end of the " +
           std::to_string(size) + "-byte file)";
}

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
    if (ok && out.version < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION)
        ok = in.skip(1);   // file-wide "is compressed" flag, per grid from 222 on
    ok = ok && in.skip(36);   // UUID as 36 ASCII characters
    if (!ok)
        throw ScanError{VSD_ERR_FORMAT, truncated(path, "the header", in.size())};
    if (!offsets)
        throw ScanError{VSD_ERR_UNSUPPORTED,
                        path + ": OpenVDB file written as a non-seekable stream (no grid "
                               "offsets); re-save it as a file"};
}

// io::MetaMap::readMeta: count, then (name, type name, byte count, bytes) per entry.
void scan_metadata(const std::string &path, ByteReader &in, const char *what)
{
    uint32_t count = 0;
    bool ok = in.read(&count, sizeof count) && int64_t(count) * 12 <= in.left();
    for (uint32_t i = 0; ok && i < count; ++i) {
        std::string name, type;
        uint32_t bytes = 0;
        ok = in.read_string(name) && in.read_string(type) && in.read(&bytes, sizeof bytes) &&
             in.skip(bytes);
    }
    if (!ok)
        throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
}

// io::GridDescriptor::read, then the grid's compression flags at its start, then a jump to
// the next descriptor at the grid's end, exactly as io::File::readGridDescriptors walks.
GridEntry scan_descriptor(const std::string &path, ByteReader &in, uint32_t version, int index)
{
    GridEntry g;
    const std::string what = "the descriptor of grid " + std::to_string(index);
    std::string parent;
    bool ok = in.read_string(g.unique) && in.read_string(g.grid_type);
    if (ok && version >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING)
        ok = in.read_string(parent);
    ok = ok && in.read(&g.grid_pos, 8) && in.read(&g.block_pos, 8) && in.read(&g.end_pos, 8);
    if (!ok)
        throw ScanError{VSD_ERR_FORMAT, truncated(path, what, in.size())};
    g.name = openvdb::io::GridDescriptor::stripSuffix(g.unique);
    g.instance = !parent.empty();
    static const std::string half_suffix = "_HalfFloat";
    if (g.grid_type.size() > half_suffix.size() &&
        g.grid_type.compare(g.grid_type.size() - half_suffix.size(), half_suffix.size(), half_suffix) == 0) {
        g.half = true;
        g.grid_type.resize(g.grid_type.size() - half_suffix.size());
    }
    const std::string label = "grid '" + g.name + "'";
    if (g.end_pos > in.size())
        throw ScanError{VSD_ERR_FORMAT, truncated(path, label, in.size())};
    if (g.grid_pos < in.pos() || g.block_pos < g.grid_pos || g.end_pos < g.block_pos)
        throw ScanError{VSD_ERR_FORMAT, path + ": truncated or corrupt OpenVDB file (" + label +
                                            " has inconsistent offsets)"};
    if (version >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION &&
        g.grid_pos + 4 <= g.end_pos && in.seek(g.grid_pos) && in.read(&g.compression, 4))
        g.has_compression = true;
    // The grid's own metadata and its transform's type name follow (io::File::readGridPartial:
    // compression, MetaMap::readMeta, Transform::read). OpenVDB sizes strings from their
    // length fields before reading them, so a corrupt length in a 10 KB file asked it for
    // 1.7 GB (found by tests/fuzz/fuzz_vdb): check them against the grid's bytes first.
    if (version >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION ? g.has_compression
                                                                        : in.seek(g.grid_pos)) {
        std::string map_type;
        scan_metadata(path, in, ("the metadata of " + label).c_str());
        // before grid instancing (223) the topology came between metadata and transform
        const bool transform_next = version >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING;
        if ((transform_next && !in.read_string(map_type)) || in.pos() > g.block_pos)
            throw ScanError{VSD_ERR_FORMAT, truncated(path, "the transform of " + label, in.size())};
    }
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
    FILE *f = std::fopen(path.c_str(), "rb");
    if (!f)
        throw ScanError{VSD_ERR_IO, path + ": cannot open: " + std::strerror(errno)};
    FileScan out;
    try {
        ByteReader in(f, int64_t(sb.st_size));
        scan_header(path, in, out);
        scan_metadata(path, in, "the file metadata");
        scan_grids(path, in, out);
    } catch (...) {
        std::fclose(f);
        throw;
    }
    std::fclose(f);
    return out;
}

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

// The name io::File looks a grid up by: "name[n]" picks exactly this descriptor even when
// several grids share the name (io::File::findDescriptor).
std::string lookup_name(const GridEntry &g)
{
    return openvdb::io::GridDescriptor::nameAsString(g.unique);
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

// ---- transform ---------------------------------------------------------------------------

// OpenVDB's affine matrix is in row-vector convention (world = [i j k 1] * M, translation in
// the last row); vsd's is row-major column-vector (w = A * (i,j,k,1)): A = transpose(M).
bool linear_matrix(const openvdb::math::Transform &xf, double m[16])
{
    if (!xf.isLinear())
        return false;
    const openvdb::Mat4d a = xf.baseMap()->getAffineMap()->getMat4();
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            m[r * 4 + c] = a(c, r);
    return true;
}

// ---- leaves and tiles into bricks --------------------------------------------------------

// Cell index and pool management while a volume is being filled.
struct BrickBuilder {
    vsd_volume *vol;
    size_t capacity = 0;   // bricks allocated in vol->voxels

    int32_t *slot_of(const openvdb::Coord &leaf_origin) const
    {
        const int64_t x = (int64_t(leaf_origin.x()) - vol->origin[0]) / 8;
        const int64_t y = (int64_t(leaf_origin.y()) - vol->origin[1]) / 8;
        const int64_t z = (int64_t(leaf_origin.z()) - vol->origin[2]) / 8;
        const int32_t *d = vol->brick_dims;
        if (x < 0 || y < 0 || z < 0 || x >= d[0] || y >= d[1] || z >= d[2])
            return nullptr;   // cannot happen for nodes inside the active bbox
        return vol->brick_slots + size_t(x) + size_t(d[0]) * (size_t(y) + size_t(d[1]) * size_t(z));
    }
    // Next free pool slot (not yet claimed: the caller claims it when the brick is non-zero).
    float *next() const { return vol->voxels + size_t(vol->brick_count) * VSD_BRICK_VOXELS; }
    void claim(int32_t *slot) { *slot = vol->brick_count++; }
};

// A leaf's 512 values, OpenVDB order (offset = x*64 + y*8 + z) transposed to vsd's x-fastest
// order; inactive voxels become 0 so that "not active" and "absent" mean the same thing.
// Returns whether any value is non-zero.
template <typename LeafT>
bool copy_leaf(const LeafT &leaf, float *dst)
{
    const auto *src = leaf.buffer().data();
    const auto &mask = leaf.getValueMask();
    bool any = false;
    for (int x = 0; x < 8; ++x) {
        const uint64_t word = mask.template getWord<uint64_t>(openvdb::Index(x));   // bits y*8+z
        for (int y = 0; y < 8; ++y)
            for (int z = 0; z < 8; ++z) {
                const int bit = y * 8 + z;
                const float v = (word >> bit) & 1u ? float(src[x * 64 + bit]) : 0.0f;
                dst[z * 64 + y * 8 + x] = v;
                any |= v != 0.0f;
            }
    }
    return any;
}

// Active tiles above leaf level (e.g. Mantaflow's constant 'shadow' grids) cover whole,
// 8-aligned leaf-sized blocks; they become full bricks of the tile value.
template <typename TreeT, typename Fn>
void for_each_active_tile(const TreeT &tree, Fn fn)
{
    auto it = tree.cbeginValueOn();
    it.setMaxDepth(it.getLeafDepth() - 1);
    for (; it; ++it) {
        if (!it.isTileValue())
            continue;
        const float v = float(*it);
        if (v != 0.0f)
            fn(it.getBoundingBox(), v);
    }
}

template <typename TreeT>
uint64_t tile_bricks(const TreeT &tree)
{
    uint64_t n = 0;
    for_each_active_tile(tree, [&n](const openvdb::CoordBBox &b, float) {
        n += uint64_t(b.dim().x() / 8) * uint64_t(b.dim().y() / 8) * uint64_t(b.dim().z() / 8);
    });
    return n;
}

template <typename TreeT>
void fill_tiles(const TreeT &tree, BrickBuilder &bb)
{
    for_each_active_tile(tree, [&bb](const openvdb::CoordBBox &b, float v) {
        for (int z = b.min().z(); z <= b.max().z(); z += 8)
            for (int y = b.min().y(); y <= b.max().y(); y += 8)
                for (int x = b.min().x(); x <= b.max().x(); x += 8) {
                    int32_t *slot = bb.slot_of(openvdb::Coord(x, y, z));
                    if (!slot)
                        continue;
                    float *dst = bb.next();
                    for (int n = 0; n < VSD_BRICK_VOXELS; ++n)
                        dst[n] = v;
                    bb.claim(slot);
                }
    });
}

// floor(v / 8) * 8 in 64 bits.
int64_t floor8(int64_t v)
{
    return (v >= 0 ? v / 8 : -((-v + 7) / 8)) * 8;
}

// Size the brick grid over the active bbox, with the low-side margin cell that the trilinear
// support needs when the bbox starts on a multiple of 8 (see core/src/volume/volume.c).
vsd_status size_cells(vsd_volume *vol, const openvdb::CoordBBox &bbox, std::string &why)
{
    int64_t cells = 1;
    for (int a = 0; a < 3; ++a) {
        const int64_t first = floor8(int64_t(bbox.min()[a]) - 1);
        const int64_t last = floor8(int64_t(bbox.max()[a]));
        if (first < INT32_MIN) {
            why = "index bbox reaches the int32 limit";
            return VSD_ERR_UNSUPPORTED;
        }
        vol->origin[a] = int32_t(first);
        vol->brick_dims[a] = int32_t((last - first) / 8 + 1);
        cells *= vol->brick_dims[a];
    }
    if (cells > INT32_MAX) {
        why = "active bbox of " + std::to_string(cells) + " brick cells is too large";
        return VSD_ERR_NOMEM;
    }
    const size_t n = size_t(cells);
    vol->brick_slots = static_cast<int32_t *>(std::malloc(n * sizeof(int32_t)));
    vol->brick_min = static_cast<float *>(std::calloc(n, sizeof(float)));
    vol->brick_max = static_cast<float *>(std::calloc(n, sizeof(float)));
    if (!vol->brick_slots || !vol->brick_min || !vol->brick_max) {
        why = "out of memory for " + std::to_string(cells) + " brick cells";
        return VSD_ERR_NOMEM;
    }
    for (size_t i = 0; i < n; ++i)
        vol->brick_slots[i] = -1;
    return VSD_OK;
}

template <typename GridT>
vsd_status fill_volume(const GridT &grid, vsd_volume *vol, std::string &why)
{
    const auto &tree = grid.tree();
    const openvdb::CoordBBox bbox = grid.evalActiveVoxelBoundingBox();
    if (bbox.empty())
        return VSD_OK;   // empty volume: brick_dims stay 0
    vsd_status st = size_cells(vol, bbox, why);
    if (st != VSD_OK)
        return st;
    const uint64_t bricks = uint64_t(tree.leafCount()) + tile_bricks(tree);
    if (bricks > uint64_t(INT32_MAX)) {
        why = std::to_string(bricks) + " bricks are too many";
        return VSD_ERR_NOMEM;
    }
    vol->voxels = static_cast<float *>(std::malloc(std::max<size_t>(1, size_t(bricks)) *
                                                    VSD_BRICK_VOXELS * sizeof(float)));
    if (!vol->voxels) {
        why = "out of memory for " + std::to_string(bricks) + " bricks";
        return VSD_ERR_NOMEM;
    }
    BrickBuilder bb{vol, size_t(bricks)};
    for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
        int32_t *slot = bb.slot_of(leaf->origin());
        if (slot && copy_leaf(*leaf, bb.next()))
            bb.claim(slot);
    }
    fill_tiles(tree, bb);
    // Give back what all-zero leaves did not use.
    if (size_t(vol->brick_count) < bb.capacity && vol->brick_count > 0) {
        if (void *p = std::realloc(vol->voxels, size_t(vol->brick_count) * VSD_BRICK_VOXELS * sizeof(float)))
            vol->voxels = static_cast<float *>(p);
    }
    vsd_volume_update_ranges(vol);
    return VSD_OK;
}

void copy_cstr(char *dst, size_t cap, const std::string &s)
{
    std::snprintf(dst, cap, "%s", s.c_str());
}

template <typename MetaT, typename ValueT>
bool get_meta(const GridBase &grid, const char *key, ValueT &out)
{
    auto m = grid.getMetadata<MetaT>(key);
    if (!m)
        return false;
    out = m->value();
    return true;
}

// Read grid `g` through OpenVDB and convert it. Throws ScanError or OpenVDB/std exceptions.
vsd_volume *load_grid(const std::string &path, const GridEntry &g)
{
    openvdb::io::File file(path);
    file.open(false);   // no delayed loading: read (and fail) now, inside our try
    GridBase::Ptr base = file.readGrid(lookup_name(g));
    file.close();
    if (!base)
        throw ScanError{VSD_ERR_FORMAT, path + ": grid '" + g.name + "' could not be read"};

    double m[16];
    if (!linear_matrix(base->transform(), m))
        throw ScanError{VSD_ERR_UNSUPPORTED,
                        path + ": grid '" + g.name + "' has a " + base->transform().mapType() +
                            " transform; vsd supports linear (affine) transforms only"};
    vsd_volume *vol = nullptr;
    char err[256];
    if (vsd_volume_create_empty(m, &vol, err, sizeof err) != VSD_OK)
        throw std::bad_alloc();
    copy_cstr(vol->grid_name, sizeof vol->grid_name, g.name);
    copy_cstr(vol->file, sizeof vol->file, path);
    vol->active_voxels = base->activeVoxelCount();
    // The voxel count the writer stored is what callers check limits against before loading
    // (vsd_vdb_list; the daemon's --max-voxels). A file whose tree holds more than that is
    // corrupt, and a flipped tile flag made a 10 KB file expand to billions of voxels (found by
    // tests/fuzz/fuzz_vdb): refuse it rather than trust either number.
    {
        int64_t stated = 0;
        if (get_meta<openvdb::Int64Metadata>(*base, GridBase::META_FILE_VOXEL_COUNT, stated) &&
            uint64_t(stated) != uint64_t(vol->active_voxels)) {
            const std::string msg = path + ": truncated or corrupt OpenVDB file (grid '" + g.name + "' holds " +
                                    std::to_string(vol->active_voxels) + " active voxels, its metadata says " +
                                    std::to_string(stated) + ")";
            vsd_volume_destroy(vol);
            throw ScanError{VSD_ERR_FORMAT, msg};
        }
    }

    std::string why;
    vsd_status st = VSD_ERR_TYPE;
    if (auto fg = openvdb::gridConstPtrCast<openvdb::FloatGrid>(base))
        st = fill_volume(*fg, vol, why);
    else if (auto dg = openvdb::gridConstPtrCast<openvdb::DoubleGrid>(base))
        st = fill_volume(*dg, vol, why);
    else
        why = "value type " + base->valueType() + " is not a scalar float grid";
    if (st != VSD_OK) {
        vsd_volume_destroy(vol);
        throw ScanError{st, path + ": grid '" + g.name + "': " + why};
    }
    return vol;
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
// when a writer left them out is the whole grid read to compute them.
void grid_stats(openvdb::io::File &file, const GridEntry &g, const GridBase &meta,
                uint64_t &active, openvdb::CoordBBox &bbox)
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
    GridBase::Ptr full = file.readGrid(lookup_name(g));
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

void describe_grid(openvdb::io::File &file, const GridEntry &g, vsd_grid_info &info)
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
    grid_stats(file, g, *meta, info.active_voxels, bbox);
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
        vsd_volume *vol = load_grid(p, g);
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
                describe_grid(file, scan.grids[i], infos[i]);
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

} // extern "C"
