#include "runtime/run_progress.hpp"

#include "common/log.hpp"
#include "common/progress.hpp"
#include "runtime/simulation.hpp"

namespace mat {

RunProgress::RunProgress(double period, int frames, long steps)
    : m_period(period)
    , m_frames(frames)
    , m_enabled(period > 0.0 && !ProgressBar::enabled())
    , m_last_steps(steps)
{
}

void RunProgress::frame_done(int frame, const Simulation& simulation)
{
    if (!m_enabled)
        return;
    const double now = m_timer.seconds();
    if (now - m_last_seconds < m_period)
        return;
    const long steps = simulation.steps() - m_last_steps;
    const double ms_per_step
        = steps > 0 ? 1e3 * (now - m_last_seconds) / static_cast<double>(steps) : 0.0;
    logger().info("frame {} of {}, {:.4f} s simulated, {:.2f} ms/step", frame, m_frames,
        simulation.time(), ms_per_step);
    m_last_seconds = now;
    m_last_steps = simulation.steps();
}

} // namespace mat
