// Pin motion: the XYZ Euler convention, keyframe interpolation and holding, rotation about the
// region's centroid.

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "runtime/scene/pin_motion.hpp"

namespace mat {
namespace {

    constexpr double tolerance = 1e-12;

    PinKeyframe keyframe(double time, const Vec3& translation, const Vec3& rotation_degrees)
    {
        PinKeyframe key;
        key.time = time;
        key.translation = translation;
        key.rotation_degrees = rotation_degrees;
        return key;
    }

    TEST(PinMotion, EulerAnglesRotateAboutXThenYThenZ)
    {
        // Single axes, right-handed.
        EXPECT_TRUE(rotation_from_euler_degrees(Vec3(90, 0, 0))
                        .isApprox(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix(),
                            tolerance));
        EXPECT_LT(
            (rotation_from_euler_degrees(Vec3(0, 0, 90)) * Vec3::UnitX() - Vec3::UnitY()).norm(),
            tolerance);
        // x first: y -> z; then y: z -> x. The other order would give y -> -z... not x.
        EXPECT_LT(
            (rotation_from_euler_degrees(Vec3(90, 90, 0)) * Vec3::UnitY() - Vec3::UnitX()).norm(),
            tolerance);
        // y first: x -> -z; then z: -z stays. (z first would give x -> y -> y.)
        EXPECT_LT(
            (rotation_from_euler_degrees(Vec3(0, 90, 90)) * Vec3::UnitX() + Vec3::UnitZ()).norm(),
            tolerance);
        // Always a rotation.
        std::mt19937 random(7);
        std::uniform_real_distribution<double> angle(-360.0, 360.0);
        for (int trial = 0; trial < 20; ++trial) {
            const Mat3 r
                = rotation_from_euler_degrees(Vec3(angle(random), angle(random), angle(random)));
            EXPECT_LT((r.transpose() * r - Mat3::Identity()).norm(), tolerance);
            EXPECT_NEAR(r.determinant(), 1.0, tolerance);
        }
    }

    TEST(PinMotion, NoKeyframesIsIdentity)
    {
        const PinTransform transform = pin_motion_at(PinRegion {}, 3.0, Vec3(1, 2, 3));
        EXPECT_EQ(transform.rotation, Mat3::Identity());
        EXPECT_EQ(transform.translation, Vec3::Zero());
    }

    TEST(PinMotion, KeyframesInterpolateAndHold)
    {
        PinRegion region;
        region.motion = { keyframe(1.0, Vec3(0, 0, 0), Vec3(0, 0, 0)),
            keyframe(2.0, Vec3(2, 0, 0), Vec3(0, 0, 90)),
            keyframe(4.0, Vec3(2, 4, 0), Vec3(0, 0, 90)) };
        const Vec3 centroid(1, 1, 0);
        const Vec3 x(2, 1, 0); // one unit from the centroid along x

        // Before the first keyframe: the first (here, rest).
        for (double t : { -1.0, 0.0, 1.0 }) {
            const PinTransform at = pin_motion_at(region, t, centroid);
            EXPECT_LT((at.apply(x) - x).norm(), tolerance) << t;
        }
        // Halfway through the first segment: translation (1, 0, 0), 45 degrees about z around
        // the centroid.
        const PinTransform half = pin_motion_at(region, 1.5, centroid);
        const Vec3 expected = centroid + Vec3(1, 0, 0) + Vec3(std::sqrt(0.5), std::sqrt(0.5), 0);
        EXPECT_LT((half.apply(x) - expected).norm(), tolerance);
        // The centroid itself only translates.
        EXPECT_LT((half.apply(centroid) - (centroid + Vec3(1, 0, 0))).norm(), tolerance);
        // A quarter into the second segment: rotation held at 90 degrees, translation (2, 1, 0).
        const PinTransform second = pin_motion_at(region, 2.5, centroid);
        EXPECT_LT((second.apply(x) - (centroid + Vec3(2, 1, 0) + Vec3(0, 1, 0))).norm(), tolerance);
        // After the last keyframe: the last holds.
        for (double t : { 4.0, 10.0 }) {
            const PinTransform at = pin_motion_at(region, t, centroid);
            EXPECT_LT((at.apply(x) - (centroid + Vec3(2, 4, 0) + Vec3(0, 1, 0))).norm(), tolerance);
        }
        // At a keyframe exactly: that keyframe.
        EXPECT_LT((pin_motion_at(region, 2.0, centroid).apply(x)
                      - (centroid + Vec3(2, 0, 0) + Vec3(0, 1, 0)))
                      .norm(),
            tolerance);
    }

    TEST(PinMotion, ApplyToRowsMatchesApply)
    {
        PinRegion region;
        region.motion = { keyframe(0.0, Vec3(1, 2, 3), Vec3(10, 20, 30)) };
        const PinTransform transform = pin_motion_at(region, 0.5, Vec3(0.5, -1, 2));
        MatX3 positions(3, 3);
        positions << 0, 0, 0, 1, 2, 3, -4, 5, 0.5;
        const MatX3 moved = apply_pin_transform(transform, positions);
        ASSERT_EQ(moved.rows(), 3);
        for (int i = 0; i < 3; ++i)
            EXPECT_LT(
                (moved.row(i).transpose() - transform.apply(positions.row(i).transpose())).norm(),
                tolerance);
        // Rigid: distances are kept.
        EXPECT_NEAR((moved.row(1) - moved.row(2)).norm(),
            (positions.row(1) - positions.row(2)).norm(), tolerance);
    }

} // namespace
} // namespace mat
