#include <gtest/gtest.h>

#include <random>

#include "common/error.hpp"
#include "preprocess/basis/handle_basis.hpp"
#include "preprocess/pd/pd_operators.hpp"
#include "preprocess/weights/handle_regions.hpp"
#include "preprocess/weights/harmonic_weights.hpp"
#include "tests/support/grid_tets.hpp"

namespace mat {
namespace {

    struct BasisSetup {
        TetMesh mesh;
        MatX3 centers;
        Eigen::SparseMatrix<double, Eigen::RowMajor> weights;
        VecX scales;
    };

    BasisSetup make_setup()
    {
        test::GridTetOptions options;
        options.nx = 7;
        options.ny = 6;
        options.nz = 5;
        options.min_corner = Vec3(10.0, -3.0, 4.0); // away from the origin on purpose
        options.max_corner = Vec3(13.5, 0.0, 6.5);
        options.jitter = 0.15;
        BasisSetup s;
        s.mesh = test::make_grid_tets(options);
        s.centers.resize(6, 3);
        s.centers << 10.5, -2.5, 4.5, 13.0, -2.5, 4.5, 11.7, -1.5, 5.2, 10.5, -0.5, 6.0, 13.0, -0.5,
            6.0, 12.2, -2.0, 6.1;
        const VecX radii = VecX::Constant(6, 0.7);
        const VecXi owner = assign_handle_regions(s.mesh.positions, s.centers, radii, 0.5);
        const Eigen::SparseMatrix<double> l = assemble_laplacian(s.mesh.num_vertices(), s.mesh.tets,
            compute_tet_rest_data(s.mesh.positions, s.mesh.tets));
        HarmonicWeightOptions weight_options;
        weight_options.max_handles_per_node = 4;
        s.weights = compute_harmonic_weights(l, owner, 6, weight_options).weights;
        s.scales = handle_support_scales(s.mesh.positions, s.weights, s.centers);
        return s;
    }

    Mat3 random_matrix(std::mt19937& rng)
    {
        std::uniform_real_distribution<double> unit(-2.0, 2.0);
        Mat3 m;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                m(r, c) = unit(rng);
        return m;
    }

    TEST(HandleBasis, ColumnMapAndShape)
    {
        const BasisSetup s = make_setup();
        Eigen::Matrix<bool, Eigen::Dynamic, 1> quadratic(6);
        quadratic << true, false, false, true, false, true;
        const HandleBasis basis
            = build_handle_basis(s.mesh.positions, s.weights, s.centers, s.scales, quadratic);
        const Index k = 3 * quadratic_handle_terms + 3 * linear_handle_terms;
        ASSERT_EQ(basis.num_columns(), k);
        EXPECT_EQ(basis.basis.rows(), s.mesh.num_vertices());
        EXPECT_EQ(basis.basis.cols(), k);
        EXPECT_EQ(basis.handle_offset[6], k);
        for (Index j = 0; j < 6; ++j)
            for (Index c = basis.handle_offset[j]; c < basis.handle_offset[j + 1]; ++c) {
                EXPECT_EQ(basis.column_handle[c], j);
                EXPECT_EQ(basis.column_term[c], c - basis.handle_offset[j]);
            }
        // Row nonzeros = sum of the terms of the node's handles; columns increase along rows.
        for (Index i = 0; i < s.mesh.num_vertices(); ++i) {
            Index expected = 0;
            for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(s.weights, i); it;
                 ++it)
                expected += quadratic[it.col()] ? 10 : 4;
            Index count = 0;
            Index previous = -1;
            for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(basis.basis, i); it;
                 ++it, ++count) {
                EXPECT_GT(it.col(), previous);
                previous = it.col();
                // Support scales keep |y| <= 1, so no entry exceeds its weight.
                const double w = s.weights.coeff(i, basis.column_handle[it.col()]);
                EXPECT_LE(std::abs(it.value()), w * (1.0 + 1e-12));
                if (basis.column_term[it.col()] == int(BasisTerm::constant)) {
                    EXPECT_EQ(it.value(), w);
                }
            }
            EXPECT_EQ(count, expected);
        }
    }

    TEST(HandleBasis, ReproducesAffineFieldsExactly)
    {
        const BasisSetup s = make_setup();
        Eigen::Matrix<bool, Eigen::Dynamic, 1> quadratic(6);
        quadratic << false, true, false, false, true, false;
        const HandleBasis basis
            = build_handle_basis(s.mesh.positions, s.weights, s.centers, s.scales, quadratic);
        std::mt19937 rng(5);
        for (int trial = 0; trial < 5; ++trial) {
            const Mat3 a = random_matrix(rng);
            const Vec3 t = random_matrix(rng).col(0) * 5.0;
            const MatX3 q = affine_coefficients(basis, a, t);
            const MatX3 u = basis.basis * q;
            const MatX3 expected = (s.mesh.positions * a.transpose()).rowwise() + t.transpose();
            const double error = (u - expected).cwiseAbs().maxCoeff();
            EXPECT_LT(error, 1e-12 * expected.cwiseAbs().maxCoeff()) << "trial " << trial;
        }
    }

    TEST(HandleBasis, ReproducesQuadraticFieldsWithQuadraticHandles)
    {
        const BasisSetup s = make_setup();
        const Eigen::Matrix<bool, Eigen::Dynamic, 1> quadratic
            = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(6, true);
        const HandleBasis basis
            = build_handle_basis(s.mesh.positions, s.weights, s.centers, s.scales, quadratic);
        std::mt19937 rng(6);
        for (int trial = 0; trial < 5; ++trial) {
            const std::array<Mat3, 3> h { random_matrix(rng), random_matrix(rng),
                random_matrix(rng) };
            const Mat3 a = random_matrix(rng);
            const Vec3 t = random_matrix(rng).col(1);
            const MatX3 u = basis.basis * quadratic_coefficients(basis, h, a, t);
            double scale = 0.0;
            double error = 0.0;
            for (Index i = 0; i < s.mesh.num_vertices(); ++i) {
                const Vec3 x = s.mesh.positions.row(i);
                for (int d = 0; d < 3; ++d) {
                    const double expected = x.dot(h[d] * x) + a.row(d).dot(x) + t[d];
                    scale = std::max(scale, std::abs(expected));
                    error = std::max(error, std::abs(u(i, d) - expected));
                }
            }
            EXPECT_LT(error, 1e-12 * scale) << "trial " << trial;
        }

        // Linear handles cannot carry a quadratic field.
        Eigen::Matrix<bool, Eigen::Dynamic, 1> mixed = quadratic;
        mixed[2] = false;
        const HandleBasis linear_too
            = build_handle_basis(s.mesh.positions, s.weights, s.centers, s.scales, mixed);
        const std::array<Mat3, 3> h { Mat3::Identity(), Mat3::Zero(), Mat3::Zero() };
        EXPECT_THROW(quadratic_coefficients(linear_too, h, Mat3::Zero(), Vec3::Zero()), Error);
    }

    TEST(HandleBasis, RejectsBadScalesAndShapes)
    {
        const BasisSetup s = make_setup();
        const Eigen::Matrix<bool, Eigen::Dynamic, 1> linear
            = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(6, false);
        VecX scales = s.scales;
        scales[3] = 0.0;
        EXPECT_THROW(
            build_handle_basis(s.mesh.positions, s.weights, s.centers, scales, linear), Error);
        EXPECT_THROW(build_handle_basis(s.mesh.positions, s.weights, s.centers.topRows(5),
                         s.scales.head(5), linear.head(5)),
            Error);
    }

} // namespace
} // namespace mat
