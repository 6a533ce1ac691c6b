// The local step: the per-tet projections against their definitions (closest rotation by brute
// force, polar decomposition, the volume constraint's optimality conditions) and the assembled
// right-hand side against the bake's Laplacian at rest.

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <gtest/gtest.h>

#include "common/parallel.hpp"
#include "runtime/measures/body_measures.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/local_step.hpp"
#include "tests/runtime/runtime_test_models.hpp"

namespace mat {
namespace {

    Mat3 random_rotation(std::mt19937& rng)
    {
        std::normal_distribution<double> normal;
        Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
        return q.normalized().toRotationMatrix();
    }

    Mat3 random_matrix(std::mt19937& rng, double spread)
    {
        std::uniform_real_distribution<double> uniform(-spread, spread);
        Mat3 m;
        for (int i = 0; i < 9; ++i)
            m(i) = uniform(rng);
        return m;
    }

    void expect_rotation(const Mat3& r)
    {
        EXPECT_LT((r.transpose() * r - Mat3::Identity()).norm(), 1e-12);
        EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    }

    TEST(ProjectTet, RotationIsAFixedPoint)
    {
        std::mt19937 rng(7);
        for (int trial = 0; trial < 50; ++trial) {
            const Mat3 r = random_rotation(rng);
            const TetProjection p = project_tet(r, 0.01);
            EXPECT_LT((p.rotation - r).norm(), 1e-12);
            EXPECT_EQ(p.volume, r); // det 1 is inside the band: F itself
        }
    }

    TEST(ProjectTet, RotationIsThePolarFactor)
    {
        std::mt19937 rng(11);
        for (int trial = 0; trial < 50; ++trial) {
            Mat3 f = Mat3::Identity() + random_matrix(rng, 0.6);
            if (f.determinant() <= 0.1)
                continue;
            const TetProjection p = project_tet(f, 0.01);
            expect_rotation(p.rotation);
            // F = R S with S symmetric positive definite.
            const Mat3 s = p.rotation.transpose() * f;
            EXPECT_LT((s - s.transpose()).norm(), 1e-10);
            EXPECT_GT(Eigen::SelfAdjointEigenSolver<Mat3>(0.5 * (s + s.transpose()))
                          .eigenvalues()
                          .minCoeff(),
                0.0);
        }
    }

    TEST(ProjectTet, InvertedTetGetsTheClosestProperRotation)
    {
        std::mt19937 rng(13);
        for (int trial = 0; trial < 20; ++trial) {
            const Mat3 f = random_rotation(rng) * Eigen::Vector3d(1.2, 0.9, -0.3).asDiagonal()
                * random_rotation(rng);
            ASSERT_LT(f.determinant(), 0.0);
            const TetProjection p = project_tet(f, 0.01);
            expect_rotation(p.rotation);
            const double best = (f - p.rotation).norm();
            for (int sample = 0; sample < 2000; ++sample)
                EXPECT_GE((f - random_rotation(rng)).norm(), best - 1e-12);
        }
    }

    TEST(ProjectTet, VolumeIsClampedOptimally)
    {
        std::mt19937 rng(17);
        const double eps = 0.05;
        for (int trial = 0; trial < 100; ++trial) {
            const Mat3 f = Mat3::Identity() + random_matrix(rng, 0.8);
            const TetProjection p = project_tet(f, eps);
            const double det_f = f.determinant();
            const double det_p = p.volume.determinant();
            if (det_f >= 1.0 - eps && det_f <= 1.0 + eps) {
                EXPECT_EQ(p.volume, f);
                continue;
            }
            const double expected = det_f > 1.0 + eps ? 1.0 + eps : 1.0 - eps;
            EXPECT_NEAR(det_p, expected, 1e-12) << "trial " << trial << " det F " << det_f;
            if (det_f <= 0.0)
                continue; // inverted: the constraint set is not convex, only feasibility holds
            // Optimality on the singular values: d - s is parallel to grad(prod d).
            const Eigen::JacobiSVD<Mat3> svd(f);
            const Eigen::JacobiSVD<Mat3> svd_p(p.volume);
            const Vec3 s = svd.singularValues();
            const Vec3 d = svd_p.singularValues();
            const Vec3 gradient(d(1) * d(2), d(0) * d(2), d(0) * d(1));
            EXPECT_LT((d - s).cross(gradient).norm(), 1e-9 * (1.0 + (d - s).norm()))
                << "s " << s.transpose() << " d " << d.transpose();
        }
    }

    TEST(LocalStep, AtRestGivesTheStiffnessTimesTheRestPositions)
    {
        test::GridTetOptions grid;
        grid.nx = grid.ny = grid.nz = 3;
        grid.jitter = 0.15;
        const BakeData bake = test::make_identity_bake(grid);
        ModelOptions options;
        const Model model(bake, Material {}, options);
        LocalStep local(model);
        MatX3 rhs(model.num_nodes(), 3);
        local.compute(model, model.rest_positions(), rhs);
        // At rest every projection is the identity, so rhs = sum_e w_e G_e^T I = L_w X.
        const double scale = model.stiffness_rest().norm();
        EXPECT_LT((rhs - model.stiffness_rest()).norm(), 1e-12 * scale);
    }

    /// A smooth bend and twist plus noise: some tets stretch, some compress, a few invert.
    MatX3 bent_and_twisted(const MatX3& rest)
    {
        std::mt19937 rng(5);
        std::normal_distribution<double> noise(0.0, 0.02);
        MatX3 x = rest;
        for (Index i = 0; i < x.rows(); ++i) {
            const Vec3 p = x.row(i).transpose();
            const double a = 0.8 * p.z();
            x.row(i) << std::cos(a) * p.x() - std::sin(a) * p.y() + 0.3 * p.z() * p.z(),
                std::sin(a) * p.x() + std::cos(a) * p.y(), 1.1 * p.z();
            for (int d = 0; d < 3; ++d)
                x(i, d) += noise(rng);
        }
        return x;
    }

    // Several chunks (the parallel units) against the plain per-tet sum with the scalar
    // reference projections, and bitwise the same sums on 1 and 2 threads.
    TEST(LocalStep, ChunkedSumMatchesThePerTetSumOnAnyThreadCount)
    {
        test::GridTetOptions grid;
        grid.nx = grid.ny = grid.nz = 11;
        grid.jitter = 0.15;
        const BakeData bake = test::make_identity_bake(grid);
        Material material;
        material.poisson_ratio = 0.45; // the volume constraint matters
        const Model model(bake, material, ModelOptions {});
        LocalStep local(model);
        ASSERT_GT(local.num_chunks(), 4);

        const MatX3 x = bent_and_twisted(model.rest_positions());

        MatX3 expected = MatX3::Zero(model.num_nodes(), 3);
        for (Index e = 0; e < model.num_tets(); ++e) {
            const Mat3 f = deformation_gradient(x, model.tets(), model.dm_inverse(), e);
            const TetProjection p = project_tet(f, model.volume_tolerance());
            const Mat3 target
                = model.strain_weight() * p.rotation + model.volume_weight() * p.volume;
            Mat3 dm_inv;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c)
                    dm_inv(r, c) = model.dm_inverse()(e, 3 * r + c);
            const Mat3 q = model.rest_volumes()(e) * dm_inv * target.transpose();
            for (int r = 0; r < 3; ++r) {
                expected.row(model.tets()(e, r + 1)) += q.row(r);
                expected.row(model.tets()(e, 0)) -= q.row(r);
            }
        }

        std::vector<MatX3> results;
        for (const int threads : { 1, 2 }) {
            set_threads(threads);
            LocalStep fresh(model);
            MatX3 rhs(model.num_nodes(), 3);
            fresh.compute(model, x, rhs);
            results.push_back(rhs);
        }
        set_threads(0);
        EXPECT_LT((results[0] - expected).norm(), 1e-9 * expected.norm());
        EXPECT_EQ(results[0], results[1]);

        // assemble = base + the sum, accumulate adds.
        const MatX3 base = MatX3::Random(model.num_nodes(), 3);
        MatX3 assembled(model.num_nodes(), 3);
        LocalStep again(model);
        again.assemble(model, x, base, assembled);
        EXPECT_LT((assembled - base - results[0]).norm(), 1e-12 * results[0].norm());
        MatX3 added = base;
        LocalStep third(model);
        third.accumulate(model, x, added);
        EXPECT_EQ(added, assembled);
    }

    // The body measures (vectorized exact projections) against their per-tet definition with
    // the scalar reference projections, strain limits on.
    TEST(MeasureBody, MatchesThePerTetDefinition)
    {
        test::GridTetOptions grid;
        grid.nx = grid.ny = grid.nz = 5;
        grid.jitter = 0.15;
        const BakeData bake = test::make_identity_bake(grid);
        Material material;
        material.poisson_ratio = 0.45;
        material.strain_limit_min = 0.9;
        material.strain_limit_max = 1.1;
        const Model model(bake, material, ModelOptions {});
        State state = State::at_rest(model);
        state.positions = bent_and_twisted(model.rest_positions());
        VecX strain;
        const BodyMeasures measures = measure_body(model, state, Vec3(0, -9.81, 0), &strain);

        double energy = 0.0, max_strain = 0.0;
        for (Index e = 0; e < model.num_tets(); ++e) {
            const Mat3 f
                = deformation_gradient(state.positions, model.tets(), model.dm_inverse(), e);
            const TetProjection p = project_tet(
                f, model.volume_tolerance(), material.strain_limit_min, material.strain_limit_max);
            energy += model.rest_volumes()(e)
                * (0.5 * model.strain_weight() * (f - p.rotation).squaredNorm()
                    + 0.5 * model.volume_weight() * (f - p.volume).squaredNorm()
                    + 0.5 * model.strain_limit_weight() * (f - p.limit).squaredNorm());
            const Eigen::JacobiSVD<Mat3> svd(f - p.rotation);
            EXPECT_NEAR(strain(e), svd.singularValues()(0), 1e-9) << e;
            max_strain = std::max(max_strain, svd.singularValues()(0));
        }
        EXPECT_GT(model.strain_limit_weight(), 0.0);
        EXPECT_NEAR(measures.elastic, energy, 1e-9 * energy);
        EXPECT_NEAR(measures.max_strain, max_strain, 1e-9);
    }

} // namespace
} // namespace mat
