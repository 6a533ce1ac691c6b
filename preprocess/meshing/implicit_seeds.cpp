#include "preprocess/meshing/implicit_seeds.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <tuple>
#include <unordered_map>

#include <tbb/parallel_for.h>

namespace mat {

std::vector<SignChange> find_sign_changes(const std::function<double(const Vec3&)>& f,
    const Box3& bounds, double spacing, const Eigen::Ref<const MatX3>& interior_points,
    int max_cells)
{
    const Vec3 extent = bounds.max() - bounds.min();
    Eigen::Vector3i cells;
    for (int axis = 0; axis < 3; ++axis)
        cells(axis) = std::clamp(
            static_cast<int>(std::ceil(extent(axis) / spacing)), 2, std::max(2, max_cells));
    const Eigen::Vector3i nodes = cells.array() + 1;
    const Vec3 step = extent.cwiseQuotient(cells.cast<double>());
    const auto node_index = [&nodes](int i, int j, int k) {
        return (static_cast<Index>(k) * nodes(1) + j) * nodes(0) + i;
    };
    const auto node_position = [&](int i, int j, int k) {
        return Vec3(bounds.min() + Vec3(i, j, k).cwiseProduct(step));
    };

    std::vector<double> values(static_cast<std::size_t>(nodes.prod()));
    tbb::parallel_for(0, nodes(2), [&](int k) {
        for (int j = 0; j < nodes(1); ++j)
            for (int i = 0; i < nodes(0); ++i)
                values[static_cast<std::size_t>(node_index(i, j, k))] = f(node_position(i, j, k));
    });

    // First crossing edge of each 2 x 2 x 2 block, in scan order (the map keeps blocks sorted).
    std::map<std::tuple<int, int, int>, SignChange> blocks;
    for (int k = 0; k < nodes(2); ++k)
        for (int j = 0; j < nodes(1); ++j)
            for (int i = 0; i < nodes(0); ++i) {
                const double value = values[static_cast<std::size_t>(node_index(i, j, k))];
                const Eigen::Vector3i here(i, j, k);
                for (int axis = 0; axis < 3; ++axis) {
                    Eigen::Vector3i next = here;
                    ++next(axis);
                    if (next(axis) >= nodes(axis))
                        continue;
                    const double next_value
                        = values[static_cast<std::size_t>(node_index(next(0), next(1), next(2)))];
                    if ((value < 0.0) == (next_value < 0.0))
                        continue;
                    const auto key = std::make_tuple(k / 2, j / 2, i / 2);
                    if (blocks.count(key) != 0)
                        continue;
                    const Vec3 a = node_position(i, j, k);
                    const Vec3 b = node_position(next(0), next(1), next(2));
                    blocks.emplace(key, value < 0.0 ? SignChange { a, b } : SignChange { b, a });
                }
            }
    std::vector<SignChange> changes;
    changes.reserve(blocks.size() + 6 * static_cast<std::size_t>(interior_points.rows()));
    for (const auto& [key, change] : blocks)
        changes.push_back(change);

    // Rays from the interior points; each is independent, so compute them in parallel.
    std::vector<std::array<std::pair<bool, SignChange>, 6>> rays(
        static_cast<std::size_t>(interior_points.rows()));
    const double march = 0.5 * spacing;
    tbb::parallel_for(Index(0), interior_points.rows(), [&](Index p) {
        const Vec3 origin = interior_points.row(p).transpose();
        auto& found = rays[static_cast<std::size_t>(p)];
        for (auto& ray : found)
            ray.first = false;
        if (!(f(origin) < 0.0))
            return;
        for (int direction = 0; direction < 6; ++direction) {
            Vec3 unit = Vec3::Zero();
            unit(direction / 2) = direction % 2 == 0 ? 1.0 : -1.0;
            Vec3 inside = origin;
            for (int s = 1;; ++s) {
                const Vec3 x = origin + (s * march) * unit;
                if (!bounds.contains(x))
                    break;
                if (f(x) > 0.0) {
                    found[static_cast<std::size_t>(direction)] = { true, SignChange { inside, x } };
                    break;
                }
                inside = x;
            }
        }
    });
    for (const auto& found : rays)
        for (const auto& [ok, change] : found)
            if (ok)
                changes.push_back(change);
    return changes;
}

std::vector<int> thin_out_points(const Eigen::Ref<const MatX3>& points, double min_distance)
{
    // A hash grid of cell size min_distance: a point closer than min_distance to a kept one
    // lies in one of the 27 cells around it.
    const auto cell_of = [min_distance](const Vec3& p) {
        return Eigen::Vector3i((p / min_distance).array().floor().cast<int>());
    };
    const auto key_of = [](const Eigen::Vector3i& c) {
        return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c(0))) * 73856093u)
            ^ (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c(1))) * 19349663u)
            ^ (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c(2))) * 83492791u);
    };
    std::unordered_multimap<std::uint64_t, int> grid;
    std::vector<int> kept;
    const double squared = min_distance * min_distance;
    for (Index i = 0; i < points.rows(); ++i) {
        const Vec3 p = points.row(i).transpose();
        const Eigen::Vector3i cell = cell_of(p);
        bool near = false;
        for (int dz = -1; dz <= 1 && !near; ++dz)
            for (int dy = -1; dy <= 1 && !near; ++dy)
                for (int dx = -1; dx <= 1 && !near; ++dx) {
                    const auto range = grid.equal_range(key_of(cell + Eigen::Vector3i(dx, dy, dz)));
                    for (auto it = range.first; it != range.second && !near; ++it)
                        near = (points.row(it->second).transpose() - p).squaredNorm() < squared;
                }
        if (near)
            continue;
        grid.emplace(key_of(cell), static_cast<int>(i));
        kept.push_back(static_cast<int>(i));
    }
    return kept;
}

} // namespace mat
