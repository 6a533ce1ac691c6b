#include <gtest/gtest.h>

#include <random>
#include <string>

#include "common/error.hpp"
#include "preprocess/basis/handle_basis.hpp"
#include "preprocess/pd/pd_operators.hpp"
#include "preprocess/pd/reduced_operators.hpp"
#include "preprocess/weights/handle_regions.hpp"
#include "preprocess/weights/harmonic_weights.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/grid_tets.hpp"

namespace mat {
namespace {

    test::GridTetOptions jittered_box()
    {
        test::GridTetOptions options;
        options.nx = 6;
        options.ny = 5;
        options.nz = 4;
        options.min_corner = Vec3(-1.0, 0.0, 0.5);
        options.max_corner = Vec3(2.0, 2.0, 2.5);
        options.jitter = 0.15;
        options.seed = 3;
        return options;
    }

    bool on_boundary(const test::GridTetOptions& o, Index node)
    {
        const Index i = node % (o.nx + 1);
        const Index j = (node / (o.nx + 1)) % (o.ny + 1);
        const Index k = node / ((o.nx + 1) * (o.ny + 1));
        return i == 0 || j == 0 || k == 0 || i == o.nx || j == o.ny || k == o.nz;
    }

    TEST(PdOperators, RestDataInvertsEdgesAndSumsToTheBoxVolume)
    {
        const test::GridTetOptions options = jittered_box();
        const TetMesh mesh = test::make_grid_tets(options);
        const TetRestData rest = compute_tet_rest_data(mesh.positions, mesh.tets);
        ASSERT_EQ(rest.volumes.size(), mesh.num_tets());
        EXPECT_NEAR(rest.volumes.sum(), 3.0 * 2.0 * 2.0, 1e-12);
        EXPECT_GT(rest.volumes.minCoeff(), 0.0);
        for (Index t = 0; t < mesh.num_tets(); t += 7) {
            Mat3 dm;
            for (int c = 0; c < 3; ++c)
                dm.col(c) = (mesh.positions.row(mesh.tets(t, c + 1))
                    - mesh.positions.row(mesh.tets(t, 0)))
                                .transpose();
            const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> inverse(
                rest.dm_inverse.row(t).data());
            EXPECT_LT((inverse * dm - Mat3::Identity()).norm(), 1e-12);
        }
    }

    TEST(PdOperators, InvertedOrOutOfRangeTetsAreNamed)
    {
        TetMesh mesh = test::make_grid_tets(jittered_box());
        std::swap(mesh.tets(5, 1), mesh.tets(5, 2));
        test::expect_error_containing(
            [&] { compute_tet_rest_data(mesh.positions, mesh.tets); }, { "tet 5 " });
        std::swap(mesh.tets(5, 1), mesh.tets(5, 2));
        mesh.tets(9, 3) = static_cast<int>(mesh.num_vertices());
        EXPECT_THROW(compute_tet_rest_data(mesh.positions, mesh.tets), Error);
    }

    TEST(PdOperators, GradientOperatorIsExactOnLinearFields)
    {
        const TetMesh mesh = test::make_grid_tets(jittered_box());
        const TetRestData rest = compute_tet_rest_data(mesh.positions, mesh.tets);
        const Vec3 a(0.3, -1.2, 2.5);
        for (Index t = 0; t < mesh.num_tets(); t += 5) {
            Vec4 f;
            for (int c = 0; c < 4; ++c)
                f[c] = a.dot(mesh.positions.row(mesh.tets(t, c))) + 4.0;
            const Vec3 gradient = tet_gradient_operator(rest.dm_inverse.row(t)) * f;
            EXPECT_LT((gradient - a).norm(), 1e-12);
        }
    }

    TEST(PdOperators, LaplacianIsSymmetricWithConstantNullSpace)
    {
        const test::GridTetOptions options = jittered_box();
        const TetMesh mesh = test::make_grid_tets(options);
        const TetRestData rest = compute_tet_rest_data(mesh.positions, mesh.tets);
        const Eigen::SparseMatrix<double> l
            = assemble_laplacian(mesh.num_vertices(), mesh.tets, rest);
        const Eigen::SparseMatrix<double> asym = l - Eigen::SparseMatrix<double>(l.transpose());
        EXPECT_LT(asym.norm(), 1e-13 * l.norm());
        EXPECT_LT((l * VecX::Ones(mesh.num_vertices())).lpNorm<Eigen::Infinity>(), 1e-12);

        // A linear field: L f = 0 at interior nodes; f^T L f = |a|^2 volume.
        const Vec3 a(1.0, -2.0, 0.5);
        const VecX f = mesh.positions * a;
        const VecX lf = l * f;
        for (Index i = 0; i < mesh.num_vertices(); ++i) {
            if (!on_boundary(options, i)) {
                EXPECT_NEAR(lf[i], 0.0, 1e-12) << "node " << i;
            }
        }
        EXPECT_NEAR(f.dot(lf), a.squaredNorm() * 12.0, 1e-10);

        // Positive semi-definite: the energy of a random field is sum vol |grad|^2 >= 0.
        std::mt19937 rng(4);
        std::uniform_real_distribution<double> unit(-1.0, 1.0);
        VecX g(mesh.num_vertices());
        for (Index i = 0; i < g.size(); ++i)
            g[i] = unit(rng);
        double energy = 0.0;
        for (Index t = 0; t < mesh.num_tets(); ++t) {
            Vec4 local;
            for (int c = 0; c < 4; ++c)
                local[c] = g[mesh.tets(t, c)];
            energy += rest.volumes[t]
                * (tet_gradient_operator(rest.dm_inverse.row(t)) * local).squaredNorm();
        }
        EXPECT_NEAR(g.dot(l * g), energy, 1e-10 * energy);
        EXPECT_GT(energy, 0.0);
    }

    TEST(PdOperators, LumpedMassesSumToTheVolume)
    {
        const TetMesh mesh = test::make_grid_tets(jittered_box());
        const TetRestData rest = compute_tet_rest_data(mesh.positions, mesh.tets);
        const VecX masses = lumped_masses(mesh.num_vertices(), mesh.tets, rest.volumes);
        const double density = 1070.0;
        EXPECT_NEAR(density * masses.sum(), density * 12.0, 1e-9);
        EXPECT_GT(masses.minCoeff(), 0.0);
    }

    TEST(PdOperators, ReducedMatricesAreSymmetricAndTheSystemIsSpd)
    {
        const TetMesh mesh = test::make_grid_tets(jittered_box());
        const TetRestData rest = compute_tet_rest_data(mesh.positions, mesh.tets);
        const Eigen::SparseMatrix<double> l
            = assemble_laplacian(mesh.num_vertices(), mesh.tets, rest);
        const VecX masses = lumped_masses(mesh.num_vertices(), mesh.tets, rest.volumes);

        MatX3 centers(5, 3);
        centers << -0.5, 0.5, 1.0, 1.5, 1.5, 2.0, 0.5, 1.0, 1.5, 1.5, 0.3, 0.8, -0.6, 1.6, 2.2;
        const VecX radii = VecX::Constant(5, 0.6);
        const VecXi owner = assign_handle_regions(mesh.positions, centers, radii, 0.5);
        HarmonicWeightOptions weight_options;
        weight_options.max_handles_per_node = 4;
        const HarmonicWeights weights = compute_harmonic_weights(l, owner, 5, weight_options);
        Eigen::Matrix<bool, Eigen::Dynamic, 1> quadratic(5);
        quadratic << false, true, false, true, false;
        const HandleBasis basis = build_handle_basis(mesh.positions, weights.weights, centers,
            handle_support_scales(mesh.positions, weights.weights, centers), quadratic);

        const ReducedOperators reduced = reduce_operators(basis.basis, l, masses);
        const Index k = basis.num_columns();
        ASSERT_EQ(reduced.laplacian.rows(), k);
        ASSERT_EQ(reduced.mass.cols(), k);
        EXPECT_EQ(reduced.laplacian, reduced.laplacian.transpose());
        EXPECT_EQ(reduced.mass, reduced.mass.transpose());

        // The same products done densely (small mesh only).
        const MatX b = MatX(basis.basis);
        EXPECT_LT(
            (reduced.laplacian - b.transpose() * (l * b)).norm(), 1e-12 * reduced.laplacian.norm());
        EXPECT_LT((reduced.mass - b.transpose() * masses.asDiagonal() * b).norm(),
            1e-12 * reduced.mass.norm());

        // Constant fields cost no energy; affine ones |a|^2 volume; total mass = volume.
        const MatX3 constant = affine_coefficients(basis, Mat3::Zero(), Vec3(1.0, 0.0, 0.0));
        const VecX q1 = constant.col(0);
        EXPECT_NEAR(q1.dot(reduced.laplacian * q1), 0.0, 1e-10);
        EXPECT_NEAR(q1.dot(reduced.mass * q1), 12.0, 1e-10);
        Mat3 a = Mat3::Zero();
        a.row(0) = Vec3(0.5, -1.0, 2.0).transpose();
        const VecX qa = affine_coefficients(basis, a, Vec3::Zero()).col(0);
        EXPECT_NEAR(qa.dot(reduced.laplacian * qa), a.row(0).squaredNorm() * 12.0, 1e-9);

        const ReducedSystemCheck check = check_reduced_system(reduced, 1.0, 1.0, 1.0 / 60.0);
        EXPECT_GT(check.reciprocal_condition, 1e-12);
        EXPECT_GT(check.min_diagonal, 0.0);
        EXPECT_THROW(check_reduced_system(reduced, 1.0, 1.0, 0.0), Error);

        // A basis with a duplicated column is rank-deficient: the check must fail.
        ReducedOperators singular = reduced;
        singular.laplacian.row(1) = singular.laplacian.row(0);
        singular.laplacian.col(1) = singular.laplacian.col(0);
        singular.mass.row(1) = singular.mass.row(0);
        singular.mass.col(1) = singular.mass.col(0);
        EXPECT_THROW(check_reduced_system(singular, 1.0, 1.0, 1.0 / 60.0), Error);
    }

} // namespace
} // namespace mat
