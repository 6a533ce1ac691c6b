#pragma once
// The scalar handle basis B (docs/method.md, section 2, steps 3 and 5): u(x) = (B kron I3) q,
// i.e. u (#V x 3) = B Q with Q = coefficients (k x 3, row-major, whose storage is the interleaved
// q).
//
// Handle j (center c_j, scale s_j) uses local coordinates y = (x - c_j) / s_j and contributes
// columns w_j(x) * [1, y1, y2, y3] (linear, 12 DOF) or additionally
// w_j(x) * [y1^2, y2^2, y3^2, y1 y2, y2 y3, y1 y3] (quadratic, 30 DOF).

#include <array>

#include <Eigen/SparseCore>

#include "common/eigen_types.hpp"
#include "common/handle_monomials.hpp"

namespace mat {

/// The polynomial term of a basis column, in column order within a handle: the index of its
/// monomial in handle_monomials() (common/handle_monomials.hpp).
enum class BasisTerm : int {
    constant = 0,
    y1,
    y2,
    y3,
    y1y1,
    y2y2,
    y3y3,
    y1y2,
    y2y3,
    y1y3,
};

static_assert(static_cast<int>(BasisTerm::y3) + 1 == linear_handle_terms
    && static_cast<int>(BasisTerm::y1y3) + 1 == quadratic_handle_terms);

struct HandleBasis {
    Eigen::SparseMatrix<double, Eigen::RowMajor> basis; ///< #V x k
    VecXi column_handle; ///< k: handle of each column
    VecXi column_term; ///< k: BasisTerm of each column
    VecXi handle_offset; ///< m + 1: handle j owns columns [offset[j], offset[j+1])
    MatX3 centers; ///< m x 3: c_j
    VecX scales; ///< m: s_j
    Eigen::Matrix<bool, Eigen::Dynamic, 1> quadratic; ///< m

    Index num_handles() const { return centers.rows(); }
    Index num_columns() const { return column_handle.size(); }
};

/// Builds B. `rest_positions`  #V x 3, `weights`  #V x m (sparse, e.g. harmonic weights),
/// `centers`  m x 3, `scales`  m (> 0), `quadratic`  m flags. Rows of B are filled in parallel;
/// the result does not depend on the thread count.
HandleBasis build_handle_basis(const Eigen::Ref<const MatX3>& rest_positions,
    const Eigen::SparseMatrix<double, Eigen::RowMajor>& weights,
    const Eigen::Ref<const MatX3>& centers, const Eigen::Ref<const VecX>& scales,
    const Eigen::Matrix<bool, Eigen::Dynamic, 1>& quadratic);

/// Conditioning scales: s_j = max distance from c_j to a node where w_j > 0, so |y| <= 1 on the
/// support of w_j and every column of B is bounded by the weight itself (no y^2 blow-up for a
/// small sphere whose weight spreads far). Falls back to 1 when the support is the center only.
/// `rest_positions`  #V x 3, `weights`  #V x m, `centers`  m x 3; returns  m.
VecX handle_support_scales(const Eigen::Ref<const MatX3>& rest_positions,
    const Eigen::SparseMatrix<double, Eigen::RowMajor>& weights,
    const Eigen::Ref<const MatX3>& centers);

/// Coefficients Q (k x 3) with B Q = x A^T + 1 t^T at every node, i.e. u(x) = A x + t, exactly
/// when the weights are a partition of unity: handle j gets constant A c_j + t and linear part
/// s_j A (quadratic terms 0).
MatX3 affine_coefficients(const HandleBasis& basis, const Mat3& a, const Vec3& t);

/// Coefficients Q (k x 3) reproducing u_d(x) = x^T H_d x + (A x)_d + t_d, d = 0..2 (`h` symmetric).
/// Requires every handle to be quadratic. Expanding x = c + s y:
/// x^T H x = c^T H c + 2 s (H c) . y + s^2 y^T H y.
MatX3 quadratic_coefficients(
    const HandleBasis& basis, const std::array<Mat3, 3>& h, const Mat3& a, const Vec3& t);

} // namespace mat
