#pragma once
// The collision-bound data of a bake (docs/method.md, section 2, step 7): which medial primitive
// encloses each surface vertex and triangle, and the per-(primitive, handle) factors that bound
// how far a deformed enclosed point can stray from its deformed primitive.
//
// Derivation. With u = (B (x) I3) q, a point x enclosed by primitive P at parameter t (the
// sphere weights of its deepest enclosing sphere, |x - c(t)| <= r(t)) moves to
// x' = x + sum_a B_{x,a} q_a, and the sphere center to c'(t) = sum_i t_i (c_i + u(c_i)). So
//   x' - c'(t) = (x - c(t)) + sum_j Q_j beta_j(x),   beta(x) = B_x - sum_i t_i B_{c_i},
// where Q_j (3 x 4 or 3 x 10) holds handle j's coefficients and beta_j the matching entries.
// Any affine motion is reproduced exactly by the basis (linear precision), so after removing the
// primitive's rigid motion (R, T), with Q~_j = Q_j - Q_j(R, T):
//   |x' - c'(t)| <= r(t) + sum_j sigma_max(Q~_j) * max_x |beta_j(x)|.
// The bake stores max_x |beta_j(x)| for every handle j with a nonzero entry of beta on P.

#include "common/bake_data.hpp"

namespace mat {

/// Builds the collision data.
///   medial                 the (inflated) medial mesh, #S spheres
///   surface                #Vs vertices, #F faces
///   surface_basis          #Vs x k, rows of B at the surface vertices
///   medial_basis           #S x k, rows of B at the sphere centers
///   handle_column_offsets  m + 1
MedialCollisionData build_collision_data(const MedialMesh& medial, const SurfaceMesh& surface,
    const SparseRowMatrix& surface_basis, const SparseRowMatrix& medial_basis,
    const Eigen::Ref<const VecXi>& handle_column_offsets);

/// Interpolates nodal basis rows at embedded points: row p = sum_k bary(p, k) B(tet(p)_k).
///   basis #n x k, tets #T x 4, tet #P, barycentric #P x 4; returns #P x k.
SparseRowMatrix interpolate_rows(const SparseRowMatrix& basis, const Eigen::Ref<const MatX4i>& tets,
    const Eigen::Ref<const VecXi>& tet, const Eigen::Ref<const MatX>& barycentric);

} // namespace mat
