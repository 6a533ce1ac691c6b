#pragma once
// mat-run's main job: read a scene, build the bodies, step them, write frames, report timings
// and (with --stats) per-frame statistics as JSON.

#include <string>

namespace mat {

struct RunOptions {
    std::string scene; ///< scene file (JSON)
    std::string output; ///< output directory (created if missing)
    int frames = 0; ///< > 0 overrides the scene's frame count
    std::string solver = "semi"; ///< "semi" (semi-reduced PD) or "full" (full-space PD)
    std::string device; ///< "cpu" or "cuda": overrides the scene's solver.device ("" keeps it)
    std::string stats; ///< --stats FILE.json, "" for none
    /// After each step, compare the collision world's triangle pairs with the exhaustive ground
    /// truth and measure the penetration (runtime/measures/collision_check.hpp).
    bool check_collisions = false;
    /// Render every output frame to OUTDIR/preview/frame_fffff.png (runtime/output/preview.hpp)
    /// and, where ffmpeg is on PATH, OUTDIR/preview.mp4.
    bool preview = false;
    int preview_width = 640; ///< pixels
    int preview_height = 480; ///< pixels
    /// --reference REF.h5, "" for none: a trajectory cache of the same scene (e.g. full-space PD
    /// at many iterations). The run then always writes OUTDIR/trajectory.h5 (h5 is added to the
    /// scene's output formats if missing) and, at the end, prints the RMS and max surface
    /// distance to REF.h5 (runtime/measures/trajectory_error.hpp) and adds them to --stats as
    /// "reference_error": {"rms_percent", "max_percent", "diagonal", "reference",
    /// "frame_rms_percent", "frame_max_percent"} (the last two: per output frame).
    std::string reference;
    /// Continue the run in `output` from its checkpoint (runtime/output/checkpoint.hpp); without
    /// one, start at frame 0. Refused if the checkpoint is of another scene, bake or solver.
    bool resume = false;
    /// Frames between checkpoints (0: at the last frame only).
    int checkpoint_every = 10;
    /// Seconds between progress lines when stderr is not a terminal (0: none).
    double progress_every = 10.0;
};

/// Runs the scene. Throws mat::Error on bad input or a failing solve; files already written
/// stay (each one is complete; the trajectory cache, the --stats JSON Lines file and the
/// checkpoint hold the frames completed; the --stats JSON appears at the end).
void run_simulation(const RunOptions& options);

} // namespace mat
