#include "runtime/pd/local_step.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/LU> // Matrix3d::inverse
#include <Eigen/SVD>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

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

TetProjection project_tet(const Mat3& deformation_gradient, double volume_tolerance)
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
    const double w_strain = model.strain_weight();
    const double w_volume = model.volume_weight();
    const double eps = model.volume_tolerance();

    tbb::parallel_for(tbb::blocked_range<Index>(0, t), [&](const tbb::blocked_range<Index>& range) {
        for (Index e = range.begin(); e != range.end(); ++e) {
            const Mat3 f = deformation_gradient(positions, tets, dm_inverse, e);
            const TetProjection p = project_tet(f, eps);
            const Mat3 target = w_strain * p.rotation + w_volume * p.volume;
            Mat3 dm_inv;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c)
                    dm_inv(r, c) = dm_inverse(e, 3 * r + c);
            // vol_e G_e^T target^T with G_e^T = E Dm^-1, E = [-1 -1 -1; I] (4 x 3).
            const Mat3 q = volumes(e) * dm_inv * target.transpose();
            const Vec3 sum = q.colwise().sum().transpose();
            m_contributions.block<1, 3>(e, 0) = -sum.transpose();
            for (int c = 0; c < 3; ++c)
                m_contributions.block<1, 3>(e, 3 * (c + 1)) = q.row(c);
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
