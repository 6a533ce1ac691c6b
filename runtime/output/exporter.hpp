#pragma once
// Writes a run's frames (apart from the step: it reads the bodies' states). For every output
// frame f (0 = the initial state) and body NAME, in the output directory:
//   obj, ply  NAME_fffff.obj / .ply           the body's surface
//   vtu       NAME_fffff.vtu and frames.pvd   the surface with the requested fields
//                                             (velocity: m/s per vertex; stretch: max |sigma-1|
//                                             of the vertex's tet), and a ParaView collection
//                                             rewritten after every frame
//   h5        trajectory.h5                    every frame of every body in one HDF5 cache
//                                             (formats/trajectory_io.hpp) with the run's frames
//                                             reserved: in place from the first frame on, and
//                                             readable to the last complete frame at any moment
// Every other file appears atomically.

#include <memory>
#include <string>
#include <vector>

#include "common/eigen_types.hpp"
#include "formats/frame_io.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/simulation.hpp"

namespace mat {

class TrajectoryWriter;

class Exporter {
public:
    /// `directory` must exist. `run_json` is stored in the trajectory cache, which reserves
    /// `frames` + 1 frames (0 to `frames`). `resume_frame` >= 0: the run goes on after that frame
    /// (mat-run --resume): the frames 0 to resume_frame of the directory's trajectory cache are
    /// kept (copied into the new one before it replaces the old), and frames.pvd lists them.
    /// Throws mat::Error if the cache to resume has fewer frames.
    Exporter(const Simulation& simulation, const OutputSettings& output, std::string directory,
        const std::string& run_json, int frames, int resume_frame = -1);
    ~Exporter();

    bool wants_stretch() const { return m_stretch; }

    /// Writes frame `frame` of every body at `time`. `tet_strain[b]` (T of body b) is needed
    /// when wants_stretch().
    void write_frame(
        int frame, double time, const Simulation& simulation, const std::vector<VecX>& tet_strain);
    /// Ends the run: commits the trajectory cache.
    void finish();
    /// Files written so far.
    long files_written() const { return m_files; }

private:
    std::string frame_path(const std::string& body, int frame, const char* extension) const;
    /// The trajectory cache: a new reserved file, with the kept frames of the old one.
    void start_trajectory(
        const Simulation& simulation, const std::string& run_json, int frames, int resume_frame);

    std::string m_directory;
    bool m_obj = false, m_ply = false, m_vtu = false, m_h5 = false;
    bool m_velocity = false, m_stretch = false;
    std::vector<PvdEntry> m_pvd;
    std::unique_ptr<TrajectoryWriter> m_trajectory;
    std::vector<MatX3> m_surface; ///< per body  #Vs x 3
    std::vector<MatX3> m_surface_velocity;
    long m_files = 0;
};

} // namespace mat
