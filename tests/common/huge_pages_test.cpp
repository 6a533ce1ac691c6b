// Huge-page storage (common/huge_pages.hpp): its alignment, layout and block sizes; whether the
// kernel grants the huge pages is a hint, not a result, and is not tested.

#include <gtest/gtest.h>

#include <cstdint>

#include "common/huge_pages.hpp"

namespace mat {
namespace {

    std::uintptr_t address(const double* p)
    {
        return reinterpret_cast<std::uintptr_t>(p);
    }

    TEST(HugePages, SmallBlocksAreColumnMajorAndCacheLineAligned)
    {
        const HugePageBlock block(3, 5);
        EXPECT_EQ(block.rows(), 3);
        EXPECT_EQ(block.cols(), 5);
        EXPECT_EQ(address(block.col(0)) % 64, 0u);
        for (Index c = 0; c < 5; ++c) {
            EXPECT_EQ(block.col(c), block.col(0) + 3 * c);
            for (Index r = 0; r < 3; ++r)
                block(r, c) = static_cast<double>(10 * c + r);
        }
        for (Index c = 0; c < 5; ++c)
            for (Index r = 0; r < 3; ++r)
                EXPECT_EQ(block.col(c)[r], static_cast<double>(10 * c + r));
        EXPECT_EQ(HugePageBlock().col(0), nullptr);
    }

    TEST(HugePages, LargeBuffersStartOnAHugePageAndHoldEveryValue)
    {
        const std::size_t count = huge_page_min_bytes / sizeof(double) + 12345;
        const HugePageBuffer buffer(count);
        EXPECT_EQ(buffer.size(), count);
        EXPECT_EQ(address(buffer.data()) % (std::size_t { 2 } << 20), 0u);
        for (std::size_t i = 0; i < count; ++i)
            buffer.data()[i] = static_cast<double>(i);
        double sum = 0.0;
        for (std::size_t i = 0; i < count; ++i)
            sum += buffer.data()[i] - static_cast<double>(i);
        EXPECT_EQ(sum, 0.0);
        // Just under the threshold: small pages, cache-line aligned.
        const HugePageBuffer small(huge_page_min_bytes / sizeof(double) - 1);
        EXPECT_EQ(address(small.data()) % 64, 0u);
    }

    TEST(HugePages, PoolBlocksFillTheThresholdWithAtLeast64Columns)
    {
        for (const Index rows : { 1, 7, 292, 734, 100000 }) {
            const Index columns = huge_block_columns(rows);
            const std::size_t column = sizeof(double) * static_cast<std::size_t>(rows);
            EXPECT_GE(columns, 64) << rows;
            EXPECT_GE(static_cast<std::size_t>(columns) * column, huge_page_min_bytes) << rows;
            if (columns > 64) {
                EXPECT_LT(static_cast<std::size_t>(columns - 1) * column, huge_page_min_bytes)
                    << rows;
            }
        }
    }

} // namespace
} // namespace mat
