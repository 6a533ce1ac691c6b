#include "preprocess/basis/handle_basis.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

namespace {
    int terms_of(bool quadratic)
    {
        return quadratic ? quadratic_handle_terms : linear_handle_terms;
    }
} // namespace

HandleBasis build_handle_basis(const Eigen::Ref<const MatX3>& rest_positions,
    const Eigen::SparseMatrix<double, Eigen::RowMajor>& weights,
    const Eigen::Ref<const MatX3>& centers, const Eigen::Ref<const VecX>& scales,
    const Eigen::Matrix<bool, Eigen::Dynamic, 1>& quadratic)
{
    const Index n = rest_positions.rows();
    const Index m = centers.rows();
    MAT_CHECK(weights.rows() == n && weights.cols() == m,
        "weights are {} x {}, expected #V x m = {} x {}", weights.rows(), weights.cols(), n, m);
    MAT_CHECK(scales.size() == m && quadratic.size() == m, "{} scales and {} flags for {} handles",
        scales.size(), quadratic.size(), m);
    for (Index j = 0; j < m; ++j)
        if (!(scales[j] > 0.0) || !std::isfinite(scales[j]) || !centers.row(j).allFinite())
            throw_error(
                "handle basis: handle {} has scale {} (must be finite and > 0)", j, scales[j]);

    HandleBasis result;
    result.centers = centers;
    result.scales = scales;
    result.quadratic = quadratic;
    result.handle_offset.resize(m + 1);
    result.handle_offset[0] = 0;
    for (Index j = 0; j < m; ++j)
        result.handle_offset[j + 1] = result.handle_offset[j] + terms_of(quadratic[j]);
    const Index k = result.handle_offset[m];
    result.column_handle.resize(k);
    result.column_term.resize(k);
    for (Index j = 0; j < m; ++j)
        for (int term = 0; term < terms_of(quadratic[j]); ++term) {
            result.column_handle[result.handle_offset[j] + term] = static_cast<int>(j);
            result.column_term[result.handle_offset[j] + term] = term;
        }

    // Row sizes, then each row filled independently (CSR written directly).
    std::vector<Index> row_start(static_cast<size_t>(n) + 1, 0);
    for (Index i = 0; i < n; ++i) {
        Index count = 0;
        for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(weights, i); it; ++it)
            if (it.value() != 0.0)
                count += terms_of(quadratic[it.col()]);
        row_start[i + 1] = row_start[i] + count;
    }
    Eigen::SparseMatrix<double, Eigen::RowMajor>& b = result.basis;
    b.resize(n, k);
    b.resizeNonZeros(row_start[n]);
    int* outer = b.outerIndexPtr();
    for (Index i = 0; i <= n; ++i)
        outer[i] = static_cast<int>(row_start[i]);
    int* inner = b.innerIndexPtr();
    double* values = b.valuePtr();
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, n, 256), [&](const tbb::blocked_range<Index>& range) {
            std::vector<std::pair<int, double>> row;
            for (Index i = range.begin(); i < range.end(); ++i) {
                row.clear();
                for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(weights, i); it;
                     ++it)
                    if (it.value() != 0.0)
                        row.emplace_back(static_cast<int>(it.col()), it.value());
                std::sort(row.begin(), row.end()); // columns of B must increase along the row
                Index position = row_start[i];
                const Vec3 x = rest_positions.row(i);
                for (const auto& [j, w] : row) {
                    const Vec3 y = (x - centers.row(j).transpose()) / scales[j];
                    double p[quadratic_handle_terms];
                    handle_monomials(y[0], y[1], y[2], p);
                    for (int term = 0; term < terms_of(quadratic[j]); ++term) {
                        inner[position] = result.handle_offset[j] + term;
                        values[position++] = w * p[term];
                    }
                }
            }
        });
    return result;
}

VecX handle_support_scales(const Eigen::Ref<const MatX3>& rest_positions,
    const Eigen::SparseMatrix<double, Eigen::RowMajor>& weights,
    const Eigen::Ref<const MatX3>& centers)
{
    MAT_CHECK(weights.rows() == rest_positions.rows() && weights.cols() == centers.rows(),
        "weights are {} x {}, expected {} x {}", weights.rows(), weights.cols(),
        rest_positions.rows(), centers.rows());
    VecX scales = VecX::Zero(centers.rows());
    for (Index i = 0; i < weights.outerSize(); ++i)
        for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(weights, i); it; ++it)
            if (it.value() > 0.0)
                scales[it.col()] = std::max(
                    scales[it.col()], (rest_positions.row(i) - centers.row(it.col())).norm());
    for (Index j = 0; j < scales.size(); ++j)
        if (!(scales[j] > 0.0))
            scales[j] = 1.0;
    return scales;
}

MatX3 affine_coefficients(const HandleBasis& basis, const Mat3& a, const Vec3& t)
{
    MatX3 q = MatX3::Zero(basis.num_columns(), 3);
    for (Index j = 0; j < basis.num_handles(); ++j) {
        const Index offset = basis.handle_offset[j];
        const Vec3 c = basis.centers.row(j);
        // A x + t = (A c + t) + s A y with x = c + s y.
        q.row(offset) = (a * c + t).transpose();
        for (int d = 0; d < 3; ++d)
            q.row(offset + 1 + d) = basis.scales[j] * a.col(d).transpose();
    }
    return q;
}

MatX3 quadratic_coefficients(
    const HandleBasis& basis, const std::array<Mat3, 3>& h, const Mat3& a, const Vec3& t)
{
    MatX3 q = MatX3::Zero(basis.num_columns(), 3);
    for (Index j = 0; j < basis.num_handles(); ++j) {
        if (!basis.quadratic[j])
            throw_error("quadratic coefficients: handle {} is linear", j);
        const Index offset = basis.handle_offset[j];
        const Vec3 c = basis.centers.row(j);
        const double s = basis.scales[j];
        for (int d = 0; d < 3; ++d) {
            const Mat3 hd = 0.5 * (h[d] + h[d].transpose());
            const Vec3 linear = s * (2.0 * hd * c + a.row(d).transpose());
            const double s2 = s * s;
            q(offset + int(BasisTerm::constant), d) = c.dot(hd * c) + a.row(d).dot(c) + t[d];
            q(offset + int(BasisTerm::y1), d) = linear[0];
            q(offset + int(BasisTerm::y2), d) = linear[1];
            q(offset + int(BasisTerm::y3), d) = linear[2];
            q(offset + int(BasisTerm::y1y1), d) = s2 * hd(0, 0);
            q(offset + int(BasisTerm::y2y2), d) = s2 * hd(1, 1);
            q(offset + int(BasisTerm::y3y3), d) = s2 * hd(2, 2);
            q(offset + int(BasisTerm::y1y2), d) = 2.0 * s2 * hd(0, 1);
            q(offset + int(BasisTerm::y2y3), d) = 2.0 * s2 * hd(1, 2);
            q(offset + int(BasisTerm::y1y3), d) = 2.0 * s2 * hd(0, 2);
        }
    }
    return q;
}

} // namespace mat
