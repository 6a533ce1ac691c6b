#pragma once
// Internal to the tet mesh readers and writers (tet_mesh_io*.cpp): what the Medit and TetGen
// code share. Not part of the formats API.

#include <string>
#include <string_view>
#include <vector>

#include "common/mesh_types.hpp"

namespace mat::tet_mesh_io_detail {

/// Case-insensitive comparison, for keywords and extensions.
bool iequals(std::string_view a, std::string_view b);
/// Whether `text` ends with `suffix`, ignoring case.
bool ends_with(std::string_view text, std::string_view suffix);

/// Mesh data as read, before it becomes a TetMesh.
struct RawTets {
    std::vector<double> positions; ///< x0 y0 z0 x1 ...
    std::vector<int> tets; ///< i0 j0 k0 l0 ..., 0-based, in range
};

/// Builds the mesh and makes every tet positively oriented (TetMesh's contract) by swapping the
/// last two indices of a negative one; logs how many were reordered and how many are flat.
TetMesh finish(const RawTets& raw, const std::string& name);

/// Throws mat::Error "<name>: cannot write: ..." for a non-finite position, an index out of range
/// or a repeated index in a tet.
void validate(const TetMesh& mesh, const std::string& name);

/// Writes `text` to `path` through an AtomicFile.
void write_atomic(const std::string& path, const std::string& text);

} // namespace mat::tet_mesh_io_detail
