#include "runtime/run_stats.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <sstream>

#include "common/log.hpp"
#include "common/timer.hpp"
#include "formats/text_io.hpp"
#include "runtime/measures/body_measures.hpp"
#include "runtime/simulation.hpp"

namespace mat {

namespace {

    /// [x, y, z].
    nlohmann::json vector_json(const Vec3& v)
    {
        return { v.x(), v.y(), v.z() };
    }

    /// Seconds per solver phase between two totals, and the export's, times `scale`.
    nlohmann::json phase_json(
        const SolverTimings& now, const SolverTimings& before, double export_seconds, double scale)
    {
        return nlohmann::json {
            { "local", scale * (now.local - before.local) },
            { "rhs", scale * (now.rhs - before.rhs) },
            { "solve", scale * (now.solve - before.solve) },
            { "reconstruct", scale * (now.reconstruct - before.reconstruct) },
            { "contact", scale * (now.contact - before.contact) },
            { "acceleration", scale * (now.acceleration - before.acceleration) },
            { "device", scale * (now.device - before.device) },
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
        into.node_tests = std::max(into.node_tests, step.node_tests);
        into.edge_tests = std::max(into.edge_tests, step.edge_tests);
        into.intersecting_triangles
            = std::max(into.intersecting_triangles, step.intersecting_triangles);
        into.contacts = std::max(into.contacts, step.contacts);
        into.edge_contacts = std::max(into.edge_contacts, step.edge_contacts);
        into.deep_vertices = std::max(into.deep_vertices, step.deep_vertices);
        into.max_penetration = std::max(into.max_penetration, step.max_penetration);
        into.add_seconds(step);
    }

    /// Seconds per collision phase times `scale`.
    nlohmann::json collision_phase_json(const CollisionReport& r, double scale)
    {
        return nlohmann::json { { "bounds", scale * r.bounds_seconds },
            { "hash", scale * r.hash_seconds }, { "primitives", scale * r.primitive_seconds },
            { "triangles", scale * r.triangle_seconds },
            { "response", scale * r.response_seconds } };
    }

    /// A frame's `collision` entry.
    nlohmann::json collision_json(const CollisionReport& r)
    {
        return nlohmann::json { { "updated_bodies", r.updated_bodies },
            { "object_pairs", r.object_pairs }, { "hashed_bodies", r.hashed_bodies },
            { "candidates", r.primitive_candidates }, { "primitive_pairs", r.primitive_pairs },
            { "triangle_tests", r.triangle_tests }, { "node_tests", r.node_tests },
            { "edge_tests", r.edge_tests }, { "intersecting_triangles", r.intersecting_triangles },
            { "contacts", r.contacts }, { "edge_contacts", r.edge_contacts },
            { "deep_vertices", r.deep_vertices }, { "max_penetration", r.max_penetration },
            { "seconds", collision_phase_json(r, 1.0) } };
    }

    /// A `collision_check` entry (a frame's or the run's).
    nlohmann::json check_json(const CollisionCheckCounts& c)
    {
        return nlohmann::json { { "far_recall", recall(c.far_found, c.far_pairs) },
            { "far_pairs", c.far_pairs }, { "far_found", c.far_found },
            { "near_recall", recall(c.near_found, c.near_pairs) }, { "near_pairs", c.near_pairs },
            { "near_found", c.near_found }, { "extra", c.extra }, { "self_pairs", c.self_pairs },
            { "max_penetration", c.max_penetration },
            { "penetrating_vertices", c.penetrating_vertices },
            { "max_self_penetration", c.max_self_penetration },
            { "self_penetrating_vertices", c.self_penetrating_vertices }, { "steps", c.steps },
            { "seconds", c.seconds } };
    }

    /// A body's measures and, after a frame's steps, its contacts over them.
    nlohmann::json body_json(const std::string& name, const BodyMeasures& m, const StepReport* r)
    {
        nlohmann::json entry { { "name", name },
            { "energy",
                { { "kinetic", m.kinetic }, { "potential", m.potential }, { "elastic", m.elastic },
                    { "total", m.kinetic + m.potential + m.elastic } } },
            { "max_strain", m.max_strain }, { "momentum", vector_json(m.momentum) } };
        if (r != nullptr)
            entry["contact"] = { { "candidates", r->contacts }, { "active", r->active_contacts },
                { "sweeps", r->contact_sweeps }, { "max_penetration", r->max_penetration },
                { "impulse", vector_json(r->contact_impulse) } };
        return entry;
    }

} // namespace

std::string frame_log_path(const std::string& stats)
{
    const std::string extension = ".json";
    const bool json = stats.size() > extension.size()
        && stats.compare(stats.size() - extension.size(), extension.size(), extension) == 0;
    return (json ? stats.substr(0, stats.size() - extension.size()) : stats) + ".frames.jsonl";
}

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
        sum.acceleration += t.acceleration;
        sum.device += t.device;
        sum.iterations += t.iterations;
        sum.accelerated += t.accelerated;
        sum.refused += t.refused;
    }
    return sum;
}

RunStats::RunStats(const Simulation& simulation, const Vec3& gravity, bool stats, bool measure,
    bool check_collisions)
    : m_simulation(simulation)
    , m_gravity(gravity)
    , m_stats(stats)
    , m_measure(measure)
    , m_check_collisions(check_collisions)
    , m_first_step(simulation.steps())
    , m_tet_strain(simulation.bodies().size())
    , m_before(total_timings(simulation))
{
}

void RunStats::open_frame_log(const std::string& path, int resume_frame)
{
    m_log_path = path;
    m_resume_frame = resume_frame;
    std::string kept;
    if (resume_frame >= 0) {
        // Complete lines only (a killed run may have left a partial last line), up to the frame.
        std::istringstream lines(text_io::read_file(path));
        std::string line;
        while (std::getline(lines, line) && !lines.eof()) {
            const nlohmann::json entry = nlohmann::json::parse(line, nullptr, false);
            if (entry.is_discarded() || !entry.contains("frame")
                || entry["frame"].get<int>() != static_cast<int>(m_frames.size())
                || entry["frame"].get<int>() > resume_frame)
                break;
            kept += line + "\n";
            m_frames.push_back(entry);
        }
        if (static_cast<int>(m_frames.size()) != resume_frame + 1)
            logger().warn("{}: holds {} of the {} frames before the resumed run: --stats lists "
                          "only those",
                path, m_frames.size(), resume_frame + 1);
    }
    text_io::write_file_atomically(path, kept);
    m_log.reset(std::fopen(path.c_str(), "a"));
    if (!m_log)
        throw_error("{}: cannot append to it: {}", path, std::strerror(errno));
}

void RunStats::start_frame()
{
    m_reports.assign(m_simulation.bodies().size(), StepReport {});
    m_frame_collision = CollisionReport {};
    m_frame_sleeping_max = 0;
    m_frame_check = CollisionCheckCounts {};
}

void RunStats::record_step()
{
    m_frame_sleeping_max = std::max(m_frame_sleeping_max, m_simulation.num_sleeping());
    m_sleeping_steps += m_simulation.num_sleeping();
    if (const CollisionWorld* collision = m_simulation.collision()) {
        accumulate(m_frame_collision, collision->last_report());
        accumulate(m_total_collision, collision->last_report());
    }
    if (m_check_collisions) {
        const CollisionCheckCounts check = check_collisions(m_simulation);
        if (check.far_found != check.far_pairs)
            logger().warn("collision check, step {}: the world found {} of the {} intersecting "
                          "triangle pairs in different bodies or non-adjacent primitives",
                m_simulation.steps(), check.far_found, check.far_pairs);
        m_frame_check.add(check);
        m_total_check.add(check);
    }
    for (std::size_t b = 0; b < m_reports.size(); ++b) {
        if (m_simulation.bodies()[b].asleep)
            continue; // not stepped: its solver's report is of an earlier step
        const StepReport& last = m_simulation.bodies()[b].solver->last_report();
        StepReport& report = m_reports[b];
        report.contacts = std::max(report.contacts, last.contacts);
        report.active_contacts = std::max(report.active_contacts, last.active_contacts);
        report.contact_sweeps += last.contact_sweeps;
        report.max_penetration = std::max(report.max_penetration, last.max_penetration);
        report.contact_impulse += last.contact_impulse;
    }
}

const std::vector<VecX>& RunStats::measure_frame()
{
    Timer timer;
    m_bodies = nlohmann::json::array();
    m_momentum = Vec3::Zero();
    if (m_measure) {
        for (std::size_t b = 0; b < m_simulation.bodies().size(); ++b) {
            const Body& body = m_simulation.bodies()[b];
            const BodyMeasures m
                = measure_body(body.model->pd(), body.state, m_gravity, &m_tet_strain[b]);
            m_momentum += m.momentum;
            m_bodies.push_back(
                body_json(body.name, m, b < m_reports.size() ? &m_reports[b] : nullptr));
        }
    }
    m_measure_seconds += timer.seconds();
    return m_tet_strain;
}

void RunStats::record_frame(
    int frame, double step_seconds, double export_seconds, double preview_seconds)
{
    m_export_seconds += export_seconds;
    m_preview_seconds += preview_seconds;
    if (!m_stats)
        return;
    const SolverTimings now = total_timings(m_simulation);
    nlohmann::json entry { { "frame", frame }, { "time", m_simulation.time() },
        { "steps", m_simulation.steps() }, { "sleeping", m_simulation.num_sleeping() },
        { "sleeping_max", m_frame_sleeping_max },
        { "iterations", now.iterations - m_before.iterations },
        { "accelerated", now.accelerated - m_before.accelerated },
        { "refused", now.refused - m_before.refused }, { "step_seconds", step_seconds },
        { "phase_seconds", phase_json(now, m_before, export_seconds, 1.0) },
        { "bodies", std::move(m_bodies) } };
    if (m_measure)
        entry["momentum"] = vector_json(m_momentum);
    if (m_simulation.collision() != nullptr)
        entry["collision"] = collision_json(m_frame_collision);
    if (m_check_collisions && frame > 0)
        entry["collision_check"] = check_json(m_frame_check);
    if (m_log) {
        const std::string line = entry.dump() + "\n";
        if (std::fputs(line.c_str(), m_log.get()) < 0 || std::fflush(m_log.get()) != 0)
            throw_error("{}: cannot append frame {}: {}", m_log_path, frame, std::strerror(errno));
    }
    m_frames.push_back(std::move(entry));
    m_before = now;
}

void RunStats::add_finish_seconds(double export_seconds, double preview_seconds)
{
    m_export_seconds += export_seconds;
    m_preview_seconds += preview_seconds;
}

long RunStats::run_steps() const
{
    return m_simulation.steps() - m_first_step;
}

double RunStats::sleeping_mean() const
{
    const long steps = run_steps();
    return steps > 0 ? static_cast<double>(m_sleeping_steps) / static_cast<double>(steps) : 0.0;
}

void RunStats::write(const std::string& path, const nlohmann::json& run_json, double setup_seconds,
    double loop_seconds, const TrajectoryError* reference_error, const std::string& reference)
{
    const long steps = run_steps();
    const double per_step = steps > 0 ? 1e3 / static_cast<double>(steps) : 0.0;
    nlohmann::json document { { "run", run_json }, { "setup_seconds", setup_seconds },
        { "loop_seconds", loop_seconds }, { "steps", m_simulation.steps() },
        { "peak_rss_bytes", peak_rss_bytes() }, { "sleeping", m_simulation.num_sleeping() },
        { "sleeping_mean", sleeping_mean() },
        { "ms_per_step",
            phase_json(total_timings(m_simulation), SolverTimings {}, m_export_seconds, per_step) },
        { "frames", std::move(m_frames) } };
    if (m_simulation.collision() != nullptr)
        document["collision_ms_per_step"] = collision_phase_json(m_total_collision, per_step);
    if (m_check_collisions)
        document["collision_check"] = check_json(m_total_check);
    if (m_resume_frame >= 0)
        document["resumed_from_frame"] = m_resume_frame;
    if (reference_error != nullptr)
        document["reference_error"] = { { "rms_percent", reference_error->rms_percent },
            { "max_percent", reference_error->max_percent },
            { "diagonal", reference_error->diagonal }, { "reference", reference },
            { "frame_rms_percent",
                std::vector<double>(reference_error->frame_rms_percent.begin(),
                    reference_error->frame_rms_percent.end()) },
            { "frame_max_percent",
                std::vector<double>(reference_error->frame_max_percent.begin(),
                    reference_error->frame_max_percent.end()) } };
    text_io::write_file_atomically(path, document.dump(1) + "\n");
    m_frames = nlohmann::json::array();
}

} // namespace mat
