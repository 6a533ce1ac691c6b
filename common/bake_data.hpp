#pragma once
// Everything a bake file holds, in memory. mat-bake fills it, formats/bake_io writes and reads
// it, and the runtime builds its immutable Model from it. The runtime recomputes nothing from
// here but the factorizations for its own time step and material.
//
// Notation (docs/method.md, section 2): n tet-mesh nodes, T tets, m handles, k scalar basis
// columns (4 per linear handle, 10 per quadratic one), so r = 3k reduced DOF and U = B (x) I3.

#include <string>
#include <vector>

#include <Eigen/SparseCore>

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

using SparseRowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

/// The kinds of medial primitive, as stored in MedialCollisionData::primitive_kind.
enum class PrimitiveKind : int { sphere = 0, cone = 1, slab = 2 };

/// Per-primitive data that keeps the deformed medial mesh enclosing the deformed surface
/// (docs/method.md, section 2, step 7, and section 4). Primitives are numbered: the cones, then
/// the slabs, then the spheres that no cone or slab uses.
struct MedialCollisionData {
    VecXi primitive_kind; ///< #P, a PrimitiveKind
    MatX3i primitive_spheres; ///< #P x 3 sphere indices, -1 where unused (cones: 2, spheres: 1)

    /// Each surface vertex is enclosed by (assigned to) one primitive: the one containing it most
    /// deeply, with the interpolation parameter of the sphere that contains it.
    VecXi vertex_primitive; ///< #Vs
    MatX3 vertex_parameter; ///< #Vs x 3 weights of the primitive's spheres (sum 1, unused 0)
    /// Each surface triangle is listed under every primitive that encloses one of its vertices.
    VecXi face_primitives_indptr; ///< #P + 1, CSR rows over primitives
    VecXi face_primitives; ///< face indices, sorted within each primitive

    /// The bound (one term per handle with weight on the primitive): for every point x it
    /// encloses, with parameter t, || (B_x - sum_i t_i B_{c_i})_j || <= factor, so that
    /// ||x' - c'(t)|| <= r(t) + sum_j factor_j * sigma_max(Q_j - Q_j^rigid) after the
    /// primitive's rigid motion is removed (Q_j: handle j's 3 x (4|10) coefficients).
    VecXi bound_indptr; ///< #P + 1
    VecXi bound_handles; ///< handle indices, sorted within each primitive
    VecX bound_factors; ///< the factor of each (primitive, handle) entry
};

struct BakeData {
    // ---- provenance ----
    std::string surface_file; ///< as given on the command line
    std::string medial_file;
    std::string surface_hash; ///< "fnv1a64:..." of the file bytes
    std::string medial_hash;
    std::string options_json; ///< every bake option, as JSON
    std::string length_unit = "m";

    // ---- tetrahedral mesh ----
    TetMesh tet_mesh; ///< n nodes, T tets, positively oriented
    MatX dm_inverse; ///< T x 9, row-major 3x3 Dm^-1 per tet (F = Ds Dm^-1)
    VecX rest_volumes; ///< T
    VecX lumped_mass; ///< n, per unit density (volume / 4 summed over adjacent tets)

    // ---- surface, embedded in the tets ----
    SurfaceMesh surface; ///< the input surface (welded)
    VecXi surface_tet; ///< #Vs containing (or nearest) tet
    MatX surface_barycentric; ///< #Vs x 4
    Index surface_outside_count = 0; ///< vertices outside the tet mesh (extrapolated weights)

    // ---- medial mesh ----
    MedialMesh medial; ///< radii already inflated to enclose every surface vertex
    VecX medial_input_radii; ///< #S radii as read
    double medial_inflation = 0.0; ///< added to every radius
    VecXi medial_tet; ///< #S containing tet of each sphere center
    MatX medial_barycentric; ///< #S x 4

    // ---- handles and weights ----
    MatX3 handle_centers; ///< m x 3 (= the medial sphere centers)
    VecX handle_scales; ///< m, local coordinates y = (x - c_j) / s_j
    VecXi handle_quadratic; ///< m, 1 for a 30-DOF handle, 0 for 12 DOF
    VecXi handle_column_offsets; ///< m + 1: handle j owns basis columns [off_j, off_{j+1})
    SparseRowMatrix weights; ///< n x m, sparse, partition of unity, in [0, 1]

    // ---- basis and PD operators ----
    SparseRowMatrix basis; ///< n x k, U = B (x) I3
    SparseRowMatrix medial_basis; ///< #S x k, rows of B at the sphere centers
    SparseRowMatrix laplacian; ///< n x n, sum_e vol_e G_e^T G_e (unit stiffness)
    MatX reduced_laplacian; ///< k x k, B^T L B
    MatX reduced_mass; ///< k x k, B^T M B per unit density

    // ---- collision ----
    MedialCollisionData collision;

    Index num_handles() const { return handle_centers.rows(); }
    Index num_columns() const { return basis.cols(); }
};

} // namespace mat
