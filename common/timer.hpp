#pragma once
// Wall-clock timers and memory readings for stage reports and per-phase timing tables.

#include <chrono>
#include <string>
#include <vector>

namespace mat {

/// A wall-clock stopwatch, started on construction.
class Timer {
public:
    Timer();
    void restart();
    /// Seconds since construction or the last restart().
    double seconds() const;

private:
    std::chrono::steady_clock::time_point m_start;
};

/// Peak resident set size of this process so far, in bytes (getrusage).
std::size_t peak_rss_bytes();

/// Current resident set size of this process, in bytes (/proc/self/statm), 0 if unknown.
std::size_t current_rss_bytes();

/// Rows of "stage, seconds, peak memory" collected while a tool runs, printed as a table.
class StageReport {
public:
    struct Row {
        std::string stage;
        double seconds;
        std::size_t peak_rss_bytes;
    };

    void add(std::string stage, double seconds);
    const std::vector<Row>& rows() const { return m_rows; }
    /// A fixed-width text table with a total line.
    std::string table() const;

private:
    std::vector<Row> m_rows;
};

} // namespace mat
