#pragma once
// Medial mesh files (.ma), in both dialects of docs/method.md, section 1:
//   Q-MAT:       header `nv ne nf`, records `v x y z r`, `e i j`, `f i j k`. The edge list also
//                holds every edge of every face: slabs = faces, cones = edges on no face.
//   the paper's: header `nv nc ns`, records `v x y z r`, `c i j` (cones), `s i j k` (slabs).
// Indices are 0-based; '#' starts a comment; blank lines are ignored. The dialect is told by
// the record letters the body uses (e/f or c/s); a file of spheres only is valid in both.
// Medial IPC's .mat files are the paper's dialect with `v x y z r t`, t the sphere's tet node:
// checked to be an integer and ignored (docs/mat-bake.md, Inputs).

#include <string>
#include <string_view>

#include "common/mesh_types.hpp"

namespace mat {

enum class MedialDialect { qmat, paper };

/// Reads a medial mesh from a .ma file of either dialect. Throws mat::Error with one line naming
/// the file, the line number and the problem: missing or malformed header, header counts that
/// the body does not match, unknown record letter, wrong number of fields, non-numeric or
/// non-finite value, index out of range, radius <= 0, degenerate or duplicate primitive, or
/// records of both dialects in one file.
MedialMesh read_medial(const std::string& path);

/// The same reader on text already in memory; `name` stands for the file in error messages.
MedialMesh read_medial_from_string(std::string_view text, const std::string& name);

/// Writes `mesh` to `path` atomically (a reader never sees a partial file), values printed with
/// %.17g so that they read back bit for bit. Q-MAT output lists the cones and then every slab
/// edge not already listed, so that reading it back gives the same cones and slabs. A cone that
/// lies on a slab edge is implied by that slab in Q-MAT and does not survive the round trip
/// (a warning is logged); the paper's dialect keeps it. Throws mat::Error naming the path and
/// the element if the mesh is invalid (the same rules as the reader) or the file cannot be
/// written.
void write_medial(
    const std::string& path, const MedialMesh& mesh, MedialDialect dialect = MedialDialect::qmat);

/// The text write_medial() writes. Throws mat::Error if the mesh is invalid.
std::string format_medial(const MedialMesh& mesh, MedialDialect dialect = MedialDialect::qmat);

} // namespace mat
