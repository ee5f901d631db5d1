// vdb_load.cpp — one OpenVDB grid into vsd_volume: its transform, and its leaves and active
// tiles copied into the brick pool of vsd/volume.h.
//
// load_grid runs only after vdb_file_scan.cpp and vdb_tree_scan.cpp have checked the file and
// the grid's tree: OpenVDB then reads the one grid (delayed loading off, so all data is read
// now, inside the caller's try block), and this file converts it, refusing trees that
// disagree with their stated voxel count or that would need a huge, nearly empty brick index.
// Kept apart from vdbio.cpp (selection, listing, the C API) because it is the only part that
// knows vsd's brick layout.
#include "vdb_load.h"

#include "vdb_scan.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <string>

namespace vsd_vdbio {
namespace {

using openvdb::GridBase;

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

// vsd's brick index is dense over the active bbox (12 bytes a cell, and
// vsd_volume_update_ranges visits every cell), while the data is only the bricks that hold
// voxels. A box that is both large and nearly empty is refused: a 10 KB file whose stated
// voxel count was unreadable and whose zero-valued tiles were flagged active spanned 66
// million cells for one brick of data, seconds of work (found by tests/fuzz/fuzz_vdb). Real
// grids hold a brick in every 1 to 3 cells (the shared data: at most 3, 7290 cells).
constexpr int64_t kSparseCells = int64_t(1) << 22;   // a 1290^3-voxel box, 48 MB of index
constexpr int64_t kCellsPerBrick = 64;

// Size the brick grid over the active bbox, with the low-side margin cell that the trilinear
// support needs when the bbox starts on a multiple of 8 (see core/src/volume/volume.c).
// `bricks` is how many bricks the data can fill (leaves and tile bricks).
vsd_status size_cells(vsd_volume *vol, const openvdb::CoordBBox &bbox, uint64_t bricks, std::string &why)
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
    if (cells > kSparseCells && uint64_t(cells) > uint64_t(kCellsPerBrick) * std::max<uint64_t>(1, bricks)) {
        why = "its active voxels span " + std::to_string(cells) + " brick cells, but only " + std::to_string(bricks) +
              " bricks hold data; vsd's dense brick index refuses a box of more than " +
              std::to_string(kSparseCells) + " cells with fewer than one brick in " + std::to_string(kCellsPerBrick);
        return VSD_ERR_UNSUPPORTED;
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
    const uint64_t bricks = uint64_t(tree.leafCount()) + tile_bricks(tree);
    vsd_status st = size_cells(vol, bbox, bricks, why);
    if (st != VSD_OK)
        return st;
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

} // namespace

// Read grid `g` through OpenVDB and convert it. Throws ScanError or OpenVDB/std exceptions.
openvdb::GridBase::Ptr read_checked_grid(openvdb::io::File &file, const std::string &path, const FileScan &scan,
                                         const GridEntry &g)
{
    scan_grid_tree(path, scan, lookup_name(g));
    return file.readGrid(lookup_name(g));
}

vsd_volume *load_grid(const std::string &path, const FileScan &scan, const GridEntry &g)
{
    openvdb::io::File file(path);
    file.open(false);   // no delayed loading: read (and fail) now, inside our try
    GridBase::Ptr base = read_checked_grid(file, path, scan, g);
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

} // namespace vsd_vdbio
