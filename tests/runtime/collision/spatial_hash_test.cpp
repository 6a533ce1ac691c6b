// The spatial hash against the O(n^2) reference on random box sets (sizes over many orders of
// magnitude, huge and tiny and empty boxes, far-apart clusters), its memory bound, the self-pair
// filter and its independence of the thread count.

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "common/parallel.hpp"
#include "runtime/collision/spatial_hash.hpp"
#include "tests/support/error_checks.hpp"

namespace mat {
namespace {

    struct RandomBoxOptions {
        int count = 600;
        int bodies = 3;
        int spheres = 200; ///< pool of sphere indices per body
        double spread = 10.0; ///< boxes placed in [0, spread]^3
        double min_size = 1e-3;
        double max_size = 1.0;
        int huge = 0; ///< boxes of size 10 x spread
        int tiny = 0; ///< boxes of size 1e-9
        int points = 0; ///< zero-size boxes
        int empty = 0; ///< empty boxes
        unsigned seed = 1;
    };

    BroadPhaseItem random_item(std::mt19937& rng, const RandomBoxOptions& o, double size)
    {
        std::uniform_real_distribution<double> u(0.0, 1.0);
        BroadPhaseItem item;
        const Vec3 corner(u(rng) * o.spread, u(rng) * o.spread, u(rng) * o.spread);
        const Vec3 sizes(size * (0.5 + u(rng)), size * (0.5 + u(rng)), size * (0.5 + u(rng)));
        item.box = Box3(corner, corner + sizes);
        item.body = static_cast<int>(rng() % static_cast<unsigned>(o.bodies));
        const int used = 1 + static_cast<int>(rng() % 3u);
        for (int k = 0; k < used; ++k)
            item.spheres[static_cast<std::size_t>(k)]
                = static_cast<int>(rng() % static_cast<unsigned>(o.spheres));
        return item;
    }

    std::vector<BroadPhaseItem> random_items(const RandomBoxOptions& o)
    {
        std::mt19937 rng(o.seed);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::vector<BroadPhaseItem> items;
        for (int i = 0; i < o.count; ++i) {
            // Log-uniform sizes between min_size and max_size.
            const double size = o.min_size * std::pow(o.max_size / o.min_size, u(rng)) / 1.0;
            items.push_back(random_item(rng, o, size));
        }
        for (int i = 0; i < o.huge; ++i)
            items.push_back(random_item(rng, o, 10.0 * o.spread));
        for (int i = 0; i < o.tiny; ++i)
            items.push_back(random_item(rng, o, 1e-9));
        for (int i = 0; i < o.points; ++i) {
            BroadPhaseItem item = random_item(rng, o, 1.0);
            item.box = Box3(item.box.min(), item.box.min());
            items.push_back(item);
        }
        for (int i = 0; i < o.empty; ++i) {
            BroadPhaseItem item = random_item(rng, o, 1.0);
            item.box = Box3(); // Eigen's empty box
            items.push_back(item);
        }
        std::shuffle(items.begin(), items.end(), rng);
        return items;
    }

    std::vector<ItemPair> hash_pairs(
        const std::vector<BroadPhaseItem>& items, const SpatialHashSettings& settings = {})
    {
        SpatialHash hash(settings);
        hash.build(items);
        return hash.pairs();
    }

    TEST(SpatialHash, RandomBoxesMatchAllPairs)
    {
        for (unsigned seed = 1; seed <= 6; ++seed) {
            RandomBoxOptions o;
            o.seed = seed;
            o.spread = 3.0;
            o.huge = static_cast<int>(seed % 3);
            o.tiny = 20;
            o.points = 10;
            o.empty = 5;
            const std::vector<BroadPhaseItem> items = random_items(o);
            const std::vector<ItemPair> expected = all_pairs_boxes(items);
            EXPECT_GT(expected.size(), 500u) << "seed " << seed;
            EXPECT_EQ(hash_pairs(items), expected) << "seed " << seed;
        }
    }

    TEST(SpatialHash, WithoutSelfPairsOnlyPairsOfDifferentBodies)
    {
        for (unsigned seed = 1; seed <= 3; ++seed) {
            RandomBoxOptions o;
            o.seed = seed;
            o.spread = 3.0;
            o.huge = static_cast<int>(seed % 2); // oversize items too
            const std::vector<BroadPhaseItem> items = random_items(o);
            std::vector<ItemPair> expected;
            for (const ItemPair& pair : all_pairs_boxes(items))
                if (items[static_cast<std::size_t>(pair.first)].body
                    != items[static_cast<std::size_t>(pair.second)].body)
                    expected.push_back(pair);
            SpatialHashSettings settings;
            settings.self_pairs = false;
            const std::vector<ItemPair> pairs = hash_pairs(items, settings);
            EXPECT_GT(expected.size(), 100u) << "seed " << seed;
            EXPECT_LT(expected.size(), all_pairs_boxes(items).size()) << "seed " << seed;
            EXPECT_EQ(pairs, expected) << "seed " << seed;

            // Items numbered body by body (as the collision world does): the scan skips the
            // entries of the item's own body.
            std::vector<BroadPhaseItem> body_major = items;
            std::stable_sort(body_major.begin(), body_major.end(),
                [](const BroadPhaseItem& a, const BroadPhaseItem& b) { return a.body < b.body; });
            ASSERT_NE(body_major.front().body, body_major.back().body);
            std::vector<ItemPair> expected_major;
            for (const ItemPair& pair : all_pairs_boxes(body_major))
                if (body_major[static_cast<std::size_t>(pair.first)].body
                    != body_major[static_cast<std::size_t>(pair.second)].body)
                    expected_major.push_back(pair);
            EXPECT_EQ(expected_major.size(), expected.size()) << "seed " << seed;
            EXPECT_EQ(hash_pairs(body_major, settings), expected_major) << "seed " << seed;
        }
    }

    TEST(SpatialHash, ManyCellSizesAndLimits)
    {
        RandomBoxOptions o;
        o.count = 400;
        o.min_size = 1e-2;
        o.max_size = 3.0;
        o.spread = 5.0;
        o.seed = 7;
        const std::vector<BroadPhaseItem> items = random_items(o);
        const std::vector<ItemPair> expected = all_pairs_boxes(items);
        for (const double factor : { 0.1, 0.5, 1.0, 2.0, 8.0 })
            for (const int max_cells : { 1, 8, 64, 512 }) {
                SpatialHashSettings settings;
                settings.cell_size_factor = factor;
                settings.max_cells_per_item = max_cells;
                EXPECT_EQ(hash_pairs(items, settings), expected)
                    << "factor " << factor << " max cells " << max_cells;
            }
        SpatialHashSettings fixed;
        fixed.cell_size = 0.37;
        SpatialHash hash(fixed);
        hash.build(items);
        EXPECT_EQ(hash.cell_size(), 0.37);
        EXPECT_EQ(hash.pairs(), expected);
    }

    TEST(SpatialHash, FarApartClustersKeepTheTableBounded)
    {
        RandomBoxOptions o;
        o.count = 300;
        o.spread = 2.0;
        o.seed = 11;
        std::vector<std::size_t> table_sizes;
        for (const double distance : { 0.0, 1e3, 1e9, 1e15, 1e30 }) {
            std::vector<BroadPhaseItem> items = random_items(o);
            // Half of the items (every other one) move to a second cluster far away; moving
            // by huge distances rounds the coordinates, which the reference sees alike.
            for (std::size_t i = 0; i < items.size(); i += 2)
                items[i].box.translate(Vec3(distance, -0.5 * distance, distance));
            SpatialHash hash;
            hash.build(items);
            EXPECT_EQ(hash.pairs(), all_pairs_boxes(items)) << "distance " << distance;
            // The table follows the number of entries (<= 64 per item), not the spread.
            EXPECT_LE(hash.num_entries(), 64u * items.size());
            EXPECT_LE(hash.table_size(), 4u * 64u * items.size());
            table_sizes.push_back(hash.table_size());
        }
        for (const std::size_t size : table_sizes)
            EXPECT_LE(size, 2 * table_sizes.front());
    }

    TEST(SpatialHash, HugeCoordinatesGoToTheOversizeList)
    {
        std::vector<BroadPhaseItem> items(4);
        items[0].box = Box3(Vec3::Zero(), Vec3::Constant(1.0));
        items[1].box = Box3(Vec3::Constant(0.5), Vec3::Constant(1.5));
        items[2].box = Box3(Vec3::Constant(1e300), Vec3::Constant(2e300));
        const double inf = std::numeric_limits<double>::infinity();
        items[3].box = Box3(Vec3::Constant(-inf), Vec3::Constant(inf));
        for (int i = 0; i < 4; ++i)
            items[static_cast<std::size_t>(i)].body = i;
        SpatialHash hash;
        hash.build(items);
        EXPECT_EQ(hash.num_oversize(), 2u);
        const std::vector<ItemPair> expected = { { 0, 1 }, { 0, 3 }, { 1, 3 }, { 2, 3 } };
        EXPECT_EQ(hash.pairs(), expected);
        EXPECT_EQ(all_pairs_boxes(items), expected);
    }

    TEST(SpatialHash, SelfPairsOnlyBetweenPrimitivesSharingNoSphere)
    {
        // Five boxes that all overlap.
        std::vector<BroadPhaseItem> items(5);
        for (auto& item : items)
            item.box = Box3(Vec3::Zero(), Vec3::Ones());
        items[0] = { items[0].box, 0, 0, { 0, 1, -1 } }; // cone 0-1
        items[1] = { items[1].box, 0, 1, { 1, 2, 3 } }; // slab sharing sphere 1 with item 0
        items[2] = { items[2].box, 0, 2, { 4, 5, -1 } }; // cone 4-5: shares nothing
        items[3] = { items[3].box, 1, 0, { 0, 1, -1 } }; // other body, same sphere indices
        items[4] = { items[4].box, 0, 3, { -1, -1, -1 } }; // no spheres: -1 is never shared
        EXPECT_FALSE(broad_phase_pair_allowed(items[0], items[1]));
        EXPECT_TRUE(broad_phase_pair_allowed(items[0], items[2]));
        EXPECT_TRUE(broad_phase_pair_allowed(items[0], items[3]));
        const std::vector<ItemPair> expected = { { 0, 2 }, { 0, 3 }, { 0, 4 }, { 1, 2 }, { 1, 3 },
            { 1, 4 }, { 2, 3 }, { 2, 4 }, { 3, 4 } };
        EXPECT_EQ(hash_pairs(items), expected);
        EXPECT_EQ(all_pairs_boxes(items), expected);
    }

    TEST(SpatialHash, TouchingBoxesArePairs)
    {
        std::vector<BroadPhaseItem> items(3);
        items[0].box = Box3(Vec3::Zero(), Vec3::Ones());
        items[1].box = Box3(Vec3(1.0, 1.0, 1.0), Vec3(2.0, 2.0, 2.0)); // corner contact
        items[2].box = Box3(Vec3(2.0 + 1e-12, 0.0, 0.0), Vec3(3.0, 1.0, 1.0)); // a gap
        items[1].body = 1;
        items[2].body = 2;
        const std::vector<ItemPair> expected = { { 0, 1 } };
        EXPECT_EQ(hash_pairs(items), expected);
    }

    TEST(SpatialHash, ResultIndependentOfThreadCountAndReusedBuffers)
    {
        RandomBoxOptions o;
        o.count = 3000;
        o.spread = 20.0;
        o.seed = 5;
        o.huge = 1;
        const std::vector<BroadPhaseItem> items = random_items(o);
        const std::vector<ItemPair> expected = all_pairs_boxes(items);

        SpatialHashSettings parallel;
        parallel.parallel_threshold = 0;
        SpatialHash hash(parallel);
        std::vector<ItemPair> out;
        for (const int threads : { 1, 2, 0 }) {
            set_threads(threads);
            hash.build(items);
            hash.pairs(out);
            EXPECT_EQ(out, expected) << threads << " threads";
        }
        set_threads(0);

        // The same object on another set, then the first again.
        RandomBoxOptions small = o;
        small.count = 50;
        small.seed = 6;
        const std::vector<BroadPhaseItem> other = random_items(small);
        hash.build(other);
        EXPECT_EQ(hash.pairs(), all_pairs_boxes(other));
        hash.build(items);
        EXPECT_EQ(hash.pairs(), expected);
    }

    TEST(SpatialHash, DegenerateSets)
    {
        SpatialHash hash;
        hash.build({});
        EXPECT_TRUE(hash.pairs().empty());

        // All boxes are the same point: the cell size falls back to a positive value.
        std::vector<BroadPhaseItem> items(4);
        for (int i = 0; i < 4; ++i) {
            items[static_cast<std::size_t>(i)].box = Box3(Vec3::Ones(), Vec3::Ones());
            items[static_cast<std::size_t>(i)].body = i % 2;
        }
        hash.build(items);
        EXPECT_GT(hash.cell_size(), 0.0);
        EXPECT_EQ(hash.pairs(), all_pairs_boxes(items));
        EXPECT_EQ(hash.pairs().size(), 6u);
    }

    TEST(SpatialHash, NanBoxIsAnErrorNamingTheItem)
    {
        std::vector<BroadPhaseItem> items(3);
        items[2].box = Box3(Vec3::Zero(), Vec3(1.0, std::nan(""), 1.0));
        items[2].body = 4;
        items[2].primitive = 17;
        SpatialHash hash;
        std::vector<BroadPhaseItem> good(2);
        good[0].box = good[1].box = Box3(Vec3::Zero(), Vec3::Ones());
        good[1].body = 1;
        hash.build(good);
        test::expect_error_containing(
            [&] { hash.build(items); }, { "item 2", "body 4", "primitive 17", "NaN" });
        // The failed build left the previous one in place.
        EXPECT_EQ(hash.pairs(), std::vector<ItemPair>({ { 0, 1 } }));
    }

} // namespace
} // namespace mat
