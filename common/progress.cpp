#include "common/progress.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <unistd.h>

#include "common/log.hpp"

namespace mat {

namespace {
    std::atomic<bool> g_user_enabled { true };

    std::int64_t now_ms()
    {
        using namespace std::chrono;
        return duration_cast<milliseconds>(steady_clock::now().time_since_epoch()).count();
    }
} // namespace

bool ProgressBar::enabled()
{
    return g_user_enabled && isatty(STDERR_FILENO);
}

void ProgressBar::set_enabled(bool on)
{
    g_user_enabled = on;
}

ProgressBar::ProgressBar(std::string label, std::int64_t total)
    : m_label(std::move(label))
    , m_total(std::max<std::int64_t>(total, 1))
{
    if (enabled())
        draw(0);
}

ProgressBar::~ProgressBar()
{
    finish();
}

void ProgressBar::advance(std::int64_t done)
{
    const std::int64_t now_done = m_done.fetch_add(done) + done;
    if (!enabled())
        return;
    const std::int64_t now = now_ms();
    std::int64_t last = m_last_draw_ms.load();
    if (now - last < 100)
        return;
    if (m_last_draw_ms.compare_exchange_strong(last, now))
        draw(now_done);
}

void ProgressBar::finish()
{
    std::lock_guard<std::mutex> lock(m_draw_mutex);
    if (m_finished)
        return;
    m_finished = true;
    if (!enabled())
        return;
    const int width = 30;
    std::fprintf(
        stderr, "\r%-24s [%.*s] 100%%\n", m_label.c_str(), width, "##############################");
    std::fflush(stderr);
}

void ProgressBar::draw(std::int64_t done)
{
    std::unique_lock<std::mutex> lock(m_draw_mutex, std::try_to_lock);
    if (!lock.owns_lock() || m_finished)
        return;
    const int width = 30;
    const double fraction = std::clamp(double(done) / double(m_total), 0.0, 1.0);
    const int filled = static_cast<int>(fraction * width);
    std::fprintf(stderr, "\r%-24s [%.*s%*s] %3d%%", m_label.c_str(), filled,
        "##############################", width - filled, "", static_cast<int>(fraction * 100));
    std::fflush(stderr);
}

ProgressHeartbeat::ProgressHeartbeat(std::string label, double interval_seconds)
    : m_label(std::move(label))
    , m_interval(interval_seconds)
    , m_thread([this] { run(); })
{
}

ProgressHeartbeat::~ProgressHeartbeat()
{
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        m_stop = true;
    }
    m_wake.notify_all();
    m_thread.join();
}

void ProgressHeartbeat::run()
{
    const auto start = std::chrono::steady_clock::now();
    const auto interval = std::chrono::duration<double>(m_interval);
    std::unique_lock<std::mutex> lock(m_mutex);
    for (int beat = 1;; ++beat) {
        const auto due
            = start + std::chrono::duration_cast<std::chrono::nanoseconds>(beat * interval);
        if (m_wake.wait_until(lock, due, [this] { return m_stop; }))
            return;
        logger().info("{}: still running after {:.0f} s", m_label, beat * m_interval);
    }
}

} // namespace mat
