#pragma once
// A progress bar on stderr that draws only when stderr is a terminal (never in logs, pipes or
// CI). Updates are cheap and thread-safe; redraws are throttled.

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

namespace mat {

class ProgressBar {
public:
    /// label: what is running; total: the number of work units (> 0).
    ProgressBar(std::string label, std::int64_t total);
    ~ProgressBar();
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;

    /// Adds done units; safe from several threads.
    void advance(std::int64_t done = 1);
    /// Marks the work complete and ends the line.
    void finish();

    /// Whether bars draw at all (stderr is a terminal and bars are not disabled).
    static bool enabled();
    /// Turns every bar off (for --quiet, tests); they are on by default on a terminal.
    static void set_enabled(bool on);

private:
    void draw(std::int64_t done);

    std::string m_label;
    std::int64_t m_total;
    std::atomic<std::int64_t> m_done { 0 };
    std::atomic<std::int64_t> m_last_draw_ms { -1000 };
    std::mutex m_draw_mutex;
    bool m_finished = false;
};

} // namespace mat
