#include "runtime/run_command.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/parallel.hpp"
#include "common/progress.hpp"
#include "common/timer.hpp"
#include "formats/text_io.hpp"
#include "formats/trajectory_io.hpp"
#include "runtime/measures/body_measures.hpp"
#include "runtime/measures/collision_check.hpp"
#include "runtime/measures/trajectory_error.hpp"
#include "runtime/output/exporter.hpp"
#include "runtime/output/preview.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/scene/scene_bodies.hpp"
#include "runtime/simulation.hpp"

namespace mat {

namespace {

    nlohmann::json vector_json(const Vec3& v)
    {
        return { v.x(), v.y(), v.z() };
    }

    /// Phase totals of all bodies' solvers.
    SolverTimings total_timings(const Simulation& simulation)
    {
        SolverTimings sum;
        for (const Body& body : simulation.bodies()) {
            const SolverTimings& t = body.solver->timings();
            sum.local += t.local;
            sum.rhs += t.rhs;
            sum.solve += t.solve;
            sum.reconstruct += t.reconstruct;
            sum.contact += t.contact;
            sum.iterations += t.iterations;
        }
        return sum;
    }

    nlohmann::json phase_json(
        const SolverTimings& now, const SolverTimings& before, double export_seconds, double scale)
    {
        return nlohmann::json {
            { "local", scale * (now.local - before.local) },
            { "rhs", scale * (now.rhs - before.rhs) },
            { "solve", scale * (now.solve - before.solve) },
            { "reconstruct", scale * (now.reconstruct - before.reconstruct) },
            { "contact", scale * (now.contact - before.contact) },
            { "export", scale * export_seconds },
        };
    }

    /// Folds one step's collision report into a frame's: counts and penetration are maxima over
    /// the steps, seconds are sums.
    void accumulate(CollisionReport& into, const CollisionReport& step)
    {
        into.updated_bodies = std::max(into.updated_bodies, step.updated_bodies);
        into.object_pairs = std::max(into.object_pairs, step.object_pairs);
        into.hashed_bodies = std::max(into.hashed_bodies, step.hashed_bodies);
        into.primitive_candidates = std::max(into.primitive_candidates, step.primitive_candidates);
        into.primitive_pairs = std::max(into.primitive_pairs, step.primitive_pairs);
        into.triangle_tests = std::max(into.triangle_tests, step.triangle_tests);
        into.intersecting_triangles
            = std::max(into.intersecting_triangles, step.intersecting_triangles);
        into.contacts = std::max(into.contacts, step.contacts);
        into.max_penetration = std::max(into.max_penetration, step.max_penetration);
        into.bounds_seconds += step.bounds_seconds;
        into.hash_seconds += step.hash_seconds;
        into.primitive_seconds += step.primitive_seconds;
        into.triangle_seconds += step.triangle_seconds;
        into.response_seconds += step.response_seconds;
    }

    double detection_seconds(const CollisionReport& r)
    {
        return r.bounds_seconds + r.hash_seconds + r.primitive_seconds + r.triangle_seconds
            + r.response_seconds;
    }

    nlohmann::json collision_phase_json(const CollisionReport& r, double scale)
    {
        return nlohmann::json { { "bounds", scale * r.bounds_seconds },
            { "hash", scale * r.hash_seconds }, { "primitives", scale * r.primitive_seconds },
            { "triangles", scale * r.triangle_seconds },
            { "response", scale * r.response_seconds } };
    }

    nlohmann::json collision_json(const CollisionReport& r)
    {
        return nlohmann::json { { "updated_bodies", r.updated_bodies },
            { "object_pairs", r.object_pairs }, { "hashed_bodies", r.hashed_bodies },
            { "candidates", r.primitive_candidates }, { "primitive_pairs", r.primitive_pairs },
            { "triangle_tests", r.triangle_tests },
            { "intersecting_triangles", r.intersecting_triangles }, { "contacts", r.contacts },
            { "max_penetration", r.max_penetration }, { "seconds", collision_phase_json(r, 1.0) } };
    }

    nlohmann::json check_json(const CollisionCheckCounts& c)
    {
        return nlohmann::json { { "far_recall", recall(c.far_found, c.far_pairs) },
            { "far_pairs", c.far_pairs }, { "far_found", c.far_found },
            { "near_recall", recall(c.near_found, c.near_pairs) }, { "near_pairs", c.near_pairs },
            { "near_found", c.near_found }, { "extra", c.extra },
            { "max_penetration", c.max_penetration },
            { "penetrating_vertices", c.penetrating_vertices }, { "steps", c.steps },
            { "seconds", c.seconds } };
    }

    std::string check_summary(const CollisionCheckCounts& c, double diagonal)
    {
        return fmt::format("collision check over {} steps: recall {:.3f}% on pairs in different "
                           "bodies or non-adjacent primitives ({} of {}{}), {:.3f}% on pairs "
                           "within one or adjacent primitives ({} of {}, not looked for), {} "
                           "reported pairs not in the ground truth, max penetration {:.4g} m "
                           "({:.3f}% of the largest diagonal), {:.3f} s\n",
            c.steps, 100.0 * recall(c.far_found, c.far_pairs), c.far_found, c.far_pairs,
            c.far_found == c.far_pairs ? "" : ": MISSED SOME",
            100.0 * recall(c.near_found, c.near_pairs), c.near_found, c.near_pairs, c.extra,
            c.max_penetration, 100.0 * c.max_penetration / std::max(diagonal, 1e-300), c.seconds);
    }

    /// The largest rest bounding-box diagonal of the bodies.
    double largest_diagonal(const Simulation& simulation)
    {
        double diagonal = 0.0;
        for (const Body& body : simulation.bodies()) {
            const MatX3& rest = body.model->pd().rest_positions();
            diagonal = std::max(
                diagonal, (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm());
        }
        return diagonal;
    }

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

} // namespace

void run_simulation(const RunOptions& options)
{
    Timer total;
    const Scene scene = read_scene(options.scene);
    const SolverKind solver_kind = parse_solver_kind(options.solver);
    if (options.frames < 0)
        throw_error("--frames {} must be positive", options.frames);
    const int frames = options.frames > 0 ? options.frames : scene.frames;
    if (options.output.empty())
        throw_error("mat-run needs an output directory (-o DIR)");
    if (options.preview
        && (options.preview_width < 16 || options.preview_height < 16
            || options.preview_width > 8192 || options.preview_height > 8192))
        throw_error("--preview-size {}x{}: each side must be 16 to 8192 pixels",
            options.preview_width, options.preview_height);
    if (!options.stats.empty()) {
        const auto parent = std::filesystem::path(options.stats).parent_path();
        if (!parent.empty() && !std::filesystem::is_directory(parent))
            throw_error(
                "--stats {}: the directory {} does not exist", options.stats, parent.string());
    }

    Simulation simulation(scene, load_bodies(scene, solver_kind));
    // --reference: read and check the reference before anything is written; the run then
    // always writes its trajectory cache, to compare at the end.
    std::unique_ptr<TrajectoryReader> reference;
    OutputSettings output_settings = scene.output;
    if (!options.reference.empty()) {
        reference = std::make_unique<TrajectoryReader>(options.reference);
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
        if (std::find(output_settings.formats.begin(), output_settings.formats.end(), "h5")
            == output_settings.formats.end())
            output_settings.formats.push_back("h5");
    }
    if (options.check_collisions && simulation.collision() == nullptr)
        throw_error("--check-collisions: {} has no collision between objects to check (it needs "
                    "solver.collision bounded or lazy, and two objects or self_collision on)",
            scene.file);
    // The output directory appears only once the inputs are known good.
    std::error_code error;
    std::filesystem::create_directories(options.output, error);
    if (error || !std::filesystem::is_directory(options.output))
        throw_error("{}: cannot create the output directory ({})", options.output,
            error ? error.message() : "not a directory");
    const nlohmann::json run_json { { "scene", options.scene }, { "solver", options.solver },
        { "dt", scene.time.dt }, { "iterations", scene.time.iterations },
        { "steps_per_frame", scene.steps_per_frame }, { "frames", frames },
        { "threads", thread_count() } };
    Exporter exporter(simulation, output_settings, options.output, run_json.dump());
    std::unique_ptr<PreviewWriter> preview;
    if (options.preview)
        preview = std::make_unique<PreviewWriter>(
            simulation, options.output, options.preview_width, options.preview_height);
    const bool stats = !options.stats.empty();
    const bool measure = stats || exporter.wants_stretch();
    logger().info("{}: {} bodies, dt {} s, {} steps per frame, {} frames, {} iterations, {} "
                  "solver",
        scene.file, simulation.bodies().size(), scene.time.dt, scene.steps_per_frame, frames,
        scene.time.iterations,
        solver_kind == SolverKind::full
            ? "full-space"
            : (solver_kind == SolverKind::hyper_reduced ? "hyper-reduced" : "semi-reduced"));
    const double setup_seconds = total.seconds();

    std::vector<VecX> tet_strain(simulation.bodies().size());
    nlohmann::json frame_stats = nlohmann::json::array();
    double export_seconds = 0.0, preview_seconds = 0.0, measure_seconds = 0.0;
    SolverTimings before = total_timings(simulation);
    CollisionReport frame_collision, total_collision;
    int frame_sleeping_max = 0; ///< most bodies asleep after a step of the frame
    long sleeping_steps = 0; ///< sum over the steps of the bodies asleep after it
    CollisionCheckCounts frame_check, total_check;
    Timer loop;

    auto output_frame
        = [&](int frame, const std::vector<StepReport>& reports, double step_seconds) {
              Timer timer;
              nlohmann::json bodies = nlohmann::json::array();
              Vec3 momentum = Vec3::Zero();
              if (measure) {
                  for (std::size_t b = 0; b < simulation.bodies().size(); ++b) {
                      const Body& body = simulation.bodies()[b];
                      const BodyMeasures m = measure_body(
                          body.model->pd(), body.state, scene.gravity, &tet_strain[b]);
                      nlohmann::json entry { { "name", body.name },
                          { "energy",
                              { { "kinetic", m.kinetic }, { "potential", m.potential },
                                  { "elastic", m.elastic },
                                  { "total", m.kinetic + m.potential + m.elastic } } },
                          { "max_strain", m.max_strain }, { "momentum", vector_json(m.momentum) } };
                      momentum += m.momentum;
                      if (b < reports.size())
                          entry["contact"] = { { "candidates", reports[b].contacts },
                              { "active", reports[b].active_contacts },
                              { "sweeps", reports[b].contact_sweeps },
                              { "max_penetration", reports[b].max_penetration },
                              { "impulse", vector_json(reports[b].contact_impulse) } };
                      bodies.push_back(std::move(entry));
                  }
              }
              measure_seconds += timer.seconds();
              timer.restart();
              exporter.write_frame(frame, simulation.time(), simulation, tet_strain);
              const double this_export = timer.seconds();
              export_seconds += this_export;
              if (preview) {
                  timer.restart();
                  preview->write_frame(frame, simulation);
                  preview_seconds += timer.seconds();
              }
              if (stats) {
                  const SolverTimings now = total_timings(simulation);
                  nlohmann::json entry { { "frame", frame }, { "time", simulation.time() },
                      { "steps", simulation.steps() }, { "sleeping", simulation.num_sleeping() },
                      { "sleeping_max", frame_sleeping_max },
                      { "iterations", now.iterations - before.iterations },
                      { "step_seconds", step_seconds },
                      { "phase_seconds", phase_json(now, before, this_export, 1.0) },
                      { "bodies", std::move(bodies) } };
                  if (measure)
                      entry["momentum"] = vector_json(momentum);
                  if (simulation.collision() != nullptr)
                      entry["collision"] = collision_json(frame_collision);
                  if (options.check_collisions && frame > 0)
                      entry["collision_check"] = check_json(frame_check);
                  frame_stats.push_back(std::move(entry));
                  before = now;
              }
          };

    output_frame(0, {}, 0.0);
    ProgressBar progress("mat-run", static_cast<std::int64_t>(frames) * scene.steps_per_frame);
    std::vector<StepReport> reports(simulation.bodies().size());
    for (int frame = 1; frame <= frames; ++frame) {
        Timer step_timer;
        for (auto& r : reports)
            r = StepReport {};
        frame_collision = CollisionReport {};
        frame_sleeping_max = 0;
        frame_check = CollisionCheckCounts {};
        for (int s = 0; s < scene.steps_per_frame; ++s) {
            simulation.step();
            frame_sleeping_max = std::max(frame_sleeping_max, simulation.num_sleeping());
            sleeping_steps += simulation.num_sleeping();
            if (const CollisionWorld* collision = simulation.collision()) {
                accumulate(frame_collision, collision->last_report());
                accumulate(total_collision, collision->last_report());
            }
            if (options.check_collisions) {
                const CollisionCheckCounts check = check_collisions(simulation);
                if (check.far_found != check.far_pairs)
                    logger().warn("collision check, step {}: the world found {} of the {} "
                                  "intersecting triangle pairs in different bodies or "
                                  "non-adjacent primitives",
                        simulation.steps(), check.far_found, check.far_pairs);
                frame_check.add(check);
                total_check.add(check);
            }
            for (std::size_t b = 0; b < reports.size(); ++b) {
                if (simulation.bodies()[b].asleep)
                    continue; // not stepped: its solver's report is of an earlier step
                const StepReport& last = simulation.bodies()[b].solver->last_report();
                reports[b].contacts = std::max(reports[b].contacts, last.contacts);
                reports[b].active_contacts
                    = std::max(reports[b].active_contacts, last.active_contacts);
                reports[b].contact_sweeps += last.contact_sweeps;
                reports[b].max_penetration
                    = std::max(reports[b].max_penetration, last.max_penetration);
                reports[b].contact_impulse += last.contact_impulse;
            }
            progress.advance();
        }
        output_frame(frame, reports, step_timer.seconds());
    }
    progress.finish();
    Timer finish_timer;
    exporter.finish();
    export_seconds += finish_timer.seconds();
    if (preview) {
        finish_timer.restart();
        preview->write_movie(1.0 / scene.frame_interval());
        preview_seconds += finish_timer.seconds();
    }
    const double loop_seconds = loop.seconds();

    const SolverTimings timings = total_timings(simulation);
    const long steps = simulation.steps();
    std::printf("simulated %.4g s in %ld steps (%d frames, %ld files) in %.3f s, setup %.3f s, "
                "peak RSS %.0f MB\n",
        simulation.time(), steps, frames,
        exporter.files_written() + (preview ? preview->files_written() : 0), loop_seconds,
        setup_seconds, peak_rss_bytes() / 1e6);
    std::fputs(timing_table(timings, detection_seconds(total_collision), export_seconds,
                   preview_seconds, measure_seconds, loop_seconds, steps)
                   .c_str(),
        stdout);
    if (scene.solver.sleep_speed > 0.0)
        std::printf("sleeping: %d of %zu bodies at the end, %.2f on average over the steps\n",
            simulation.num_sleeping(), simulation.bodies().size(),
            steps > 0 ? static_cast<double>(sleeping_steps) / static_cast<double>(steps) : 0.0);
    if (options.check_collisions)
        std::fputs(check_summary(total_check, largest_diagonal(simulation)).c_str(), stdout);
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

    if (stats) {
        nlohmann::json document { { "run", run_json }, { "setup_seconds", setup_seconds },
            { "loop_seconds", loop_seconds }, { "steps", steps },
            { "peak_rss_bytes", peak_rss_bytes() }, { "sleeping", simulation.num_sleeping() },
            { "sleeping_mean",
                steps > 0 ? static_cast<double>(sleeping_steps) / static_cast<double>(steps)
                          : 0.0 },
            { "ms_per_step",
                phase_json(timings, SolverTimings {}, export_seconds,
                    steps > 0 ? 1e3 / static_cast<double>(steps) : 0.0) },
            { "frames", std::move(frame_stats) } };
        if (simulation.collision() != nullptr)
            document["collision_ms_per_step"] = collision_phase_json(
                total_collision, steps > 0 ? 1e3 / static_cast<double>(steps) : 0.0);
        if (options.check_collisions)
            document["collision_check"] = check_json(total_check);
        if (reference)
            document["reference_error"] = { { "rms_percent", reference_error.rms_percent },
                { "max_percent", reference_error.max_percent },
                { "diagonal", reference_error.diagonal }, { "reference", options.reference },
                { "frame_rms_percent",
                    std::vector<double>(reference_error.frame_rms_percent.begin(),
                        reference_error.frame_rms_percent.end()) },
                { "frame_max_percent",
                    std::vector<double>(reference_error.frame_max_percent.begin(),
                        reference_error.frame_max_percent.end()) } };
        text_io::write_file_atomically(options.stats, document.dump(1) + "\n");
    }
}

} // namespace mat
