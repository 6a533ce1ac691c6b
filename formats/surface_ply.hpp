#pragma once
// Internal to formats/: our own PLY reader. assimp 5.2's PLY loader hangs or crashes on some
// malformed files (a truncated header, a corrupted keyword), so read_surface() never hands PLY
// to it. Reads ascii, binary_little_endian and binary_big_endian; keeps double coordinates.

#include <string>

#include "formats/surface_io_internal.hpp"

namespace mat::detail {

/// True if the file starts with the PLY magic line ("ply" then a line break).
bool has_ply_magic(const std::string& path);

/// Reads the "vertex" element's x, y, z and the "face" element's vertex_indices (or
/// vertex_index) list; polygons are fan-triangulated, other elements and properties skipped.
/// Throws mat::Error naming the file, the header line or element index, and the problem.
RawSurface read_ply(const std::string& path);

} // namespace mat::detail
