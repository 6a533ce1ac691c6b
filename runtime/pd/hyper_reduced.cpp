#include "runtime/pd/hyper_reduced.hpp"

#include <algorithm>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/SparseCore>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/timer.hpp"

namespace mat {

std::vector<int> farthest_point_tets(const Model& model, Index count)
{
    const Index t = model.num_tets();
    MAT_CHECK(t > 0, "hyper-reduced: the model has no tets");
    count = std::clamp<Index>(count, 1, t);
    const MatX3& x = model.rest_positions();
    const MatX4i& tets = model.tets();
    MatX3 centroids(t, 3);
    for (Index e = 0; e < t; ++e)
        centroids.row(e) = 0.25
            * (x.row(tets(e, 0)) + x.row(tets(e, 1)) + x.row(tets(e, 2)) + x.row(tets(e, 3)));
    std::vector<double> distance(t, std::numeric_limits<double>::infinity());
    std::vector<int> samples;
    samples.reserve(count);
    Index next = 0;
    for (Index s = 0; s < count; ++s) {
        samples.push_back(static_cast<int>(next));
        const Eigen::RowVector3d c = centroids.row(next);
        Index farthest = 0;
        double best = -1.0;
        for (Index e = 0; e < t; ++e) {
            const double d = (centroids.row(e) - c).squaredNorm();
            if (d < distance[e])
                distance[e] = d;
            if (distance[e] > best) {
                best = distance[e];
                farthest = e;
            }
        }
        next = farthest;
    }
    std::sort(samples.begin(), samples.end());
    return samples;
}

namespace {

    /// L_S = sum_{e in samples} vol_e G_e^T G_e  n x n (the unit Laplacian of the samples), with
    /// G_e^T = E Dm^-1 (local_step.cpp): corner c + 1 has gradient row c of Dm^-1, corner 0
    /// minus their sum.
    Eigen::SparseMatrix<double> sample_laplacian(const Model& model, const std::vector<int>& tets)
    {
        std::vector<Eigen::Triplet<double>> entries;
        entries.reserve(16 * tets.size());
        const MatX& dm_inverse = model.dm_inverse();
        for (const int e : tets) {
            Eigen::Matrix<double, 4, 3> g;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c)
                    g(r + 1, c) = dm_inverse(e, 3 * r + c);
            g.row(0) = -(g.row(1) + g.row(2) + g.row(3));
            const Eigen::Matrix4d local = model.rest_volumes()(e) * g * g.transpose();
            for (int a = 0; a < 4; ++a)
                for (int b = 0; b < 4; ++b)
                    entries.emplace_back(model.tets()(e, a), model.tets()(e, b), local(a, b));
        }
        Eigen::SparseMatrix<double> laplacian(model.num_nodes(), model.num_nodes());
        laplacian.setFromTriplets(entries.begin(), entries.end());
        return laplacian;
    }

} // namespace

Index automatic_samples(Index columns, bool contacts)
{
    return std::max<Index>((contacts ? 5 : 4) * columns, 256);
}

SampledLocalStage::SampledLocalStage(
    const Model& model, bool exact_projections, Index samples, ReducedGlobalStep& reduced)
    : m_reduced(&reduced)
{
    Timer timer;
    const Index k = model.num_columns();
    const Index n = model.num_nodes();
    if (samples < 0)
        throw_error("hyper-reduced: sample count {} must be non-negative", samples);
    if (samples == 0)
        samples = automatic_samples(k, false);
    m_samples = farthest_point_tets(model, samples);
    for (const int e : m_samples)
        for (int c = 0; c < 4; ++c)
            m_sample_nodes.push_back(model.tets()(e, c));
    std::sort(m_sample_nodes.begin(), m_sample_nodes.end());
    m_sample_nodes.erase(
        std::unique(m_sample_nodes.begin(), m_sample_nodes.end()), m_sample_nodes.end());
    m_local = std::make_unique<LocalStep>(model, exact_projections, m_samples);
    // The basis rows of the sample nodes, compact (CSR).
    const SparseRowMatrix& basis_rows = model.basis();
    m_row_offsets.assign(1, 0);
    for (const int i : m_sample_nodes) {
        for (SparseRowMatrix::InnerIterator it(basis_rows, i); it; ++it) {
            m_row_columns.push_back(static_cast<int>(it.index()));
            m_row_values.push_back(it.value());
        }
        m_row_offsets.push_back(static_cast<int>(m_row_columns.size()));
    }

    // H = B^T L_S B, regularized; Z = S^-1 K H^-1 and the constant part of the fitted
    // right-hand side.
    const Eigen::SparseMatrix<double> laplacian = sample_laplacian(model, m_samples);
    const Eigen::SparseMatrix<double> basis = model.basis();
    const Eigen::SparseMatrix<double> basis_t = model.basis_transpose();
    MatX h = MatX(basis_t * (laplacian * basis));
    const double epsilon = 1e-8 * std::max(h.diagonal().mean(), 1e-300);
    h.diagonal().array() += epsilon;
    const Eigen::LLT<MatX> h_factor(h);
    if (h_factor.info() != Eigen::Success)
        throw_error(
            "hyper-reduced: the fit matrix of {} samples ({} x {}) is not positive definite",
            m_samples.size(), k, k);
    // K H^-1 = (H^-1 K)^T (both symmetric).
    const MatX fit_map = h_factor.solve(model.reduced_laplacian()).transpose();
    const double w = model.strain_weight() + model.volume_weight() + model.strain_limit_weight();
    const MatX rest_term = MatX(basis_t * model.stiffness_rest()); // w B^T L X
    const MatX sample_rest = MatX(basis_t * (laplacian * model.rest_positions())); // B^T L_S X
    m_fit_constant = rest_term - w * (fit_map * sample_rest);
    m_fit_solution = model.reduced_system().solve(fit_map);

    m_positions = MatX3::Zero(n, 3);
    m_forces = MatX3::Zero(n, 3);
    m_base = MatX::Zero(k, 3);
    m_base_rows = MatX3::Zero(k, 3);
    m_q_rows = MatX3::Zero(k, 3);
    m_sample_rows = MatX3::Zero(k, 3);
    m_sample_rhs = MatX::Zero(k, 3);
    m_q_base = MatX::Zero(k, 3);
    m_q = MatX::Zero(k, 3);
    logger().debug(
        "hyper-reduced: {} of {} tets sampled ({} nodes), fit {} x {}, set up in {:.3f} s",
        m_samples.size(), model.num_tets(), m_sample_nodes.size(), k, k, timer.seconds());
}

SampledLocalStage::~SampledLocalStage() = default;

// Per iteration: the samples' positions from q, their local step r_S, y = B^T r_S, and
//   q = S^-1 (B^T base + w (B^T L X - K H^-1 B^T L_S X)) + S^-1 K H^-1 y,
// the first term once per step.
void SampledLocalStage::iterate(const Model& model, int iteration,
    const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3>& base,
    GlobalStep& global, SolverTimings& timings)
{
    MAT_CHECK(&global == m_reduced, "hyper-reduced: solving with another global step");
    Timer timer;
    const Index count = static_cast<Index>(m_sample_nodes.size());
    if (iteration == 0) {
        // The samples start from the inertia target.
        for (const int i : m_sample_nodes)
            m_positions.row(i) = positions.row(i);
    } else {
        // x_i = X_i + B_i q at the kept solution (with its contact displacements).
        m_q_rows = *m_reduced->reduced_coordinates();
        const MatX3& rest = model.rest_positions();
        for (Index s = 0; s < count; ++s) {
            const int i = m_sample_nodes[s];
            double x0 = rest(i, 0), x1 = rest(i, 1), x2 = rest(i, 2);
            for (int e = m_row_offsets[s]; e < m_row_offsets[s + 1]; ++e) {
                const double v = m_row_values[e];
                const double* q = m_q_rows.data() + 3 * m_row_columns[e];
                x0 += v * q[0];
                x1 += v * q[1];
                x2 += v * q[2];
            }
            m_positions(i, 0) = x0;
            m_positions(i, 1) = x1;
            m_positions(i, 2) = x2;
        }
    }
    timings.reconstruct += timer.seconds();

    timer.restart();
    m_local->compute_touched(model, m_positions, m_forces);
    timings.local += timer.seconds();

    timer.restart();
    if (iteration == 0) {
        m_reduced->products().transpose_times(base.data(), m_base_rows.data());
        m_base = m_base_rows;
        m_base += m_fit_constant;
        timings.rhs += timer.seconds();
        m_reduced->solve_reduced(m_base, timings); // its own timing
        m_q_base = *m_reduced->reduced_coordinates();
        timer.restart();
    }
    m_sample_rows.setZero();
    for (Index s = 0; s < count; ++s) {
        const double* f = m_forces.data() + 3 * m_sample_nodes[s];
        for (int e = m_row_offsets[s]; e < m_row_offsets[s + 1]; ++e) {
            double* y = m_sample_rows.data() + 3 * m_row_columns[e];
            const double v = m_row_values[e];
            y[0] += v * f[0];
            y[1] += v * f[1];
            y[2] += v * f[2];
        }
    }
    m_sample_rhs = m_sample_rows;
    timings.rhs += timer.seconds();
    timer.restart();
    tbb::parallel_for(0, 3, [&](int c) {
        m_q.col(c) = m_q_base.col(c);
        m_q.col(c).noalias() += m_fit_solution * m_sample_rhs.col(c);
    });
    m_reduced->set_reduced_coordinates(m_q);
    timings.solve += timer.seconds();
}

} // namespace mat
