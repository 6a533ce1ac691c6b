#include "runtime/pd/local_step.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/LU> // Matrix3d::inverse
#include <Eigen/SVD>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "runtime/pd/projection_kernel.hpp"

namespace mat {

namespace {
    /// Block colors fit one 64-bit mask per node.
    constexpr int max_block_colors = 64;
} // namespace

Mat3 deformation_gradient(const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX4i>& tets, const MatX& dm_inverse, Index tet)
{
    const Vec3 x0 = positions.row(tets(tet, 0)).transpose();
    Mat3 ds;
    for (int c = 0; c < 3; ++c)
        ds.col(c) = positions.row(tets(tet, c + 1)).transpose() - x0;
    Mat3 dm_inv;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            dm_inv(r, c) = dm_inverse(tet, 3 * r + c);
    return ds * dm_inv;
}

TetProjection project_tet(const Mat3& deformation_gradient, double volume_tolerance,
    double strain_limit_min, double strain_limit_max)
{
    const Eigen::JacobiSVD<Mat3> svd(
        deformation_gradient, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 u = svd.matrixU();
    const Mat3 v = svd.matrixV();
    Vec3 s = svd.singularValues(); // decreasing, >= 0
    if (u.determinant() * v.determinant() < 0.0) {
        // Reflection: flip the smallest singular direction so that U V^T is a rotation.
        u.col(2) = -u.col(2);
        s(2) = -s(2);
    }
    TetProjection result;
    result.rotation = u * v.transpose();
    const Vec3 clamped = s.cwiseMax(strain_limit_min).cwiseMin(strain_limit_max);
    result.limit
        = clamped == s ? deformation_gradient : Mat3(u * clamped.asDiagonal() * v.transpose());

    const double det = s.prod();
    const double target = std::clamp(det, 1.0 - volume_tolerance, 1.0 + volume_tolerance);
    if (det == target) {
        result.volume = deformation_gradient;
        return result;
    }
    // min ||d - s||^2 subject to d0 d1 d2 = target. Feasible start: |s| scaled uniformly.
    Vec3 d = s.cwiseAbs();
    const double abs_prod = d.prod();
    if (abs_prod > 1e-30)
        d *= std::cbrt(target / abs_prod);
    else
        d.setConstant(std::cbrt(target));
    // Newton on the KKT conditions d - s + lambda grad C(d) = 0, C(d) = prod d - target = 0.
    Vec3 gradient(d(1) * d(2), d(0) * d(2), d(0) * d(1));
    double lambda = -gradient.dot(d - s) / std::max(gradient.squaredNorm(), 1e-300);
    for (int iteration = 0; iteration < 20; ++iteration) {
        gradient = Vec3(d(1) * d(2), d(0) * d(2), d(0) * d(1));
        const Vec3 r_d = d - s + lambda * gradient;
        const double r_c = d.prod() - target;
        if (std::max(r_d.cwiseAbs().maxCoeff(), std::abs(r_c)) < 1e-13)
            break;
        // Newton system [H g; g^T 0] [dd; dl] = -[r_d; r_c], H = I + lambda Hessian(prod d),
        // solved through the Schur complement g^T H^-1 g.
        Mat3 h = Mat3::Identity();
        h(0, 1) = h(1, 0) = lambda * d(2);
        h(0, 2) = h(2, 0) = lambda * d(1);
        h(1, 2) = h(2, 1) = lambda * d(0);
        const Mat3 h_inv = h.inverse();
        const Vec3 h_inv_g = h_inv * gradient;
        const double schur = gradient.dot(h_inv_g);
        const double d_lambda = (r_c - gradient.dot(h_inv * r_d)) / schur;
        Vec3 delta = -h_inv * r_d - h_inv_g * d_lambda;
        double step_lambda = d_lambda;
        if (!delta.allFinite() || !std::isfinite(step_lambda))
            break;
        // Halve the step until the iterate stays positive (the branch with prod d > 0).
        int halvings = 0;
        while (!((d + delta).minCoeff() > 0.0) && halvings++ < 40) {
            delta *= 0.5;
            step_lambda *= 0.5;
        }
        if (!((d + delta).minCoeff() > 0.0))
            break; // keep the last positive iterate
        d += delta;
        lambda += step_lambda;
    }
    d *= std::cbrt(target / d.prod()); // exact det (d > 0 here)
    result.volume = u * d.asDiagonal() * v.transpose();
    return result;
}

LocalStep::LocalStep(const Model& model)
    : m_num_tets(model.num_tets())
{
    constexpr int lanes = projection_lanes;
    const Index t = model.num_tets();
    const Index num_blocks = (t + lanes - 1) / lanes;
    const MatX4i& tets = model.tets();
    const MatX& dm_inverse = model.dm_inverse();
    const VecX& volumes = model.rest_volumes();
    m_blocks.resize(num_blocks);
    m_warm.resize(num_blocks);
    for (Index b = 0; b < num_blocks; ++b) {
        Block& block = m_blocks[b];
        const Index first = b * lanes;
        block.count = static_cast<int>(std::min<Index>(lanes, t - first));
        for (int l = 0; l < lanes; ++l) {
            const Index e = first + (l < block.count ? l : 0);
            for (int c = 0; c < 4; ++c)
                block.nodes[c][l] = tets(e, c);
            for (int i = 0; i < 9; ++i)
                block.dm_inverse[i][l] = dm_inverse(e, i);
            block.volume[l] = l < block.count ? volumes(e) : 0.0;
        }
    }

    // Greedy coloring in block order: a block takes the lowest color none of its nodes has seen.
    // Colors are bits of a 64-bit mask per node; a block that finds all 64 taken goes to a last
    // color whose blocks run one after the other.
    std::vector<std::uint64_t> seen(model.num_nodes(), 0);
    std::vector<int> color(num_blocks);
    int used = 0;
    for (Index b = 0; b < num_blocks; ++b) {
        const Block& block = m_blocks[b];
        std::uint64_t taken = 0;
        for (int c = 0; c < 4; ++c)
            for (int l = 0; l < block.count; ++l)
                taken |= seen[block.nodes[c][l]];
        int k = 0;
        while (k < max_block_colors && (taken >> k) & 1u)
            ++k;
        color[b] = k; // k == max_block_colors: the sequential color
        if (k < max_block_colors)
            for (int c = 0; c < 4; ++c)
                for (int l = 0; l < block.count; ++l)
                    seen[block.nodes[c][l]] |= std::uint64_t(1) << k;
        used = std::max(used, k + 1);
    }
    m_color_offsets.assign(used + 1, 0);
    for (Index b = 0; b < num_blocks; ++b)
        ++m_color_offsets[color[b] + 1];
    for (int k = 0; k < used; ++k)
        m_color_offsets[k + 1] += m_color_offsets[k];
    // Store the blocks in color order: a color is then a contiguous range streamed from memory
    // in order (prefetch-friendly), not blocks scattered across the array.
    std::vector<int> fill(m_color_offsets.begin(), m_color_offsets.end() - 1);
    std::vector<Block> ordered(num_blocks);
    for (Index b = 0; b < num_blocks; ++b)
        ordered[fill[color[b]]++] = m_blocks[b];
    m_blocks.swap(ordered);
}

void LocalStep::compute(
    const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs)
{
    rhs.setZero();
    accumulate(model, positions, rhs);
}

void LocalStep::accumulate(
    const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs)
{
    const Index n = model.num_nodes();
    MAT_CHECK(positions.rows() == n && rhs.rows() == n,
        "local step: {} positions / {} rhs rows for a model of {} nodes", positions.rows(),
        rhs.rows(), n);
    MAT_CHECK(m_num_tets == model.num_tets(), "local step: made for {} tets, model has {}",
        m_num_tets, model.num_tets());
    MAT_CHECK(positions.outerStride() == 3 && rhs.outerStride() == 3,
        "local step: positions and rhs must be contiguous rows");
    ProjectionParams params;
    params.volume_tolerance = model.volume_tolerance();
    params.limit_min = model.material().strain_limit_min;
    params.limit_max = model.material().strain_limit_max;
    params.rotation_weight = model.strain_weight();
    params.volume_weight = model.volume_weight();
    params.limit_weight = model.strain_limit_weight();
    constexpr int lanes = projection_lanes;
    const double* x = positions.data(); // row-major n x 3
    double* out = rhs.data();

    // One block: gather F = Ds Dm^-1, project, scatter vol_e G_e^T target^T into rhs. With
    // G_e^T = E Dm^-1, E = [-1 -1 -1; I] (4 x 3), corner c + 1 gets row c of
    // vol_e Dm^-1 target^T and corner 0 minus their sum.
    const auto run_block = [&](int b, MatBlock& f, MatBlock& target) {
        const Block& block = m_blocks[b];
        // Gathered corner positions (scalar loads), then F in SIMD over lanes.
        alignas(64) double p[4][3][lanes];
        for (int l = 0; l < lanes; ++l)
#pragma GCC unroll 4
            for (int c = 0; c < 4; ++c) {
                const double* xc = x + 3 * block.nodes[c][l];
                p[c][0][l] = xc[0];
                p[c][1][l] = xc[1];
                p[c][2][l] = xc[2];
            }
        for (int l = 0; l < lanes; ++l)
#pragma GCC unroll 3
            for (int r = 0; r < 3; ++r) {
                const double x0 = p[0][r][l];
                const double d0 = p[1][r][l] - x0, d1 = p[2][r][l] - x0, d2 = p[3][r][l] - x0;
#pragma GCC unroll 3
                for (int c = 0; c < 3; ++c)
                    f.m[3 * r + c][l] = d0 * block.dm_inverse[c][l]
                        + d1 * block.dm_inverse[3 + c][l] + d2 * block.dm_inverse[6 + c][l];
            }
        project_block(f, params, target, m_warm[b]);
        // q(r, c) = vol (Dm^-1 target^T)(r, c) = vol sum_j Dm^-1(r, j) target(c, j), into f.
        for (int l = 0; l < lanes; ++l)
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c)
                    f.m[3 * r + c][l] = block.volume[l]
                        * (block.dm_inverse[3 * r][l] * target.m[3 * c][l]
                            + block.dm_inverse[3 * r + 1][l] * target.m[3 * c + 1][l]
                            + block.dm_inverse[3 * r + 2][l] * target.m[3 * c + 2][l]);
        for (int l = 0; l < block.count; ++l) {
            double* o0 = out + 3 * block.nodes[0][l];
            for (int r = 0; r < 3; ++r) {
                double* o = out + 3 * block.nodes[r + 1][l];
                for (int c = 0; c < 3; ++c) {
                    o[c] += f.m[3 * r + c][l];
                    o0[c] -= f.m[3 * r + c][l];
                }
            }
        }
    };

    const int num_colors = static_cast<int>(m_color_offsets.size()) - 1;
    for (int k = 0; k < num_colors; ++k) {
        const int begin = m_color_offsets[k], end = m_color_offsets[k + 1];
        if (k == max_block_colors) { // the sequential color (see the constructor)
            MatBlock f, target;
            for (int b = begin; b < end; ++b)
                run_block(b, f, target);
            continue;
        }
        tbb::parallel_for(
            tbb::blocked_range<int>(begin, end, 32), [&](const tbb::blocked_range<int>& range) {
                MatBlock f, target;
                for (int b = range.begin(); b != range.end(); ++b)
                    run_block(b, f, target);
            });
    }
}

} // namespace mat
