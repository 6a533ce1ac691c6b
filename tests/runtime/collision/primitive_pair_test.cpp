// Primitive-pair tests: random pairs of every kind against the brute-force reference
// (primitive_pair_reference.hpp), tiny and huge scales, pairs a hair apart or overlapping,
// closed forms (sphere against sphere, against a cone or slab through the library's exact point
// distance), bad input.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <fmt/format.h>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"
#include "runtime/collision/primitive_pair.hpp"
#include "tests/runtime/collision/primitive_pair_reference.hpp"

namespace mat::test {
namespace {

    // ---- random pairs of every kind ----

    TEST(PrimitivePair, RandomPairsOfEveryKindMatchBruteForce)
    {
        Rng rng(20240611);
        const int pairs = 400 / k_fewer;
        int hits = 0, total = 0;
        for (int count_a = 1; count_a <= 3; ++count_a)
            for (int count_b = count_a; count_b <= 3; ++count_b)
                for (int n = 0; n < pairs; ++n) {
                    const auto [a, b] = random_pair(count_a, count_b, rng);
                    SCOPED_TRACE(std::string(kind_name(count_a)) + "-" + kind_name(count_b) + " #"
                        + std::to_string(n));
                    const std::string failure = check_against_brute_force(a, b);
                    ASSERT_TRUE(failure.empty()) << failure;
                    hits += primitives_intersect(a, b);
                    ++total;
                }
        // Both outcomes are well represented.
        EXPECT_GT(hits, total / 5);
        EXPECT_LT(hits, 4 * total / 5);
    }

    TEST(PrimitivePair, TinyAndHugeScales)
    {
        Rng rng(7);
        for (const double scale : { 1e-7, 1e-3, 1e3, 1e7 })
            for (int count_a = 1; count_a <= 3; ++count_a)
                for (int count_b = 1; count_b <= 3; ++count_b)
                    for (int n = 0; n < 12 / k_fewer + 1; ++n) {
                        const auto [a0, b0] = random_pair(count_a, count_b, rng);
                        const Vec3 shift = scale * rng.box();
                        const Primitive a = transformed(a0, scale, shift);
                        const Primitive b = transformed(b0, scale, shift);
                        SCOPED_TRACE(fmt::format("scale {:g}", scale));
                        const std::string failure = check_against_brute_force(a, b);
                        ASSERT_TRUE(failure.empty()) << failure;
                        // Same decision as at unit scale, depth scaled.
                        EXPECT_NEAR(deepest_penetration(a, b).depth,
                            scale * deepest_penetration(a0, b0).depth, 1e-11 * pair_size(a, b));
                    }
    }

    TEST(PrimitivePair, NearlyTouchingPairsOfEveryKind)
    {
        // Moving b along the normal by t changes the distance between separated convex volumes
        // by exactly t: place b at separations of +-1e-6 and +-1e-10 and 0 (x size).
        Rng rng(12);
        for (int count_a = 1; count_a <= 3; ++count_a)
            for (int count_b = 1; count_b <= 3; ++count_b)
                for (int n = 0; n < 20 / k_fewer + 1; ++n) {
                    auto [a, b0] = random_pair(count_a, count_b, rng);
                    // Radii > 0: zero-radius volumes (points, segments) may pass each other.
                    for (int i = 0; i < 3; ++i) {
                        a.radii[i] += 0.05;
                        b0.radii[i] += 0.05;
                    }
                    const Primitive far = transformed(b0, 1.0, 4.0 * rng.unit());
                    const PrimitivePenetration apart = deepest_penetration(a, far);
                    ASSERT_LT(apart.depth, 0.0);
                    const double size = pair_size(a, far);
                    for (const double gap : { 1e-6, 1e-10, 0.0, -1e-10, -1e-6 }) {
                        const Primitive b
                            = transformed(far, 1.0, (-apart.depth - gap * size) * apart.normal);
                        SCOPED_TRACE(std::string(kind_name(count_a)) + "-" + kind_name(count_b)
                            + fmt::format(" gap {:g}", gap));
                        const bool hit = primitives_intersect(a, b);
                        if (gap != 0.0)
                            EXPECT_EQ(hit, gap < 0.0);
                        else
                            EXPECT_TRUE(hit);
                        const std::string failure = check_against_brute_force(a, b);
                        ASSERT_TRUE(failure.empty()) << failure;
                    }
                }
    }

    // ---- closed forms ----

    TEST(PrimitivePair, SphereAgainstSphereIsTheClosedForm)
    {
        Rng rng(1);
        for (int n = 0; n < 2000; ++n) {
            const Primitive a = Primitive::sphere(rng.box(), rng.uniform(0.0, 0.5));
            const Primitive b = Primitive::sphere(rng.box(), rng.uniform(0.0, 0.5));
            const double distance = (a.centers[0] - b.centers[0]).norm();
            const PrimitivePenetration pen = deepest_penetration(a, b);
            EXPECT_EQ(pen.depth, a.radii[0] + b.radii[0] - distance);
            EXPECT_EQ(primitives_intersect(a, b), distance <= a.radii[0] + b.radii[0]);
        }
    }

    TEST(PrimitivePair, SphereAgainstConeOrSlabMatchesThePointDistance)
    {
        // min over t of |p - c(t)| - r(t) is the library's exact sphere_distance.
        Rng rng(2);
        for (int n = 0; n < 3000 / k_fewer; ++n) {
            const int count = rng.integer(2, 3);
            const Primitive prim = random_primitive(count, rng, 1.0, 0.6);
            const Primitive s = Primitive::sphere(1.5 * rng.box(), rng.uniform(0.0, 0.4));
            double point_distance = 0.0;
            if (count == 2) {
                point_distance
                    = MedialCone(prim.centers[0], prim.radii[0], prim.centers[1], prim.radii[1])
                          .distance(s.centers[0])
                          .sphere_distance;
            } else {
                const MedialSlab slab(MedialSphere(prim.centers[0], prim.radii[0]),
                    MedialSphere(prim.centers[1], prim.radii[1]),
                    MedialSphere(prim.centers[2], prim.radii[2]));
                point_distance = slab.distance(s.centers[0]).sphere_distance;
            }
            const double exact_g = point_distance - s.radii[0];
            const double size = pair_size(prim, s);
            const PrimitivePenetration pen = deepest_penetration(s, prim);
            ASSERT_NEAR(pen.depth, -exact_g, 1e-12 * size) << describe(s) << " " << describe(prim);
            if (std::abs(exact_g) > 1e-12 * size) {
                ASSERT_EQ(primitives_intersect(prim, s), exact_g < 0.0)
                    << describe(s) << " " << describe(prim);
            }
        }
    }

    // ---- bad input ----

    TEST(PrimitivePair, BadPrimitivesThrow)
    {
        const Primitive good = Primitive::cone(Vec3(0, 0, 0), 0.5, Vec3(1, 0, 0), 0.5);
        Primitive bad = good;
        bad.count = 4;
        EXPECT_THROW(primitives_intersect(good, bad), Error);
        bad.count = 0;
        EXPECT_THROW(deepest_penetration(bad, good), Error);
        bad = good;
        bad.radii[1] = -0.1;
        EXPECT_THROW(primitives_intersect(bad, good), Error);
        bad = good;
        bad.centers[0].x() = std::numeric_limits<double>::quiet_NaN();
        EXPECT_THROW(deepest_penetration(good, bad), Error);
        bad = good;
        bad.radii[0] = std::numeric_limits<double>::infinity();
        try {
            primitives_intersect(good, bad);
            ADD_FAILURE() << "no error";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("primitive b, sphere 0"), std::string::npos)
                << e.what();
        }
        // Data past the count is ignored.
        Primitive sphere = Primitive::sphere(Vec3(0, 0, 0), 1.0);
        sphere.radii[2] = -1.0;
        sphere.centers[1].y() = std::numeric_limits<double>::quiet_NaN();
        EXPECT_TRUE(primitives_intersect(sphere, good));
    }

} // namespace
} // namespace mat::test
