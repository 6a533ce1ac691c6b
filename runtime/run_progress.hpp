#pragma once
// mat-run's progress off a terminal (docs/mat-run.md, "Outputs and statistics"): one log line
// every `period` seconds at most, after a frame, with the frame, the time simulated and the
// milliseconds per step since the last line. On a terminal the progress bar shows instead.

#include "common/timer.hpp"

namespace mat {

class Simulation;

class RunProgress {
public:
    /// `period` seconds between lines (0: none); `frames`: the run's last frame.
    RunProgress(double period, int frames, long steps);
    /// After output frame `frame`: prints a line if `period` has passed since the last.
    void frame_done(int frame, const Simulation& simulation);

private:
    double m_period;
    int m_frames;
    bool m_enabled;
    Timer m_timer;
    double m_last_seconds = 0.0;
    long m_last_steps;
};

} // namespace mat
