#include "runtime/pd/local_step.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/LU> // Matrix3d::inverse
#include <Eigen/SVD>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "runtime/pd/projection_kernel.hpp"

namespace mat {

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
    : m_contributions(model.num_tets(), 12)
{
}

void LocalStep::compute(
    const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs)
{
    const Index n = model.num_nodes();
    const Index t = model.num_tets();
    MAT_CHECK(positions.rows() == n && rhs.rows() == n,
        "local step: {} positions / {} rhs rows "
        "for a model of {} nodes",
        positions.rows(), rhs.rows(), n);
    MAT_CHECK(m_contributions.rows() == t, "local step: workspace made for {} tets, model has {}",
        m_contributions.rows(), t);
    const MatX4i& tets = model.tets();
    const MatX& dm_inverse = model.dm_inverse();
    const VecX& volumes = model.rest_volumes();
    ProjectionParams params;
    params.volume_tolerance = model.volume_tolerance();
    params.limit_min = model.material().strain_limit_min;
    params.limit_max = model.material().strain_limit_max;
    params.rotation_weight = model.strain_weight();
    params.volume_weight = model.volume_weight();
    params.limit_weight = model.strain_limit_weight();
    constexpr int lanes = projection_lanes;
    const Index num_blocks = (t + lanes - 1) / lanes;
    const double* x = positions.data(); // row-major n x 3, rows contiguous (checked below)
    MAT_CHECK(positions.outerStride() == 3, "local step: positions must be contiguous rows");

    // Blocks of `lanes` consecutive tets (Morton-ordered by the bake): gather F, project, scatter
    // the 12 numbers per tet. A block's result does not depend on how TBB splits the range.
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, num_blocks), [&](const tbb::blocked_range<Index>& range) {
            MatBlock f, target;
            for (Index block = range.begin(); block != range.end(); ++block) {
                const Index first = block * lanes;
                const int count = static_cast<int>(std::min<Index>(lanes, t - first));
                // F = Ds Dm^-1 per lane; padding lanes get the identity.
                for (int l = 0; l < lanes; ++l) {
                    if (l >= count) {
                        for (int i = 0; i < 9; ++i)
                            f.m[i][l] = (i % 4 == 0) ? 1.0 : 0.0;
                        continue;
                    }
                    const Index e = first + l;
                    const double* x0 = x + 3 * tets(e, 0);
                    double ds[3][3]; // ds[r][c] = x_{c+1}(r) - x_0(r)
                    for (int c = 0; c < 3; ++c) {
                        const double* xc = x + 3 * tets(e, c + 1);
                        for (int r = 0; r < 3; ++r)
                            ds[r][c] = xc[r] - x0[r];
                    }
                    const double* dm = &dm_inverse(e, 0);
                    const Index stride = dm_inverse.rows(); // column-major T x 9
                    for (int r = 0; r < 3; ++r)
                        for (int c = 0; c < 3; ++c)
                            f.m[3 * r + c][l] = ds[r][0] * dm[(3 * 0 + c) * stride]
                                + ds[r][1] * dm[(3 * 1 + c) * stride]
                                + ds[r][2] * dm[(3 * 2 + c) * stride];
                }
                project_block(f, params, target);
                // vol_e G_e^T target^T with G_e^T = E Dm^-1, E = [-1 -1 -1; I] (4 x 3):
                // row c + 1 of the 4 x 3 contribution is vol_e (Dm^-1 target^T) row c.
                for (int l = 0; l < count; ++l) {
                    const Index e = first + l;
                    const double* dm = &dm_inverse(e, 0);
                    const Index stride = dm_inverse.rows();
                    const double vol = volumes(e);
                    double* out = m_contributions.row(e).data();
                    double sum[3] = { 0.0, 0.0, 0.0 };
                    for (int r = 0; r < 3; ++r)
                        for (int c = 0; c < 3; ++c) {
                            // (Dm^-1 target^T)(r, c) = sum_j Dm^-1(r, j) target(c, j)
                            const double q = vol
                                * (dm[(3 * r + 0) * stride] * target.m[3 * c + 0][l]
                                    + dm[(3 * r + 1) * stride] * target.m[3 * c + 1][l]
                                    + dm[(3 * r + 2) * stride] * target.m[3 * c + 2][l]);
                            out[3 * (r + 1) + c] = q;
                            sum[c] += q;
                        }
                    for (int c = 0; c < 3; ++c)
                        out[c] = -sum[c];
                }
            }
        });

    const VecXi& indptr = model.incident_indptr();
    const VecXi& corners = model.incident_corners();
    tbb::parallel_for(tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
        for (Index i = range.begin(); i != range.end(); ++i) {
            Eigen::RowVector3d acc = Eigen::RowVector3d::Zero();
            for (int j = indptr(i); j < indptr(i + 1); ++j) {
                const int e = corners(j) / 4, c = corners(j) % 4;
                acc += m_contributions.block<1, 3>(e, 3 * c);
            }
            rhs.row(i) = acc;
        }
    });
}

} // namespace mat
