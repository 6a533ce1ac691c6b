#pragma once
// Internal to formats/: checks of text OFF and OBJ files before assimp reads them. assimp 5.2's
// OFF loader trusts the header: a file with fewer vertex or face lines than announced, or a face
// index past the last vertex, ends in its validation text ("aiMesh::mFaces[5553].mIndices is
// nullptr") or is read with the index clamped; its OBJ loader names no line for a bad index.
// docs/mat-bake.md lists what is checked.

#include <string>

namespace mat::detail {

/// Checks a text OFF file ("OFF", "COFF", "NOFF", "STOFF" ... or no keyword) against its header:
/// three counts, as many vertex lines (3 numeric coordinates first) and face lines ("k i1 .. ik"
/// with 1 <= k <= 9 and every index a vertex of the file) as announced. Throws mat::Error
/// "<path>: line <n>: <problem>" naming the vertex or face. Files it does not know (binary OFF,
/// "4OFF", "nOFF", not OFF at all) are left to assimp.
void check_off_text(const std::string& path);

/// Checks the vertex indices of the f, l and p records of a .obj file: whole numbers, not 0,
/// positive ones at most the file's vertex count, negative ones (counted back) within the
/// vertices before the record. Throws mat::Error "<path>: line <n>: face <f>: <problem>".
void check_obj_text(const std::string& path);

/// Called after assimp failed to read `path`: a message naming the line (or byte) and the
/// problem for the classes assimp reports without one, or "" to keep assimp's reason. Knows an
/// ASCII STL that breaks the solid / facet / outer loop / 3 x vertex / endloop / endfacet
/// structure (a truncated file among them: assimp says "Invalid number of vertices") and a .gltf
/// that is not valid JSON (assimp says "No suitable reader found").
std::string explain_import_failure(const std::string& path);

} // namespace mat::detail
