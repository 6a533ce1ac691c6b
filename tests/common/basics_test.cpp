#include <gtest/gtest.h>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/parallel.hpp"
#include "common/timer.hpp"

namespace mat {
namespace {

    TEST(Error, MessageIsOneLine)
    {
        try {
            throw_error("{}: line {}: bad\nvalue", "file.ma", 3);
            FAIL() << "no throw";
        } catch (const Error& e) {
            EXPECT_STREQ(e.what(), "file.ma: line 3: bad value");
        }
    }

    TEST(Error, CheckThrowsWithLocation)
    {
        EXPECT_NO_THROW(MAT_CHECK(1 + 1 == 2, "math"));
        try {
            MAT_CHECK(1 + 1 == 3, "value was {}", 2);
            FAIL() << "no throw";
        } catch (const Error& e) {
            const std::string text = e.what();
            EXPECT_NE(text.find("value was 2"), std::string::npos) << text;
            EXPECT_NE(text.find("basics_test.cpp"), std::string::npos) << text;
        }
    }

    TEST(Log, RejectsUnknownLevel)
    {
        EXPECT_NO_THROW(set_log_level("warn"));
        EXPECT_EQ(logger().level(), spdlog::level::warn);
        EXPECT_NO_THROW(set_log_level("off"));
        EXPECT_THROW(set_log_level("loud"), Error);
        set_log_level("info");
    }

    TEST(Parallel, SetsThreadCount)
    {
        set_threads(1);
        EXPECT_EQ(thread_count(), 1);
        set_threads(2);
        EXPECT_EQ(thread_count(), 2);
        EXPECT_THROW(set_threads(-1), Error);
        set_threads(0);
        EXPECT_GE(thread_count(), 1);
    }

    TEST(Timer, ReportHasEveryStageAndTotal)
    {
        StageReport report;
        report.add("read", 0.5);
        report.add("mesh", 1.25);
        const std::string table = report.table();
        EXPECT_NE(table.find("read"), std::string::npos);
        EXPECT_NE(table.find("mesh"), std::string::npos);
        EXPECT_NE(table.find("1.750"), std::string::npos) << table;
        EXPECT_GT(peak_rss_bytes(), 0u);
        EXPECT_GT(current_rss_bytes(), 0u);
    }

} // namespace
} // namespace mat
