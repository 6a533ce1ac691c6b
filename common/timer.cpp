#include "common/timer.hpp"

#include <cstdio>
#include <sys/resource.h>
#include <unistd.h>

#include <fmt/format.h>

namespace mat {

Timer::Timer()
    : m_start(std::chrono::steady_clock::now())
{
}

void Timer::restart()
{
    m_start = std::chrono::steady_clock::now();
}

double Timer::seconds() const
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
}

std::size_t peak_rss_bytes()
{
    rusage usage {};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<std::size_t>(usage.ru_maxrss) * 1024; // ru_maxrss is in KiB on Linux
}

std::size_t current_rss_bytes()
{
    std::FILE* file = std::fopen("/proc/self/statm", "r");
    if (!file)
        return 0;
    long pages_total = 0, pages_resident = 0;
    const int read = std::fscanf(file, "%ld %ld", &pages_total, &pages_resident);
    std::fclose(file);
    if (read != 2)
        return 0;
    return static_cast<std::size_t>(pages_resident)
        * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

void StageReport::add(std::string stage, double seconds)
{
    m_rows.push_back({ std::move(stage), seconds, peak_rss_bytes() });
}

std::string StageReport::table() const
{
    std::size_t width = 5;
    for (const Row& row : m_rows)
        width = std::max(width, row.stage.size());
    std::string out
        = fmt::format("{:<{}}  {:>10}  {:>14}\n", "stage", width, "time (s)", "peak RSS (MB)");
    double total = 0;
    std::size_t peak = 0;
    for (const Row& row : m_rows) {
        out += fmt::format("{:<{}}  {:>10.3f}  {:>14.1f}\n", row.stage, width, row.seconds,
            row.peak_rss_bytes / 1048576.0);
        total += row.seconds;
        peak = std::max(peak, row.peak_rss_bytes);
    }
    out += fmt::format("{:<{}}  {:>10.3f}  {:>14.1f}\n", "total", width, total, peak / 1048576.0);
    return out;
}

} // namespace mat
