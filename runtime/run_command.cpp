#include "runtime/run_command.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/parallel.hpp"
#include "common/progress.hpp"
#include "common/timer.hpp"
#include "formats/atomic_file.hpp"
#include "formats/trajectory_io.hpp"
#include "runtime/measures/collision_check.hpp"
#include "runtime/measures/trajectory_error.hpp"
#include "runtime/output/checkpoint.hpp"
#include "runtime/output/exporter.hpp"
#include "runtime/output/preview.hpp"
#include "runtime/run_progress.hpp"
#include "runtime/run_stats.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/scene/scene_bodies.hpp"
#include "runtime/simulation.hpp"

namespace mat {

namespace {

    /// Total collision detection time of a report.
    double detection_seconds(const CollisionReport& r)
    {
        return r.bounds_seconds + r.hash_seconds + r.primitive_seconds + r.triangle_seconds
            + r.response_seconds;
    }

    /// The --check-collisions summary line (docs/mat-run.md, "Checking a run").
    std::string check_summary(const CollisionCheckCounts& c, double diagonal)
    {
        return fmt::format("collision check over {} steps: recall {:.3f}% on pairs in different "
                           "bodies or non-adjacent primitives ({} of {}{}), {:.3f}% on pairs "
                           "within one or adjacent primitives ({} of {}, not looked for), {} "
                           "reported pairs not in the ground truth, max penetration {:.4g} m "
                           "({:.3f}% of the largest diagonal); within a body: {} far pairs, max "
                           "self penetration {:.4g} m; {:.3f} s\n",
            c.steps, 100.0 * recall(c.far_found, c.far_pairs), c.far_found, c.far_pairs,
            c.far_found == c.far_pairs ? "" : ": MISSED SOME",
            100.0 * recall(c.near_found, c.near_pairs), c.near_found, c.near_pairs, c.extra,
            c.max_penetration, 100.0 * c.max_penetration / std::max(diagonal, 1e-300), c.self_pairs,
            c.max_self_penetration, c.seconds);
    }

    /// The largest rest bounding-box diagonal of the bodies.
    double largest_diagonal(const Simulation& simulation)
    {
        double diagonal = 0.0;
        for (const Body& body : simulation.bodies())
            diagonal = std::max(diagonal, body.model->rest_diagonal());
        return diagonal;
    }

    /// The end-of-run table of seconds per phase (docs/mat-run.md, "Outputs and statistics").
    std::string timing_table(const SolverTimings& t, double collision_seconds,
        double export_seconds, double preview_seconds, double measure_seconds, double total_seconds,
        long steps)
    {
        struct Row {
            const char* phase;
            double seconds;
        };
        const Row rows[] = {
            { "local step", t.local },
            { "global: right-hand side", t.rhs },
            { "global: solve", t.solve },
            { "global: reconstruct", t.reconstruct },
            { "collision (detection)", collision_seconds },
            { "collision (contact)", t.contact },
            { "acceleration", t.acceleration },
            { "GPU step (--device)", t.device },
            { "export", export_seconds },
            { "preview (--preview)", preview_seconds },
            { "measures (stats)", measure_seconds },
        };
        std::string text = fmt::format("{:<26}{:>10}{:>12}{:>8}\n", "phase", "s", "ms/step", "%");
        double listed = 0.0;
        const double per_step = steps > 0 ? 1e3 / static_cast<double>(steps) : 0.0;
        for (const Row& row : rows) {
            listed += row.seconds;
            text += fmt::format("{:<26}{:>10.3f}{:>12.3f}{:>8.1f}\n", row.phase, row.seconds,
                row.seconds * per_step, 100.0 * row.seconds / std::max(total_seconds, 1e-12));
        }
        const double other = std::max(0.0, total_seconds - listed);
        text += fmt::format("{:<26}{:>10.3f}{:>12.3f}{:>8.1f}\n", "other", other, other * per_step,
            100.0 * other / std::max(total_seconds, 1e-12));
        text += fmt::format("{:<26}{:>10.3f}{:>12.3f}{:>8.1f}\n", "total", total_seconds,
            total_seconds * per_step, 100.0);
        return text;
    }

    /// Checks the options that need no body (before any bake is read); returns the frame count.
    int checked_frames(const RunOptions& options, const Scene& scene)
    {
        if (options.frames < 0)
            throw_error("--frames {} must be positive", options.frames);
        if (options.checkpoint_every < 0)
            throw_error("--checkpoint-every {} must not be negative", options.checkpoint_every);
        if (!(options.progress_every >= 0.0))
            throw_error("--progress-every {} must not be negative", options.progress_every);
        if (options.output.empty())
            throw_error("mat-run needs an output directory (-o DIR)");
        if (options.preview
            && (options.preview_width < 16 || options.preview_height < 16
                || options.preview_width > 8192 || options.preview_height > 8192))
            throw_error("--preview-size {}x{}: each side must be 16 to 8192 pixels",
                options.preview_width, options.preview_height);
        if (!options.stats.empty()) {
            // The stats file may go into the -o directory, which the run creates later
            // (docs/mat-run.md).
            namespace fs = std::filesystem;
            const fs::path parent = fs::path(options.stats).parent_path();
            const auto directory = [](const fs::path& path) {
                std::error_code error;
                fs::path full = fs::weakly_canonical(path, error).lexically_normal();
                return full.has_filename() ? full : full.parent_path();
            };
            const bool into_output
                = !parent.empty() && directory(parent) == directory(options.output);
            if (!parent.empty() && !into_output && !fs::is_directory(parent))
                throw_error("--stats {}: the directory {} does not exist (it may be the -o "
                            "directory, which the run creates)",
                    options.stats, parent.string());
        }
        return options.frames > 0 ? options.frames : scene.frames;
    }

    /// --reference: reads and checks the reference before anything is written (null without
    /// it); the run then always writes its trajectory cache (h5 joins `output`'s formats), to
    /// compare at the end.
    std::unique_ptr<TrajectoryReader> open_reference(
        const RunOptions& options, const Simulation& simulation, int frames, OutputSettings& output)
    {
        if (options.reference.empty())
            return nullptr;
        auto reference = std::make_unique<TrajectoryReader>(options.reference);
        std::vector<std::string> names;
        std::vector<Index> vertex_counts;
        for (const Body& body : simulation.bodies()) {
            names.push_back(body.name);
            vertex_counts.push_back(body.model->surface().num_vertices());
        }
        check_reference(*reference, names, vertex_counts, Index(frames) + 1);
        std::error_code same_error;
        if (std::filesystem::equivalent(
                options.reference, options.output + "/trajectory.h5", same_error))
            throw_error("--reference {}: this run would overwrite it (choose another -o)",
                options.reference);
        if (std::find(output.formats.begin(), output.formats.end(), OutputFormat::h5)
            == output.formats.end())
            output.formats.push_back(OutputFormat::h5);
        return reference;
    }

    /// Creates the output directory (once the inputs are known good) and removes the
    /// temporaries that killed runs left there and beside the stats file.
    void create_output_directory(const RunOptions& options)
    {
        namespace fs = std::filesystem;
        const std::string& output = options.output;
        std::error_code error;
        fs::create_directories(output, error);
        if (error || !fs::is_directory(output))
            throw_error("{}: cannot create the output directory ({})", output,
                error ? error.message() : "not a directory");
        int removed
            = remove_stale_temporaries(output) + remove_stale_temporaries(output + "/preview");
        if (!options.stats.empty()) {
            const fs::path stats(options.stats);
            const std::string directory
                = stats.has_parent_path() ? stats.parent_path().string() : ".";
            removed += remove_stale_temporaries(directory, stats.filename().string())
                + remove_stale_temporaries(
                    directory, fs::path(frame_log_path(options.stats)).filename().string());
        }
        if (removed > 0)
            logger().info("{}: removed {} temporary files of earlier runs", output, removed);
    }

    /// With --resume and a checkpoint in the output directory: restores the simulation from it
    /// and returns its frame; else -1 (a fresh run, which removes an old checkpoint).
    int resume(
        const RunOptions& options, const RunIdentity& identity, int frames, Simulation& simulation)
    {
        const std::string path = options.output + "/checkpoint.h5";
        std::error_code error;
        if (!std::filesystem::exists(path, error)) {
            if (options.resume)
                logger().info(
                    "--resume: no checkpoint in {}: the run starts at frame 0", options.output);
            return -1;
        }
        if (!options.resume) {
            std::filesystem::remove(path, error);
            if (error)
                throw_error("{}: cannot remove the checkpoint of an earlier run: {}", path,
                    error.message());
            return -1;
        }
        Checkpoint checkpoint = read_checkpoint(path, identity);
        if (checkpoint.frame > frames)
            throw_error("{}: the run is at frame {}, past the {} frames asked (--frames)", path,
                checkpoint.frame, frames);
        simulation.restore(checkpoint.snapshot);
        logger().info("--resume: continuing {} after frame {} ({} steps)", options.output,
            checkpoint.frame, simulation.steps());
        return checkpoint.frame;
    }

    /// The solver's name in the first log line.
    const char* solver_name(SolverKind kind)
    {
        return kind == SolverKind::full
            ? "full-space"
            : (kind == SolverKind::hyper_reduced ? "hyper-reduced" : "semi-reduced");
    }

    /// Writes frame `frame` at the current state: measures, files, preview and stats entry.
    void output_frame(int frame, double step_seconds, const Simulation& simulation, RunStats& stats,
        Exporter& exporter, PreviewWriter* preview)
    {
        const std::vector<VecX>& tet_strain = stats.measure_frame();
        Timer timer;
        exporter.write_frame(frame, simulation.time(), simulation, tet_strain);
        const double export_seconds = timer.seconds();
        double preview_seconds = 0.0;
        if (preview) {
            timer.restart();
            preview->write_frame(frame, simulation);
            preview_seconds = timer.seconds();
        }
        stats.record_frame(frame, step_seconds, export_seconds, preview_seconds);
    }

    /// Where and how often the frame loop writes checkpoints.
    struct CheckpointPlan {
        std::string path;
        const RunIdentity* identity = nullptr;
        int every = 0; ///< frames between checkpoints (0: the last frame only)
    };

    /// The frame loop: frame 0 (unless resuming after `first - 1`), each frame's steps, outputs
    /// and checkpoint, then the files closed.
    void run_frames(Simulation& simulation, const Scene& scene, int first, int frames,
        const CheckpointPlan& checkpoints, double progress_every, RunStats& stats,
        Exporter& exporter, PreviewWriter* preview)
    {
        if (first == 0)
            output_frame(0, 0.0, simulation, stats, exporter, preview);
        ProgressBar progress("mat-run",
            static_cast<std::int64_t>(frames - std::max(first - 1, 0)) * scene.steps_per_frame);
        RunProgress lines(progress_every, frames, simulation.steps());
        for (int frame = std::max(first, 1); frame <= frames; ++frame) {
            Timer step_timer;
            stats.start_frame();
            for (int s = 0; s < scene.steps_per_frame; ++s) {
                simulation.set_triangle_pairs(
                    stats.wants_triangle_pairs(s + 1 == scene.steps_per_frame));
                simulation.step();
                stats.record_step();
                progress.advance();
            }
            simulation.sync_host(); // --device cuda: the frame's states from the GPU
            output_frame(frame, step_timer.seconds(), simulation, stats, exporter, preview);
            if (frame == frames || (checkpoints.every > 0 && frame % checkpoints.every == 0)) {
                Timer timer;
                write_checkpoint(
                    checkpoints.path, *checkpoints.identity, frame, simulation.snapshot());
                stats.add_finish_seconds(timer.seconds(), 0.0);
            }
            lines.frame_done(frame, simulation);
        }
        progress.finish();
        Timer finish_timer;
        exporter.finish();
        const double export_seconds = finish_timer.seconds();
        double preview_seconds = 0.0;
        if (preview) {
            finish_timer.restart();
            preview->write_movie(1.0 / scene.frame_interval());
            preview_seconds = finish_timer.seconds();
        }
        stats.add_finish_seconds(export_seconds, preview_seconds);
    }

    /// What the end report needs besides the recorder.
    struct RunTotals {
        int frames = 0;
        long files = 0; ///< files written (frames, caches, previews)
        double setup_seconds = 0.0;
        double loop_seconds = 0.0;
    };

    /// Prints the end-of-run summary to stdout; with a reference, compares the run's trajectory
    /// cache with it there and returns the error (docs/mat-run.md, "Checking a run").
    TrajectoryError print_end_report(const RunOptions& options, const Scene& scene,
        const Simulation& simulation, const RunStats& stats, const RunTotals& totals,
        const TrajectoryReader* reference)
    {
        const long steps = stats.run_steps();
        std::printf("simulated %.4g s in %ld steps (%d frames, %ld files) in %.3f s, setup %.3f s, "
                    "peak RSS %.0f MB\n",
            simulation.time(), steps, totals.frames, totals.files, totals.loop_seconds,
            totals.setup_seconds, peak_rss_bytes() / 1e6);
        std::fputs(timing_table(total_timings(simulation),
                       detection_seconds(stats.total_collision()), stats.export_seconds(),
                       stats.preview_seconds(), stats.measure_seconds(), totals.loop_seconds, steps)
                       .c_str(),
            stdout);
        if (scene.solver.sleep_speed > 0.0)
            std::printf("sleeping: %d of %zu bodies at the end, %.2f on average over the steps\n",
                simulation.num_sleeping(), simulation.bodies().size(), stats.sleeping_mean());
        if (options.check_collisions)
            std::fputs(
                check_summary(stats.total_check(), largest_diagonal(simulation)).c_str(), stdout);
        TrajectoryError reference_error;
        if (reference) {
            reference_error
                = trajectory_error(TrajectoryReader(options.output + "/trajectory.h5"), *reference);
            std::printf("reference error (surface distance to %s, max over frames, %% of the "
                        "reference's bounding-box diagonal %.4g m): RMS %.6g%%, max %.6g%%\n",
                options.reference.c_str(), reference_error.diagonal, reference_error.rms_percent,
                reference_error.max_percent);
        }
        std::fflush(stdout);
        return reference_error;
    }

} // namespace

void run_simulation(const RunOptions& options)
{
    Timer total;
    Scene scene = read_scene(options.scene);
    if (!options.device.empty())
        scene.solver.device = options.device == "cuda" ? DeviceMode::cuda : DeviceMode::cpu;
    const SolverKind solver_kind = parse_solver_kind(options.solver);
    const int frames = checked_frames(options, scene);
    if (scene.solver.device == DeviceMode::cuda
        && scene.solver.angular_momentum != AngularMomentumMode::integrator
        && solver_kind == SolverKind::semi_reduced)
        logger().warn("{}: --device cuda steps do not keep angular momentum (solver."
                      "angular_momentum runs on the CPU only; docs/gpu.md)",
            scene.file);

    Simulation simulation(scene, load_bodies(scene, solver_kind));
    OutputSettings output_settings = scene.output;
    const std::unique_ptr<TrajectoryReader> reference
        = open_reference(options, simulation, frames, output_settings);
    if (options.check_collisions && simulation.collision() == nullptr)
        throw_error("--check-collisions: {} has no collision between objects to check (it needs "
                    "solver.collision bounded or lazy, and two objects or self_collision on)",
            scene.file);
    create_output_directory(options);
    const RunIdentity identity = run_identity(scene, options.solver);
    const int resume_frame = resume(options, identity, frames, simulation);
    const nlohmann::json run_json { { "scene", options.scene }, { "solver", options.solver },
        { "dt", scene.time.dt }, { "iterations", scene.time.iterations },
        { "steps_per_frame", scene.steps_per_frame }, { "frames", frames },
        { "threads", thread_count() } };
    Exporter exporter(
        simulation, output_settings, options.output, run_json.dump(), frames, resume_frame);
    std::unique_ptr<PreviewWriter> preview;
    if (options.preview)
        preview = std::make_unique<PreviewWriter>(
            simulation, options.output, options.preview_width, options.preview_height);
    const bool stats = !options.stats.empty();
    const bool measure = stats || exporter.wants_stretch();
    logger().info("{}: {} bodies, dt {} s, {} steps per frame, {} frames, {} iterations, {} "
                  "solver",
        scene.file, simulation.bodies().size(), scene.time.dt, scene.steps_per_frame, frames,
        scene.time.iterations, solver_name(solver_kind));
    const double setup_seconds = total.seconds();

    RunStats recorder(simulation, scene.gravity, stats, measure, options.check_collisions);
    if (stats)
        recorder.open_frame_log(frame_log_path(options.stats), resume_frame);
    Timer loop;
    const CheckpointPlan checkpoints { options.output + "/checkpoint.h5", &identity,
        options.checkpoint_every };
    run_frames(simulation, scene, resume_frame + 1, frames, checkpoints, options.progress_every,
        recorder, exporter, preview.get());
    const double loop_seconds = loop.seconds();

    const RunTotals totals { frames,
        exporter.files_written() + (preview ? preview->files_written() : 0), setup_seconds,
        loop_seconds };
    const TrajectoryError reference_error
        = print_end_report(options, scene, simulation, recorder, totals, reference.get());
    if (stats)
        recorder.write(options.stats, run_json, setup_seconds, loop_seconds,
            reference ? &reference_error : nullptr, options.reference);
}

} // namespace mat
