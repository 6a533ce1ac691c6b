#pragma once
// Tetrahedral mesh files for interchange with meshing tools:
//   Medit `.mesh` (ASCII): MeshVersionFormatted, Dimension 3, Vertices (x y z ref),
//     Tetrahedra (1-based i j k l ref), End. Other sections (Triangles, Edges, Corners, ...)
//     are skipped on read. Keywords and counts may share a line or not; each entry is one line.
//   TetGen `.node`/`.ele`: `.node` = `#P 3 #attributes #markers`, then `id x y z [attr] [marker]`;
//     `.ele` = `#T 4|10 #attributes`, then `id i j k l [...]`. Numbering is 0- or 1-based as the
//     first point's id says; attributes, boundary markers and quadratic nodes are skipped.
// Readers return positively oriented tets (det[x1-x0, x2-x0, x3-x0] > 0, as in docs/method.md,
// section 2, step 1): a tet read with negative orientation has its last two indices swapped, and
// the count is logged.

#include <string>
#include <string_view>

#include "common/mesh_types.hpp"

namespace mat {

/// Reads a tet mesh, choosing the format by extension: .mesh (Medit) or .node/.ele (TetGen,
/// both files are read). Throws mat::Error with one line naming the file, the line number and
/// the problem (bad counts, wrong number of fields, non-numeric or non-finite values, indices
/// out of range, repeated index in a tet), or an unknown extension.
TetMesh read_tet_mesh(const std::string& path);

/// Writes a tet mesh, choosing the format by extension: .mesh (Medit) or .node/.ele (TetGen:
/// writes both `<base>.node` and `<base>.ele`). Atomic: nothing is left half-written (for TetGen
/// both temporaries are written before either is committed). Throws mat::Error on an invalid
/// mesh (non-finite position, index out of range, repeated index) or an I/O failure.
void write_tet_mesh(const std::string& path, const TetMesh& mesh);

/// Medit .mesh reader and writer (see the file comment).
TetMesh read_medit(const std::string& path);
/// The Medit reader on text in memory; `name` stands for the file in error messages.
TetMesh read_medit_from_string(std::string_view text, const std::string& name);
void write_medit(const std::string& path, const TetMesh& mesh);

/// TetGen reader: `basename_or_node_path` is `base`, `base.node` or `base.ele`; reads both.
TetMesh read_tetgen(const std::string& basename_or_node_path);
/// The TetGen reader on texts in memory; the names stand for the files in error messages.
TetMesh read_tetgen_from_strings(std::string_view node_text, const std::string& node_name,
    std::string_view ele_text, const std::string& ele_name);
/// TetGen writer: writes `<base>.node` and `<base>.ele` (0-based) for `base`, `base.node` or
/// `base.ele`.
void write_tetgen(const std::string& basename_or_path, const TetMesh& mesh);

} // namespace mat
