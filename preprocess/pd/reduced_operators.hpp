#pragma once
// Reduced projective dynamics matrices (docs/method.md, section 2, steps 5-6): with
// u = (B kron I3) q every reduced matrix is three copies of one scalar k x k block, so the bake
// stores B^T L B and B^T M B (per unit stiffness and density) and the runtime assembles
// S = stiffness B^T L B + density B^T M B / h^2 for any time step.

#include <exception>

#include <Eigen/SparseCore>

#include "common/eigen_types.hpp"

namespace mat {

struct ReducedOperators {
    MatX laplacian; ///< k x k: B^T L B, symmetric positive semi-definite
    MatX mass; ///< k x k: B^T M B, symmetric positive definite for a full-rank B
};

/// B^T L B and B^T M B through sparse products (no dense n x k matrix), symmetrized exactly.
/// `basis`  #V x k (sparse), `laplacian`  #V x #V, `masses`  #V (lumped, per unit density).
ReducedOperators reduce_operators(const Eigen::SparseMatrix<double, Eigen::RowMajor>& basis,
    const Eigen::SparseMatrix<double>& laplacian, const VecX& masses);

struct ReducedSystemCheck {
    double reciprocal_condition = 0.0; ///< LLT's 1-norm estimate of 1 / cond(S)
    double min_diagonal = 0.0; ///< smallest diagonal entry of S
    double max_diagonal = 0.0; ///< largest diagonal entry of S
};

/// Factors S = stiffness * laplacian + density * mass / dt^2 (dense LLT) and reports its
/// conditioning. Throws mat::Error if S is not symmetric positive definite or its estimated
/// 1 / cond is below 1e-13 (a rank-deficient basis: a handle whose weights cover too few nodes).
ReducedSystemCheck check_reduced_system(
    const ReducedOperators& reduced, double stiffness, double density, double dt);

/// Whether `error` says the basis is rank-deficient (check_reduced_system, or handle regions
/// that cannot be widened): too few tet-mesh nodes for the handles, so a finer tet mesh may do.
/// Such messages contain "the basis is rank-deficient".
bool reports_rank_deficient_basis(const std::exception& error);

} // namespace mat
