#pragma once
// Full-space projective dynamics operators of a tet mesh (docs/method.md, section 2, step 6):
// per-tet rest data (Dm^-1, volume), the scalar stiffness Laplacian L = sum_e vol_e G_e^T G_e
// (which is also the cotangent / linear FEM Laplacian used for harmonic weights) and lumped
// masses. Everything is per unit stiffness and per unit density.

#include <Eigen/SparseCore>

#include "common/eigen_types.hpp"

namespace mat {

/// #T x 9, row-major 3x3 matrices stored row by row.
using MatX9 = Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor>;

struct TetRestData {
    MatX9 dm_inverse; ///< #T x 9: Dm^-1 row-major, Dm = [X1-X0, X2-X0, X3-X0]
    VecX volumes; ///< #T rest volumes, > 0
};

/// Dm^-1 and the rest volume of every tet.
/// `rest_positions`  #V x 3, `tets`  #T x 4 (positively oriented).
/// Throws mat::Error naming the tet if an index is out of range or a volume is not positive
/// (inverted or degenerate tet).
TetRestData compute_tet_rest_data(
    const Eigen::Ref<const MatX3>& rest_positions, const Eigen::Ref<const MatX4i>& tets);

/// The 3x4 gradient operator G_e of tet e: for node values f (4), grad f = G_e f, so that for
/// positions X_e (4 x 3), G_e X_e = F^T with F = Ds Dm^-1. `dm_inverse_row`: one row of
/// TetRestData::dm_inverse.
Eigen::Matrix<double, 3, 4> tet_gradient_operator(
    const Eigen::Ref<const Eigen::Matrix<double, 1, 9>>& dm_inverse_row);

/// L = sum_e vol_e G_e^T G_e  #V x #V, symmetric positive semi-definite, constant null space
/// (Bouaziz et al. 2014, eq. 13, with per-unit stiffness). Each tet's 4x4 block is computed in
/// parallel; assembly order is fixed, so the result does not depend on the thread count.
/// `num_vertices` = #V, `tets`  #T x 4.
Eigen::SparseMatrix<double> assemble_laplacian(
    Index num_vertices, const Eigen::Ref<const MatX4i>& tets, const TetRestData& rest);

/// Lumped masses per unit density  #V: m_i = sum of the volumes of the tets around i / 4.
VecX lumped_masses(Index num_vertices, const Eigen::Ref<const MatX4i>& tets, const VecX& volumes);

} // namespace mat
