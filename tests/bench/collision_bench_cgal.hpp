#pragma once
// A triangle-only broad phase with CGAL's box_intersection_d, for collision_bench.

#include "common/mesh_types.hpp"

namespace mat::bench {

struct TriangleBroadPhase {
    long box_pairs = 0; ///< triangle pairs whose boxes overlap (each tested exactly)
    long intersecting = 0; ///< of which intersect
};

/// Every intersecting pair of a triangle of `a` and a triangle of `b` (positions #V x 3, faces
/// #F x 3), single-threaded.
TriangleBroadPhase cgal_triangle_pairs(const SurfaceMesh& a, const SurfaceMesh& b);

} // namespace mat::bench
