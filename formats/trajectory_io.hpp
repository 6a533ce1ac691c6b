#pragma once
// The trajectory cache of a run: one HDF5 file holding the surfaces of every object of a scene
// at every saved frame, written frame by frame (memory stays bounded whatever the run's
// length) and read back frame by frame.
//
// Layout (HDF5, see formats/hdf5_file.hpp):
//   /                       format_name = "medial-elastics-trajectory", format_version = 2,
//                           created_by = "medial elastics <version>",
//                           frame_count = #frames: the frames that are complete
//   /options                the run's options (JSON text, stored as given)
//   /time                   #rows >= #frames, float64
//   /objects/<name>/        attribute `index` = the object's position in the scene (0, 1, ...)
//       faces               #F x 3 int32 (0-based)
//       rest_positions      #V x 3 float64 (the positions the object was given at the start)
//       positions           #rows x #V x 3 float64
//       velocities          #rows x #V x 3 float64 (only if the run saved velocities)
// Only the first frame_count rows are frames. A growing trajectory has #rows = frame_count
// (chunked, extendible datasets); a reserved one (TrajectoryLayout::capacity) has the rows it
// reserved, stored contiguously, and frame_count is rewritten after every frame, once the
// frame's data is in the file: a file whose writer was killed holds every frame completed
// before (docs/mat-run.md, "Outputs and statistics"). Version 1 (no rows past the frames,
// frame_count optional) is read too.
//
// Errors throw mat::Error with one line naming the file and the dataset or object.

#include <string>
#include <vector>

#include "common/eigen_types.hpp"
#include "formats/hdf5_file.hpp"

namespace mat {

inline constexpr const char* trajectory_format_name = "medial-elastics-trajectory";
inline constexpr int trajectory_format_version = 2;

/// One object of a trajectory.
struct TrajectoryObject {
    std::string name; ///< non-empty, unique, no '/', not "." or ".."
    MatX3i faces; ///< #F x 3, 0-based indices into the vertices
    MatX3 rest_positions; ///< #V x 3, V >= 1
};

/// How a trajectory is stored.
struct TrajectoryLayout {
    /// 0: growing (the datasets grow by a frame per append). > 0: this many frames reserved
    /// (appends past it throw), for a file written in place and readable after every append.
    Index capacity = 0;
    /// Reserved only: whether the frames have velocities (decided up front).
    bool velocities = false;
};

/// Writes a trajectory: construct, append() every saved frame, commit() at the end. The file
/// is written to a temporary beside `path`; a growing trajectory is renamed at commit(), and a
/// writer destroyed without commit() (an exception, an aborted run) removes it and leaves an
/// existing `path` untouched. A reserved one may be renamed earlier by publish(), and is then
/// written in place: it holds the frames appended so far whenever the writer stops.
/// After an append() that threw, the writer refuses further appends and commit().
class TrajectoryWriter {
public:
    /// Starts the file: objects, their faces and rest positions, the options (JSON text).
    /// Throws mat::Error on invalid objects or if the file cannot be created.
    TrajectoryWriter(std::string path, const std::vector<TrajectoryObject>& objects,
        const std::string& options_json = "{}", H5WriterOptions options = {},
        TrajectoryLayout layout = {});

    /// Appends one frame at `time` (finite, greater than the previous frame's).
    /// `positions[i]  #V_i x 3` of object i, in the order given to the constructor;
    /// `velocities`, if given, likewise. The first append decides whether the trajectory holds
    /// velocities: later frames must then all give them, or all omit them.
    void append(double time, const std::vector<MatX3>& positions,
        const std::vector<MatX3>* velocities = nullptr);

    /// Frames appended so far.
    Index frame_count() const { return m_frames; }
    const std::string& path() const { return m_writer.target(); }

    /// A reserved trajectory: renames the file to `path` now (replacing an existing one); from
    /// then on every append() leaves it readable with the frames so far.
    void publish();

    /// Closes the file and renames it to `path`. Throws mat::Error on failure (no file is then
    /// left at `path`). No append() may follow.
    void commit();

private:
    struct Object {
        std::string group; ///< "/objects/<name>"
        Index num_vertices = 0;
    };

    void check_frame(const std::vector<MatX3>& values, const char* what) const;

    H5Writer m_writer;
    std::vector<Object> m_objects;
    TrajectoryLayout m_layout;
    Index m_frames = 0;
    double m_last_time = 0.0;
    bool m_velocities = false;
    bool m_failed = false;
};

/// Reads a trajectory written by TrajectoryWriter: its frame_count complete frames (of a file
/// still being written, or whose writer was killed, the frames complete at its last append).
/// The constructor checks the format stamp and the shapes of every dataset (frame counts,
/// vertex counts, face indices), so that the accessors only fail on an out-of-range argument or
/// an I/O error.
class TrajectoryReader {
public:
    explicit TrajectoryReader(std::string path);

    const std::string& path() const { return m_reader.path(); }
    /// The file's format version (1 or 2).
    int version() const { return m_version; }
    /// The options stored by the writer (JSON text).
    std::string options() const;

    Index frame_count() const { return m_times.size(); }
    /// `#frames` frame times, increasing.
    const VecX& times() const { return m_times; }

    Index object_count() const { return Index(m_names.size()); }
    /// Object names in the order they were given to the writer.
    const std::vector<std::string>& object_names() const { return m_names; }
    /// The index of the object named `name`. Throws mat::Error if there is none.
    Index object_index(const std::string& name) const;
    Index vertex_count(Index object) const;
    /// `#F x 3` faces of `object`.
    MatX3i faces(Index object) const;
    /// `#V x 3` rest positions of `object`.
    MatX3 rest_positions(Index object) const;

    /// `#V x 3` positions of `object` at `frame` (0-based).
    MatX3 positions(Index object, Index frame) const;
    bool has_velocities() const { return m_velocities; }
    /// `#V x 3` velocities of `object` at `frame`. Throws mat::Error if the file has none.
    MatX3 velocities(Index object, Index frame) const;

private:
    std::string group(Index object) const;
    void check_index(Index object, Index frame) const;

    H5Reader m_reader;
    int m_version = 0;
    VecX m_times;
    std::vector<std::string> m_names;
    std::vector<Index> m_vertex_counts;
    bool m_velocities = false;
};

/// Appends the first `count` frames of `from` to `to` (the same objects in the same order, with
/// velocities if and only if `to` has them: append() throws otherwise).
void copy_frames(const TrajectoryReader& from, TrajectoryWriter& to, Index count);

} // namespace mat
