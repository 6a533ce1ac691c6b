#include "preprocess/pd/pd_operators.hpp"

#include <cmath>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

namespace {
    using Mat34 = Eigen::Matrix<double, 3, 4>;
    using Mat44 = Eigen::Matrix<double, 4, 4, Eigen::RowMajor>;

    void check_indices(Index num_vertices, const Eigen::Ref<const MatX4i>& tets)
    {
        for (Index t = 0; t < tets.rows(); ++t)
            for (int c = 0; c < 4; ++c)
                if (tets(t, c) < 0 || tets(t, c) >= num_vertices)
                    throw_error("tet mesh: tet {} has node index {} outside [0, {})", t, tets(t, c),
                        num_vertices);
    }
} // namespace

TetRestData compute_tet_rest_data(
    const Eigen::Ref<const MatX3>& rest_positions, const Eigen::Ref<const MatX4i>& tets)
{
    check_indices(rest_positions.rows(), tets);
    const Index num_tets = tets.rows();
    TetRestData rest;
    rest.dm_inverse.resize(num_tets, 9);
    rest.volumes.resize(num_tets);
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, num_tets, 1024), [&](const tbb::blocked_range<Index>& range) {
            for (Index t = range.begin(); t < range.end(); ++t) {
                const Vec3 x0 = rest_positions.row(tets(t, 0));
                Mat3 dm;
                for (int c = 0; c < 3; ++c)
                    dm.col(c) = rest_positions.row(tets(t, c + 1)).transpose() - x0;
                const double det = dm.determinant();
                rest.volumes[t] = det / 6.0;
                Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> inverse(
                    rest.dm_inverse.row(t).data());
                if (det > 0.0 && std::isfinite(det))
                    inverse = dm.inverse();
                else
                    inverse.setZero();
            }
        });
    // Sequential scan so that the reported tet is the first bad one whatever the threads did.
    for (Index t = 0; t < num_tets; ++t) {
        const double volume = rest.volumes[t];
        if (!(volume > 0.0) || !std::isfinite(volume))
            throw_error("tet mesh: tet {} (nodes {} {} {} {}) has rest volume {:g}: inverted or "
                        "degenerate",
                t, tets(t, 0), tets(t, 1), tets(t, 2), tets(t, 3), volume);
        if (!rest.dm_inverse.row(t).allFinite())
            throw_error("tet mesh: tet {} is too degenerate to invert its rest shape", t);
    }
    return rest;
}

Eigen::Matrix<double, 3, 4> tet_gradient_operator(
    const Eigen::Ref<const Eigen::Matrix<double, 1, 9>>& dm_inverse_row)
{
    // f_i - f_0 = g . (X_i - X_0)  =>  Dm^T g = [f_1-f_0, f_2-f_0, f_3-f_0]  =>  g = Dm^-T D f.
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> dm_inverse(
        dm_inverse_row.data());
    Mat34 gradient;
    gradient.col(0) = -dm_inverse.transpose().rowwise().sum();
    gradient.rightCols<3>() = dm_inverse.transpose();
    return gradient;
}

Eigen::SparseMatrix<double> assemble_laplacian(
    Index num_vertices, const Eigen::Ref<const MatX4i>& tets, const TetRestData& rest)
{
    check_indices(num_vertices, tets);
    MAT_CHECK(rest.volumes.size() == tets.rows() && rest.dm_inverse.rows() == tets.rows(),
        "rest data has {} tets, the mesh {}", rest.volumes.size(), tets.rows());
    const Index num_tets = tets.rows();
    // Bouaziz et al. 2014, eq. 13: L = sum_e w_e G_e^T G_e with w_e = vol_e (unit stiffness).
    std::vector<Eigen::Triplet<double>> triplets(static_cast<size_t>(num_tets) * 16);
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, num_tets, 1024), [&](const tbb::blocked_range<Index>& range) {
            for (Index t = range.begin(); t < range.end(); ++t) {
                const Mat34 gradient = tet_gradient_operator(rest.dm_inverse.row(t));
                const Mat44 local = rest.volumes[t] * gradient.transpose() * gradient;
                Eigen::Triplet<double>* out = &triplets[static_cast<size_t>(t) * 16];
                for (int a = 0; a < 4; ++a)
                    for (int b = 0; b < 4; ++b)
                        *out++ = Eigen::Triplet<double>(tets(t, a), tets(t, b), local(a, b));
            }
        });
    Eigen::SparseMatrix<double> laplacian(num_vertices, num_vertices);
    // Duplicates are summed in triplet order: deterministic.
    laplacian.setFromTriplets(triplets.begin(), triplets.end());
    return laplacian;
}

VecX lumped_masses(Index num_vertices, const Eigen::Ref<const MatX4i>& tets, const VecX& volumes)
{
    check_indices(num_vertices, tets);
    MAT_CHECK(volumes.size() == tets.rows(), "{} volumes for {} tets", volumes.size(), tets.rows());
    VecX masses = VecX::Zero(num_vertices);
    for (Index t = 0; t < tets.rows(); ++t)
        for (int c = 0; c < 4; ++c)
            masses[tets(t, c)] += 0.25 * volumes[t];
    return masses;
}

} // namespace mat
