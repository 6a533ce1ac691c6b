#pragma once
// What mat-run records while it runs: per-frame measures, step reports and phase timings, the
// --stats file written from them at the end (docs/mat-run.md, "Outputs and statistics") and the
// totals of the end-of-run summary.

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/eigen_types.hpp"
#include "runtime/collision/collision_world.hpp"
#include "runtime/measures/collision_check.hpp"
#include "runtime/measures/trajectory_error.hpp"
#include "runtime/pd/global_step.hpp"
#include "runtime/pd/solver.hpp"

namespace mat {

class Simulation;

/// Phase totals of all bodies' solvers.
SolverTimings total_timings(const Simulation& simulation);

/// The per-frame JSON Lines file beside the --stats file `stats`: "run.json" -> "run.frames.jsonl"
/// (docs/mat-run.md, "Outputs and statistics").
std::string frame_log_path(const std::string& stats);

/// Accumulates a run's per-frame JSON and report data, and writes --stats at the end.
class RunStats {
public:
    /// `stats`: --stats is on (per-frame entries are kept); `measure`: bodies are measured each
    /// frame (--stats or a stretch field to export); `check_collisions`: --check-collisions.
    RunStats(const Simulation& simulation, const Vec3& gravity, bool stats, bool measure,
        bool check_collisions);

    /// With --stats: appends every frame's entry to the JSON Lines file `path` as well, one line
    /// each, flushed (a killed run's file holds every frame it completed; a last line without
    /// its newline is incomplete). `resume_frame` >= 0: the run continues after that frame: the
    /// file's entries up to it are kept (the file is rewritten atomically without the later
    /// ones) and go into the final document; else the file starts empty. Throws mat::Error if
    /// the file cannot be written.
    void open_frame_log(const std::string& path, int resume_frame);

    /// Whether a step needs the collision world's intersecting triangle pairs: every step with
    /// --check-collisions, a frame's last step with --stats (its `intersecting_triangles`).
    bool wants_triangle_pairs(bool frame_end) const
    {
        return m_check_collisions || (m_stats && frame_end);
    }
    /// Starts a frame's steps: clears the per-frame maxima and sums.
    void start_frame();
    /// After each step: sleeping bodies, the collision report, the solvers' step reports and,
    /// with --check-collisions, the exhaustive check of the step (warns on a missed pair).
    void record_step();
    /// Measures the bodies at the current state (when measuring); returns the per-tet strain
    /// per body for the exporter (empty when not measuring).
    const std::vector<VecX>& measure_frame();
    /// Ends frame `frame` (after measure_frame() and its files): adds the output times and,
    /// with --stats, the frame's entry.
    void record_frame(
        int frame, double step_seconds, double export_seconds, double preview_seconds);
    /// Adds the output time spent after the last frame (closing files, the preview movie).
    void add_finish_seconds(double export_seconds, double preview_seconds);

    /// Seconds spent so far writing files, previews and measuring (the end report's table).
    double export_seconds() const { return m_export_seconds; }
    double preview_seconds() const { return m_preview_seconds; }
    double measure_seconds() const { return m_measure_seconds; }
    /// The collision reports of all steps folded into one (see accumulate in run_stats.cpp).
    const CollisionReport& total_collision() const { return m_total_collision; }
    /// The --check-collisions counts of all steps added up.
    const CollisionCheckCounts& total_check() const { return m_total_check; }
    /// Bodies asleep after a step, on average over this run's steps (0 before any step).
    double sleeping_mean() const;
    /// Steps this run made (a resumed run: since it resumed).
    long run_steps() const;

    /// Writes the --stats document to `path` atomically (once, at the end: the frames move out).
    /// `reference_error`: null without --reference.
    void write(const std::string& path, const nlohmann::json& run_json, double setup_seconds,
        double loop_seconds, const TrajectoryError* reference_error, const std::string& reference);

private:
    const Simulation& m_simulation;
    Vec3 m_gravity;
    bool m_stats;
    bool m_measure;
    bool m_check_collisions;
    long m_first_step = 0; ///< the simulation's steps when this run began (resumed: > 0)
    int m_resume_frame = -1;
    std::string m_log_path;
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> m_log { nullptr, &std::fclose };
    std::vector<VecX> m_tet_strain; ///< per body, from the last measure_frame()
    nlohmann::json m_bodies; ///< per body, from the last measure_frame()
    Vec3 m_momentum = Vec3::Zero(); ///< summed over the bodies at the last measure_frame()
    nlohmann::json m_frames = nlohmann::json::array(); ///< the --stats entry of each frame
    double m_export_seconds = 0.0;
    double m_preview_seconds = 0.0;
    double m_measure_seconds = 0.0;
    SolverTimings m_before; ///< the solvers' totals at the last frame entry
    std::vector<StepReport> m_reports; ///< per body over the frame's steps (empty at frame 0)
    CollisionReport m_frame_collision;
    CollisionReport m_total_collision;
    int m_frame_sleeping_max = 0; ///< most bodies asleep after a step of the frame
    long m_sleeping_steps = 0; ///< sum over the steps of the bodies asleep after it
    CollisionCheckCounts m_frame_check;
    CollisionCheckCounts m_total_check;
};

} // namespace mat
