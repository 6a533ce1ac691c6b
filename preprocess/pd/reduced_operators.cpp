// GCC 12 reports a false -Wmaybe-uninitialized inside its own AVX-512 intrinsics when Eigen's
// matrix-vector kernels are inlined with -march=native (GCC bug 105593).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include "preprocess/pd/reduced_operators.hpp"

#include <string>

#include <Eigen/Cholesky>

#include "common/error.hpp"

namespace mat {

namespace {
    // The dense symmetric part (A + A^T) / 2 of a sparse k x k product.
    MatX symmetrized(const Eigen::SparseMatrix<double>& product)
    {
        const MatX dense = MatX(product);
        return 0.5 * (dense + dense.transpose());
    }
} // namespace

ReducedOperators reduce_operators(const Eigen::SparseMatrix<double, Eigen::RowMajor>& basis,
    const Eigen::SparseMatrix<double>& laplacian, const VecX& masses)
{
    const Index n = basis.rows();
    MAT_CHECK(laplacian.rows() == n && laplacian.cols() == n,
        "Laplacian is {} x {}, the basis has {} rows", laplacian.rows(), laplacian.cols(), n);
    MAT_CHECK(masses.size() == n, "{} masses for a basis with {} rows", masses.size(), n);
    const Eigen::SparseMatrix<double> b = basis; // column-major copy for the products
    const Eigen::SparseMatrix<double> bt = b.transpose();
    ReducedOperators reduced;
    const Eigen::SparseMatrix<double> lb = laplacian * b;
    reduced.laplacian = symmetrized(bt * lb);
    const Eigen::SparseMatrix<double> mb = masses.asDiagonal() * b;
    reduced.mass = symmetrized(bt * mb);
    return reduced;
}

ReducedSystemCheck check_reduced_system(
    const ReducedOperators& reduced, double stiffness, double density, double dt)
{
    const Index k = reduced.laplacian.rows();
    MAT_CHECK(reduced.mass.rows() == k && reduced.mass.cols() == k && reduced.laplacian.cols() == k,
        "reduced matrices have mismatched sizes");
    MAT_CHECK(dt > 0.0 && stiffness >= 0.0 && density > 0.0,
        "need dt > 0, stiffness >= 0, density > 0 (got {}, {}, {})", dt, stiffness, density);
    const MatX system = stiffness * reduced.laplacian + (density / (dt * dt)) * reduced.mass;
    if (!system.allFinite())
        throw_error("reduced system: non-finite entries");
    const Eigen::LLT<MatX> llt(system);
    if (llt.info() != Eigen::Success)
        throw_error("reduced system B^T (L + M/h^2) B ({} x {}) is not positive definite: the "
                    "basis is rank-deficient",
            k, k);
    ReducedSystemCheck check;
    check.reciprocal_condition = k > 0 ? llt.rcond() : 1.0;
    // Round-off can leave a tiny positive pivot on an exactly singular matrix.
    if (check.reciprocal_condition < 1e-13)
        throw_error("reduced system B^T (L + M/h^2) B ({} x {}) is numerically singular (1/cond "
                    "= {:.1e}): the basis is rank-deficient",
            k, k, check.reciprocal_condition);
    check.min_diagonal = k > 0 ? system.diagonal().minCoeff() : 0.0;
    check.max_diagonal = k > 0 ? system.diagonal().maxCoeff() : 0.0;
    return check;
}

bool reports_rank_deficient_basis(const std::exception& error)
{
    return std::string(error.what()).find("the basis is rank-deficient") != std::string::npos;
}

} // namespace mat
