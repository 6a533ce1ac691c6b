#pragma once
// The two CGAL Mesh_3 entry points: tetrahedralize a closed surface, and mesh the zero level set
// of an implicit function. Plain Eigen types in and out; every CGAL header stays in
// cgal_mesh3.cpp, the one translation unit that instantiates Mesh_3 (it compiles for over a
// minute), so nothing else recompiles it.
//
// Both are deterministic (bit for bit, run to run): sequential meshing, fixed random seeds, no
// perturbation, exudation without a time limit (or none).

#include <functional>

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

/// Mesh_3 criteria for tetrahedralize(), in ABSOLUTE units (the caller converts from fractions
/// of the bounding-box diagonal, e.g. with tetrahedralize_options_for()).
struct TetrahedralizeOptions {
    double cell_size = 0.0; ///< upper bound on a tet's circumradius, > 0
    double facet_size = 0.0; ///< upper bound on a boundary facet's Delaunay ball radius, > 0
    double facet_distance = 0.0; ///< upper bound on the facet-to-surface distance, > 0
    double facet_angle = 25.0; ///< lower bound on boundary facet angles, degrees, <= 30
    double cell_radius_edge_ratio = 3.0; ///< upper bound on circumradius / shortest edge, >= 2
    /// Sliver exudation without a time limit (so deterministic), stopped once every tet's
    /// smallest dihedral angle exceeds exude_sliver_bound degrees (0: improve while it can).
    /// On the armadillo at the default size it lifts the minimum dihedral angle from 0.3 to 4
    /// degrees for ~15% more time; a bound of 0 gives the same minimum in 5x the time.
    bool exude = true;
    double exude_sliver_bound = 15.0;
    /// Sliver perturbation without a time limit (deterministic), before exudation, aiming at a
    /// smallest dihedral angle of perturb_sliver_bound degrees. The creature at the default
    /// size: minimum dihedral angle 4.7 -> 8.8 degrees, meshing 0.2 -> 4.8 s; the armadillo
    /// (35k tets): 4.2 -> 8.7 degrees, 0.6 -> 3.3 s. The time rises steeply with the bound: the
    /// armadillo at tet size 0.06 (1.9k tets) meshes in 0.1 s without, 1.3 s at 10 degrees and
    /// 33 s at 15 (its whole bake: 1.6 s, 2.9 s at 10, 5.8 s at 12, 35 s at 15).
    bool perturb = true;
    double perturb_sliver_bound = 10.0;
    bool detect_features = false; ///< protect sharp edges (dihedral angle below feature_angle)
    double feature_angle = 60.0; ///< degrees; used only with detect_features
    /// Bound on the vertices of Mesh_3's triangulation (docs/mat-bake.md, "Bounds"): past it
    /// tetrahedralize() stops with an error. 0: no bound.
    Index max_vertices = 0;
};

/// The recommended default tet size, as a fraction of the bounding-box diagonal: the armadillo
/// (52k triangles) gives about 35k tets, 0.02 gives 17k, 0.04 gives 4k.
inline constexpr double k_default_tet_size = 0.015;

/// Options derived from one relative size: cell_size = tet_size * diagonal, facet_size the same,
/// facet_distance = tet_size * diagonal / 10.
/// diagonal  the length of the surface's bounding-box diagonal, > 0
inline TetrahedralizeOptions tetrahedralize_options_for(double diagonal, double tet_size)
{
    TetrahedralizeOptions options;
    options.cell_size = tet_size * diagonal;
    options.facet_size = tet_size * diagonal;
    options.facet_distance = 0.1 * tet_size * diagonal;
    return options;
}

/// Tetrahedralizes the interior of a closed, manifold, outward-oriented surface with CGAL Mesh_3
/// (polyhedral domain). The result holds only vertices used by tets, every tet positively
/// oriented, vertices in Morton (Z-curve) order and tets sorted by their centroid's Morton key.
/// Throws mat::Error on invalid options, a surface CGAL cannot use, or an empty result.
TetMesh tetrahedralize(const SurfaceMesh& surface, const TetrahedralizeOptions& options);

/// Mesh_3 criteria for mesh_implicit_surface(), in absolute units.
struct ImplicitSurfaceOptions {
    double facet_size = 0.0; ///< upper bound on a facet's surface Delaunay ball radius, > 0
    double facet_distance = 0.0; ///< upper bound on the facet-to-surface distance, > 0
    double facet_angle = 30.0; ///< lower bound on facet angles, degrees, <= 30
    double relative_error_bound = 1e-8; ///< of the domain's bisection onto the zero set
    int projection_steps = 3; ///< Newton steps projecting each vertex onto the zero set after
                              ///< meshing (finite-difference gradient); 0 turns it off
    /// #P x 3 points known to lie inside (e.g. medial sphere centers). Rays from each along the
    /// 6 axis directions seed Mesh_3 on the zero set, so that no part holding one is missed;
    /// the zero set is also seeded from a grid of spacing ~facet_size over the bounds.
    MatX3 interior_points;
};

/// A closed, manifold surface of the zero level set of `signed_distance` (negative inside),
/// which must be positive on the boundary of `bounds` and safe to call concurrently (the seeding
/// grid and the projection evaluate it in parallel). Faces are oriented outward (the enclosed
/// signed volume is positive), vertices are shared between faces.
/// Throws mat::Error on invalid options or when the level set inside `bounds` is empty.
SurfaceMesh mesh_implicit_surface(const std::function<double(const Vec3&)>& signed_distance,
    const Box3& bounds, const ImplicitSurfaceOptions& options);

} // namespace mat
