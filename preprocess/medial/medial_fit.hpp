#pragma once
// How a medial mesh fits its surface (mat-bake step 1): every sphere center must lie inside the
// surface; the envelope should cover every surface vertex, and radii are inflated by the least
// uniform amount that makes it, so that collision culling is conservative.

#include <string>

#include "common/mesh_types.hpp"

namespace mat {

/// Generalized winding number of a closed, outward surface at p: 1 inside, 0 outside
/// (Jacobson et al. 2013, solid angles by Van Oosterom and Strackee 1983).
double winding_number(const SurfaceMesh& surface, const Eigen::Ref<const Vec3>& p);

/// Throws mat::Error naming `medial_file`, the sphere and its center if a sphere center lies
/// outside `surface` (winding number < 0.5).
void require_centers_inside(const MedialMesh& medial, const SurfaceMesh& surface,
    const std::string& medial_file, const std::string& surface_file);

struct MedialCoverage {
    Index vertices = 0; ///< surface vertices tested
    Index uncovered = 0; ///< vertices enclosed by no primitive
    double max_outside = 0.0; ///< largest distance of a vertex outside the envelope
    double inflation = 0.0; ///< amount added to every radius so that all are enclosed
    double bbox_diagonal = 0.0; ///< of the surface, to express the figures relatively
};

/// Measures the coverage of the surface's vertices by the envelope of `medial`.
MedialCoverage measure_coverage(const MedialMesh& medial, const SurfaceMesh& surface);

/// Adds the least uniform amount to every radius so that the envelope encloses every surface
/// vertex (a little more than coverage.max_outside, for rounding). Returns the inflated mesh;
/// coverage.inflation is set to the amount.
MedialMesh inflate_to_cover(const MedialMesh& medial, MedialCoverage& coverage);

} // namespace mat
