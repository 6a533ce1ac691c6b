// Primitive-pair tests on degenerate families against the brute-force reference
// (primitive_pair_reference.hpp): identical primitives, parallel, coaxial and nearly parallel
// cones, touching spheres and tangent primitives, nesting, zero radii (segments, triangles),
// collinear or coincident slab centers, zero-length cones, swallowed spheres, equal radii.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"
#include "runtime/collision/primitive_pair.hpp"
#include "tests/runtime/collision/primitive_pair_reference.hpp"

namespace mat::test {
namespace {

    TEST(PrimitivePair, IdenticalPrimitivesOverlapByTheLargestDiameter)
    {
        Rng rng(3);
        for (int n = 0; n < 300 / k_fewer; ++n) {
            const Primitive a = transformed(
                random_primitive(rng.integer(1, 3), rng, 1.0, 0.6), 1.0, 3.0 * rng.box());
            const double max_radius = *std::max_element(a.radii.begin(), a.radii.begin() + a.count);
            const std::string failure = check_against_brute_force(a, a, -2.0 * max_radius);
            ASSERT_TRUE(failure.empty()) << failure;
            EXPECT_TRUE(primitives_intersect(a, a));
        }
    }

    // ---- degenerate families ----

    TEST(PrimitivePair, ParallelAndCoaxialCones)
    {
        Rng rng(4);
        for (int n = 0; n < 150 / k_fewer; ++n) {
            const Vec3 u = rng.unit();
            const Vec3 side = u.cross(rng.unit()).normalized();
            const Vec3 origin = rng.box();
            const double length_a = rng.uniform(0.0, 2.0), length_b = rng.uniform(0.0, 2.0);
            const double along = rng.uniform(-2.5, 2.5);
            const double across = n % 3 == 0 ? 0.0 : rng.uniform(0.0, 1.5); // 0: coaxial
            const double direction = n % 2 == 0 ? 1.0 : -1.0; // parallel or antiparallel
            const bool capsules = n % 5 < 2;
            const double r = rng.uniform(0.0, 0.6);
            const Primitive a = Primitive::cone(origin, capsules ? r : rng.uniform(0.0, 0.6),
                origin + length_a * u, capsules ? r : rng.uniform(0.0, 0.6));
            const Vec3 start = origin + along * u + across * side;
            const Primitive b = Primitive::cone(start, capsules ? r : rng.uniform(0.0, 0.6),
                start + direction * length_b * u, capsules ? r : rng.uniform(0.0, 0.6));
            // Equal-radius capsules whose axes overlap along u are apart by `across`.
            double exact_g = k_infinity;
            const double lo_b = std::min(along, along + direction * length_b);
            const double hi_b = std::max(along, along + direction * length_b);
            if (capsules && lo_b <= length_a && hi_b >= 0.0)
                exact_g = across - 2.0 * r;
            const std::string failure = check_against_brute_force(a, b, exact_g);
            ASSERT_TRUE(failure.empty()) << "#" << n << failure;
        }
    }

    TEST(PrimitivePair, NearlyParallelCones)
    {
        Rng rng(5);
        for (const double angle : { 1e-15, 1e-12, 1e-9, 1e-6, 1e-3 })
            for (int n = 0; n < 30 / k_fewer; ++n) {
                const Vec3 u = rng.unit();
                const Vec3 side = u.cross(rng.unit()).normalized();
                const Vec3 origin = rng.box();
                const Vec3 v = std::cos(angle) * u + std::sin(angle) * side;
                const Vec3 start = origin + rng.uniform(-1.0, 1.0) * u
                    + (n % 2 ? 0.0 : rng.uniform(0.0, 1.0)) * side;
                const bool capsules = n % 3 == 0;
                const double r = rng.uniform(0.0, 0.5);
                const Primitive a = Primitive::cone(origin, capsules ? r : rng.uniform(0, 0.5),
                    origin + rng.uniform(0.2, 2.0) * u, capsules ? r : rng.uniform(0, 0.5));
                const Primitive b = Primitive::cone(start, capsules ? r : rng.uniform(0, 0.5),
                    start + rng.uniform(0.2, 2.0) * v, capsules ? r : rng.uniform(0, 0.5));
                const std::string failure = check_against_brute_force(a, b);
                ASSERT_TRUE(failure.empty()) << "angle " << angle << " #" << n << failure;
            }
    }

    TEST(PrimitivePair, TouchingSpheresAndTangentPrimitivesIntersect)
    {
        Rng rng(6);
        for (int n = 0; n < 500; ++n) {
            const Vec3 u = rng.unit();
            const double ra = rng.uniform(0.0, 1.0), rb = rng.uniform(0.0, 1.0);
            const Vec3 ca = rng.box();
            // Touching up to rounding: reported as intersecting, depth ~ 0.
            const Primitive a = Primitive::sphere(ca, ra);
            const Primitive b = Primitive::sphere(ca + (ra + rb) * u, rb);
            EXPECT_TRUE(primitives_intersect(a, b));
            EXPECT_NEAR(deepest_penetration(a, b).depth, 0.0, 1e-14 * pair_size(a, b));
            // Apart by 1e-9: not intersecting, depth -1e-9.
            const Primitive c = Primitive::sphere(ca + (ra + rb + 1e-9) * u, rb);
            EXPECT_FALSE(primitives_intersect(a, c));
            EXPECT_NEAR(deepest_penetration(a, c).depth, -1e-9, 1e-14 * pair_size(a, c));
        }
        for (int n = 0; n < 200; ++n) {
            // A sphere touching the side of a capsule, a capsule lying on a flat slab.
            const Vec3 u = rng.unit();
            const Vec3 side = u.cross(rng.unit()).normalized();
            const double r = rng.uniform(0.05, 0.5), rs = rng.uniform(0.0, 0.5);
            const Vec3 o = rng.box();
            const Primitive capsule = Primitive::cone(o, r, o + u, r);
            const Primitive sphere
                = Primitive::sphere(o + rng.uniform(0.0, 1.0) * u + (r + rs) * side, rs);
            EXPECT_TRUE(primitives_intersect(capsule, sphere));
            const Vec3 w = u.cross(side);
            const Primitive slab = Primitive::slab(o, rs, o + u, rs, o + w, rs);
            const Vec3 foot = o + 0.25 * u + 0.25 * w + (r + rs) * side;
            const Primitive lying = Primitive::cone(foot, r, foot + 0.5 * (u - w), r);
            EXPECT_TRUE(primitives_intersect(slab, lying));
            EXPECT_NEAR(
                deepest_penetration(slab, lying).depth, 0.0, 1e-14 * pair_size(slab, lying));
            const std::string failure = check_against_brute_force(slab, lying);
            ASSERT_TRUE(failure.empty()) << failure;
        }
    }

    TEST(PrimitivePair, OnePrimitiveInsideAnother)
    {
        Rng rng(8);
        for (int n = 0; n < 150 / k_fewer; ++n) {
            // A big primitive, and a small one around a point of its medial part.
            const int count_big = rng.integer(2, 3), count_small = rng.integer(1, 3);
            Primitive big = random_primitive(count_big, rng, 1.0, 0.1);
            for (int i = 0; i < big.count; ++i)
                big.radii[i] += 0.8;
            const Weights w = { rng.uniform(), rng.uniform(), rng.uniform() };
            Vec3 inside = Vec3::Zero();
            double sum = 0.0;
            for (int i = 0; i < big.count; ++i)
                sum += w[i];
            for (int i = 0; i < big.count; ++i)
                inside += w[i] / sum * big.centers[i];
            const Primitive small
                = transformed(random_primitive(count_small, rng, 0.1, 0.1), 1.0, inside);
            const std::string failure = check_against_brute_force(big, small);
            ASSERT_TRUE(failure.empty()) << failure;
            EXPECT_TRUE(primitives_intersect(small, big));
            EXPECT_GT(deepest_penetration(small, big).depth, 0.6);
        }
    }

    TEST(PrimitivePair, ZeroRadiiSegmentsAndTriangles)
    {
        // Crossing segments at height z: the separation is |z|.
        for (const double z : { 0.0, 1e-12, 0.5, -2.0 }) {
            const Primitive a = Primitive::cone(Vec3(-1, 0, 0), 0.0, Vec3(1, 0, 0), 0.0);
            const Primitive b = Primitive::cone(Vec3(0.3, -1, z), 0.0, Vec3(0.3, 2, z), 0.0);
            EXPECT_NEAR(deepest_penetration(a, b).depth, -std::abs(z), 1e-15);
            EXPECT_EQ(primitives_intersect(a, b), z == 0.0);
        }
        // A segment piercing a triangle, and one lying in its plane across it.
        const Primitive triangle
            = Primitive::slab(Vec3(0, 0, 0), 0.0, Vec3(1, 0, 0), 0.0, Vec3(0, 1, 0), 0.0);
        const Primitive piercing = Primitive::cone(Vec3(0.2, 0.3, -1), 0.0, Vec3(0.3, 0.2, 1), 0.0);
        EXPECT_TRUE(primitives_intersect(triangle, piercing));
        EXPECT_NEAR(deepest_penetration(triangle, piercing).depth, 0.0, 1e-15);
        const Primitive in_plane = Primitive::cone(Vec3(-1, 0.3, 0), 0.0, Vec3(2, 0.2, 0), 0.0);
        EXPECT_TRUE(primitives_intersect(in_plane, triangle));
        EXPECT_NEAR(deepest_penetration(in_plane, triangle).depth, 0.0, 1e-15);
        const Primitive above = Primitive::cone(Vec3(0.2, 0.3, 0.1), 0.0, Vec3(0.3, 0.2, 1), 0.0);
        EXPECT_FALSE(primitives_intersect(triangle, above));
        EXPECT_NEAR(deepest_penetration(triangle, above).depth, -0.1, 1e-15);

        Rng rng(9);
        for (int n = 0; n < 300 / k_fewer; ++n) {
            auto [a, b] = random_pair(rng.integer(2, 3), rng.integer(1, 3), rng);
            for (int i = 0; i < 3; ++i)
                a.radii[i] = b.radii[i] = 0.0;
            const std::string failure = check_against_brute_force(a, b);
            ASSERT_TRUE(failure.empty()) << failure;
        }
    }

    TEST(PrimitivePair, DegenerateSlabsAndCones)
    {
        // Slabs whose centers are collinear or coincide, cones of zero length, flat radii.
        Rng rng(10);
        for (int n = 0; n < 400 / k_fewer; ++n) {
            auto [a, b] = random_pair(3, rng.integer(1, 3), rng);
            const int mode = n % 4;
            if (mode == 0) // the third center on the line of the first two
                a.centers[2]
                    = a.centers[0] + rng.uniform(-0.5, 1.5) * (a.centers[1] - a.centers[0]);
            if (mode == 1) // two coincident centers
                a.centers[2] = a.centers[1];
            if (mode == 2) // all centers coincide: the largest ball
                a.centers[1] = a.centers[2] = a.centers[0];
            if (mode == 3) // both collinear, along the same line
                for (Primitive* p : { &a, &b })
                    for (int i = 1; i < p->count; ++i)
                        p->centers[i] = a.centers[0] + rng.uniform(-1.0, 1.0) * Vec3(1, 2, 3);
            if (b.count >= 2 && rng.uniform() < 0.3) // a zero-length cone or edge
                b.centers[1] = b.centers[0];
            const std::string failure = check_against_brute_force(a, b);
            ASSERT_TRUE(failure.empty()) << "mode " << mode << failure;
        }
    }

    TEST(PrimitivePair, SwallowedSpheresAndEqualRadii)
    {
        // Cones and slabs where one ball contains the others (|c_i - c_j| <= |r_i - r_j|), and
        // primitives with all radii equal.
        Rng rng(11);
        for (int n = 0; n < 200 / k_fewer; ++n) {
            auto [a, b] = random_pair(rng.integer(2, 3), rng.integer(2, 3), rng);
            if (n % 2 == 0) {
                a.radii[0] = 1.0;
                for (int i = 1; i < a.count; ++i)
                    a.centers[i] = a.centers[0] + rng.uniform(0.0, 0.5) * rng.unit();
            } else {
                for (Primitive* p : { &a, &b })
                    for (int i = 1; i < p->count; ++i)
                        p->radii[i] = p->radii[0];
            }
            const std::string failure = check_against_brute_force(a, b);
            ASSERT_TRUE(failure.empty()) << failure;
        }
    }

} // namespace
} // namespace mat::test
