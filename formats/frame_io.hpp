#pragma once
// Frames of a simulation run on disk, one file per frame, fast enough to write every step of a
// 10k-vertex surface:
// - surfaces as .obj (text, shortest round-trip doubles) or .ply (binary little-endian),
// - VTK XML UnstructuredGrid (.vtu) triangles with named per-vertex fields, for ParaView,
// - a ParaView collection (.pvd) listing the frames with their times.
// Every file appears atomically (formats/atomic_file.hpp): a failed write throws mat::Error
// (one line naming the path and the problem) and leaves no file behind, and an existing file is
// replaced only by a complete one. Non-finite coordinates or field values and face indices out
// of range are errors, so that no viewer ever meets a file it cannot read.

#include <string>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// The format of a surface frame.
enum class SurfaceFrameFormat {
    obj, ///< Wavefront OBJ text: `v x y z` and 1-based `f a b c` lines
    ply, ///< binary little-endian PLY: double x, y, z; faces as uchar-counted int lists
};

/// "obj" or "ply": the usual extension of `format`, without the dot.
const char* extension(SurfaceFrameFormat format);
/// Parses "obj" or "ply" (case-insensitive). Throws mat::Error naming `name` otherwise.
SurfaceFrameFormat parse_surface_frame_format(const std::string& name);

/// Writes one surface frame to `path` in `format` (whatever the extension of `path`).
/// `positions  #V x 3`, `faces  #F x 3` (0-based vertex indices).
void write_frame_surface(const std::string& path, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3i>& faces, SurfaceFrameFormat format);

/// A named per-vertex array of a VTU frame.
struct PointField {
    std::string name; ///< non-empty, unique among the fields of a frame
    MatX values; ///< #V x k, k = 1 (a scalar such as "stretch") or 3 (a vector, "velocity")
};

/// How a VTU stores its arrays.
enum class VtuEncoding {
    binary, ///< inline base64 with a UInt64 byte-count header (format="binary"): compact
    ascii, ///< inline text (format="ascii"), shortest round-trip doubles: readable, larger
};

/// Writes a VTK XML UnstructuredGrid of triangles (VTK cell type 5): Float64 points,
/// Int32 connectivity and offsets, UInt8 types, and one Float64 point-data array per field
/// (the first 1-component field is marked as the active scalars, the first 3-component one
/// as the active vectors). `positions  #V x 3`, `faces  #F x 3` (0-based).
void write_vtu(const std::string& path, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3i>& faces, const std::vector<PointField>& fields = {},
    VtuEncoding encoding = VtuEncoding::binary);

/// One frame of a ParaView collection.
struct PvdEntry {
    double time = 0.0; ///< simulated time of the frame (finite)
    int part = 0; ///< which object (piece) of the scene the file holds
    std::string file; ///< the frame's file, relative to the .pvd's directory
};

/// Writes a ParaView collection (.pvd) of `entries`, in the given order. Written atomically, so
/// a driver may rewrite it after every frame and a viewer always finds a valid file.
void write_pvd(const std::string& path, const std::vector<PvdEntry>& entries);

} // namespace mat
