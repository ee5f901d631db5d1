// vdb_tree_scan.cpp — the tree part of vdbio's structural scan.
//
// OpenVDB 10 trusts the sizes inside a grid's tree data: io::bloscFromStream and
// io::unzipFromStream allocate whatever a chunk's int64 size field says (tests/fuzz/fuzz_vdb
// found `new char[0x7f3f1e000000007f]`), read an "uncompressed" chunk of -size bytes into a
// buffer sized for the expected values before comparing the two, and Blosc then trusts the
// compressed size in its own 16-byte header as the size of its input. So before OpenVDB
// reads a tree, this file walks it the way OpenVDB will and checks every count, every
// mask-dependent length and every chunk against the bytes of that grid: the topology
// (io::Archive::readGrid -> Tree::readTopology) between the end of the transform and the
// grid's block position, then the leaf buffers (Tree::readBuffers) up to the grid's end.
// Nothing is decompressed here; the walk reads masks, counts and chunk headers only.
//
// The layout followed (OpenVDB 10.0, file format versions 220..224):
//   Tree        int32 buffer count (ignored by OpenVDB), then the root
//   RootNode    background value; uint32 tile count; uint32 child count;
//               tiles: int32 x,y,z, value, bool active; children: int32 x,y,z + InternalNode.
//               The table is a std::map keyed by origin: readBuffers visits children in
//               Coord order, so the file's children must already be in that order.
//   InternalNode<5|4>  child mask, value mask (4096 | 512 bytes each), compressed values
//               (all 32768 | 4096 of them; only childMask.countOff() before version 222),
//               then each child in child-mask order.
//   LeafNode<T,3>  topology: the 64-byte value mask. Buffers: 64-byte value mask (File
//               streams are seekable, so OpenVDB seeks over it and keeps the topology's),
//               [before 222: int32 origin[3], int8 buffer count], compressed values (512).
//   compressed values (io::readCompressedValues): [>= 222: int8 mask-compression flag;
//               0..2 inactive values; a selection mask], then a chunk of tempCount values,
//               tempCount = valueMask.countOn() when the grid has COMPRESS_ACTIVE_MASK and
//               the flag is not NO_MASK_AND_ALL_VALS, else all of them. Values are halves
//               when the grid's metadata says so and the type is real (io::HalfReader: then
//               an empty chunk is not written at all); inactive values stay full size.
//   chunk (io::readData): Blosc if COMPRESS_BLOSC (even when COMPRESS_ZIP is also set),
//               else zlib if COMPRESS_ZIP: int64 size, size <= 0 meaning -size raw bytes;
//               else the raw bytes.
#include "vdb_scan.h"

#include <openvdb/io/Compression.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/openvdb.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <type_traits>

namespace vsd_vdbio {
namespace {

using openvdb::Coord;

// ---- which trees can be walked -------------------------------------------------------------

// The value sizes of one registered grid type built from the standard nodes (RootNode,
// InternalNode<.., 5>, InternalNode<.., 4>, LeafNode<T, 3>), which all share the layout
// above. Bool, mask and point grids have leaves of their own format; vdbio never loads them.
struct ValueLayout {
    std::string grid_type;
    int64_t value_bytes;   // sizeof(ValueType): background, root tiles, inactive values
    int64_t half_bytes;    // sizeof(RealToHalf<ValueType>::HalfT) for real types, else 0
};

template <typename GridT>
ValueLayout layout_of()
{
    using TreeT = typename GridT::TreeType;
    using N5 = typename TreeT::RootNodeType::ChildNodeType;
    using N4 = typename N5::ChildNodeType;
    using LeafT = typename N4::ChildNodeType;
    using V = typename GridT::ValueType;
    using H = openvdb::io::RealToHalf<V>;
    static_assert(N5::LOG2DIM == 5 && N4::LOG2DIM == 4 && LeafT::LOG2DIM == 3, "a 5_4_3 tree");
    static_assert(std::is_same<LeafT, openvdb::tree::LeafNode<V, 3>>::value, "standard leaves");
    return {GridT::gridType(), int64_t(sizeof(V)), H::isReal ? int64_t(sizeof(typename H::HalfT)) : 0};
}

const ValueLayout *layout_for(const std::string &grid_type)
{
    static const ValueLayout table[] = {
        layout_of<openvdb::FloatGrid>(), layout_of<openvdb::DoubleGrid>(),
        layout_of<openvdb::Int32Grid>(), layout_of<openvdb::Int64Grid>(),
        layout_of<openvdb::Vec3IGrid>(), layout_of<openvdb::Vec3SGrid>(),
        layout_of<openvdb::Vec3DGrid>(),
    };
    for (const ValueLayout &l : table)
        if (l.grid_type == grid_type)
            return &l;
    return nullptr;
}

// ---- the walk ------------------------------------------------------------------------------

constexpr int64_t kBloscHeader = 16;   // BLOSC_MIN_HEADER_LENGTH == BLOSC_MAX_OVERHEAD
constexpr int kNoMaskAndAllVals = openvdb::io::NO_MASK_AND_ALL_VALS;

uint32_t le32(const unsigned char *p)
{
    return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// zlib's compressBound(): the most compress() can turn n bytes into. OpenVDB writes a zlib
// chunk only when it came out smaller than its input, so a valid one is far below this.
int64_t zlib_bound(int64_t n)
{
    return n + (n >> 12) + (n >> 14) + (n >> 25) + 13;
}

std::string coord_str(const Coord &c)
{
    return "(" + std::to_string(c.x()) + ", " + std::to_string(c.y()) + ", " + std::to_string(c.z()) + ")";
}

std::string n_str(int64_t n)
{
    return std::to_string(n);
}

class TreeWalk {
public:
    TreeWalk(const std::string &path, const FileScan &scan, const GridEntry &g, const ValueLayout &layout,
             ByteReader &in)
        : path_(path), g_(g), in_(in), version_(scan.version),
          value_bytes_(layout.value_bytes),
          elem_bytes_(g.half_meta && layout.half_bytes > 0 ? layout.half_bytes : layout.value_bytes),
          half_(g.half_meta && layout.half_bytes > 0)
    {
        if (version_ >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION)
            compression_ = g.compression;
        else
            compression_ = scan.file_zip ? uint32_t(openvdb::io::COMPRESS_ZIP) : 0u;
    }

    void run()
    {
        limit_ = g_.block_pos;
        if (g_.topo_pos < 0 || !in_.seek(g_.topo_pos))
            fail("its topology could not be located");
        topology();
        if (in_.pos() != g_.block_pos)
            fail("its topology ends at byte " + n_str(in_.pos()) + ", but its descriptor puts the leaf buffers at byte " +
                 n_str(g_.block_pos));
        limit_ = g_.end_pos;
        in_buffers_ = true;
        buffers();
        if (in_.pos() != g_.end_pos)
            fail("its leaf buffers end at byte " + n_str(in_.pos()) + ", but its descriptor says the grid ends at byte " +
                 n_str(g_.end_pos));
    }

private:
    struct Leaf {
        Coord origin;
        uint32_t active;   // value-mask bits on (the topology's mask is the one OpenVDB keeps)
    };
    enum class Node { Tree, Root, Tile, RootChild, Internal, Leaf };

    [[noreturn]] void fail(const std::string &what) const
    {
        throw ScanError{VSD_ERR_FORMAT, corrupt(path_, "grid '" + g_.name + "': " + what)};
    }

    // The node being read, for messages (built only when something fails).
    std::string node() const
    {
        switch (node_) {
        case Node::Tree: return "the tree header";
        case Node::Root: return "the root node";
        case Node::Tile:
            return "root tile " + n_str(node_index_) + (key_read_ ? " at " + coord_str(node_origin_) : "");
        case Node::RootChild:
            return "root child " + n_str(node_index_) + (key_read_ ? " at " + coord_str(node_origin_) : "");
        case Node::Internal:
            return std::string(node_level_ == 5 ? "the internal node" : "the lower internal node") + " at " +
                   coord_str(node_origin_);
        case Node::Leaf:
            return "leaf " + n_str(node_index_) + " at " + coord_str(node_origin_);
        }
        return "a node";
    }

    int64_t room() const { return limit_ - in_.pos(); }
    const char *region() const { return in_buffers_ ? "buffers" : "topology"; }

    // n bytes of `part` must lie before the end of the current region.
    void need(int64_t n, const char *part)
    {
        if (n < 0 || n > room())
            fail(node() + "'s " + part + ": " + n_str(n) + " bytes needed, " + n_str(room()) + " left in the grid's " +
                 region());
    }
    void read(void *dst, int64_t n, const char *part)
    {
        need(n, part);
        if (!in_.read(dst, n))
            fail(node() + "'s " + part + " could not be read");
    }
    void skip(int64_t n, const char *part)
    {
        need(n, part);
        if (!in_.skip(n))
            fail(node() + "'s " + part + " could not be read");
    }

    // ---- topology ----

    void topology()
    {
        node_ = Node::Tree;
        int32_t buffer_count = 0;   // always 1 since OpenVDB 2; OpenVDB only warns otherwise
        read(&buffer_count, 4, "buffer count");
        node_ = Node::Root;
        skip(value_bytes_, "background value");
        uint32_t counts[2] = {0, 0};
        read(counts, 8, "tile and child counts");
        const int64_t tiles = counts[0], children = counts[1];
        const int64_t tile_bytes = 12 + value_bytes_ + 1;
        if (tiles * tile_bytes > room())
            fail("the root's " + n_str(tiles) + " tiles need " + n_str(tiles * tile_bytes) + " bytes, " +
                 n_str(room()) + " left in the grid's topology");
        // a child is at least its origin and an internal node's two 4096-byte masks
        const int64_t child_min = 12 + 2 * mask_bytes(5);
        if (children * child_min > room() - tiles * tile_bytes)
            fail("the root's " + n_str(children) + " children need at least " + n_str(children * child_min) +
                 " bytes, " + n_str(room() - tiles * tile_bytes) + " left in the grid's topology");
        Coord prev;
        for (int64_t i = 0; i < tiles; ++i) {
            node_ = Node::Tile;
            node_index_ = i;
            prev = read_key(i > 0, prev, "tile");
            skip(value_bytes_, "value");
            uint8_t active = 0;
            read(&active, 1, "active flag");
            // stored as a C++ bool: any other byte is undefined behaviour when read back
            if (active > 1)
                fail(node() + " has an active flag of " + n_str(active) + ", not 0 or 1");
        }
        for (int64_t i = 0; i < children; ++i) {
            node_ = Node::RootChild;
            node_index_ = i;
            prev = read_key(i > 0, prev, "child");
            internal(5, prev);
        }
    }

    // A root table key: aligned to the 4096-voxel span of a child (RootNode::coordToKey; then
    // no node's bounding box can overflow int32), and after the previous key of its kind, as
    // the std::map the writer walked gives them (and as readBuffers will visit children).
    Coord read_key(bool has_prev, const Coord &prev, const char *kind)
    {
        int32_t v[3];
        key_read_ = false;
        read(v, 12, "origin");
        const Coord c(v[0], v[1], v[2]);
        node_origin_ = c;
        key_read_ = true;
        for (int a = 0; a < 3; ++a)
            if (uint32_t(v[a]) & 4095u)
                fail(node() + " is not aligned to the 4096-voxel root grid");
        if (has_prev && !(prev < c))
            fail(node() + " does not come after the previous root " + kind + " at " + coord_str(prev) +
                 " (root entries are stored in ascending order)");
        return c;
    }

    static int64_t mask_bytes(int log2dim) { return (int64_t(1) << (3 * log2dim)) / 8; }

    void internal(int log2dim, const Coord &origin)
    {
        const int64_t bytes = mask_bytes(log2dim), words = bytes / 8;
        const int64_t size = int64_t(1) << (3 * log2dim);
        const int child_shift = log2dim == 5 ? 7 : 3;   // log2 of the child's span in voxels
        std::vector<uint64_t> &child_mask = log2dim == 5 ? child5_ : child4_;
        std::vector<uint64_t> &value_mask = log2dim == 5 ? value5_ : value4_;
        child_mask.assign(size_t(words), 0);
        value_mask.assign(size_t(words), 0);
        node_ = Node::Internal;
        node_level_ = log2dim;
        node_origin_ = origin;
        read(child_mask.data(), bytes, "child mask");
        read(value_mask.data(), bytes, "value mask");
        int64_t children = 0, active = 0;
        for (int64_t w = 0; w < words; ++w) {
            children += __builtin_popcountll(child_mask[size_t(w)]);
            active += __builtin_popcountll(value_mask[size_t(w)]);
        }
        // before version 222 only the values of tiles (not of child slots) were stored
        const int64_t values = version_ < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION ? size - children : size;
        compressed_values(values, active, bytes);
        for (int64_t w = 0; w < words; ++w) {
            for (uint64_t bits = child_mask[size_t(w)]; bits; bits &= bits - 1) {
                const int64_t n = w * 64 + __builtin_ctzll(bits);
                // InternalNode::offsetToLocalCoord: n = x << 2*log2dim | y << log2dim | z
                const int64_t mask = (int64_t(1) << log2dim) - 1;
                const Coord child(origin.x() + int32_t((n >> (2 * log2dim)) << child_shift),
                                  origin.y() + int32_t(((n >> log2dim) & mask) << child_shift),
                                  origin.z() + int32_t((n & mask) << child_shift));
                if (log2dim == 5) {
                    internal(4, child);
                    // internal(4) reused the per-level buffers of level 4 only; restore context
                    node_ = Node::Internal;
                    node_level_ = 5;
                    node_origin_ = origin;
                } else {
                    leaf_topology(child);
                }
            }
        }
    }

    void leaf_topology(const Coord &origin)
    {
        node_ = Node::Leaf;
        node_index_ = int64_t(leaves_.size());
        node_origin_ = origin;
        uint64_t mask[8];
        read(mask, 64, "value mask");
        uint32_t active = 0;
        for (uint64_t w : mask)
            active += uint32_t(__builtin_popcountll(w));
        leaves_.push_back({origin, active});
        node_ = Node::Internal;
        node_level_ = 4;
        node_origin_ = Coord(origin.x() & ~127, origin.y() & ~127, origin.z() & ~127);
    }

    // ---- values ----

    // io::readCompressedValues for `count` values whose value mask has `active` bits on.
    void compressed_values(int64_t count, int64_t active, int64_t selection_mask_bytes)
    {
        int8_t flag = kNoMaskAndAllVals;
        if (version_ >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) {
            read(&flag, 1, "mask-compression flag");
            if (flag < 0 || flag > kNoMaskAndAllVals)
                fail(node() + " has a mask-compression flag of " + n_str(flag) + ", not 0.." +
                     n_str(kNoMaskAndAllVals));
        }
        using namespace openvdb::io;
        if (flag == NO_MASK_AND_ONE_INACTIVE_VAL || flag == MASK_AND_ONE_INACTIVE_VAL ||
            flag == MASK_AND_TWO_INACTIVE_VALS)
            skip(value_bytes_ * (flag == MASK_AND_TWO_INACTIVE_VALS ? 2 : 1), "inactive-value data");
        if (flag == MASK_AND_NO_INACTIVE_VALS || flag == MASK_AND_ONE_INACTIVE_VAL ||
            flag == MASK_AND_TWO_INACTIVE_VALS)
            skip(selection_mask_bytes, "selection mask");
        int64_t n = count;
        if ((compression_ & COMPRESS_ACTIVE_MASK) && flag != kNoMaskAndAllVals &&
            version_ >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION)
            n = active;
        if (half_ && n < 1)
            return;   // io::HalfReader reads nothing for no values
        chunk(n * elem_bytes_, compression_);
    }

    // io::readData of `expected` bytes under `compression`.
    void chunk(int64_t expected, uint32_t compression)
    {
        using namespace openvdb::io;
        if (!(compression & (COMPRESS_BLOSC | COMPRESS_ZIP))) {
            skip(expected, "value data");
            return;
        }
        const bool blosc = compression & COMPRESS_BLOSC;
        int64_t size = 0;
        read(&size, 8, "value chunk size");
        if (size <= 0) {
            // raw bytes: OpenVDB reads -size of them into the expected-size buffer first and
            // compares afterwards, so a larger -size would overrun the buffer
            if (size != -expected)
                fail(node() + "'s uncompressed value chunk holds " +
                     (size == INT64_MIN ? std::string("2^63") : n_str(-size)) + " bytes, not the " + n_str(expected) +
                     " its values take");
            skip(expected, "value data");
            return;
        }
        // OpenVDB allocates `size` bytes and reads them in one go
        if (size > room())
            fail(node() + "'s compressed value chunk claims " + n_str(size) + " bytes, " + n_str(room()) +
                 " left in the grid's " + region());
        if (!blosc) {
            if (size > zlib_bound(expected))
                fail(node() + "'s zlib chunk claims " + n_str(size) + " bytes for " + n_str(expected) +
                     " bytes of values (zlib never needs more than " + n_str(zlib_bound(expected)) + ")");
            skip(size, "zlib chunk");
            return;
        }
        // Blosc never grows its input by more than its header (the writer passes
        // inBytes + BLOSC_MAX_OVERHEAD as the room), and blosc_decompress_ctx is given no
        // input size: it takes the header's compressed size as the size of its input.
        if (size < kBloscHeader || size > expected + kBloscHeader)
            fail(node() + "'s Blosc chunk claims " + n_str(size) + " bytes for " + n_str(expected) +
                 " bytes of values (a Blosc chunk takes 16 to " + n_str(expected + kBloscHeader) + ")");
        unsigned char header[kBloscHeader];
        read(header, kBloscHeader, "Blosc header");
        const uint32_t nbytes = le32(header + 4), cbytes = le32(header + 12);
        if (nbytes != uint64_t(expected))
            fail(node() + "'s Blosc header says " + n_str(nbytes) + " uncompressed bytes, not the " +
                 n_str(expected) + " its values take");
        if (cbytes != uint64_t(size))
            fail(node() + "'s Blosc header says " + n_str(cbytes) + " compressed bytes, but the chunk holds " +
                 n_str(size));
        skip(size - kBloscHeader, "Blosc chunk");
    }

    // ---- buffers ----

    void buffers()
    {
        const bool old = version_ < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION;
        for (size_t i = 0; i < leaves_.size(); ++i) {
            const Leaf &leaf = leaves_[i];
            node_ = Node::Leaf;
            node_index_ = int64_t(i);
            node_origin_ = leaf.origin;
            skip(64, "value mask");
            int8_t buffer_count = 1;
            if (old) {
                // OpenVDB overwrites the leaf's origin with this one: it must be the one the
                // topology gave the leaf, or the leaf lands elsewhere (even past int32)
                int32_t v[3];
                read(v, 12, "origin");
                if (Coord(v[0], v[1], v[2]) != leaf.origin)
                    fail(node() + "'s buffer says it is at " + coord_str(Coord(v[0], v[1], v[2])));
                read(&buffer_count, 1, "buffer count");
            }
            compressed_values(openvdb::tree::LeafNode<float, 3>::SIZE, leaf.active, 64);
            // auxiliary buffers of old files: all 512 values, zlib-compressed when the file is
            for (int b = 1; b < buffer_count; ++b)
                chunk(512 * elem_bytes_, compression_ & openvdb::io::COMPRESS_ZIP);
        }
    }

    const std::string &path_;
    const GridEntry &g_;
    ByteReader &in_;
    const uint32_t version_;
    uint32_t compression_ = 0;
    const int64_t value_bytes_, elem_bytes_;
    const bool half_;
    int64_t limit_ = 0;   // end of the region being read: the block position, then the grid's end
    bool in_buffers_ = false;
    std::vector<Leaf> leaves_;
    std::vector<uint64_t> child5_, value5_, child4_, value4_;
    Node node_ = Node::Tree;
    int node_level_ = 5;
    int64_t node_index_ = 0;
    Coord node_origin_;
    bool key_read_ = false;   // the current root entry's key is known
};

} // namespace

void scan_grid_tree(const std::string &path, const FileScan &scan, const std::string &read_name)
{
    // What io::File::readGrid(name) reads: the descriptor findDescriptor picks, and for an
    // instance the parent it names (read as a grid of its own, so with its own compression,
    // metadata and type; a parent that is an instance itself brings no tree).
    const GridEntry *g = find_descriptor(scan, read_name);
    if (!g)
        return;   // io::File throws KeyError before reading anything
    const GridEntry *owner = g;
    if (g->instance) {
        owner = find_descriptor(scan, openvdb::io::GridDescriptor::nameAsString(g->parent));
        if (!owner || owner->instance)
            return;   // OpenVDB throws for a missing parent; an instance's own tree is empty
        if (owner->grid_type != g->grid_type)
            throw ScanError{VSD_ERR_FORMAT, corrupt(path, "grid '" + g->name + "' shares the tree of grid '" +
                                                              owner->name + "', which has another type (" +
                                                              owner->grid_type + ", not " + g->grid_type + ")")};
    }
    const ValueLayout *layout = layout_for(owner->grid_type);
    if (!layout) {
        if (!openvdb::GridBase::isRegistered(owner->grid_type))
            return;   // io::File::createGrid throws before reading
        throw ScanError{VSD_ERR_UNSUPPORTED,
                        path + ": grid '" + owner->name + "' is a " + owner->grid_type +
                            " grid, whose tree vsd cannot check before OpenVDB reads it"};
    }
    const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        throw ScanError{VSD_ERR_IO, path + ": cannot open: " + std::strerror(errno)};
    struct stat sb;
    if (fstat(fd, &sb) != 0 || int64_t(sb.st_size) != scan.size) {
        close(fd);
        throw ScanError{VSD_ERR_IO, path + ": the file changed while it was being read"};
    }
    try {
        ByteReader in(fd, scan.size);
        TreeWalk(path, scan, *owner, *layout, in).run();
    } catch (...) {
        close(fd);
        throw;
    }
    close(fd);
}

} // namespace vsd_vdbio
