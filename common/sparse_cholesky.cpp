#include "common/sparse_cholesky.hpp"

#include <cholmod.h>

#include <cmath>
#include <utility>

#include "common/error.hpp"

namespace mat {

struct SparseCholesky::Impl {
    cholmod_common common;
    cholmod_factor* factor = nullptr;
    // Solve workspace, reused while the number of right-hand sides does not change.
    cholmod_dense* solution = nullptr;
    cholmod_dense* work_y = nullptr;
    cholmod_dense* work_e = nullptr;
    // Column-major copy of interleaved right-hand sides (solve_in_place_rows).
    cholmod_dense* rows_rhs = nullptr;
    std::string label = "matrix";
    Index n = 0;
    double lnz = 0.0;

    Impl()
    {
        cholmod_start(&common);
        common.supernodal = CHOLMOD_SUPERNODAL;
        common.print = 0; // failures are reported as mat::Error, never printed
        common.error_handler = nullptr;
    }

    ~Impl()
    {
        free_solve_workspace();
        if (factor)
            cholmod_free_factor(&factor, &common);
        cholmod_finish(&common);
    }

    void free_solve_workspace()
    {
        for (cholmod_dense** dense : { &solution, &work_y, &work_e, &rows_rhs })
            if (*dense)
                cholmod_free_dense(dense, &common);
    }

    void check_status(const char* what)
    {
        if (common.status == CHOLMOD_OUT_OF_MEMORY)
            throw_error("{}: CHOLMOD {} ran out of memory (n = {})", label, what, n);
        if (common.status < 0)
            throw_error(
                "{}: CHOLMOD {} failed with status {} (n = {})", label, what, common.status, n);
    }

    // A read-only CHOLMOD view of Eigen's compressed column storage: no copy. stype = -1 makes
    // CHOLMOD read the lower triangle only, so full and lower-stored matrices both work.
    static cholmod_sparse view(const Eigen::SparseMatrix<double>& matrix)
    {
        cholmod_sparse a {};
        a.nrow = static_cast<size_t>(matrix.rows());
        a.ncol = static_cast<size_t>(matrix.cols());
        a.nzmax = static_cast<size_t>(matrix.nonZeros());
        a.p = const_cast<int*>(matrix.outerIndexPtr());
        a.i = const_cast<int*>(matrix.innerIndexPtr());
        a.x = const_cast<double*>(matrix.valuePtr());
        a.stype = -1;
        a.itype = CHOLMOD_INT;
        a.xtype = CHOLMOD_REAL;
        a.dtype = CHOLMOD_DOUBLE;
        a.sorted = 0;
        a.packed = 1;
        return a;
    }

    void check_input(const Eigen::SparseMatrix<double>& matrix) const
    {
        if (matrix.rows() != matrix.cols())
            throw_error("{}: cannot factor a non-square {} x {} matrix", label, matrix.rows(),
                matrix.cols());
        for (Index col = 0; col < matrix.outerSize(); ++col)
            for (Eigen::SparseMatrix<double>::InnerIterator it(matrix, col); it; ++it)
                if (!std::isfinite(it.value()))
                    throw_error("{}: entry ({}, {}) is not finite ({})", label, it.row(), it.col(),
                        it.value());
    }

    void numeric_factor(const Eigen::SparseMatrix<double>& compressed)
    {
        cholmod_sparse a = view(compressed);
        cholmod_factorize(&a, factor, &common);
        if (common.status == CHOLMOD_NOT_POSDEF) {
            const auto minor = static_cast<Index>(factor->minor);
            const int* perm = static_cast<const int*>(factor->Perm);
            const Index original = (perm && minor < n) ? perm[minor] : minor;
            throw_error("{}: matrix is not positive definite (Cholesky breaks down at row {} of "
                        "{})",
                label, original, n);
        }
        check_status("factorization");
        if (static_cast<Index>(factor->minor) < n)
            throw_error("{}: Cholesky factorization stopped at row {} of {}", label,
                static_cast<Index>(factor->minor), n);
    }

    void solve(cholmod_dense* rhs)
    {
        if (!factor)
            throw_error("{}: solve called before the matrix was factored", label);
        cholmod_solve2(
            CHOLMOD_A, factor, rhs, nullptr, &solution, nullptr, &work_y, &work_e, &common);
        check_status("solve");
        const auto* x = static_cast<const double*>(solution->x);
        const size_t count = solution->nrow * solution->ncol;
        for (size_t i = 0; i < count; ++i)
            if (!std::isfinite(x[i]))
                throw_error("{}: the solve produced a non-finite value in row {} (non-finite "
                            "right-hand side?)",
                    label, i % solution->nrow);
    }
};

namespace {
    // Eigen's compressed storage or, when the matrix is in uncompressed mode, a compressed copy.
    const Eigen::SparseMatrix<double>& compressed_form(
        const Eigen::SparseMatrix<double>& matrix, Eigen::SparseMatrix<double>& copy)
    {
        if (matrix.isCompressed())
            return matrix;
        copy = matrix;
        copy.makeCompressed();
        return copy;
    }
} // namespace

SparseCholesky::SparseCholesky()
    : m_impl(std::make_unique<Impl>())
{
}

SparseCholesky::~SparseCholesky() = default;
SparseCholesky::SparseCholesky(SparseCholesky&&) noexcept = default;
SparseCholesky& SparseCholesky::operator=(SparseCholesky&&) noexcept = default;

void SparseCholesky::compute(const Eigen::SparseMatrix<double>& matrix, const std::string& label)
{
    Impl& impl = *m_impl;
    impl.label = label;
    impl.free_solve_workspace();
    if (impl.factor)
        cholmod_free_factor(&impl.factor, &impl.common);
    impl.n = 0;
    impl.check_input(matrix);
    Eigen::SparseMatrix<double> copy;
    const Eigen::SparseMatrix<double>& compressed = compressed_form(matrix, copy);

    impl.n = matrix.rows();
    cholmod_sparse a = Impl::view(compressed);
    impl.factor = cholmod_analyze(&a, &impl.common);
    impl.check_status("analysis");
    if (!impl.factor)
        throw_error("{}: CHOLMOD analysis returned no factor (n = {})", label, impl.n);
    impl.lnz = impl.common.lnz;
    try {
        impl.numeric_factor(compressed);
    } catch (...) {
        cholmod_free_factor(&impl.factor, &impl.common);
        impl.n = 0;
        throw;
    }
}

void SparseCholesky::refactor(const Eigen::SparseMatrix<double>& matrix)
{
    Impl& impl = *m_impl;
    if (!impl.factor)
        throw_error("{}: refactor called before compute", impl.label);
    if (matrix.rows() != impl.n || matrix.cols() != impl.n)
        throw_error("{}: refactor with a {} x {} matrix, the analysis was for {} x {}", impl.label,
            matrix.rows(), matrix.cols(), impl.n, impl.n);
    impl.check_input(matrix);
    Eigen::SparseMatrix<double> copy;
    impl.numeric_factor(compressed_form(matrix, copy));
}

MatX SparseCholesky::solve(const Eigen::Ref<const MatX>& rhs)
{
    MatX result = rhs;
    solve_in_place(result);
    return result;
}

void SparseCholesky::solve_in_place(Eigen::Ref<MatX> rhs)
{
    Impl& impl = *m_impl;
    if (rhs.rows() != impl.n)
        throw_error(
            "{}: right-hand side has {} rows, the matrix has {}", impl.label, rhs.rows(), impl.n);
    if (rhs.cols() == 0 || impl.n == 0)
        return;
    cholmod_dense b {};
    b.nrow = static_cast<size_t>(rhs.rows());
    b.ncol = static_cast<size_t>(rhs.cols());
    b.d = static_cast<size_t>(rhs.outerStride());
    b.nzmax = b.d * b.ncol;
    b.x = rhs.data();
    b.xtype = CHOLMOD_REAL;
    b.dtype = CHOLMOD_DOUBLE;
    impl.solve(&b);
    const auto* x = static_cast<const double*>(impl.solution->x);
    const auto d = static_cast<Index>(impl.solution->d);
    for (Index col = 0; col < rhs.cols(); ++col)
        rhs.col(col) = Eigen::Map<const VecX>(x + col * d, rhs.rows());
}

void SparseCholesky::solve_in_place_rows(Eigen::Ref<MatX3> rhs)
{
    Impl& impl = *m_impl;
    if (rhs.rows() != impl.n)
        throw_error(
            "{}: right-hand side has {} rows, the matrix has {}", impl.label, rhs.rows(), impl.n);
    if (impl.n == 0)
        return;
    if (!impl.rows_rhs) {
        impl.rows_rhs = cholmod_allocate_dense(static_cast<size_t>(impl.n), 3,
            static_cast<size_t>(impl.n), CHOLMOD_REAL, &impl.common);
        impl.check_status("workspace allocation");
    }
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3>> columns(
        static_cast<double*>(impl.rows_rhs->x), impl.n, 3);
    columns = rhs;
    impl.solve(impl.rows_rhs);
    rhs = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3>>(
        static_cast<const double*>(impl.solution->x), impl.n, 3);
}

bool SparseCholesky::factored() const
{
    return m_impl->factor != nullptr;
}

Index SparseCholesky::rows() const
{
    return m_impl->n;
}

Index SparseCholesky::factor_nonzeros() const
{
    return static_cast<Index>(m_impl->lnz);
}

std::string SparseCholesky::ordering() const
{
    if (!m_impl->factor)
        return "none";
    switch (m_impl->factor->ordering) {
    case CHOLMOD_NATURAL:
        return "natural";
    case CHOLMOD_GIVEN:
        return "given";
    case CHOLMOD_AMD:
        return "AMD";
    case CHOLMOD_METIS:
        return "METIS";
    case CHOLMOD_NESDIS:
        return "NESDIS";
    case CHOLMOD_COLAMD:
        return "COLAMD";
    case CHOLMOD_POSTORDERED:
        return "postordered";
    default:
        return "unknown";
    }
}

} // namespace mat
