#include "preprocess/model_size/model_error.hpp"

#include <cmath>

#include <Eigen/SVD>

#include "common/error.hpp"
#include "runtime/pd/local_step.hpp"

namespace mat {

SurfaceError surface_error(
    const Eigen::Ref<const MatX3>& a, const Eigen::Ref<const MatX3>& b, double diagonal)
{
    if (a.rows() != b.rows() || a.rows() == 0)
        throw_error("surface error: {} and {} vertices (the same non-empty surface expected)",
            a.rows(), b.rows());
    const VecX distances = (a - b).rowwise().norm();
    SurfaceError error;
    error.max_percent = 100.0 * distances.maxCoeff() / diagonal;
    error.rms_percent
        = 100.0 * std::sqrt(distances.squaredNorm() / double(distances.size())) / diagonal;
    return error;
}

VecX handle_residuals(const BakeData& bake, const Eigen::Ref<const MatX3>& positions)
{
    const MatX4i& tets = bake.tet_mesh.tets;
    const Index m = bake.num_handles();
    VecX residual = VecX::Zero(m);
    for (Index e = 0; e < tets.rows(); ++e) {
        const Mat3 f = deformation_gradient(positions, tets, bake.dm_inverse, e);
        const Eigen::JacobiSVD<Mat3> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
        Mat3 u = svd.matrixU();
        if ((u * svd.matrixV().transpose()).determinant() < 0)
            u.col(2) *= -1.0;
        const double energy
            = bake.rest_volumes(e) * (f - u * svd.matrixV().transpose()).squaredNorm();
        for (int c = 0; c < 4; ++c)
            for (SparseRowMatrix::InnerIterator it(bake.weights, tets(e, c)); it; ++it)
                residual(it.col()) += 0.25 * it.value() * energy;
    }
    return residual;
}

} // namespace mat
