#include "runtime/collision/medial_bounds_kernels.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

namespace mat {
namespace {

    Mat3 random_matrix(std::mt19937& rng)
    {
        std::normal_distribution<double> normal;
        Mat3 m;
        for (int i = 0; i < 9; ++i)
            m.data()[i] = normal(rng);
        return m;
    }

    Mat3 random_rotation(std::mt19937& rng)
    {
        std::normal_distribution<double> normal;
        const Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
        return q.normalized().toRotationMatrix();
    }

    // Checks the bound against the (backward stable) QR eigenvalues of a PSD matrix: above it,
    // and within `tightness` (relative).
    void expect_tight_upper_bound(const Mat3& gram, double tightness)
    {
        const Eigen::SelfAdjointEigenSolver<Mat3> reference(gram, Eigen::EigenvaluesOnly);
        const double exact = reference.eigenvalues()(2);
        const double bound = largest_eigenvalue_upper_bound(gram);
        const double rounding = 8 * std::numeric_limits<double>::epsilon() * gram.norm();
        EXPECT_GE(bound, exact - rounding) << gram;
        EXPECT_LE(bound, exact * (1.0 + tightness) + rounding) << gram;
    }

    TEST(MedialBoundsKernels, LargestEigenvalueIsATightUpperBound)
    {
        std::mt19937 rng(5);
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        EXPECT_EQ(largest_eigenvalue_upper_bound(Mat3::Zero()), 0.0);
        for (int c = 0; c < 2000; ++c) {
            // Eigenvalues: generic, repeated largest (double root), rank 1 and 2, and scales far
            // from 1.
            const Mat3 rotation = random_rotation(rng);
            Vec3 values(unit(rng), unit(rng), unit(rng));
            switch (c % 5) {
            case 1:
                values(1) = values(0) = std::max(values(0), values(1));
                break;
            case 2:
                values(1) = values(2) = 0.0;
                break;
            case 3:
                values(2) = 0.0;
                break;
            case 4:
                values(2) = values(0) * (1.0 + 1e-9);
                break;
            default:
                break;
            }
            const double scale = std::pow(10.0, (c % 7) * 6 - 18); // 1e-18 ... 1e18
            const Mat3 gram = rotation * (scale * values).asDiagonal() * rotation.transpose();
            expect_tight_upper_bound(
                0.5 * (gram + gram.transpose()), c % 5 == 1 || c % 5 == 4 ? 1e-4 : 1e-7);
            const Mat3 a = random_matrix(rng);
            expect_tight_upper_bound(a * a.transpose(), 1e-7);
        }
    }

    TEST(MedialBoundsKernels, NearestRotationMatchesThePolarDecomposition)
    {
        std::mt19937 rng(9);
        std::normal_distribution<double> normal;
        for (int c = 0; c < 1000; ++c) {
            // Rotations with stretch and shear, some inverted, some nearly singular.
            Mat3 f = random_rotation(rng) * (Mat3::Identity() + 0.3 * random_matrix(rng));
            if (c % 10 == 1)
                f.col(0) = -f.col(0);
            if (c % 10 == 2)
                f.col(2) = f.col(0) + 1e-9 * f.col(1);
            const Mat3 r = nearest_rotation(f);
            EXPECT_LE((r.transpose() * r - Mat3::Identity()).norm(), 1e-14);
            EXPECT_NEAR(r.determinant(), 1.0, 1e-14);
            const Eigen::JacobiSVD<Mat3> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
            if (f.determinant() > 1e-3 * std::pow(f.norm(), 3)) {
                // The polar factor, unique for an invertible f with det > 0.
                const Mat3 polar = svd.matrixU() * svd.matrixV().transpose();
                EXPECT_LE((r - polar).norm(), 1e-9) << f;
            } else {
                // Still the maximizer of trace(R^T f) over rotations (up to rounding).
                Mat3 u = svd.matrixU();
                if ((u * svd.matrixV().transpose()).determinant() < 0)
                    u.col(2) = -u.col(2);
                const Mat3 best = u * svd.matrixV().transpose();
                EXPECT_GE((r.transpose() * f).trace(), (best.transpose() * f).trace() - 1e-9);
            }
        }
        const Mat3 rotation = random_rotation(rng);
        EXPECT_LE((nearest_rotation(rotation) - rotation).norm(), 1e-15);
        EXPECT_LE((nearest_rotation(Mat3::Zero()).transpose() * nearest_rotation(Mat3::Zero())
                      - Mat3::Identity())
                      .norm(),
            1e-15);
    }

} // namespace
} // namespace mat
