// The contact responses' cache: a response is kept across steps while it fits the budget, the
// responses asked for longest ago are forgotten first, and those of the current step are kept
// whatever the budget.
#include <gtest/gtest.h>

#include "runtime/pd/response_cache.hpp"

namespace mat {
namespace {

    /// Asks for `node`'s column and fills it with node + 0.5 when it is fresh; returns fresh.
    bool ask(ResponseCache& cache, int node)
    {
        bool fresh = false;
        Eigen::Ref<VecX> column = cache.column(node, fresh);
        if (fresh)
            column.setConstant(node + 0.5);
        EXPECT_EQ(column(0), node + 0.5) << "node " << node;
        EXPECT_EQ(column(column.size() - 1), node + 0.5) << "node " << node;
        return fresh;
    }

    TEST(ResponseCache, KeepsResponsesAcrossStepsWithinTheBudget)
    {
        ResponseCache cache(1000, 7); // the default budget holds every node
        cache.begin_step();
        for (int node = 0; node < 100; ++node)
            EXPECT_TRUE(ask(cache, node));
        for (int step = 0; step < 3; ++step) {
            cache.begin_step();
            // Nodes not asked for in the last steps are still there.
            EXPECT_FALSE(ask(cache, 99 - step));
            EXPECT_FALSE(ask(cache, step));
        }
        EXPECT_EQ(cache.kept(), 100);
    }

    TEST(ResponseCache, ForgetsTheLeastRecentlyAskedBeyondTheBudget)
    {
        // 8 rows of doubles: a budget of 64 columns' bytes holds 64 responses.
        ResponseCache cache(1000, 8, 64 * 8 * sizeof(double));
        cache.begin_step();
        for (int node = 0; node < 100; ++node) // one step asks for more than the budget
            EXPECT_TRUE(ask(cache, node));
        EXPECT_EQ(cache.kept(), 100); // the current step's are all kept
        cache.begin_step();
        EXPECT_EQ(cache.kept(), 64);
        // The same step's responses go by slot: nodes 36..99 are kept, 0..35 forgotten.
        EXPECT_FALSE(ask(cache, 99));
        EXPECT_FALSE(ask(cache, 36));
        EXPECT_TRUE(ask(cache, 35));
        // Asked again, 99 and 36 and 35 are now the newest: the next trim keeps them.
        for (int node = 200; node < 240; ++node)
            EXPECT_TRUE(ask(cache, node));
        cache.begin_step();
        EXPECT_EQ(cache.kept(), 64);
        EXPECT_FALSE(ask(cache, 99));
        EXPECT_FALSE(ask(cache, 36));
        EXPECT_FALSE(ask(cache, 35));
        EXPECT_FALSE(ask(cache, 239));
        EXPECT_TRUE(ask(cache, 37)); // among the oldest: forgotten
    }

} // namespace
} // namespace mat
