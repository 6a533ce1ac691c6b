#pragma once
// A progress bar on stderr that draws only when stderr is a terminal (never in logs, pipes or
// CI). Updates are cheap and thread-safe; redraws are throttled.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

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

/// The progress line of a long stage in logs and pipes, where bars do not draw (docs/mat-bake.md,
/// "Bounds"): while it lives, a thread logs "LABEL: still running after N s" at info level every
/// `interval_seconds` (none for a stage that ends sooner). It only logs, so results stay the same.
class ProgressHeartbeat {
public:
    explicit ProgressHeartbeat(std::string label, double interval_seconds = 15.0);
    ~ProgressHeartbeat();
    ProgressHeartbeat(const ProgressHeartbeat&) = delete;
    ProgressHeartbeat& operator=(const ProgressHeartbeat&) = delete;

private:
    void run();

    std::string m_label;
    double m_interval;
    bool m_stop = false;
    std::mutex m_mutex;
    std::condition_variable m_wake;
    std::thread m_thread;
};

} // namespace mat
