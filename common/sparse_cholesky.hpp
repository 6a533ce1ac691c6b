#pragma once
// Sparse Cholesky factorization of a symmetric positive definite matrix through CHOLMOD
// (supernodal, BLAS-backed). Used by the bake (harmonic weights) and by the runtime's full-space
// projective dynamics solver. cholmod.h is included only by the .cpp.
//
// The object keeps the CHOLMOD workspace, the factor and the solve workspace alive, so repeated
// solves with the same number of right-hand sides allocate nothing. It is not thread-safe: one
// object per thread if several threads solve at once.

#include <memory>
#include <string>

#include <Eigen/SparseCore>

#include "common/eigen_types.hpp"

namespace mat {

class SparseCholesky {
public:
    SparseCholesky();
    ~SparseCholesky();
    SparseCholesky(SparseCholesky&&) noexcept;
    SparseCholesky& operator=(SparseCholesky&&) noexcept;
    SparseCholesky(const SparseCholesky&) = delete;
    SparseCholesky& operator=(const SparseCholesky&) = delete;

    /// Orders, analyzes and factors `matrix`  n x n, symmetric positive definite, compressed,
    /// stored either full or as its lower triangle (entries above the diagonal are ignored).
    /// `label` names what is being factored in error messages ("harmonic weight Laplacian").
    /// Throws mat::Error if the matrix is not square, has non-finite entries, is not positive
    /// definite (naming the failing column) or CHOLMOD fails (out of memory...).
    void compute(const Eigen::SparseMatrix<double>& matrix, const std::string& label);

    /// Refactors a matrix with the same nonzero pattern as the last compute() (e.g. a new time
    /// step), reusing the ordering and symbolic analysis.
    void refactor(const Eigen::SparseMatrix<double>& matrix);

    /// Solves A X = rhs. `rhs`  n x m, returns X  n x m.
    MatX solve(const Eigen::Ref<const MatX>& rhs);

    /// Solves A X = rhs, overwriting `rhs`  n x m (column-major) with X. Reuses the workspace
    /// of the previous solve when m is unchanged.
    void solve_in_place(Eigen::Ref<MatX> rhs);

    /// The same for interleaved (row-major) n x 3 data such as positions: `rhs`  n x 3.
    void solve_in_place_rows(Eigen::Ref<MatX3> rhs);

    bool factored() const;
    /// n, the size of the factored matrix (0 before compute()).
    Index rows() const;
    /// Nonzeros of the factor L (supernodal storage counts its dense blocks).
    Index factor_nonzeros() const;
    /// The fill-reducing ordering CHOLMOD chose ("AMD", "METIS", "natural", ...).
    std::string ordering() const;

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
};

} // namespace mat
