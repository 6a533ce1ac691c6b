// Triangle-level tests: the exact predicates against integer arithmetic, triangle-triangle on
// known configurations (crossing, touching, coplanar, degenerate) and against sampling on random
// pairs. The closest-point queries are in triangle_tests_closest_test.cpp.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "runtime/collision/triangle_tests.hpp"

namespace mat {
namespace {

    using Int = __int128;

    int sign(Int v)
    {
        return v > 0 ? 1 : (v < 0 ? -1 : 0);
    }

    // Exact orient3d of integer points (|coordinates| < 2^40 keeps the products in 128 bits).
    int orient3d_int(const std::array<std::int64_t, 3>& a, const std::array<std::int64_t, 3>& b,
        const std::array<std::int64_t, 3>& c, const std::array<std::int64_t, 3>& d)
    {
        Int m[3][3];
        for (int k = 0; k < 3; ++k) {
            m[0][k] = Int(a[k]) - d[k];
            m[1][k] = Int(b[k]) - d[k];
            m[2][k] = Int(c[k]) - d[k];
        }
        const Int det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        return sign(det);
    }

    Vec3 to_vec(const std::array<std::int64_t, 3>& p, double scale)
    {
        return Vec3(static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2]))
            * scale;
    }

    TEST(ExactPredicates, Orient3dMatchesIntegerArithmeticNearCoplanar)
    {
        // d = a + s (b - a) + t (c - a), half of the time nudged by a few units: products of
        // 2^30-sized differences exceed 53 bits, so a double evaluation of the exactly coplanar
        // cases is noise.
        std::mt19937_64 rng(3);
        std::uniform_int_distribution<std::int64_t> coordinate(-(1ll << 30), 1ll << 30);
        std::uniform_int_distribution<std::int64_t> weight(-8, 8);
        std::uniform_int_distribution<std::int64_t> nudge(-2, 2);
        std::bernoulli_distribution coplanar(0.5);
        int zero = 0;
        int nonzero = 0;
        int naive_wrong = 0;
        for (int trial = 0; trial < 4000; ++trial) {
            std::array<std::int64_t, 3> a, b, c, d;
            for (int k = 0; k < 3; ++k) {
                a[k] = coordinate(rng) / 8;
                b[k] = a[k] + coordinate(rng) / 16;
                c[k] = a[k] + coordinate(rng) / 16;
            }
            const std::int64_t s = weight(rng), t = weight(rng);
            const bool in_plane = coplanar(rng);
            for (int k = 0; k < 3; ++k)
                d[k] = a[k] + s * (b[k] - a[k]) + t * (c[k] - a[k]) + (in_plane ? 0 : nudge(rng));
            const int expected = orient3d_int(a, b, c, d);
            // Scaling by a power of two keeps the doubles exact and the sign unchanged.
            const double scale = std::ldexp(1.0, -20 + static_cast<int>(trial % 40));
            const Vec3 pa = to_vec(a, scale), pb = to_vec(b, scale), pc = to_vec(c, scale),
                       pd = to_vec(d, scale);
            ASSERT_EQ(orient3d(pa, pb, pc, pd), expected) << "trial " << trial;
            // Odd permutations flip the sign.
            ASSERT_EQ(orient3d(pb, pa, pc, pd), -expected) << "trial " << trial;
            ASSERT_EQ(orient3d(pa, pb, pd, pc), -expected) << "trial " << trial;
            (expected == 0 ? zero : nonzero)++;
            const double naive = (pa - pd).dot((pb - pd).cross(pc - pd));
            naive_wrong += (naive > 0) - (naive < 0) != expected;
        }
        EXPECT_GT(zero, 100);
        EXPECT_GT(nonzero, 1000);
        // The cases are hard: a plain double evaluation gets many of them wrong.
        EXPECT_GT(naive_wrong, 100);
    }

    TEST(ExactPredicates, Orient2dMatchesIntegerArithmeticNearCollinear)
    {
        std::mt19937_64 rng(4);
        std::uniform_int_distribution<std::int64_t> coordinate(-(1ll << 40), 1ll << 40);
        std::uniform_int_distribution<std::int64_t> weight(-1000, 1000);
        std::uniform_int_distribution<std::int64_t> nudge(-1, 1);
        for (int trial = 0; trial < 4000; ++trial) {
            const std::int64_t ax = coordinate(rng), ay = coordinate(rng);
            const std::int64_t bx = ax + coordinate(rng) / 4096, by = ay + coordinate(rng) / 4096;
            const std::int64_t w = weight(rng);
            const std::int64_t cx = ax + w * (bx - ax) / 64 + nudge(rng);
            const std::int64_t cy = ay + w * (by - ay) / 64 + nudge(rng);
            const Int det = (Int(bx) - ax) * (Int(cy) - ay) - (Int(by) - ay) * (Int(cx) - ax);
            const Vec2 a(static_cast<double>(ax), static_cast<double>(ay));
            const Vec2 b(static_cast<double>(bx), static_cast<double>(by));
            const Vec2 c(static_cast<double>(cx), static_cast<double>(cy));
            ASSERT_EQ(orient2d(a, b, c), sign(det)) << "trial " << trial;
            ASSERT_EQ(orient2d(b, a, c), -sign(det)) << "trial " << trial;
        }
    }

    // Both argument orders and all 36 corner orders (rotations and reflections of each
    // triangle) must agree: the answer is a property of the two point sets.
    bool intersect_checked(const std::array<Vec3, 3>& a, const std::array<Vec3, 3>& b)
    {
        const bool result = triangles_intersect(a[0], a[1], a[2], b[0], b[1], b[2]);
        static const int perms[6][3]
            = { { 0, 1, 2 }, { 1, 2, 0 }, { 2, 0, 1 }, { 1, 0, 2 }, { 0, 2, 1 }, { 2, 1, 0 } };
        for (const auto& p : perms)
            for (const auto& q : perms) {
                EXPECT_EQ(triangles_intersect(a[p[0]], a[p[1]], a[p[2]], b[q[0]], b[q[1]], b[q[2]]),
                    result);
                EXPECT_EQ(triangles_intersect(b[q[0]], b[q[1]], b[q[2]], a[p[0]], a[p[1]], a[p[2]]),
                    result);
            }
        return result;
    }

    const std::array<Vec3, 3> base
        = { Vec3(0.0, 0.0, 0.0), Vec3(4.0, 0.0, 0.0), Vec3(0.0, 4.0, 0.0) };

    TEST(TrianglesIntersect, KnownConfigurations)
    {
        // Crossing: a vertical triangle through the middle of the base.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(1.0, 1.0, -1.0), Vec3(1.0, 1.0, 1.0), Vec3(2.0, 1.0, 1.0) }));
        // The same, lifted clear of the plane.
        EXPECT_FALSE(intersect_checked(
            base, { Vec3(1.0, 1.0, 0.5), Vec3(1.0, 1.0, 1.0), Vec3(2.0, 1.0, 1.0) }));
        // Crossing the plane outside the base (past the hypotenuse).
        EXPECT_FALSE(intersect_checked(
            base, { Vec3(3.0, 3.0, -1.0), Vec3(3.0, 3.0, 1.0), Vec3(4.0, 3.0, 1.0) }));
        // A vertex touching the interior of the base.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(1.0, 1.0, 0.0), Vec3(1.0, 1.0, 1.0), Vec3(2.0, 1.0, 1.0) }));
        // A vertex touching the hypotenuse exactly (2 + 2 = 4), and just off it.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(2.0, 2.0, 0.0), Vec3(2.0, 2.0, 1.0), Vec3(3.0, 2.0, 1.0) }));
        EXPECT_FALSE(intersect_checked(base,
            { Vec3(2.0, std::nextafter(2.0, 3.0), 0.0), Vec3(2.0, 2.0, 1.0),
                Vec3(3.0, 2.0, 1.0) }));
        // Vertex on vertex.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(4.0, 0.0, 0.0), Vec3(5.0, 1.0, 1.0), Vec3(5.0, -1.0, 1.0) }));
        // An edge lying on the base's plane, inside it; and the edge along the base's edge.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(1.0, 1.0, 0.0), Vec3(2.0, 1.0, 0.0), Vec3(1.0, 1.0, 2.0) }));
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(1.0, 0.0, 0.0), Vec3(2.0, 0.0, 0.0), Vec3(1.0, -1.0, 2.0) }));
        // Edge-edge contact of two non-coplanar triangles: the edge (2,-1,0)-(2,1,0) crosses
        // the base's edge y = 0 at (2, 0, 0); the rest is below y = 0 or above z = 0.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(2.0, -1.0, 0.0), Vec3(2.0, 1.0, 0.0), Vec3(2.0, -1.0, 1.0) }));
        // Coplanar: overlapping, one inside the other, sharing an edge segment, a corner, and
        // disjoint.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(1.0, 1.0, 0.0), Vec3(5.0, 1.0, 0.0), Vec3(1.0, 5.0, 0.0) }));
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(0.5, 0.5, 0.0), Vec3(1.0, 0.5, 0.0), Vec3(0.5, 1.0, 0.0) }));
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(1.0, 0.0, 0.0), Vec3(3.0, 0.0, 0.0), Vec3(2.0, -2.0, 0.0) }));
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(4.0, 0.0, 0.0), Vec3(6.0, 0.0, 0.0), Vec3(5.0, -2.0, 0.0) }));
        EXPECT_FALSE(intersect_checked(
            base, { Vec3(3.0, 3.0, 0.0), Vec3(5.0, 3.0, 0.0), Vec3(3.0, 5.0, 0.0) }));
        EXPECT_FALSE(intersect_checked(
            base, { Vec3(0.0, -0.5, 0.0), Vec3(4.0, -0.5, 0.0), Vec3(2.0, -2.0, 0.0) }));
        // Coplanar in a tilted plane, star of David: no vertex inside the other, edges cross.
        const Vec3 u(1.0, 2.0, 3.0), v(-2.0, 1.0, 0.5), o(0.25, -1.0, 2.0);
        const auto plane = [&](double s, double t) -> Vec3 { return o + s * u + t * v; };
        EXPECT_TRUE(intersect_checked(
            { plane(0, 0), plane(6, 0), plane(3, 6) }, { plane(0, 4), plane(6, 4), plane(3, -2) }));
    }

    TEST(TrianglesIntersect, DegenerateTriangles)
    {
        // A segment (collinear triangle) piercing the base, and one missing it.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(1.0, 1.0, -1.0), Vec3(1.0, 1.0, 0.0), Vec3(1.0, 1.0, 2.0) }));
        EXPECT_FALSE(intersect_checked(
            base, { Vec3(3.0, 3.0, -1.0), Vec3(3.0, 3.0, 0.0), Vec3(3.0, 3.0, 2.0) }));
        // A segment in the base's plane, crossing its edge from outside.
        EXPECT_TRUE(intersect_checked(
            base, { Vec3(-1.0, 1.0, 0.0), Vec3(0.5, 1.0, 0.0), Vec3(1.0, 1.0, 0.0) }));
        // A point (all three corners equal) inside, on the boundary, outside.
        const Vec3 in(1.0, 1.0, 0.0), on(2.0, 2.0, 0.0), out(2.0, 2.0, 1e-300);
        EXPECT_TRUE(intersect_checked(base, { in, in, in }));
        EXPECT_TRUE(intersect_checked(base, { on, on, on }));
        EXPECT_FALSE(intersect_checked(base, { out, out, out }));
        // Two degenerate triangles: crossing segments, skew segments, collinear overlapping,
        // collinear disjoint, a point on a segment, and two equal points.
        const auto seg = [](const Vec3& a, const Vec3& b) -> std::array<Vec3, 3> {
            return { a, 0.5 * (a + b), b };
        };
        EXPECT_TRUE(intersect_checked(
            seg(Vec3(0, 0, 0), Vec3(2, 2, 2)), seg(Vec3(2, 0, 0), Vec3(0, 2, 2))));
        EXPECT_FALSE(intersect_checked(
            seg(Vec3(0, 0, 0), Vec3(2, 2, 0)), seg(Vec3(2, 0, 1), Vec3(0, 2, 1))));
        EXPECT_TRUE(intersect_checked(
            seg(Vec3(0, 0, 0), Vec3(2, 4, 6)), seg(Vec3(1, 2, 3), Vec3(3, 6, 9))));
        EXPECT_FALSE(intersect_checked(
            seg(Vec3(0, 0, 0), Vec3(1, 2, 3)), seg(Vec3(1.5, 3, 4.5), Vec3(3, 6, 9))));
        EXPECT_TRUE(intersect_checked(
            seg(Vec3(0, 0, 0), Vec3(2, 4, 6)), { Vec3(1, 2, 3), Vec3(1, 2, 3), Vec3(1, 2, 3) }));
        EXPECT_TRUE(intersect_checked({ Vec3(1, 2, 3), Vec3(1, 2, 3), Vec3(1, 2, 3) },
            { Vec3(1, 2, 3), Vec3(1, 2, 3), Vec3(1, 2, 3) }));
        EXPECT_FALSE(intersect_checked({ Vec3(1, 2, 3), Vec3(1, 2, 3), Vec3(1, 2, 3) },
            { Vec3(1, 2, 4), Vec3(1, 2, 4), Vec3(1, 2, 4) }));
    }

    // Exactly coplanar random triangles in a tilted plane (integer combinations of integer
    // vectors), against an integer 2D test in the plane's own coordinates.
    int orient2d_int(const std::array<std::int64_t, 2>& a, const std::array<std::int64_t, 2>& b,
        const std::array<std::int64_t, 2>& c)
    {
        return sign(
            (Int(b[0]) - a[0]) * (Int(c[1]) - a[1]) - (Int(b[1]) - a[1]) * (Int(c[0]) - a[0]));
    }

    bool segments_int(const std::array<std::int64_t, 2>& a, const std::array<std::int64_t, 2>& b,
        const std::array<std::int64_t, 2>& c, const std::array<std::int64_t, 2>& d)
    {
        const auto between
            = [](const std::array<std::int64_t, 2>& p, const std::array<std::int64_t, 2>& q,
                  const std::array<std::int64_t, 2>& r) {
                  return std::min(p[0], q[0]) <= r[0] && r[0] <= std::max(p[0], q[0])
                      && std::min(p[1], q[1]) <= r[1] && r[1] <= std::max(p[1], q[1]);
              };
        const int o1 = orient2d_int(a, b, c), o2 = orient2d_int(a, b, d);
        const int o3 = orient2d_int(c, d, a), o4 = orient2d_int(c, d, b);
        if (o1 * o2 < 0 && o3 * o4 < 0)
            return true;
        return (o1 == 0 && between(a, b, c)) || (o2 == 0 && between(a, b, d))
            || (o3 == 0 && between(c, d, a)) || (o4 == 0 && between(c, d, b));
    }

    TEST(TrianglesIntersect, CoplanarAgainstIntegerReference)
    {
        std::mt19937 rng(8);
        std::uniform_int_distribution<std::int64_t> coordinate(-6, 6);
        const Vec3 o(0.5, -0.25, 1.0), u(3.0, 1.0, -2.0), v(1.0, -2.0, 0.5);
        int hits = 0;
        for (int trial = 0; trial < 2000; ++trial) {
            std::array<std::array<std::int64_t, 2>, 6> p;
            for (auto& q : p)
                q = { coordinate(rng), coordinate(rng) };
            // Keep both triangles non-degenerate in the plane.
            if (orient2d_int(p[0], p[1], p[2]) == 0 || orient2d_int(p[3], p[4], p[5]) == 0)
                continue;
            bool expected = false;
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    expected = expected
                        || segments_int(p[i], p[(i + 1) % 3], p[3 + j], p[3 + (j + 1) % 3]);
            const auto inside = [&](const std::array<std::int64_t, 2>& q, int t) {
                const int s0 = orient2d_int(p[t], p[t + 1], q);
                const int s1 = orient2d_int(p[t + 1], p[t + 2], q);
                const int s2 = orient2d_int(p[t + 2], p[t], q);
                return !((s0 < 0 || s1 < 0 || s2 < 0) && (s0 > 0 || s1 > 0 || s2 > 0));
            };
            expected = expected || inside(p[0], 3) || inside(p[3], 0);
            std::array<Vec3, 6> x;
            for (int i = 0; i < 6; ++i)
                x[i] = o + static_cast<double>(p[i][0]) * u + static_cast<double>(p[i][1]) * v;
            ASSERT_EQ(triangles_intersect(x[0], x[1], x[2], x[3], x[4], x[5]), expected)
                << "trial " << trial;
            hits += expected;
        }
        EXPECT_GT(hits, 200);
        EXPECT_LT(hits, 1800);
    }

    // Sampled checks on random pairs. A "chord" of triangle a (a segment between points of two
    // of its edges) that crosses b's plane at a point well inside b proves an intersection;
    // a declared intersection must bring sampled points of a close to b.
    bool chord_clearly_crosses(const std::array<Vec3, 3>& a, const std::array<Vec3, 3>& b)
    {
        const Vec3 n = (b[1] - b[0]).cross(b[2] - b[0]);
        const int steps = 24;
        for (int e = 0; e < 3; ++e)
            for (int i = 0; i <= steps; ++i)
                for (int j = 0; j <= steps; ++j) {
                    const double s = double(i) / steps, t = double(j) / steps;
                    const Vec3 p = a[e] + s * (a[(e + 1) % 3] - a[e]);
                    const Vec3 q = a[e] + t * (a[(e + 2) % 3] - a[e]);
                    const double dp = n.dot(p - b[0]), dq = n.dot(q - b[0]);
                    if (!(dp * dq < 0.0))
                        continue;
                    const double w = dp / (dp - dq);
                    if (w < 1e-6 || w > 1.0 - 1e-6)
                        continue;
                    const Vec3 x = p + w * (q - p);
                    const PointTriangleClosest c = point_triangle_closest(x, b[0], b[1], b[2]);
                    if (c.barycentric.minCoeff() > 1e-6)
                        return true;
                }
        return false;
    }

    double sampled_distance(const std::array<Vec3, 3>& a, const std::array<Vec3, 3>& b)
    {
        const int steps = 60;
        double best = 1e300;
        for (int i = 0; i <= steps; ++i)
            for (int j = 0; i + j <= steps; ++j) {
                const double s = double(i) / steps, t = double(j) / steps;
                const Vec3 p = (1.0 - s - t) * a[0] + s * a[1] + t * a[2];
                best = std::min(
                    best, std::sqrt(point_triangle_closest(p, b[0], b[1], b[2]).squared_distance));
            }
        return best;
    }

    TEST(TrianglesIntersect, RandomPairsAgainstSampling)
    {
        std::mt19937 rng(12);
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        int hits = 0;
        int misses = 0;
        for (int trial = 0; trial < 300; ++trial) {
            std::array<Vec3, 3> a, b;
            for (auto& p : a)
                p = Vec3(u(rng), u(rng), u(rng));
            const Vec3 shift = 0.6 * Vec3(u(rng), u(rng), u(rng));
            for (auto& p : b)
                p = shift + 0.8 * Vec3(u(rng), u(rng), u(rng));
            const bool result = triangles_intersect(a[0], a[1], a[2], b[0], b[1], b[2]);
            if (result) {
                ++hits;
                // Some point of a (the intersection) lies on b: a sample is near it.
                const double diameter = std::max(
                    { (a[1] - a[0]).norm(), (a[2] - a[1]).norm(), (a[0] - a[2]).norm() });
                EXPECT_LE(sampled_distance(a, b), 2.0 * diameter / 60.0) << "trial " << trial;
            } else {
                ++misses;
                EXPECT_FALSE(chord_clearly_crosses(a, b)) << "trial " << trial;
                EXPECT_FALSE(chord_clearly_crosses(b, a)) << "trial " << trial;
            }
        }
        EXPECT_GT(hits, 50);
        EXPECT_GT(misses, 50);
    }

    TEST(TrianglesIntersect, NonFiniteInputsReturn)
    {
        // Unspecified answers, but no crash or sanitizer report.
        const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
        for (const Vec3& bad : { Vec3(nan, 0, 0), Vec3(inf, 1, 0), Vec3(-inf, inf, nan) }) {
            triangles_intersect(bad, base[1], base[2], base[0], base[1] + Vec3::UnitZ(), bad);
            triangles_intersect(bad, bad, bad, bad, bad, bad);
            segment_triangle_intersect(bad, base[0], base[0], base[1], bad);
        }
        SUCCEED();
    }

    TEST(TrianglesIntersect, SegmentTriangle)
    {
        EXPECT_TRUE(
            segment_triangle_intersect(Vec3(1, 1, -1), Vec3(1, 1, 1), base[0], base[1], base[2]));
        EXPECT_TRUE(
            segment_triangle_intersect(Vec3(1, 1, 0), Vec3(1, 1, 1), base[0], base[1], base[2]));
        EXPECT_FALSE(
            segment_triangle_intersect(Vec3(1, 1, 0.5), Vec3(1, 1, 1), base[0], base[1], base[2]));
        EXPECT_TRUE(
            segment_triangle_intersect(Vec3(-1, 1, 0), Vec3(5, 1, 0), base[0], base[1], base[2]));
        EXPECT_FALSE(
            segment_triangle_intersect(Vec3(-1, 5, 0), Vec3(5, 5, 0), base[0], base[1], base[2]));
    }

} // namespace
} // namespace mat
