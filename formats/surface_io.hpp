#pragma once
// Triangle surfaces on disk. Reading goes through assimp (any format it reads: OBJ, PLY, STL,
// OFF, glTF 2.0, ...); writing uses small writers of our own for .obj, .off, .ply and .stl.

#include <string>

#include "common/mesh_types.hpp"

namespace mat {

/// Reads a triangle surface from any format assimp reads. Polygons are triangulated, every mesh
/// of the scene is moved to world space by its node transforms and merged into one surface, and
/// vertices at exactly the same position are welded (normals, colors and texture coordinates are
/// discarded first, so that they do not keep copies apart). Points and lines are dropped with a
/// warning. assimp stores coordinates in single precision, so positions carry float precision.
/// Throws mat::Error naming the file and the reason if the file is missing or unreadable or
/// holds no triangle.
SurfaceMesh read_surface(const std::string& path);

/// Writes `mesh` by the extension of `path` (case-insensitive): .obj and .off (text, full double
/// precision), .ply (binary little-endian, double coordinates), .stl (binary, float coordinates).
/// The file appears atomically. Throws mat::Error on an unknown extension, an index outside the
/// vertex range or an I/O failure.
void write_surface(const std::string& path, const SurfaceMesh& mesh);

} // namespace mat
