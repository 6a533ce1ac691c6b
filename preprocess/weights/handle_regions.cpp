#include "preprocess/weights/handle_regions.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "common/error.hpp"

namespace mat {

VecXi assign_handle_regions(const Eigen::Ref<const MatX3>& rest_positions,
    const Eigen::Ref<const MatX3>& centers, const Eigen::Ref<const VecX>& radii, double alpha)
{
    const Index n = rest_positions.rows();
    const Index m = centers.rows();
    MAT_CHECK(radii.size() == m, "{} radii for {} handle centers", radii.size(), m);
    if (!(alpha > 0.0) || !std::isfinite(alpha))
        throw_error("handle regions: alpha must be > 0, got {}", alpha);
    if (m > n)
        throw_error("handle regions: {} handles but only {} tet-mesh nodes", m, n);
    for (Index j = 0; j < m; ++j)
        if (!(radii[j] > 0.0) || !std::isfinite(radii[j]) || !centers.row(j).allFinite())
            throw_error(
                "handle regions: handle {} has radius {} (must be finite and > 0)", j, radii[j]);

    // Steps 1-2: each node picks, among the balls containing it, the smallest relative distance.
    VecXi owner = VecXi::Constant(n, -1);
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, n, 256), [&](const tbb::blocked_range<Index>& range) {
            for (Index i = range.begin(); i < range.end(); ++i) {
                double best = std::numeric_limits<double>::infinity();
                for (Index j = 0; j < m; ++j) {
                    const double relative
                        = (rest_positions.row(i) - centers.row(j)).norm() / radii[j];
                    if (relative <= alpha && relative < best) {
                        best = relative;
                        owner[i] = static_cast<int>(j);
                    }
                }
            }
        });

    // Step 3: empty handles, in index order, take their nearest node unless it is the only node
    // of another region. One always exists: m <= #V, so if every node is owned some region
    // has two.
    VecXi count = VecXi::Zero(m);
    for (Index i = 0; i < n; ++i)
        if (owner[i] >= 0)
            ++count[owner[i]];
    for (Index j = 0; j < m; ++j) {
        if (count[j] > 0)
            continue;
        Index nearest = -1;
        double best = std::numeric_limits<double>::infinity();
        for (Index i = 0; i < n; ++i) {
            if (owner[i] >= 0 && count[owner[i]] < 2)
                continue;
            const double distance = (rest_positions.row(i) - centers.row(j)).squaredNorm();
            if (distance < best) {
                best = distance;
                nearest = i;
            }
        }
        MAT_CHECK(nearest >= 0, "no node left for handle {}", j);
        if (owner[nearest] >= 0)
            --count[owner[nearest]];
        owner[nearest] = static_cast<int>(j);
        count[j] = 1;
    }
    return owner;
}

namespace {
    using TetChoice = std::pair<double, Index>; // (squared centroid distance, tet), lexicographic

    // The nearest tet (by centroid) for which `eligible(tet)` holds; tet -1 if none. The
    // lexicographic minimum does not depend on how TBB splits the range.
    template <typename Eligible>
    TetChoice nearest_tet(const MatX3& centroids, const Vec3& center, const Eligible& eligible)
    {
        const TetChoice none(std::numeric_limits<double>::infinity(), -1);
        return tbb::parallel_reduce(
            tbb::blocked_range<Index>(0, centroids.rows(), 4096), none,
            [&](const tbb::blocked_range<Index>& range, TetChoice best) {
                for (Index t = range.begin(); t < range.end(); ++t) {
                    const double d = (centroids.row(t).transpose() - center).squaredNorm();
                    if (TetChoice(d, t) < best && eligible(t))
                        best = TetChoice(d, t);
                }
                return best;
            },
            [](const TetChoice& a, const TetChoice& b) { return std::min(a, b); });
    }
} // namespace

bool spanning_nodes(const Eigen::Ref<const MatX3>& positions, const std::vector<Index>& nodes,
    std::array<Index, 4>& frame)
{
    if (nodes.size() < 4)
        return false;
    // Greedy: a node, the farthest from it, the farthest from their line, the farthest from
    // their plane; spanning when that tet's volume is not small against the first distance.
    const auto at = [&](Index i) -> Vec3 { return positions.row(i).transpose(); };
    const Vec3 p0 = at(nodes[0]);
    const auto farthest = [&](const auto& distance) {
        Index best = nodes[0];
        double best_distance = -1.0;
        for (const Index i : nodes) {
            const double d = distance(at(i));
            if (d > best_distance) {
                best_distance = d;
                best = i;
            }
        }
        return best;
    };
    const Index i1 = farthest([&](const Vec3& p) { return (p - p0).squaredNorm(); });
    const Vec3 e1 = at(i1) - p0;
    const Index i2 = farthest([&](const Vec3& p) { return e1.cross(p - p0).squaredNorm(); });
    const Vec3 normal = e1.cross(at(i2) - p0);
    const Index i3 = farthest([&](const Vec3& p) { return std::abs(normal.dot(p - p0)); });
    const double scale = e1.norm();
    frame = { nodes[0], i1, i2, i3 };
    return std::abs(normal.dot(at(i3) - p0)) > min_spanning_volume_ratio * scale * scale * scale;
}

WholeTetRegions give_every_region_a_tet(const Eigen::Ref<const VecXi>& region_owner,
    const Eigen::Ref<const MatX3>& rest_positions, const Eigen::Ref<const MatX4i>& tets,
    const Eigen::Ref<const MatX3>& centers)
{
    const Index n = rest_positions.rows();
    const Index m = centers.rows();
    MAT_CHECK(region_owner.size() == n, "{} region owners for {} nodes", region_owner.size(), n);
    MAT_CHECK(tets.size() == 0 || (tets.minCoeff() >= 0 && tets.maxCoeff() < n),
        "tet indices out of range");
    MatX3 centroids(tets.rows(), 3);
    for (Index t = 0; t < tets.rows(); ++t) {
        centroids.row(t).setZero();
        for (int c = 0; c < 4; ++c)
            centroids.row(t) += 0.25 * rest_positions.row(tets(t, c));
    }

    WholeTetRegions result;
    result.owner = region_owner;
    VecXi& owner = result.owner;
    // kept(i): the handle that keeps node i (its nearest whole tet, or else 4 spanning nodes of
    // its region, below), or -1.
    VecXi kept = VecXi::Constant(n, -1);
    std::vector<TetChoice> own(
        static_cast<size_t>(m), TetChoice(std::numeric_limits<double>::infinity(), -1));
    for (Index t = 0; t < tets.rows(); ++t) {
        const int j = owner[tets(t, 0)];
        if (j < 0 || owner[tets(t, 1)] != j || owner[tets(t, 2)] != j || owner[tets(t, 3)] != j)
            continue;
        MAT_CHECK(j < m, "node {} is assigned to handle {} of {}", tets(t, 0), j, m);
        const double d = (centroids.row(t) - centers.row(j)).squaredNorm();
        own[static_cast<size_t>(j)] = std::min(own[static_cast<size_t>(j)], TetChoice(d, t));
    }
    for (Index j = 0; j < m; ++j)
        if (own[static_cast<size_t>(j)].second >= 0)
            for (int c = 0; c < 4; ++c)
                kept[tets(own[static_cast<size_t>(j)].second, c)] = static_cast<int>(j);
    // A handle without a whole tet whose region still spans 3D keeps 4 spanning nodes instead
    // and is left alone (its weights, and so existing bakes, do not change).
    std::vector<std::vector<Index>> region_nodes(static_cast<size_t>(m));
    for (Index i = 0; i < n; ++i)
        if (owner[i] >= 0 && owner[i] < m)
            region_nodes[static_cast<size_t>(owner[i])].push_back(i);
    std::vector<char> needy(static_cast<size_t>(m), 0);
    for (Index j = 0; j < m; ++j) {
        if (own[static_cast<size_t>(j)].second >= 0)
            continue;
        std::array<Index, 4> frame {};
        if (spanning_nodes(rest_positions, region_nodes[static_cast<size_t>(j)], frame)) {
            for (const Index i : frame)
                kept[i] = static_cast<int>(j);
        } else {
            needy[static_cast<size_t>(j)] = 1;
        }
    }

    // Needy handles take the nearest tet free of kept nodes; their nodes leave other regions
    // (never another handle's kept nodes, so every handle keeps its frame).
    for (Index j = 0; j < m; ++j) {
        if (!needy[static_cast<size_t>(j)])
            continue;
        const Vec3 center = centers.row(j).transpose();
        const TetChoice choice = nearest_tet(centroids, center, [&](Index t) {
            return kept[tets(t, 0)] < 0 && kept[tets(t, 1)] < 0 && kept[tets(t, 2)] < 0
                && kept[tets(t, 3)] < 0;
        });
        if (choice.second < 0)
            throw_error("handle regions: no tet is left for handle {} (every tet touches another "
                        "handle's kept nodes; {} handles for {} tet-mesh nodes; the basis is "
                        "rank-deficient): use fewer spheres or a smaller --tet-size",
                j, m, n);
        for (int c = 0; c < 4; ++c) {
            owner[tets(choice.second, c)] = static_cast<int>(j);
            kept[tets(choice.second, c)] = static_cast<int>(j);
        }
        ++result.handles_given_tets;
    }
    return result;
}

} // namespace mat
