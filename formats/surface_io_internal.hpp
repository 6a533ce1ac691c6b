#pragma once
// Internal to formats/: what the surface reader, writer and PLY reader share.

#include <array>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include "common/mesh_types.hpp"

namespace mat::detail {

/// The triangles of a file as read, before welding.
struct RawSurface {
    std::vector<Vec3> positions;
    std::vector<std::array<Index, 3>> faces; ///< indices into positions, all in range
    Index dropped_points = 0; ///< one-vertex primitives skipped
    Index dropped_lines = 0; ///< two-vertex primitives skipped
    Index dropped_polygons = 0; ///< other primitives skipped (unexpected after triangulation)
};

/// The extension of `path` in lower case, with its dot (".obj"), or "" if there is none.
inline std::string lower_extension(const std::string& path)
{
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext)
        c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

/// Checks the chunk lengths of a binary glTF (GLB, versions 1 and 2) against the file's size:
/// assimp 5.2 allocates what a chunk header claims (4 GB for a 240-byte file). Files without
/// the "glTF" magic are left alone. Throws mat::Error "<path>: GLB chunk <i> ...".
void check_glb_header(const std::string& path);

} // namespace mat::detail
