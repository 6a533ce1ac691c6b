#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "common/union_find.hpp"

namespace mat {
namespace {

    TEST(UnionFind, RootsAreTheSmallestElements)
    {
        UnionFind sets(6);
        EXPECT_EQ(sets.size(), 6);
        for (Index i = 0; i < 6; ++i)
            EXPECT_EQ(sets.find(i), i);
        sets.unite(5, 3);
        sets.unite(4, 1);
        sets.unite(3, 4);
        EXPECT_EQ(sets.find(5), 1);
        EXPECT_EQ(sets.find(3), 1);
        EXPECT_EQ(sets.find(4), 1);
        EXPECT_EQ(sets.find(0), 0);
        EXPECT_EQ(sets.find(2), 2);
        sets.unite(1, 1);
        EXPECT_EQ(sets.find(1), 1);
    }

    // Against a brute-force labelling: merge two labels by relabelling every element.
    TEST(UnionFind, MatchesBruteForceOnRandomMerges)
    {
        std::mt19937 rng(7);
        const Index n = 200;
        std::uniform_int_distribution<Index> pick(0, n - 1);
        UnionFind sets(n);
        std::vector<Index> label(n);
        for (Index i = 0; i < n; ++i)
            label[i] = i;
        for (int step = 0; step < 150; ++step) {
            const Index a = pick(rng), b = pick(rng);
            sets.unite(a, b);
            const Index from = std::max(label[a], label[b]), to = std::min(label[a], label[b]);
            for (Index& l : label)
                if (l == from)
                    l = to;
            if (step % 10 == 0)
                for (Index i = 0; i < n; ++i)
                    ASSERT_EQ(sets.find(i), label[i]) << "step " << step << " element " << i;
        }
    }

} // namespace
} // namespace mat
