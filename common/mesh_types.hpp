#pragma once
// Plain mesh containers shared by every stage. No behaviour beyond size queries: readers fill
// them, algorithms take their members as Eigen references.

#include "common/eigen_types.hpp"

namespace mat {

/// A triangle surface.
struct SurfaceMesh {
    MatX3 positions; ///< #V x 3
    MatX3i faces; ///< #F x 3, counter-clockwise seen from outside for a well-oriented surface

    Index num_vertices() const { return positions.rows(); }
    Index num_faces() const { return faces.rows(); }
};

/// A tetrahedral volume mesh.
struct TetMesh {
    MatX3 positions; ///< #V x 3
    MatX4i tets; ///< #T x 4, positively oriented: det[x1-x0, x2-x0, x3-x0] > 0

    Index num_vertices() const { return positions.rows(); }
    Index num_tets() const { return tets.rows(); }
};

/// A medial mesh: spheres (center, radius) joined by cones (2 spheres) and slabs (3 spheres).
/// Primitives interpolate linearly between their spheres (docs/method.md, section 1).
struct MedialMesh {
    MatX3 centers; ///< #S x 3 sphere centers
    VecX radii; ///< #S sphere radii, > 0
    MatX2i cones; ///< #C x 2 sphere indices
    MatX3i slabs; ///< #L x 3 sphere indices

    Index num_spheres() const { return centers.rows(); }
    Index num_cones() const { return cones.rows(); }
    Index num_slabs() const { return slabs.rows(); }
};

} // namespace mat
