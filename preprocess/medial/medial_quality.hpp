#pragma once
// How well a medial mesh's envelope (the union of its primitives) fits a closed surface: the
// two-sided Hausdorff distance between the surface and the envelope's boundary, and the
// fraction of the surface the envelope encloses.

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"
#include "preprocess/medial/surface_distance.hpp"

namespace mat {

struct MedialFitMeasure {
    Index surface_samples = 0; ///< surface points measured
    Index envelope_samples = 0; ///< envelope boundary points measured
    double surface_to_envelope = 0.0; ///< max over surface points of |envelope signed distance|
    double envelope_to_surface = 0.0; ///< max over envelope boundary points of the distance
    double hausdorff = 0.0; ///< the larger of the two, absolute
    double coverage = 0.0; ///< fraction of surface points inside the envelope, in [0, 1]
    double bbox_diagonal = 0.0; ///< of the surface
    Vec3 worst_surface_point = Vec3::Zero(); ///< where surface_to_envelope is reached
    Vec3 worst_envelope_point = Vec3::Zero(); ///< where envelope_to_surface is reached

    double hausdorff_percent() const { return 100.0 * hausdorff / bbox_diagonal; }
};

/// Measures the fit of `medial` to `surface` (whose SurfaceDistance is `distance`).
/// Surface -> envelope: the exact envelope signed distance (MedialDistanceField) at every
/// vertex and about `surface_samples` points of sample_surface(). Envelope -> surface: from the
/// center of every sphere, of the middle sphere of every cone and of the centroid sphere of every
/// slab, rays in `directions` Fibonacci directions (fewer, down to 12, past 200k rays) are marched
/// to the envelope's boundary (each step the depth there, which never crosses it), and the boundary
/// points' distances to the surface are taken. Deterministic; parallel.
MedialFitMeasure measure_medial_fit(const MedialMesh& medial, const SurfaceMesh& surface,
    const SurfaceDistance& distance, Index surface_samples = 50000, int directions = 48);

} // namespace mat
