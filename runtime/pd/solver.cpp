#include "runtime/pd/solver.hpp"

#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

namespace {

    void check_step(const Model& model, const SolverOptions& options, const State& in,
        const State& out, double dt, const char* solver)
    {
        const Index n = model.num_nodes();
        if (in.positions.rows() != n || in.velocities.rows() != n)
            throw_error("{}: state has {} positions and {} velocities, the model has {} nodes",
                solver, in.positions.rows(), in.velocities.rows(), n);
        if (&in == &out)
            throw_error("{}: the input and output states must be different objects", solver);
        if (std::abs(dt - model.time_step()) > 1e-12 * model.time_step())
            throw_error("{}: time step {} differs from the model's {} (its matrices are factored "
                        "for it)",
                solver, dt, model.time_step());
        if (options.iterations < 1)
            throw_error("{}: iterations {} must be at least 1", solver, options.iterations);
        if (!(options.damping >= 0.0 && options.damping < 1.0))
            throw_error("{}: damping {} must be in [0, 1)", solver, options.damping);
    }

    /// s = x_n + h v_n + h^2 g  n x 3 (Bouaziz et al. 2014, eq. 9 with f_ext = M g).
    void inertia_target(const State& in, const Vec3& gravity, double h, MatX3& s)
    {
        const Eigen::RowVector3d shift = (h * h) * gravity.transpose();
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, s.rows()), [&](const tbb::blocked_range<Index>& range) {
                for (Index i = range.begin(); i != range.end(); ++i)
                    s.row(i) = in.positions.row(i) + h * in.velocities.row(i) + shift;
            });
    }

    void finish_step(const State& in, State& out, double h, double damping)
    {
        const double scale = (1.0 - damping) / h;
        out.velocities.resize(in.positions.rows(), 3);
        tbb::parallel_for(tbb::blocked_range<Index>(0, in.positions.rows()),
            [&](const tbb::blocked_range<Index>& range) {
                for (Index i = range.begin(); i != range.end(); ++i)
                    out.velocities.row(i) = scale * (out.positions.row(i) - in.positions.row(i));
            });
        if (!out.positions.allFinite())
            throw_error("projective dynamics: the positions are not finite after the step");
    }

} // namespace

SemiReducedSolver::SemiReducedSolver(const Model& model, const SolverOptions& options)
    : m_options(options)
    , m_local(model)
    , m_inertia(model.num_nodes(), 3)
    , m_rhs(model.num_nodes(), 3)
    , m_q(model.num_columns(), 3)
{
}

// Global step in displacement form (Lan et al. 2020). The full-space global step solves
//   A x = M s / h^2 + r + P p,   A = L_w + M / h^2 + P,
// with r = sum_e w_e G_e^T P_e^T (local step), P the pin weights (diagonal) and p their
// targets. Write x = X + u with the displacement u = B q restricted to the basis (U = B (x) I3
// acts column by column on n x 3 data) and require the residual to be orthogonal to the basis
// (Galerkin): B^T A (X + B q) = B^T (M s / h^2 + r + P p), i.e.
//   S q = B^T (M (s - X) / h^2 + r - L_w X + P (p - X)),   S = B^T A B,
// using A X = L_w X + M X / h^2 + P X. L_w X is constant (Model::stiffness_rest). Then x = X + B q.
void SemiReducedSolver::step(const Model& model, const State& in, State& out, double dt)
{
    check_step(model, m_options, in, out, dt, "semi-reduced solver");
    const Index n = model.num_nodes();
    const Index k = model.num_columns();
    MAT_CHECK(m_inertia.rows() == n && m_q.rows() == k,
        "semi-reduced solver: workspace made "
        "for another model");
    const double h = dt;
    const double inv_h2 = 1.0 / (h * h);
    const MatX3& rest = model.rest_positions();
    const VecX& masses = model.masses();
    const MatX3& stiffness_rest = model.stiffness_rest();
    const SparseRowMatrix& basis = model.basis();
    const SparseRowMatrix& basis_t = model.basis_transpose();

    inertia_target(in, m_options.gravity, h, m_inertia);
    out.positions = m_inertia;

    for (int iteration = 0; iteration < m_options.iterations; ++iteration) {
        m_local.compute(model, out.positions, m_rhs);
        // y = M (s - X) / h^2 + r - L_w X  (pins added below), in place in m_rhs.
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
                for (Index i = range.begin(); i != range.end(); ++i)
                    m_rhs.row(i) += (masses(i) * inv_h2) * (m_inertia.row(i) - rest.row(i))
                        - stiffness_rest.row(i);
            });
        const auto& pins = model.pinned_nodes();
        for (std::size_t p = 0; p < pins.size(); ++p)
            m_rhs.row(pins[p]) += model.pin_weight()
                * (model.pin_targets().row(static_cast<Index>(p)) - rest.row(pins[p]));
        // B^T y, one row of B^T (a basis column) per task: O(nnz(B)), fixed summation order.
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, k), [&](const tbb::blocked_range<Index>& range) {
                for (Index a = range.begin(); a != range.end(); ++a) {
                    Eigen::RowVector3d acc = Eigen::RowVector3d::Zero();
                    for (SparseRowMatrix::InnerIterator it(basis_t, a); it; ++it)
                        acc += it.value() * m_rhs.row(it.index());
                    m_q.row(a) = acc;
                }
            });
        for (int c = 0; c < 3; ++c) {
            auto column = m_q.col(c);
            model.reduced_system().solveInPlace(column);
        }
        // x = X + B q.
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
                for (Index i = range.begin(); i != range.end(); ++i) {
                    Eigen::RowVector3d acc = rest.row(i);
                    for (SparseRowMatrix::InnerIterator it(basis, i); it; ++it)
                        acc += it.value() * m_q.row(it.index());
                    out.positions.row(i) = acc;
                }
            });
    }
    finish_step(in, out, h, m_options.damping);
}

FullSolver::FullSolver(const Model& model, const SolverOptions& options)
    : m_options(options)
    , m_local(model)
    , m_inertia(model.num_nodes(), 3)
    , m_rhs(model.num_nodes(), 3)
{
    m_cholesky.compute(model.full_system(), "full-space projective dynamics system");
}

// Full-space global step (Bouaziz et al. 2014, eq. 13 with pins):
//   (L_w + M / h^2 + P) x = M s / h^2 + r + P p.
void FullSolver::step(const Model& model, const State& in, State& out, double dt)
{
    check_step(model, m_options, in, out, dt, "full-space solver");
    const Index n = model.num_nodes();
    MAT_CHECK(m_inertia.rows() == n && m_cholesky.rows() == n,
        "full-space solver: workspace "
        "made for another model");
    const double h = dt;
    const double inv_h2 = 1.0 / (h * h);
    const VecX& masses = model.masses();

    inertia_target(in, m_options.gravity, h, m_inertia);
    out.positions = m_inertia;

    for (int iteration = 0; iteration < m_options.iterations; ++iteration) {
        m_local.compute(model, out.positions, m_rhs);
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
                for (Index i = range.begin(); i != range.end(); ++i)
                    m_rhs.row(i) += (masses(i) * inv_h2) * m_inertia.row(i);
            });
        const auto& pins = model.pinned_nodes();
        for (std::size_t p = 0; p < pins.size(); ++p)
            m_rhs.row(pins[p])
                += model.pin_weight() * model.pin_targets().row(static_cast<Index>(p));
        m_cholesky.solve_in_place_rows(m_rhs);
        out.positions = m_rhs;
    }
    finish_step(in, out, h, m_options.damping);
}

} // namespace mat
