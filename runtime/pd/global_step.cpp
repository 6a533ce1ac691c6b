#include "runtime/pd/global_step.hpp"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/timer.hpp"

namespace mat {

// ---- reduced ------------------------------------------------------------------------------------

ReducedGlobalStep::ReducedGlobalStep(const Model& model)
    : m_model(model)
    , m_products(model)
    , m_rest_system(model.num_nodes(), 3)
    , m_q(model.num_columns(), 3)
    , m_q_rows(model.num_columns(), 3)
    , m_cache(model.num_nodes(), model.num_columns())
    , m_nodal_cache(model.num_nodes(), model.num_nodes())
{
    // A X = L_w X + M X / h^2 + P X.
    const double inv_h2 = 1.0 / (model.time_step() * model.time_step());
    m_rest_system = model.stiffness_rest();
    for (Index i = 0; i < model.num_nodes(); ++i)
        m_rest_system.row(i) += (model.masses()(i) * inv_h2) * model.rest_positions().row(i);
    for (const int i : model.pinned_nodes())
        m_rest_system.row(i) += model.pin_weight() * model.rest_positions().row(i);
    m_q.setZero();
    const Index k = model.num_columns();
    if (k > 0 && k <= dense_inverse_limit)
        m_inverse = model.reduced_system().solve(MatX::Identity(k, k));
    const auto bytes = [](Index rows, Index cols) {
        return static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * sizeof(double);
    };
    const Index n = model.num_nodes();
    m_node_space = m_inverse.size() > 0 && bytes(n, n) <= ResponseCache::default_budget
        && bytes(n, k) <= ResponseCache::default_budget;
}

void ReducedGlobalStep::solve_rows()
{
    if (m_inverse.size() == 0) {
        m_q = m_q_rows; // columns: one right-hand side each
        // The three right-hand sides are independent: one task each.
        tbb::parallel_for(0, 3, [&](int c) {
            auto column = m_q.col(c);
            m_model.reduced_system().solveInPlace(column);
        });
        return;
    }
    m_q_columns = m_q_rows; // contiguous right-hand sides for the dot products
    // Row blocks of a fixed size: each row is summed the same way for any thread count.
    constexpr Index rows_per_block = 32;
    const Index k = m_inverse.rows();
    const Index blocks = (k + rows_per_block - 1) / rows_per_block;
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, blocks, 1), [&](const tbb::blocked_range<Index>& range) {
            for (Index b = range.begin(); b != range.end(); ++b) {
                const Index first = b * rows_per_block;
                const Index count = std::min(rows_per_block, k - first);
                for (Index i = first; i < first + count; ++i) {
                    const auto row = m_inverse.row(i);
                    for (int c = 0; c < 3; ++c)
                        m_q(i, c) = row.dot(m_q_columns.col(c));
                }
            }
        });
}

// Galerkin projection of A x = b onto x = X + B q (Lan et al. 2020, displacement form):
//   S q = B^T (b - A X),  S = B^T A B.
void ReducedGlobalStep::add_constant_terms(Eigen::Ref<MatX3> base) const
{
    tbb::parallel_for(tbb::blocked_range<Index>(0, m_model.num_nodes()),
        [&](const tbb::blocked_range<Index>& range) {
            for (Index i = range.begin(); i != range.end(); ++i)
                base.row(i) -= m_rest_system.row(i);
        });
}

void ReducedGlobalStep::solve(Eigen::Ref<MatX3> rhs, SolverTimings& timings)
{
    Timer timer;
    MAT_CHECK(rhs.outerStride() == 3, "reduced global step: rhs must be contiguous rows");
    m_products.transpose_times(rhs.data(), m_q_rows.data());
    timings.rhs += timer.seconds();
    timer.restart();
    solve_rows();
    timings.solve += timer.seconds();
}

void ReducedGlobalStep::solve_reduced(const Eigen::Ref<const MatX>& rhs, SolverTimings& timings)
{
    Timer timer;
    MAT_CHECK(rhs.rows() == m_q.rows() && rhs.cols() == 3,
        "reduced global step: the reduced right-hand side is {} x {}, expected {} x 3", rhs.rows(),
        rhs.cols(), m_q.rows());
    m_q_rows = rhs;
    solve_rows();
    timings.solve += timer.seconds();
}

void ReducedGlobalStep::set_reduced_coordinates(const Eigen::Ref<const MatX>& q)
{
    MAT_CHECK(q.rows() == m_q.rows() && q.cols() == 3,
        "reduced global step: q is {} x {}, expected {} x 3", q.rows(), q.cols(), m_q.rows());
    m_q = q;
}

void ReducedGlobalStep::solve(const LocalSums& rhs, SolverTimings& timings)
{
    Timer timer;
    m_products.transpose_times(rhs, m_q_rows.data());
    timings.rhs += timer.seconds();
    timer.restart();
    solve_rows();
    timings.solve += timer.seconds();
}

Eigen::Ref<const VecX> ReducedGlobalStep::node_response(int node)
{
    if (m_node_space) {
        // S^-1 b_j^T is row j of B S^-1 (S symmetric): column j of its transpose.
        basis_inverse();
        return Eigen::Map<const VecX>(m_inverse_basis.col(node), m_inverse_basis.rows());
    }
    bool fresh = false;
    auto z = m_cache.column(node, fresh);
    if (!fresh)
        return z;
    z.setZero();
    for (SparseRowMatrix::InnerIterator it(m_model.basis(), node); it; ++it)
        z(it.index()) = it.value();
    m_model.reduced_system().solveInPlace(z);
    return z;
}

Eigen::Map<const MatX> ReducedGlobalStep::basis_inverse()
{
    const Index n = m_model.basis().rows();
    const Index k = m_inverse.cols();
    if (m_basis_inverse.rows() != n || m_basis_inverse.cols() != k) {
        m_basis_inverse = HugePageBlock(n, k, huge_page_min_bytes / 4);
        Eigen::Map<MatX>(m_basis_inverse.col(0), n, k).noalias() = m_model.basis() * m_inverse;
        m_inverse_basis = HugePageBlock(k, n, huge_page_min_bytes / 4);
        Eigen::Map<MatX>(m_inverse_basis.col(0), k, n).noalias()
            = Eigen::Map<const MatX>(m_basis_inverse.col(0), n, k).transpose();
    }
    return Eigen::Map<const MatX>(m_basis_inverse.col(0), n, k);
}

Eigen::Ref<const VecX> ReducedGlobalStep::nodal_response(int node)
{
    bool fresh = false;
    auto column = m_nodal_cache.column(node, fresh);
    if (!fresh)
        return column;
    if (!m_node_space) {
        column.noalias() = m_model.basis() * node_response(node);
        return column;
    }
    // B S^-1 b_j^T as a sum of b_j's entries times columns of B S^-1.
    const Eigen::Map<const MatX> basis_inverse = this->basis_inverse();
    column.setZero();
    for (SparseRowMatrix::InnerIterator it(m_model.basis(), node); it; ++it)
        column.noalias() += it.value() * basis_inverse.col(it.index());
    return column;
}

double ReducedGlobalStep::apply(int node, const Eigen::Ref<const VecX>& response) const
{
    double sum = 0.0;
    for (SparseRowMatrix::InnerIterator it(m_model.basis(), node); it; ++it)
        sum += it.value() * response(it.index());
    return sum;
}

void ReducedGlobalStep::direction(const int* nodes, const double* weights, int count,
    std::vector<int>& index, std::vector<double>& value, Vec3& offset,
    std::vector<int>& slots) const
{
    // sum_t w_t (X_t + b_t q): the rest part, and the basis rows merged.
    const std::size_t first = index.size();
    offset.setZero();
    for (int t = 0; t < count; ++t) {
        offset += weights[t] * m_model.rest_positions().row(nodes[t]).transpose();
        for (SparseRowMatrix::InnerIterator it(m_model.basis(), nodes[t]); it; ++it) {
            const int column = static_cast<int>(it.index());
            if (slots[column] < 0) {
                slots[column] = static_cast<int>(index.size());
                index.push_back(column);
                value.push_back(weights[t] * it.value());
            } else {
                value[static_cast<std::size_t>(slots[column])] += weights[t] * it.value();
            }
        }
    }
    for (std::size_t i = first; i < index.size(); ++i)
        slots[index[i]] = -1;
}

Vec3 ReducedGlobalStep::node_position(int node) const
{
    Eigen::RowVector3d x = m_model.rest_positions().row(node);
    for (SparseRowMatrix::InnerIterator it(m_model.basis(), node); it; ++it)
        x += it.value() * m_q.row(it.index());
    return x.transpose();
}

void ReducedGlobalStep::add_displacement(const Eigen::Ref<const MatX3>& displacement)
{
    m_q += displacement;
}

void ReducedGlobalStep::displaced_positions(
    const Eigen::Ref<const MatX3>& displacement, Eigen::Ref<MatX3> out)
{
    MAT_CHECK(out.outerStride() == 3 && out.rows() == m_model.num_nodes(),
        "reduced global step: displaced positions must be n contiguous rows");
    m_displaced_rows = m_q + displacement;
    m_products.reconstruct(m_displaced_rows.data(), out.data());
}

void ReducedGlobalStep::positions(Eigen::Ref<MatX3> out, SolverTimings& timings)
{
    Timer timer;
    MAT_CHECK(out.outerStride() == 3, "reduced global step: positions must be contiguous rows");
    m_q_rows = m_q; // row-major copy: a node reads whole rows of q
    m_products.reconstruct(m_q_rows.data(), out.data());
    timings.reconstruct += timer.seconds();
}

// ---- full ---------------------------------------------------------------------------------------

FullGlobalStep::FullGlobalStep(const Model& model)
    : m_x(model.num_nodes(), 3)
    , m_cache(model.num_nodes(), model.num_nodes())
{
    m_cholesky.compute(model.full_system(), "full-space projective dynamics system");
    m_x.setZero();
}

void FullGlobalStep::solve(Eigen::Ref<MatX3> rhs, SolverTimings& timings)
{
    Timer timer;
    m_cholesky.solve_in_place_rows(rhs);
    m_x = rhs;
    timings.solve += timer.seconds();
}

Eigen::Ref<const VecX> FullGlobalStep::node_response(int node)
{
    bool fresh = false;
    auto z = m_cache.column(node, fresh);
    if (fresh) {
        MatX unit = MatX::Zero(m_x.rows(), 1);
        unit(node, 0) = 1.0;
        m_cholesky.solve_in_place(unit);
        z = unit.col(0);
    }
    return z;
}

void FullGlobalStep::direction(const int* nodes, const double* weights, int count,
    std::vector<int>& index, std::vector<double>& value, Vec3& offset,
    std::vector<int>& /*slots*/) const
{
    offset.setZero();
    for (int t = 0; t < count; ++t) {
        index.push_back(nodes[t]);
        value.push_back(weights[t]);
    }
}

void FullGlobalStep::add_displacement(const Eigen::Ref<const MatX3>& displacement)
{
    m_x += displacement;
}

void FullGlobalStep::positions(Eigen::Ref<MatX3> out, SolverTimings& timings)
{
    Timer timer;
    out = m_x;
    timings.reconstruct += timer.seconds();
}

} // namespace mat
