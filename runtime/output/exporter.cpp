#include "runtime/output/exporter.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "common/error.hpp"
#include "formats/trajectory_io.hpp"

namespace mat {

Exporter::Exporter(const Simulation& simulation, const OutputSettings& output,
    std::string directory, const std::string& run_json, int frames, int resume_frame)
    : m_directory(std::move(directory))
{
    const auto has = [](const auto& list, auto item) {
        return std::find(list.begin(), list.end(), item) != list.end();
    };
    m_obj = has(output.formats, OutputFormat::obj);
    m_ply = has(output.formats, OutputFormat::ply);
    m_vtu = has(output.formats, OutputFormat::vtu);
    m_h5 = has(output.formats, OutputFormat::h5);
    m_velocity = has(output.fields, OutputField::velocity);
    m_stretch = has(output.fields, OutputField::stretch);
    const auto& bodies = simulation.bodies();
    for (const Body& body : bodies) {
        m_surface.emplace_back(body.model->surface().num_vertices(), 3);
        m_surface_velocity.emplace_back(body.model->surface().num_vertices(), 3);
    }
    if (m_h5)
        start_trajectory(simulation, run_json, frames, resume_frame);
    if (m_vtu) // the collection lists the kept frames
        for (int frame = 0; frame <= resume_frame; ++frame) {
            const Scene& scene = simulation.scene();
            const double time = static_cast<double>(long(frame) * scene.steps_per_frame)
                * scene.time.dt; // as Simulation::time() gives it
            for (std::size_t b = 0; b < bodies.size(); ++b)
                m_pvd.push_back(PvdEntry { time, static_cast<int>(b),
                    fmt::format("{}_{:05d}.vtu", bodies[b].name, frame) });
        }
}

void Exporter::start_trajectory(
    const Simulation& simulation, const std::string& run_json, int frames, int resume_frame)
{
    const auto& bodies = simulation.bodies();
    const std::string path = m_directory + "/trajectory.h5";
    // Rest positions: the bodies' placed rest state (of the first frame when resuming).
    std::unique_ptr<TrajectoryReader> kept;
    if (resume_frame >= 0) {
        kept = std::make_unique<TrajectoryReader>(path);
        if (kept->frame_count() < Index(resume_frame) + 1)
            throw_error("{}: holds {} frames, the checkpoint is at frame {} (run without --resume "
                        "to start over)",
                path, kept->frame_count(), resume_frame);
        if (kept->object_names().size() != bodies.size())
            throw_error("{}: has {} objects, the scene {}", path, kept->object_names().size(),
                bodies.size());
    }
    std::vector<TrajectoryObject> objects;
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        if (kept && kept->object_names()[b] != bodies[b].name)
            throw_error("{}: object {} is '{}', the scene's is '{}'", path, b,
                kept->object_names()[b], bodies[b].name);
        const MatX3 rest = kept ? kept->rest_positions(Index(b)) : [&] {
            MatX3 surface(bodies[b].model->surface().num_vertices(), 3);
            bodies[b].model->surface().positions(bodies[b].state.positions, surface);
            return surface;
        }();
        objects.push_back(
            TrajectoryObject { bodies[b].name, bodies[b].model->surface().faces(), rest });
    }
    H5WriterOptions unlocked; // readable by others while the run writes it
    unlocked.file_locking = false;
    m_trajectory = std::make_unique<TrajectoryWriter>(
        path, objects, run_json, unlocked, TrajectoryLayout { Index(frames) + 1, m_velocity });
    if (kept)
        copy_frames(*kept, *m_trajectory, Index(resume_frame) + 1);
    m_trajectory->publish();
}

Exporter::~Exporter() = default;

std::string Exporter::frame_path(const std::string& body, int frame, const char* extension) const
{
    return fmt::format("{}/{}_{:05d}.{}", m_directory, body, frame, extension);
}

void Exporter::write_frame(
    int frame, double time, const Simulation& simulation, const std::vector<VecX>& tet_strain)
{
    const auto& bodies = simulation.bodies();
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        const Body& body = bodies[b];
        body.model->surface().positions(body.state.positions, m_surface[b]);
        if (m_velocity)
            body.model->surface().interpolate(body.state.velocities, m_surface_velocity[b]);
        if (m_obj) {
            write_frame_surface(frame_path(body.name, frame, "obj"), m_surface[b],
                body.model->surface().faces(), SurfaceFrameFormat::obj);
            ++m_files;
        }
        if (m_ply) {
            write_frame_surface(frame_path(body.name, frame, "ply"), m_surface[b],
                body.model->surface().faces(), SurfaceFrameFormat::ply);
            ++m_files;
        }
        if (m_vtu) {
            std::vector<PointField> fields;
            if (m_velocity)
                fields.push_back(PointField { "velocity", m_surface_velocity[b] });
            if (m_stretch) {
                MAT_CHECK(
                    b < tet_strain.size() && tet_strain[b].size() == body.model->pd().num_tets(),
                    "exporter: no stretch given for body {}", body.name);
                const VecXi& tets = body.model->surface().tets();
                MatX stretch(tets.size(), 1);
                for (Index v = 0; v < tets.size(); ++v)
                    stretch(v, 0) = tet_strain[b](tets(v));
                fields.push_back(PointField { "stretch", std::move(stretch) });
            }
            const std::string path = frame_path(body.name, frame, "vtu");
            write_vtu(path, m_surface[b], body.model->surface().faces(), fields);
            m_pvd.push_back(PvdEntry {
                time, static_cast<int>(b), fmt::format("{}_{:05d}.vtu", body.name, frame) });
            ++m_files;
        }
    }
    if (m_vtu)
        write_pvd(m_directory + "/frames.pvd", m_pvd);
    if (m_h5)
        m_trajectory->append(time, m_surface, m_velocity ? &m_surface_velocity : nullptr);
}

void Exporter::finish()
{
    if (m_trajectory) {
        m_trajectory->commit();
        m_trajectory.reset();
        ++m_files;
    }
}

} // namespace mat
