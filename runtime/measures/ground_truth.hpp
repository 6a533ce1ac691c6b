#pragma once
// Exhaustive collision ground truth: every pair of intersecting triangles among a set of
// surfaces, between surfaces (object-object) and within one (self). The culling pipeline
// (medial broad and narrow phases, then triangle tests among the enclosed triangles) is judged
// against it, so it must miss nothing: a sort-and-sweep over the triangles' boxes (along the
// longest axis of the scene, in columns across it) finds every pair of overlapping closed
// boxes, and the exact triangles_intersect decides each (touching counts as intersecting).

#include <array>
#include <vector>

#include "common/mesh_types.hpp"

namespace mat {

/// (body_a, face_a, body_b, face_b) with (body_a, face_a) < (body_b, face_b).
using TrianglePair = std::array<int, 4>;

struct GroundTruthOptions {
    bool object_pairs = true; ///< pairs of triangles of different surfaces
    bool self_pairs = true; ///< pairs of triangles of one surface that share no vertex index
};

/// All intersecting triangle pairs of `surfaces` (each positions #V x 3, faces #F x 3), sorted.
/// Triangles of one surface that share a vertex index are adjacent and never reported. Throws
/// mat::Error naming the surface and the face (or vertex) on an out-of-range index or a
/// non-finite coordinate. Parallel (TBB); the result does not depend on the thread count.
std::vector<TrianglePair> intersecting_triangle_pairs(
    const std::vector<SurfaceMesh>& surfaces, const GroundTruthOptions& options = {});

} // namespace mat
