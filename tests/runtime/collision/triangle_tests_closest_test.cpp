// The closest-point queries of triangle_tests.hpp (vertex-triangle, edge-edge) against dense
// sampling and hand-made cases of each Voronoi region.

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "runtime/collision/triangle_tests.hpp"

namespace mat {
namespace {

    TEST(PointTriangleClosest, AgainstDenseSampling)
    {
        std::mt19937 rng(21);
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        const int steps = 200;
        for (int trial = 0; trial < 60; ++trial) {
            std::array<Vec3, 3> t;
            for (auto& p : t)
                p = Vec3(u(rng), u(rng), u(rng));
            if (trial % 10 == 9)
                t[2] = t[0] + 0.3 * (t[1] - t[0]); // degenerate: collinear
            const Vec3 p = 1.5 * Vec3(u(rng), u(rng), u(rng));
            const PointTriangleClosest c = point_triangle_closest(p, t[0], t[1], t[2]);
            EXPECT_NEAR(c.barycentric.sum(), 1.0, 1e-12);
            EXPECT_GE(c.barycentric.minCoeff(), -1e-12);
            EXPECT_LT((c.barycentric[0] * t[0] + c.barycentric[1] * t[1] + c.barycentric[2] * t[2]
                          - c.point)
                          .norm(),
                1e-12);
            EXPECT_NEAR(c.squared_distance, (p - c.point).squaredNorm(), 1e-12);
            double best = 1e300;
            for (int i = 0; i <= steps; ++i)
                for (int j = 0; i + j <= steps; ++j) {
                    const double s = double(i) / steps, r = double(j) / steps;
                    best = std::min(best, (p - ((1 - s - r) * t[0] + s * t[1] + r * t[2])).norm());
                }
            const double distance = std::sqrt(c.squared_distance);
            // No sample is closer, and the closest sample is within the sampling step.
            EXPECT_LE(distance, best + 1e-12) << "trial " << trial;
            EXPECT_GE(distance, best - 4.0 / steps) << "trial " << trial;
        }
        // Each Voronoi region of a right triangle, by hand.
        const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
        EXPECT_EQ(point_triangle_closest(Vec3(-1, -1, 2), a, b, c).point, a);
        EXPECT_EQ(point_triangle_closest(Vec3(2, -1, 0), a, b, c).point, b);
        EXPECT_EQ(point_triangle_closest(Vec3(-1, 3, 0), a, b, c).point, c);
        EXPECT_TRUE(
            point_triangle_closest(Vec3(0.5, -1, 1), a, b, c).point.isApprox(Vec3(0.5, 0, 0)));
        EXPECT_TRUE(
            point_triangle_closest(Vec3(-1, 0.25, 0), a, b, c).point.isApprox(Vec3(0, 0.25, 0)));
        EXPECT_TRUE(
            point_triangle_closest(Vec3(1, 1, 0), a, b, c).point.isApprox(Vec3(0.5, 0.5, 0)));
        const PointTriangleClosest face = point_triangle_closest(Vec3(0.25, 0.25, -3), a, b, c);
        EXPECT_TRUE(face.point.isApprox(Vec3(0.25, 0.25, 0)));
        EXPECT_NEAR(face.squared_distance, 9.0, 1e-12);
        // A triangle collapsed to a point.
        EXPECT_NEAR(point_triangle_closest(Vec3(0, 0, 2), b, b, b).squared_distance, 5.0, 1e-12);
    }

    TEST(SegmentSegmentClosest, AgainstDenseSampling)
    {
        std::mt19937 rng(22);
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        const int steps = 400;
        for (int trial = 0; trial < 60; ++trial) {
            Vec3 a0(u(rng), u(rng), u(rng)), a1(u(rng), u(rng), u(rng));
            Vec3 b0(u(rng), u(rng), u(rng)), b1(u(rng), u(rng), u(rng));
            if (trial % 6 == 1)
                b1 = b0 + 0.7 * (a1 - a0); // parallel
            if (trial % 6 == 2)
                a1 = a0; // a point
            if (trial % 6 == 3)
                b1 = b0 + (a1 - a0) * 1e-9 + Vec3(0, 0, 1e-12); // tiny, nearly parallel
            const SegmentSegmentClosest c = segment_segment_closest(a0, a1, b0, b1);
            EXPECT_GE(c.s, 0.0);
            EXPECT_LE(c.s, 1.0);
            EXPECT_GE(c.t, 0.0);
            EXPECT_LE(c.t, 1.0);
            EXPECT_LT((a0 + c.s * (a1 - a0) - c.point_a).norm(), 1e-12);
            EXPECT_LT((b0 + c.t * (b1 - b0) - c.point_b).norm(), 1e-12);
            // Sample one segment densely; the exact point-segment distance on the other.
            double best = 1e300;
            for (int i = 0; i <= steps; ++i) {
                const Vec3 p = a0 + (double(i) / steps) * (a1 - a0);
                const Vec3 d = b1 - b0;
                const double t = d.squaredNorm() > 0
                    ? std::clamp((p - b0).dot(d) / d.squaredNorm(), 0.0, 1.0)
                    : 0.0;
                best = std::min(best, (p - (b0 + t * d)).norm());
            }
            const double distance = std::sqrt(c.squared_distance);
            EXPECT_LE(distance, best + 1e-12) << "trial " << trial;
            EXPECT_GE(distance, best - 4.0 / steps) << "trial " << trial;
        }
        // Crossing segments meet; parallel overlapping segments are at their gap.
        EXPECT_NEAR(
            segment_segment_closest(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 0), Vec3(0, 1, 0))
                .squared_distance,
            0.0, 1e-30);
        const SegmentSegmentClosest parallel = segment_segment_closest(
            Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(1, 0.5, 0), Vec3(3, 0.5, 0));
        EXPECT_NEAR(parallel.squared_distance, 0.25, 1e-15);
    }

} // namespace
} // namespace mat
