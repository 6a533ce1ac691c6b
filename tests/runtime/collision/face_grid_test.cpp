// The narrow phase's face grid against a brute-force scan: on box sets whose sizes differ by
// orders of magnitude (filed in several levels), with per-column grows, with the allowed-position
// mask, with the later positions only and with non-finite boxes, every query visits exactly the
// boxes that overlap it, each once.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "runtime/collision/face_grid.hpp"

namespace mat {
namespace {

    /// `count` boxes in [0, 10]^3: most of size `small`, every `every`-th of a size up to
    /// `large`, spread over the log scale between them.
    std::vector<GridItem> mixed_boxes(
        unsigned seed, int count, double small, double large, int every)
    {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::vector<GridItem> items;
        for (int i = 0; i < count; ++i) {
            const double size
                = i % every == 0 ? small * std::pow(large / small, u(rng)) : small * (0.5 + u(rng));
            const Vec3 corner(10.0 * u(rng), 10.0 * u(rng), 10.0 * u(rng));
            const Vec3 sizes(size * u(rng), size * u(rng), size * (0.2 + u(rng)));
            items.push_back({ Box3(corner, corner + sizes), 1000 + i, 0 });
        }
        return items;
    }

    bool overlaps(const Box3& a, const Box3& b)
    {
        return (a.min().array() <= b.max().array()).all()
            && (b.min().array() <= a.max().array()).all();
    }

    /// The visits of one query, as (index, position), sorted; each position's item must carry
    /// the index visited.
    template <class Query>
    std::vector<std::pair<int, int>> visits(const FaceGrid& grid, const Query& query)
    {
        std::vector<std::pair<int, int>> seen;
        query([&](int index, int position) {
            EXPECT_EQ(grid.at(static_cast<std::size_t>(position)).index, index);
            seen.emplace_back(index, position);
        });
        std::sort(seen.begin(), seen.end());
        return seen;
    }

    std::vector<std::pair<int, int>> brute_force(const FaceGrid& grid, const Box3& query,
        const std::vector<double>& grow_of_column, const std::uint64_t* allowed)
    {
        std::vector<std::pair<int, int>> expected;
        for (std::size_t k = 0; k < grid.items.size(); ++k) {
            const GridItem& item = grid.at(k);
            const double grow = grow_of_column[static_cast<std::size_t>(item.column)];
            if (!(grow >= 0.0))
                continue;
            if (allowed != nullptr && ((allowed[k / 64] >> (k % 64)) & 1u) == 0)
                continue;
            const Box3 grown(query.min().array() - grow, query.max().array() + grow);
            if (overlaps(item.box, grown))
                expected.emplace_back(item.index, static_cast<int>(k));
        }
        std::sort(expected.begin(), expected.end());
        return expected;
    }

    void check_queries(FaceGrid& grid, unsigned seed, int queries)
    {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        for (int axis = 0; axis < 3; ++axis) {
            grid.build(axis);
            // The columns are numbered in filed order, each holding its items' positions.
            for (int c = 0; c < grid.num_columns(); ++c)
                for (int k = grid.column_begin(c); k < grid.column_begin(c + 1); ++k)
                    ASSERT_EQ(grid.at(static_cast<std::size_t>(k)).column, c);
            const std::size_t n = grid.items.size();
            std::vector<std::uint64_t> allowed((n + 63) / 64);
            for (std::uint64_t& word : allowed)
                word = (static_cast<std::uint64_t>(rng()) << 32) ^ rng();
            for (int q = 0; q < queries; ++q) {
                const Vec3 at(10.0 * u(rng), 10.0 * u(rng), 10.0 * u(rng));
                const Box3 box(at, at + Vec3(0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng)));
                const double max_grow = q % 4 == 0 ? 2.0 * u(rng) : 0.1 * u(rng);
                std::vector<double> grow_of(static_cast<std::size_t>(grid.num_columns()));
                for (double& g : grow_of)
                    g = u(rng) < 0.2 ? -1.0 : max_grow * u(rng);
                const auto grow = [&](int c) { return grow_of[static_cast<std::size_t>(c)]; };
                const auto plain = visits(
                    grid, [&](const auto& visit) { grid.overlapping(box, max_grow, grow, visit); });
                ASSERT_EQ(plain, brute_force(grid, box, grow_of, nullptr))
                    << "axis " << axis << " query " << q;
                const auto masked = visits(grid, [&](const auto& visit) {
                    grid.overlapping_allowed(box, max_grow, grow, allowed.data(), visit);
                });
                ASSERT_EQ(masked, brute_force(grid, box, grow_of, allowed.data()))
                    << "axis " << axis << " query " << q;
                // The later positions only, without a grow, allowed by the words.
                const int after = static_cast<int>(u(rng) * static_cast<double>(n)) - 1;
                const auto words = [&](int w) { return allowed[static_cast<std::size_t>(w)]; };
                const auto later = visits(grid,
                    [&](const auto& visit) { grid.overlapping_after(box, after, words, visit); });
                std::vector<std::pair<int, int>> expected = brute_force(
                    grid, box, std::vector<double>(grow_of.size(), 0.0), allowed.data());
                expected.erase(std::remove_if(expected.begin(), expected.end(),
                                   [&](const auto& hit) { return hit.second <= after; }),
                    expected.end());
                ASSERT_EQ(later, expected) << "axis " << axis << " query " << q;
            }
        }
    }

    TEST(FaceGrid, UniformBoxesVisitExactlyTheOverlappingOnes)
    {
        FaceGrid grid;
        grid.items = mixed_boxes(1, 3000, 0.05, 0.05, 1);
        check_queries(grid, 11, 400);
    }

    TEST(FaceGrid, BoxesOfManySizesVisitExactlyTheOverlappingOnes)
    {
        // Sizes from 0.02 to 8: several levels, the largest in the last.
        FaceGrid grid;
        grid.items = mixed_boxes(2, 3000, 0.02, 8.0, 7);
        check_queries(grid, 12, 400);
    }

    TEST(FaceGrid, PointAndNonFiniteBoxesAreFiledAndFound)
    {
        FaceGrid grid;
        grid.items = mixed_boxes(3, 500, 0.05, 3.0, 5);
        // Point boxes (size 0, as many as the others: the median size is 0) and a box with a NaN
        // corner, which overlaps nothing but must not break the filing of the others.
        for (int i = 0; i < 600; ++i) {
            const Vec3 x(0.01 * i, 5.0, 5.0);
            grid.items.push_back({ Box3(x, x), 5000 + i, 0 });
        }
        const double nan = std::numeric_limits<double>::quiet_NaN();
        grid.items.push_back({ Box3(Vec3(nan, 1.0, 1.0), Vec3(nan, 2.0, 2.0)), 9000, 0 });
        check_queries(grid, 13, 300);
    }

    // Each item looking up the later ones (all allowed) finds every overlapping pair of items
    // exactly once: the self search of one body's triangles.
    TEST(FaceGrid, LaterItemsGiveEachOverlappingPairOnce)
    {
        FaceGrid grid;
        grid.items = mixed_boxes(4, 1500, 0.6, 3.0, 9);
        const auto every = [](int) { return ~std::uint64_t { 0 }; };
        for (int axis = 0; axis < 3; ++axis) {
            grid.build(axis);
            const int n = static_cast<int>(grid.items.size());
            std::vector<std::pair<int, int>> found, expected;
            for (int k = 0; k < n; ++k) {
                grid.overlapping_after(grid.at(static_cast<std::size_t>(k)).box, k, every,
                    [&](int, int at) { found.emplace_back(std::min(k, at), std::max(k, at)); });
                for (int j = k + 1; j < n; ++j)
                    if (overlaps(grid.at(static_cast<std::size_t>(k)).box,
                            grid.at(static_cast<std::size_t>(j)).box))
                        expected.emplace_back(k, j);
            }
            std::sort(found.begin(), found.end());
            EXPECT_GT(expected.size(), 500u);
            EXPECT_EQ(found, expected) << "axis " << axis;
        }
    }

    TEST(FaceGrid, AnEmptyGridVisitsNothing)
    {
        FaceGrid grid;
        grid.build(1);
        int seen = 0;
        grid.overlapping(Box3(Vec3::Zero(), Vec3::Ones()), 1.0, [&](int, int) { ++seen; });
        EXPECT_EQ(seen, 0);
        EXPECT_EQ(grid.num_columns(), 0);
    }

} // namespace
} // namespace mat
