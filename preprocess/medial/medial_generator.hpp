#pragma once
// A medial mesh for any closed surface (docs/method.md, section 1), so that a bare surface can be
// baked:
//   1. sample the surface (deterministic lattice, thinned to a target count);
//   2. Delaunay-tetrahedralize the samples (CGAL) and keep the Voronoi vertices inside the
//      surface, with the Voronoi edges and faces between them (the inner Voronoi complex);
//      pieces that parts thinner than the sampling split off are bridged, and if some remain
//      the surface is sampled 4x more densely (twice at most);
//   3. simplify it to N spheres by edge collapse: with the spherical quadric error and the
//      stability ratio of Q-MAT (Li et al. 2015) down to 3N, then by the exact distance each
//      collapse causes; every center kept inside, every new primitive within a tolerance of the
//      surface (medial_simplify.hpp);
//   4. remove sliver slabs and degenerate cones;
//   5. measure the fit: two-sided Hausdorff distance surface <-> envelope and coverage.
// Deterministic (sequential CGAL, order-independent parallel loops).

#include <string>

#include "common/mesh_types.hpp"

namespace mat {

struct MedialGeneratorOptions {
    Index spheres = 200; ///< N, the number of spheres wanted, in [1, samples / 4]
    Index samples = 20000; ///< surface samples for the Voronoi diagram, in [100, 500000]
    /// Every sphere center lies at least this deep inside (fraction of the bbox diagonal).
    double min_depth = 1e-4;
    /// Allowed crossing of the surface by a sphere or a new primitive during the simplification
    /// (fraction of the bbox diagonal); doubled whenever no collapse is left.
    double max_protrusion = 0.005;
    /// k of the collapse cost (E + k) tau^2, as a fraction of the diagonal (squared inside).
    double stability = 0.003;
    /// The last collapses, from refine_factor x N spheres down to N, are ranked by the exact
    /// distance they cause (slower, much closer fit; 1 turns it off).
    double refine_factor = 3.0;
    /// Smallest interior angle of a slab's center triangle, degrees; thinner slabs become cones.
    double min_slab_angle = 2.0;
    /// Bound on the simplification's work: surface distance queries per sphere of the inner
    /// Voronoi complex (docs/mat-bake.md, "Bounds"); past it the generator stops with an error.
    double query_bound = 200.0;
    Index quality_samples = 50000; ///< surface points for the Hausdorff distance and coverage
    int quality_directions = 48; ///< rays per explored sphere for the envelope -> surface side
    std::string surface_name = "surface"; ///< names the surface in error messages
};

/// What the generator did and how well the result fits (absolute lengths; see hausdorff_percent).
struct MedialQuality {
    Index samples = 0; ///< surface samples of the Voronoi diagram
    Index initial_spheres = 0, initial_edges = 0, initial_triangles = 0;
    Index spheres = 0, cones = 0, slabs = 0;
    Index removed_slivers = 0; ///< slabs turned into cones by the cleanup
    int resamplings = 0; ///< times the surface was sampled again, 4x more densely
    Index pieces = 0; ///< of the inner Voronoi complex, through its edges
    int relaxations = 0; ///< times the protrusion tolerance was doubled
    Index surface_queries = 0; ///< made by the simplification's checks
    double bbox_diagonal = 0.0;
    double hausdorff = 0.0; ///< two-sided, surface <-> envelope boundary
    double surface_to_envelope = 0.0;
    double envelope_to_surface = 0.0;
    double coverage = 0.0; ///< fraction of surface samples enclosed (before any inflation)
    double seconds = 0.0;

    double hausdorff_percent() const { return 100.0 * hausdorff / bbox_diagonal; }
    /// One line for the log and the CLI.
    std::string summary() const;
};

/// Generates a medial mesh of `surface` with options.spheres spheres (fewer only if the inner
/// Voronoi complex has fewer). The result has cones and slabs, no sliver slab, finite radii > 0
/// and every center inside the surface (winding number > 0.5). Fills *quality if given, and
/// logs its summary. Throws mat::Error naming options.surface_name if the surface is not a
/// closed, outward manifold, if the options are out of range, or if no valid medial mesh can be
/// made (e.g. parts too thin for the sampling).
MedialMesh generate_medial_mesh(
    const SurfaceMesh& surface, const MedialGeneratorOptions& options, MedialQuality* quality);

} // namespace mat
