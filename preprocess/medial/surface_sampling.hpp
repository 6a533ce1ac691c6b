#pragma once
// Deterministic, roughly uniform point samples of a triangle surface: every vertex, points on
// the edges and inside the faces at a lattice spacing, thinned on a grid when there are too many.

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

struct SurfaceSamples {
    MatX3 points; ///< #P x 3, pairwise distinct
    VecXi faces; ///< #P, a face each point lies on
    double spacing = 0.0; ///< the lattice spacing used
};

/// About `target_count` points spread over `surface` (at least its vertices while they are
/// fewer than 1.3 x target_count; beyond that the vertices are thinned too, keeping per grid cell
/// the point closest to the cell center). Faces bigger than the spacing get a barycentric
/// lattice; every vertex and every edge point is emitted once. Deterministic.
/// target_count  > 0
SurfaceSamples sample_surface(const SurfaceMesh& surface, Index target_count);

} // namespace mat
