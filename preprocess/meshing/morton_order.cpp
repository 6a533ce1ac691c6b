#include "preprocess/meshing/morton_order.hpp"

#include <algorithm>
#include <numeric>

namespace mat {
namespace {

    constexpr int k_bits_per_axis = 21;

    /// Spreads the low 21 bits of x so that bit i moves to bit 3i.
    std::uint64_t spread_bits(std::uint64_t x)
    {
        x &= 0x1fffffULL;
        x = (x | (x << 32)) & 0x1f00000000ffffULL;
        x = (x | (x << 16)) & 0x1f0000ff0000ffULL;
        x = (x | (x << 8)) & 0x100f00f00f00f00fULL;
        x = (x | (x << 4)) & 0x10c30c30c30c30c3ULL;
        x = (x | (x << 2)) & 0x1249249249249249ULL;
        return x;
    }

    std::uint64_t quantize(double value, double lower, double extent)
    {
        constexpr double cells = double((1u << k_bits_per_axis) - 1);
        const double unit = extent > 0.0 ? (value - lower) / extent : 0.0;
        return static_cast<std::uint64_t>(std::clamp(unit, 0.0, 1.0) * cells);
    }

} // namespace

std::vector<std::uint64_t> morton_keys(const Eigen::Ref<const MatX3>& points, const Box3& box)
{
    const Vec3 lower = box.min();
    const Vec3 extent = box.isEmpty() ? Vec3::Zero() : Vec3(box.max() - box.min());
    std::vector<std::uint64_t> keys(static_cast<std::size_t>(points.rows()));
    for (Index i = 0; i < points.rows(); ++i) {
        std::uint64_t key = 0;
        for (int axis = 0; axis < 3; ++axis)
            key |= spread_bits(quantize(points(i, axis), lower(axis), extent(axis))) << axis;
        keys[static_cast<std::size_t>(i)] = key;
    }
    return keys;
}

std::vector<int> morton_sort_order(const std::vector<std::uint64_t>& keys)
{
    std::vector<int> order(keys.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&keys](int a, int b) {
        return keys[static_cast<std::size_t>(a)] < keys[static_cast<std::size_t>(b)];
    });
    return order;
}

TetMesh morton_reorder(const TetMesh& mesh)
{
    const Index num_vertices = mesh.num_vertices();
    const Index num_tets = mesh.num_tets();
    Box3 box;
    box.setEmpty();
    for (Index v = 0; v < num_vertices; ++v)
        box.extend(mesh.positions.row(v).transpose());

    const std::vector<int> vertex_order = morton_sort_order(morton_keys(mesh.positions, box));
    std::vector<int> new_index(static_cast<std::size_t>(num_vertices));
    TetMesh result;
    result.positions.resize(num_vertices, 3);
    for (Index v = 0; v < num_vertices; ++v) {
        const int old = vertex_order[static_cast<std::size_t>(v)];
        new_index[static_cast<std::size_t>(old)] = static_cast<int>(v);
        result.positions.row(v) = mesh.positions.row(old);
    }

    MatX3 centroids(num_tets, 3);
    for (Index t = 0; t < num_tets; ++t) {
        Vec3 sum = Vec3::Zero();
        for (int k = 0; k < 4; ++k)
            sum += mesh.positions.row(mesh.tets(t, k)).transpose();
        centroids.row(t) = (sum / 4.0).transpose();
    }
    const std::vector<int> tet_order = morton_sort_order(morton_keys(centroids, box));
    result.tets.resize(num_tets, 4);
    for (Index t = 0; t < num_tets; ++t) {
        const int old = tet_order[static_cast<std::size_t>(t)];
        for (int k = 0; k < 4; ++k)
            result.tets(t, k) = new_index[static_cast<std::size_t>(mesh.tets(old, k))];
    }
    return result;
}

} // namespace mat
