// Writes the small .vdb seeds of tests/fuzz/corpus/vdb (run by tests/fuzz/seeds/make_seeds.sh):
// tiny grids (voxels inside one leaf at the origin, so one node per tree level) that cover what real files hold, so each fuzz input costs microseconds,
// not the milliseconds a 300 KB Mantaflow cache costs: float / double / half grids, zip,
// blosc and no compression, active tiles, several grids (shared names), a vec3 grid, an
// empty grid, a non-uniform transform and an instanced (shared-tree) grid.
#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <string>

using namespace openvdb;

static FloatGrid::Ptr ball(const std::string &name, int r, float v)
{
    FloatGrid::Ptr g = FloatGrid::create(0.0f);
    auto acc = g->getAccessor();
    for (int x = -r; x <= r; ++x)
        for (int y = -r; y <= r; ++y)
            for (int z = -r; z <= r; ++z)
                if (x * x + y * y + z * z <= r * r) acc.setValue(Coord(x + 4, y + 4, z + 4), v * float(r * r - x * x - y * y - z * z + 1));
    g->setName(name);
    g->setGridClass(GRID_FOG_VOLUME);
    g->setTransform(math::Transform::createLinearTransform(0.1));
    return g;
}

static void save(const std::string &path, const GridPtrVec &grids, uint32_t comp)
{
    io::File f(path);
    f.setCompression(comp);
    f.write(grids);
    f.close();
}

int main(int argc, char **argv)
{
    const std::string dir = argc > 1 ? argv[1] : ".";
    initialize();
    save(dir + "/ball_zip.vdb", {ball("density", 3, 0.1f)}, io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK);
    save(dir + "/ball_none.vdb", {ball("density", 2, 0.5f)}, io::COMPRESS_NONE);
    save(dir + "/ball_blosc.vdb", {ball("smoke", 3, 0.2f)}, io::COMPRESS_BLOSC);
    {
        FloatGrid::Ptr g = ball("density", 2, 1.0f);
        g->setSaveFloatAsHalf(true);
        save(dir + "/ball_half.vdb", {g}, io::COMPRESS_ACTIVE_MASK);
    }
    {
        DoubleGrid::Ptr g = DoubleGrid::create(0.0);
        g->tree().setValue(Coord(1, 2, 3), 0.75);
        g->tree().setValue(Coord(6, 0, 4), 2.0);
        g->setName("density");
        save(dir + "/double.vdb", {g}, io::COMPRESS_ZIP);
    }
    {
        // an active tile above leaf level (Mantaflow's 'shadow' grids hold these)
        FloatGrid::Ptr g = FloatGrid::create(0.0f);
        g->tree().addTile(1, Coord(0, 0, 0), 0.5f, true);
        g->tree().setValue(Coord(20, 0, 0), 1.0f);
        g->setName("density");
        save(dir + "/tile.vdb", {g}, io::COMPRESS_ACTIVE_MASK);
    }
    {
        FloatGrid::Ptr a = ball("density", 1, 1.0f), b = ball("density", 2, 0.5f);
        Vec3SGrid::Ptr v = Vec3SGrid::create(Vec3s(0));
        v->tree().setValue(Coord(0, 0, 0), Vec3s(1, 2, 3));
        v->setName("velocity");
        FloatGrid::Ptr e = FloatGrid::create(0.0f);
        e->setName("flame");
        save(dir + "/multi.vdb", {v, a, b, e}, io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK);
    }
    {
        FloatGrid::Ptr g = ball("density", 2, 1.0f);
        math::Mat4d m = math::Mat4d::identity();
        m.preScale(Vec3d(0.1, 0.2, 0.05));
        m.preRotate(math::Z_AXIS, 0.3);
        m.postTranslate(Vec3d(1, -2, 0.5));
        g->setTransform(math::Transform::createLinearTransform(m));
        FloatGrid::Ptr t = ball("temperature", 1, 300.0f);
        save(dir + "/affine_temp.vdb", {g, t}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);
    }
    {
        FloatGrid::Ptr g = ball("density", 1, 1.0f);
        GridBase::Ptr inst = g->copyGrid(); // shares the tree: written as an instance
        inst->setName("density_copy");
        save(dir + "/instance.vdb", {g, inst}, io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK);
    }
    {
        Int32Grid::Ptr g = Int32Grid::create(0);
        g->tree().setValue(Coord(0, 0, 0), 7);
        g->setName("obstacles");
        save(dir + "/int32.vdb", {g}, io::COMPRESS_ACTIVE_MASK);
    }
    return 0;
}
