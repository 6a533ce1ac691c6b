#pragma once
// Simplification of a medial complex to a given number of spheres by edge collapse (Q-MAT, Li
// et al., ACM TOG 2015), in two phases:
//   1. down to refine_factor x N spheres: collapses ranked by the spherical quadric error of
//      the merged sphere against the tangent planes at the surface samples its spheres touched,
//      times the squared stability ratio, so that unstable edges (one sphere nearly inside the
//      other: the spikes of a sampled medial axis) go first;
//   2. down to N: every surface sample is given to its nearest sphere, and collapses are ranked
//      by the largest exact distance between those samples and the primitives the merged
//      sphere would have. The quadric sums squared errors, so it gives up small features
//      (ears, toes) for large smooth areas; this phase bounds the Hausdorff distance instead.
// A collapse is taken only if the merged center stays at least min_depth inside the surface
// and neither the merged sphere nor the middle of its new cones and slabs crosses the surface by
// more than max_protrusion (doubled whenever no collapse is left).

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"
#include "preprocess/medial/surface_distance.hpp"
#include "preprocess/medial/voronoi_medial.hpp"

namespace mat {

struct SimplifyOptions {
    Index target_spheres = 200; ///< N: stop at this many spheres, >= 1
    double min_depth = 0.0; ///< absolute: every center at least this deep inside, > 0
    double max_protrusion = 0.0; ///< absolute: allowed crossing of the surface, > 0
    double stability_constant = 0.0; ///< absolute squared length k of the cost (E + k) tau^2
    double refine_factor = 3.0; ///< phase 2 starts at refine_factor x N spheres, >= 1
    /// Stop once the checks have made this many surface distance queries (0: no bound); the
    /// report says so, and the result has more than N spheres.
    Index max_surface_queries = 0;
};

struct SimplifyReport {
    Index collapses = 0;
    Index refine_collapses = 0; ///< of which in phase 2
    Index rejected = 0; ///< candidate collapses refused by the checks
    int relaxations = 0; ///< times max_protrusion was doubled
    double final_max_protrusion = 0.0; ///< the tolerance in force at the end
    Index surface_queries = 0; ///< surface distance queries made by the checks
    bool stopped_at_bound = false; ///< max_surface_queries was reached
};

/// Simplifies `complex` (whose contact samples index rows of `samples`, #P x 3, the surface
/// samples) to options.target_spheres spheres, or as far as its components' edges allow.
/// Returns the spheres (in the order of their lowest original index), cones (edges on no slab)
/// and slabs, without further cleanup. Deterministic whatever the thread count.
MedialMesh simplify_medial(const MedialComplex& complex, const Eigen::Ref<const MatX3>& samples,
    const SurfaceDistance& surface, const SimplifyOptions& options, SimplifyReport* report);

} // namespace mat
