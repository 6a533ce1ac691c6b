// Medial primitives against brute force: dense sampling and golden-section search of the
// parameter domain (outside), ray casting against the union of interpolated spheres (inside),
// dense sampling of the support-function dual, and closed forms (sphere, capsule, rounded
// triangle, swallowed sphere).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"
#include "common/medial_primitives_kernels.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/golden_section.hpp"

namespace mat {
namespace {

    constexpr double k_pi = 3.14159265358979323846;

#if defined(__SANITIZE_ADDRESS__)
    constexpr int k_fewer = 5; // sanitizer builds run ~10x slower: fewer random cases
#else
    constexpr int k_fewer = 1;
#endif

    class Rng {
    public:
        explicit Rng(unsigned seed)
            : m_gen(seed)
        {
        }
        double uniform(double lo = 0.0, double hi = 1.0)
        {
            return std::uniform_real_distribution<double>(lo, hi)(m_gen);
        }
        int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(m_gen); }
        Vec3 box() { return Vec3(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)); }
        Vec3 unit()
        {
            std::normal_distribution<double> normal;
            Vec3 v(normal(m_gen), normal(m_gen), normal(m_gen));
            return v.normalized();
        }

    private:
        std::mt19937_64 m_gen;
    };

    /// The 2 (cone) or 3 (slab) spheres of a primitive, for the brute-force references.
    struct Balls {
        std::vector<Vec3> c;
        std::vector<double> r;

        int size() const { return static_cast<int>(c.size()); }
        /// Weights of the spheres at parameter (a, b): cone (1-a, a), slab (a, b, 1-a-b).
        std::vector<double> weights(double a, double b) const
        {
            if (size() == 2)
                return { 1.0 - a, a };
            return { a, b, 1.0 - a - b };
        }
        MedialSphere sphere(double a, double b) const
        {
            const std::vector<double> w = weights(a, b);
            MedialSphere s;
            for (int i = 0; i < size(); ++i) {
                s.center += w[i] * c[i];
                s.radius += w[i] * r[i];
            }
            return s;
        }
        /// F(a, b) = |p - c(a, b)| - r(a, b).
        double value(double a, double b, const Vec3& p) const
        {
            return sphere(a, b).signed_distance(p);
        }
        /// Size of the primitive, for relative tolerances.
        double scale() const
        {
            double s = 0.0;
            for (int i = 0; i < size(); ++i) {
                s = std::max(s, r[i]);
                for (int j = 0; j < size(); ++j)
                    s = std::max(s, (c[i] - c[j]).norm());
            }
            return s;
        }
        /// Lipschitz constant of F in each parameter (|dF/da| <= |c_i - c_j| + |r_i - r_j|).
        double lipschitz() const
        {
            double s = 0.0;
            for (int i = 0; i < size(); ++i)
                for (int j = 0; j < size(); ++j)
                    s = std::max(s, (c[i] - c[j]).norm() + std::abs(r[i] - r[j]));
            return s;
        }
        /// f(n) = max_i n.(c_i - p) + r_i (minus the signed distance to the support plane).
        double support_gap(const Vec3& n, const Vec3& p) const
        {
            double f = -std::numeric_limits<double>::infinity();
            for (int i = 0; i < size(); ++i)
                f = std::max(f, n.dot(c[i] - p) + r[i]);
            return f;
        }
        Box3 bounds() const
        {
            Box3 box;
            for (int i = 0; i < size(); ++i) {
                box.extend(c[i] - Vec3::Constant(r[i]));
                box.extend(c[i] + Vec3::Constant(r[i]));
            }
            return box;
        }
    };

    MedialCone make_cone(const Balls& b)
    {
        return MedialCone(b.c[0], b.r[0], b.c[1], b.r[1]);
    }
    MedialSlab make_slab(const Balls& b)
    {
        return MedialSlab(MedialSphere(b.c[0], b.r[0]), MedialSphere(b.c[1], b.r[1]),
            MedialSphere(b.c[2], b.r[2]));
    }

    /// Exact signed distance and minimizing parameter through the library.
    struct Exact {
        double signed_distance;
        double sphere_distance;
        Vec2 ab;
    };
    Exact exact(const Balls& b, const Vec3& p)
    {
        if (b.size() == 2) {
            const ConeDistance d = make_cone(b).distance(p);
            return { d.signed_distance, d.sphere_distance, Vec2(d.t, 0.0) };
        }
        const SlabDistance d = make_slab(b).distance(p);
        return { d.signed_distance, d.sphere_distance, d.ab };
    }

    // ---- brute force: the parameter domain ----

    /// Grid of the parameter domain with n points per side.
    template <typename Visit> void for_each_parameter(const Balls& b, int n, Visit visit)
    {
        for (int i = 0; i < n; ++i) {
            const double a = double(i) / (n - 1);
            if (b.size() == 2) {
                visit(a, 0.0);
                continue;
            }
            for (int j = 0; i + j < n; ++j)
                visit(a, double(j) / (n - 1));
        }
    }

    double grid_min(const Balls& b, const Vec3& p, int n)
    {
        double best = std::numeric_limits<double>::infinity();
        for_each_parameter(
            b, n, [&](double a, double bb) { best = std::min(best, b.value(a, bb, p)); });
        return best;
    }

    template <typename F> double golden_min(F f, double lo, double hi, int iterations = 90)
    {
        return test::golden_section_min(f, lo, hi, iterations);
    }

    /// min of the convex F over the parameter domain by (nested) golden-section search.
    double refined_min(const Balls& b, const Vec3& p)
    {
        if (b.size() == 2)
            return golden_min([&](double t) { return b.value(t, 0.0, p); }, 0.0, 1.0);
        return golden_min(
            [&](double a) {
                return golden_min([&](double bb) { return b.value(a, bb, p); }, 0.0, 1.0 - a, 60);
            },
            0.0, 1.0, 60);
    }

    // ---- brute force: the boundary of the union of spheres, by ray casting ----

    bool in_domain(const Balls& b, double a, double bb)
    {
        if (b.size() == 2)
            return a >= 0.0 && a <= 1.0;
        return a >= 0.0 && bb >= 0.0 && a + bb <= 1.0;
    }

    /// min over the parameters of |x - c| - r: <= 0 iff x is in the union of the interpolated
    /// spheres. This is the library's closed-form minimum (precomputed form), which
    /// AgainstParameterSampling checks against dense sampling and a golden-section search; a dense
    /// grid alone would be too slow and too coarse for the bisection below.
    struct UnionOracle {
        explicit UnionOracle(const Balls& b)
            : count(b.size())
            , cone(b.c[0], b.r[0], b.c[1], b.r[1])
            , slab(count == 3
                      ? detail::SlabData({ b.c[0], b.c[1], b.c[2] }, { b.r[0], b.r[1], b.r[2] })
                      : detail::SlabData())
        {
        }
        double operator()(const Vec3& x) const
        {
            return count == 2 ? detail::cone_distance(cone, x).sphere_distance
                              : slab.distance(x).sphere_distance;
        }
        int count;
        detail::PairData cone;
        detail::SlabData slab;
    };

    /// Where the ray p + s d (p inside) leaves the union of the interpolated spheres, by
    /// bisection on s.
    double ray_exit(const Balls& b, const UnionOracle& union_value, const Vec3& p, const Vec3& d)
    {
        const Box3 box = b.bounds();
        double lo = 0.0;
        double hi = (box.max() - box.min()).norm() + (p - box.center()).norm();
        while (hi - lo > 1e-15 * b.scale()) {
            const double mid = 0.5 * (lo + hi);
            if (mid <= lo || mid >= hi)
                break;
            (union_value(p + mid * d) <= 0.0 ? lo : hi) = mid;
        }
        return lo;
    }

    std::vector<Vec3> fibonacci_sphere(int n)
    {
        std::vector<Vec3> dirs;
        const double golden = k_pi * (3.0 - std::sqrt(5.0));
        for (int i = 0; i < n; ++i) {
            const double z = 1.0 - 2.0 * (i + 0.5) / n;
            const double rho = std::sqrt(1.0 - z * z);
            dirs.emplace_back(rho * std::cos(golden * i), rho * std::sin(golden * i), z);
        }
        return dirs;
    }

    /// Local minimization over unit vectors by a compass search in the tangent plane.
    template <typename F>
    double refine_on_sphere(F f, Vec3 d, double value, double first_step, double last_step)
    {
        double step = first_step;
        for (int iteration = 0; step > last_step && iteration < 400; ++iteration) {
            Vec3 t1 = d.cross(std::abs(d.x()) < 0.5 ? Vec3::UnitX() : Vec3::UnitY()).normalized();
            Vec3 t2 = d.cross(t1);
            bool improved = false;
            for (const Vec3& t : { t1, Vec3(-t1), t2, Vec3(-t2) }) {
                const Vec3 q = (d + step * t).normalized();
                const double v = f(q);
                if (v < value) {
                    value = v;
                    d = q;
                    improved = true;
                    break;
                }
            }
            step = improved ? std::min(2.0 * step, first_step) : 0.5 * step;
        }
        return value;
    }

    /// Distance from an inside point p to the boundary of the union: min over ray directions
    /// of the exit distance (dense directions, then local refinement of the best ones).
    double ray_depth(const Balls& b, const Vec3& p)
    {
        static const std::vector<Vec3> dirs = fibonacci_sphere(200);
        const UnionOracle oracle(b);
        std::vector<std::pair<double, int>> exits;
        for (size_t i = 0; i < dirs.size(); ++i)
            exits.emplace_back(ray_exit(b, oracle, p, dirs[i]), int(i));
        std::sort(exits.begin(), exits.end());
        // Refine the best directions of up to 3 distinct basins.
        double best = exits.front().first;
        const auto exit_at = [&](const Vec3& d) { return ray_exit(b, oracle, p, d); };
        std::vector<Vec3> starts;
        for (const auto& [value, i] : exits) {
            bool distinct = true;
            for (const Vec3& d : starts)
                distinct = distinct && d.dot(dirs[i]) < std::cos(0.3);
            if (!distinct)
                continue;
            starts.push_back(dirs[i]);
            best = std::min(best, refine_on_sphere(exit_at, dirs[i], value, 0.1, 1e-9));
            if (starts.size() == 3)
                break;
        }
        return best;
    }

    /// min over unit n of f(n) by dense sampling and local refinement (an upper bound on the
    /// true minimum, which is minus the signed distance).
    double sampled_dual(const Balls& b, const Vec3& p)
    {
        static const std::vector<Vec3> dirs = fibonacci_sphere(1000);
        std::vector<std::pair<double, int>> values;
        for (size_t i = 0; i < dirs.size(); ++i)
            values.emplace_back(b.support_gap(dirs[i], p), int(i));
        std::sort(values.begin(), values.end());
        // Zoom in around the best samples of distinct basins: a grid on a shrinking cap. f has
        // ridges where the active sphere changes, along which no sampling converges fast: the
        // result is only an upper bound of min f, close to it within ~1e-3 of the size.
        std::vector<Vec3> starts;
        for (const auto& [value, i] : values) {
            bool distinct = true;
            for (const Vec3& d : starts)
                distinct = distinct && d.dot(dirs[i]) < std::cos(0.3);
            if (distinct)
                starts.push_back(dirs[i]);
            if (starts.size() == 4)
                break;
        }
        double best = values.front().first;
        for (Vec3 center : starts) {
            double center_value = b.support_gap(center, p);
            for (double cap = 0.1; cap > 1e-8; cap *= 0.5) {
                const Vec3 t1
                    = center.cross(std::abs(center.x()) < 0.5 ? Vec3::UnitX() : Vec3::UnitY())
                          .normalized();
                const Vec3 t2 = center.cross(t1);
                Vec3 next = center;
                for (int i = -3; i <= 3; ++i) {
                    for (int j = -3; j <= 3; ++j) {
                        const Vec3 n = (center + cap * (i * t1 + j * t2) / 3.0).normalized();
                        const double v = b.support_gap(n, p);
                        if (v < center_value) {
                            center_value = v;
                            next = n;
                        }
                    }
                }
                center = next;
            }
            best = std::min(best, center_value);
        }
        return best;
    }

    // ---- random primitives ----

    /// Random spheres, with degenerate kinds. kind: 0 generic, 1 equal radii, 2 one sphere
    /// inside another, 3 zero-length edge, 4 collinear centers, 5 nearly collinear, 6 zero
    /// radius, 7 nearly swallowed (|c1 - c0| barely above |r1 - r0|).
    Balls random_balls(Rng& rng, int count, int kind)
    {
        Balls b;
        for (int i = 0; i < count; ++i) {
            b.c.push_back(rng.box());
            b.r.push_back(rng.uniform(0.05, 0.8));
        }
        switch (kind) {
        case 1:
            for (double& r : b.r)
                r = b.r[0];
            break;
        case 2:
            b.c[1] = b.c[0] + 0.3 * rng.uniform() * rng.unit();
            b.r[1] = b.r[0] + (b.c[1] - b.c[0]).norm() + rng.uniform(0.0, 0.3);
            break;
        case 3:
            b.c[count - 1] = b.c[0];
            break;
        case 4:
            b.c[count - 1] = b.c[0] + rng.uniform(-0.5, 1.5) * (b.c[1] - b.c[0]);
            break;
        case 5:
            b.c[count - 1] = b.c[0] + rng.uniform(-0.5, 1.5) * (b.c[1] - b.c[0])
                + std::pow(10.0, rng.uniform(-9.0, -4.0)) * rng.unit();
            break;
        case 6:
            b.r[rng.integer(0, count - 1)] = 0.0;
            break;
        case 7: {
            const double gap
                = std::abs(b.r[1] - b.r[0]) * (1.0 + std::pow(10.0, rng.uniform(-9, -3)));
            b.c[1] = b.c[0] + gap * rng.unit();
            break;
        }
        default:
            break;
        }
        return b;
    }

    Balls scaled(Balls b, double s, const Vec3& offset)
    {
        for (int i = 0; i < b.size(); ++i) {
            b.c[i] = s * b.c[i] + offset;
            b.r[i] *= s;
        }
        return b;
    }

    /// A point inside the union: in a random interpolated sphere.
    Vec3 random_inside(Rng& rng, const Balls& b)
    {
        double a = rng.uniform(), bb = rng.uniform();
        if (b.size() == 3 && a + bb > 1.0) {
            a = 1.0 - a;
            bb = 1.0 - bb;
        }
        const MedialSphere s = b.sphere(a, bb);
        return s.center + s.radius * std::cbrt(rng.uniform()) * rng.unit();
    }

    /// A point near or around the primitive, inside or outside.
    Vec3 random_point(Rng& rng, const Balls& b)
    {
        const Box3 box = b.bounds();
        const double u = rng.uniform();
        if (u < 0.4) // near the surface of an interpolated sphere
        {
            double a = rng.uniform(), bb = rng.uniform();
            if (b.size() == 3 && a + bb > 1.0) {
                a = 1.0 - a;
                bb = 1.0 - bb;
            }
            const MedialSphere s = b.sphere(a, bb);
            return s.center + (s.radius + 0.05 * b.scale() * rng.uniform(-1, 1)) * rng.unit();
        }
        const double spread = u < 0.9 ? 0.75 : 4.0;
        return box.center() + spread * box.sizes().cwiseProduct(Vec3(rng.box())) * 0.5;
    }

    // ---- tests ----

    TEST(MedialSphere, ClosedForm)
    {
        const MedialSphere s(Vec3(1, 2, 3), 0.5);
        EXPECT_DOUBLE_EQ(s.signed_distance(Vec3(1, 2, 3)), -0.5);
        EXPECT_DOUBLE_EQ(s.signed_distance(Vec3(1, 2, 4)), 0.5);
        EXPECT_TRUE(s.contains(Vec3(1.4, 2, 3)));
        EXPECT_FALSE(s.contains(Vec3(1.6, 2, 3)));
        EXPECT_TRUE(s.contains(Vec3(1.6, 2, 3), 0.11));
        EXPECT_TRUE(s.bounds().isApprox(Box3(Vec3(0.5, 1.5, 2.5), Vec3(1.5, 2.5, 3.5))));
    }

    TEST(MedialCone, InterpolationAndFromMesh)
    {
        MedialMesh mesh;
        mesh.centers.resize(3, 3);
        mesh.centers << 0, 0, 0, 2, 0, 0, 0, 4, 0;
        mesh.radii = Vec3(1.0, 3.0, 0.5);
        mesh.cones.resize(1, 2);
        mesh.cones << 0, 1;
        mesh.slabs.resize(1, 3);
        mesh.slabs << 0, 1, 2;
        const MedialCone cone = MedialCone::from_mesh(mesh, 0);
        EXPECT_TRUE(cone.center(0.25).isApprox(Vec3(0.5, 0, 0)));
        EXPECT_DOUBLE_EQ(cone.radius(0.25), 1.5);
        const MedialSlab slab = MedialSlab::from_mesh(mesh, 0);
        EXPECT_TRUE(slab.center(0.5, 0.25).isApprox(Vec3(0.5, 1.0, 0)));
        EXPECT_DOUBLE_EQ(slab.radius(0.5, 0.25), 0.5 + 0.75 + 0.125);
        EXPECT_DOUBLE_EQ(slab.sphere(0.0, 1.0).radius, 3.0);

        EXPECT_THROW(MedialCone::from_mesh(mesh, 1), Error);
        EXPECT_THROW(MedialSlab::from_mesh(mesh, -1), Error);
        EXPECT_THROW(MedialSphere::from_mesh(mesh, 3), Error);
        mesh.slabs(0, 2) = 7;
        test::expect_error_containing(
            [&] { MedialSlab::from_mesh(mesh, 0); }, { "slab 0 references sphere 7" });
        EXPECT_THROW(MedialDistanceField { mesh }, Error);
        EXPECT_THROW(medial_mesh_signed_distance(mesh, Vec3::Zero()), Error);
        mesh.slabs(0, 2) = 2;
        EXPECT_NO_THROW(MedialDistanceField { mesh });
        mesh.radii(1) = -0.5;
        EXPECT_THROW(MedialDistanceField { mesh }, Error);
        mesh.radii(1) = 0.5;
        mesh.centers(2, 1) = std::numeric_limits<double>::quiet_NaN();
        EXPECT_THROW(MedialDistanceField { mesh }, Error);
    }

    double segment_distance(const Vec3& a, const Vec3& b, const Vec3& p)
    {
        const Vec3 d = b - a;
        const double t
            = d.squaredNorm() > 0 ? std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
        return (a + t * d - p).norm();
    }

    TEST(MedialCone, CapsuleClosedForm)
    {
        // Equal radii: the cone is a capsule, sd = dist(p, segment) - r on both sides.
        Rng rng(11);
        for (int k = 0; k < 2000; ++k) {
            const Vec3 a = rng.box(), b = rng.box();
            const double r = rng.uniform(0.01, 1.0);
            const MedialCone cone(a, r, b, r);
            const Vec3 p = 1.5 * rng.box();
            const double expected = segment_distance(a, b, p) - r;
            const ConeDistance d = cone.distance(p);
            ASSERT_NEAR(d.signed_distance, expected, 1e-12) << k;
            ASSERT_EQ(cone.contains(p), expected <= 0.0) << k;
            // With equal radii, min_t |p - c(t)| - r(t) is the same closed form, inside too.
            ASSERT_NEAR(cone.sphere(d.t).signed_distance(p), expected, 1e-12) << k;
        }
    }

    TEST(MedialCone, SwallowedSphereIsTheBiggerSphere)
    {
        Rng rng(12);
        for (int k = 0; k < 2000; ++k) {
            const Vec3 big = rng.box();
            const double r_big = rng.uniform(0.5, 1.0);
            const Vec3 small = big + rng.uniform(0.0, 0.4) * rng.unit();
            const double r_small = k % 3 == 0 ? r_big - (small - big).norm() // internally tangent
                                              : rng.uniform(0.0, r_big - (small - big).norm());
            const MedialCone cone = k % 2 ? MedialCone(big, r_big, small, r_small)
                                          : MedialCone(small, r_small, big, r_big);
            const Vec3 p = 1.5 * rng.box();
            const double expected = (p - big).norm() - r_big;
            const ConeDistance d = cone.distance(p);
            ASSERT_NEAR(d.signed_distance, expected, 1e-12) << k;
            ASSERT_NEAR(d.sphere_distance, expected, 1e-12) << k;
        }
        // Zero-length cone: same center, the bigger radius wins; equal spheres: that sphere.
        const MedialCone point(Vec3(1, 0, 0), 0.5, Vec3(1, 0, 0), 0.75);
        EXPECT_NEAR(point.signed_distance(Vec3(3, 0, 0)), 1.25, 1e-15);
        EXPECT_NEAR(point.signed_distance(Vec3(1, 0.25, 0)), -0.5, 1e-15);
        EXPECT_DOUBLE_EQ(point.distance(Vec3(3, 0, 0)).t, 1.0);
        const MedialCone same(Vec3(1, 0, 0), 0.5, Vec3(1, 0, 0), 0.5);
        EXPECT_NEAR(same.signed_distance(Vec3(1, 0, 0)), -0.5, 1e-15);
        EXPECT_NEAR(same.signed_distance(Vec3(1, 2, 0)), 1.5, 1e-15);
    }

    double triangle_distance(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& p)
    {
        const Vec3 n = (b - a).cross(c - a).normalized();
        const Vec3 foot = p - n.dot(p - a) * n;
        const auto inside_edge
            = [&](const Vec3& u, const Vec3& v) { return (v - u).cross(foot - u).dot(n) >= 0.0; };
        if (inside_edge(a, b) && inside_edge(b, c) && inside_edge(c, a))
            return std::abs(n.dot(p - a));
        return std::min(
            { segment_distance(a, b, p), segment_distance(b, c, p), segment_distance(c, a, p) });
    }

    TEST(MedialSlab, RoundedTriangleClosedForm)
    {
        // Equal radii: the slab is a triangle offset by r, sd = dist(p, triangle) - r.
        Rng rng(13);
        for (int k = 0; k < 2000; ++k) {
            const Vec3 a = rng.box(), b = rng.box(), c = rng.box();
            const double r = rng.uniform(0.01, 1.0);
            const MedialSlab slab(MedialSphere(a, r), MedialSphere(b, r), MedialSphere(c, r));
            const Vec3 p = 1.5 * rng.box();
            const double expected = triangle_distance(a, b, c, p) - r;
            const SlabDistance d = slab.distance(p);
            ASSERT_NEAR(d.signed_distance, expected, 1e-11) << k;
            ASSERT_EQ(slab.contains(p), d.signed_distance <= 0.0) << k;
            ASSERT_NEAR(
                slab.sphere(d.ab.x(), d.ab.y()).signed_distance(p), d.sphere_distance, 1e-13);
            if (expected > 0.0) {
                ASSERT_NEAR(d.sphere_distance, expected, 1e-11) << k;
            }
        }
    }

    TEST(MedialSlab, CollinearOutsideIsTheBestEdge)
    {
        // With collinear centers the slab's volume is the union of its three edge cones.
        Rng rng(14);
        for (int k = 0; k < 2000; ++k) {
            Balls b = random_balls(rng, 3, 4);
            const Vec3 p = random_point(rng, b);
            const MedialSlab slab = make_slab(b);
            double expected = std::numeric_limits<double>::infinity();
            for (int e = 0; e < 3; ++e)
                expected = std::min(expected,
                    MedialCone(b.c[e], b.r[e], b.c[(e + 1) % 3], b.r[(e + 1) % 3])
                        .signed_distance(p));
            const double d = slab.signed_distance(p);
            if (expected > 0.0) {
                ASSERT_NEAR(d, expected, 1e-12) << k;
            } else {
                ASSERT_LE(d, expected + 1e-12) << k; // at least as deep as in any edge cone
            }
        }
    }

    struct Tally {
        double worst = 0.0;
        int count = 0;
        void add(double x)
        {
            worst = std::max(worst, x);
            ++count;
        }
    };

    /// Outside distance and parameter against the dense grid and the refined search, and the
    /// signed distance against the sampled support-function dual, on random degenerate cases.
    void check_against_parameter_sampling(int count, unsigned seed, int cases)
    {
        Rng rng(seed);
        const int grid = count == 2 ? 2001 : 81;
        const double scales[] = { 1e-6, 1.0, 1e6 };
        Tally grid_gap, refined_gap, dual_gap;
        for (int k = 0; k < cases; ++k) {
            const double s = scales[k % 3];
            const Balls b = scaled(random_balls(rng, count, (k / 3) % 8), s, s * rng.box());
            const double scale = b.scale();
            const double eps = 1e-12 * scale;
            const Vec3 q = random_point(rng, b);
            const Exact e = exact(b, q);
            SCOPED_TRACE(
                testing::Message() << "case " << k << " scale " << s << " kind " << (k / 3) % 8);

            // The minimizing parameter is in the domain and reproduces sphere_distance.
            ASSERT_TRUE(in_domain(b, e.ab.x(), count == 2 ? 0.0 : e.ab.y()));
            ASSERT_NEAR(b.value(e.ab.x(), e.ab.y(), q), e.sphere_distance, 4 * eps);
            // sphere_distance = min F: never above brute force, and within the sampling error.
            const double brute = grid_min(b, q, grid);
            ASSERT_LE(e.sphere_distance, brute + eps);
            const double h = 1.0 / (grid - 1);
            ASSERT_LE(brute - e.sphere_distance, b.lipschitz() * h + eps);
            grid_gap.add((brute - e.sphere_distance) / (b.lipschitz() * h + eps));
            const double refined = refined_min(b, q);
            ASSERT_LE(e.sphere_distance, refined + eps);
            ASSERT_NEAR(e.sphere_distance, refined, 1e-9 * scale);
            refined_gap.add(std::abs(e.sphere_distance - refined) / scale);
            // Sign and containment agree; outside the signed distance is the sphere distance,
            // inside it is deeper (or equal).
            ASSERT_EQ(e.signed_distance <= 0.0, e.sphere_distance <= 0.0);
            const bool contained = count == 2 ? make_cone(b).contains(q) : make_slab(b).contains(q);
            ASSERT_EQ(contained, e.signed_distance <= 0.0);
            if (e.sphere_distance > 0.0) {
                ASSERT_EQ(e.signed_distance, e.sphere_distance);
            } else {
                ASSERT_LE(e.signed_distance, e.sphere_distance);
            }
            // Dual: sd = -min over unit n of f(n); sampling only finds values >= min f.
            const double dual = sampled_dual(b, q);
            ASSERT_LE(-e.signed_distance, dual + eps);
            ASSERT_NEAR(-e.signed_distance, dual, 1e-2 * (scale + (q - b.c[0]).norm()));
            dual_gap.add(std::abs(-e.signed_distance - dual) / (scale + (q - b.c[0]).norm()));
        }

        std::printf("  %d cases: grid gap <= %.3g of its bound, refined gap %.3g, dual gap %.3g\n",
            grid_gap.count, grid_gap.worst, refined_gap.worst, dual_gap.worst);
    }

    TEST(MedialCone, AgainstParameterSampling)
    {
        check_against_parameter_sampling(2, 21, 2400 / k_fewer);
    }
    TEST(MedialSlab, AgainstParameterSampling)
    {
        check_against_parameter_sampling(3, 22, 1800 / k_fewer);
    }

    /// Inside points: the depth against ray casting on the union of interpolated spheres.
    void check_inside_against_rays(int count, unsigned seed, int cases)
    {
        Rng rng(seed);
        const double scales[] = { 1e-6, 1.0, 1e6 };
        Tally gap;
        for (int k = 0; k < cases; ++k) {
            const double s = scales[k % 3];
            const int kind = (k / 3) % 8;
            Balls b = scaled(random_balls(rng, count, kind), s, s * rng.box());
            if (kind == 6) // a zero radius may leave no volume: use a tiny one instead
                for (double& r : b.r)
                    r = std::max(r, 1e-3 * s);
            const double scale = b.scale();
            // Also the special branches: p at a sphere center, p on the axis of an edge.
            const Vec3 p = k % 5 == 1 ? b.c[rng.integer(0, count - 1)]
                : k % 5 == 2          ? b.sphere(rng.uniform(), 0.0).center
                                      : random_inside(rng, b);
            const Exact e = exact(b, p);
            SCOPED_TRACE(testing::Message() << "case " << k << " scale " << s << " kind " << kind);
            ASSERT_LE(e.signed_distance, 1e-12 * scale);
            const double depth = ray_depth(b, p);
            // Never deeper than a boundary point actually found, and close to the best one (the
            // search over ray directions converges slowly where the exit distance barely depends
            // on the direction, e.g. p within 1e-5 of a cone's axis: hence 1e-6).
            ASSERT_LE(-e.signed_distance, depth + 1e-12 * scale);
            ASSERT_NEAR(-e.signed_distance, depth, 1e-6 * scale);
            gap.add(std::abs(-e.signed_distance - depth) / scale);
        }
        std::printf(
            "  %d inside cases: |exact - ray casting| <= %.3g x size\n", gap.count, gap.worst);
    }

    TEST(MedialCone, InsideAgainstRayCasting)
    {
        check_inside_against_rays(2, 31, 160 / k_fewer);
    }
    TEST(MedialSlab, InsideAgainstRayCasting)
    {
        check_inside_against_rays(3, 32, 160 / k_fewer);
    }

    TEST(MedialSlab, InsideBallIsContained)
    {
        // The ball of radius |sd| around an inside point lies in the slab; a slightly bigger
        // one pokes out somewhere (checked with ray casting above); here: containment only.
        Rng rng(33);
        const std::vector<Vec3> dirs = fibonacci_sphere(200);
        for (int k = 0; k < 300; ++k) {
            const Balls b = random_balls(rng, 3, k % 8);
            const MedialSlab slab = make_slab(b);
            const Vec3 p = random_inside(rng, b);
            const double depth = -slab.signed_distance(p);
            for (const Vec3& d : dirs)
                ASSERT_TRUE(slab.contains(p + depth * (1.0 - 1e-9) * d, 1e-12)) << k;
        }
    }

    /// A random medial mesh: a strip of slabs, a chain of cones and isolated spheres.
    MedialMesh random_mesh(Rng& rng, int spheres, int cones, int slabs)
    {
        MedialMesh mesh;
        mesh.centers.resize(spheres, 3);
        mesh.radii.resize(spheres);
        for (int i = 0; i < spheres; ++i) {
            mesh.centers.row(i) = 3.0 * rng.box().transpose();
            mesh.radii(i) = rng.uniform(0.1, 0.6);
        }
        mesh.cones.resize(cones, 2);
        for (int i = 0; i < cones; ++i)
            mesh.cones.row(i) << rng.integer(0, spheres - 1), rng.integer(0, spheres - 1);
        mesh.slabs.resize(slabs, 3);
        for (int i = 0; i < slabs; ++i)
            mesh.slabs.row(i) << rng.integer(0, spheres / 2), rng.integer(0, spheres / 2),
                rng.integer(0, spheres / 2);
        return mesh;
    }

    TEST(MedialDistanceField, MatchesMinOverPrimitives)
    {
        Rng rng(41);
        for (int m = 0; m < 6; ++m) {
            const MedialMesh mesh = random_mesh(rng, 40, 20 + m, 15 + 2 * m);
            const MedialDistanceField field(mesh);
            std::vector<char> used(mesh.num_spheres(), 0);
            for (Index i = 0; i < mesh.num_cones(); ++i)
                used[mesh.cones(i, 0)] = used[mesh.cones(i, 1)] = 1;
            for (Index i = 0; i < mesh.num_slabs(); ++i)
                for (int k = 0; k < 3; ++k)
                    used[mesh.slabs(i, k)] = 1;
            Box3 bounds;
            for (int k = 0; k < 400; ++k) {
                const Vec3 p = 4.0 * rng.box();
                double expected = std::numeric_limits<double>::infinity();
                bool inside = false;
                for (Index i = 0; i < mesh.num_spheres(); ++i) {
                    if (used[i])
                        continue;
                    const MedialSphere s = MedialSphere::from_mesh(mesh, i);
                    expected = std::min(expected, s.signed_distance(p));
                    inside = inside || s.contains(p);
                    if (k == 0)
                        bounds.extend(s.bounds());
                }
                for (Index i = 0; i < mesh.num_cones(); ++i) {
                    const MedialCone c = MedialCone::from_mesh(mesh, i);
                    expected = std::min(expected, c.signed_distance(p));
                    inside = inside || c.contains(p);
                    if (k == 0)
                        bounds.extend(c.bounds());
                }
                for (Index i = 0; i < mesh.num_slabs(); ++i) {
                    const MedialSlab s = MedialSlab::from_mesh(mesh, i);
                    expected = std::min(expected, s.signed_distance(p));
                    inside = inside || s.contains(p);
                    if (k == 0)
                        bounds.extend(s.bounds());
                }
                ASSERT_EQ(field(p), expected) << m << " " << k;
                ASSERT_EQ(medial_mesh_signed_distance(mesh, p), expected) << m << " " << k;
                ASSERT_EQ(field(p) <= 0.0, inside) << m << " " << k;
            }
            EXPECT_TRUE(field.bounds().isApprox(bounds));
        }
    }

    TEST(MedialDistanceField, InsideValueIsAConservativeBall)
    {
        // Inside the union, the ball of radius |value| lies inside the envelope.
        Rng rng(42);
        const MedialMesh mesh = random_mesh(rng, 30, 15, 20);
        const MedialDistanceField field(mesh);
        const std::vector<Vec3> dirs = fibonacci_sphere(100);
        int inside = 0;
        for (int k = 0; k < 2000 && inside < 100; ++k) {
            const Vec3 p = 3.0 * rng.box();
            const double v = field(p);
            if (v >= 0.0)
                continue;
            ++inside;
            for (const Vec3& d : dirs)
                ASSERT_LE(field(Vec3(p - v * (1.0 - 1e-9) * d)), 1e-12) << k;
        }
        EXPECT_EQ(inside, 100);
    }

    TEST(MedialDistanceField, EmptyMeshAndIsolatedSpheres)
    {
        MedialMesh empty;
        EXPECT_EQ(medial_mesh_signed_distance(empty, Vec3::Zero()),
            std::numeric_limits<double>::infinity());
        EXPECT_EQ(
            MedialDistanceField(empty)(Vec3::Zero()), std::numeric_limits<double>::infinity());
        MedialMesh spheres;
        spheres.centers.resize(2, 3);
        spheres.centers << 0, 0, 0, 4, 0, 0;
        spheres.radii = Vec2(1.0, 2.0);
        const MedialDistanceField field(spheres);
        EXPECT_DOUBLE_EQ(field(Vec3(-1.5, 0, 0)), 0.5);
        EXPECT_DOUBLE_EQ(field(Vec3(1.0, 0, 0)), 0.0);
        EXPECT_DOUBLE_EQ(field(Vec3(4.0, 0, 0)), -2.0);
        EXPECT_DOUBLE_EQ(medial_mesh_signed_distance(spheres, Vec3(4, 0, 0)), -2.0);
    }

    TEST(MedialDistanceField, FreeFunctionFollowsMeshEdits)
    {
        // medial_mesh_signed_distance caches a field per thread: edits must be seen, and a bad
        // mesh must throw without spoiling the next call.
        MedialMesh mesh;
        mesh.centers.resize(2, 3);
        mesh.centers << 0, 0, 0, 4, 0, 0;
        mesh.radii = Vec2(1.0, 1.0);
        mesh.cones.resize(1, 2);
        mesh.cones << 0, 1;
        EXPECT_DOUBLE_EQ(medial_mesh_signed_distance(mesh, Vec3(2, 3, 0)), 2.0);
        mesh.radii(1) = 2.0;
        EXPECT_DOUBLE_EQ(medial_mesh_signed_distance(mesh, Vec3(4, 3, 0)), 1.0);
        mesh.centers(1, 0) = 6.0;
        EXPECT_DOUBLE_EQ(medial_mesh_signed_distance(mesh, Vec3(6, 3, 0)), 1.0);
        MedialMesh bad = mesh;
        bad.cones(0, 1) = 2;
        EXPECT_THROW(medial_mesh_signed_distance(bad, Vec3::Zero()), Error);
        EXPECT_DOUBLE_EQ(medial_mesh_signed_distance(mesh, Vec3(6, 3, 0)), 1.0);
        mesh.cones.resize(0, 2);
        EXPECT_DOUBLE_EQ(medial_mesh_signed_distance(mesh, Vec3(3, 0, 0)), 1.0);
    }

    TEST(MedialDistanceField, ConcurrentCallsAgree)
    {
        Rng rng(43);
        const MedialMesh mesh = random_mesh(rng, 60, 30, 40);
        const MedialDistanceField field(mesh);
        std::vector<Vec3> points(4000);
        for (Vec3& p : points)
            p = 4.0 * rng.box();
        std::vector<double> serial(points.size()), parallel(points.size()), free(points.size());
        for (size_t i = 0; i < points.size(); ++i)
            serial[i] = field(points[i]);
        tbb::parallel_for(size_t(0), points.size(), [&](size_t i) {
            parallel[i] = field(points[i]);
            free[i] = medial_mesh_signed_distance(mesh, points[i]);
        });
        for (size_t i = 0; i < points.size(); ++i) {
            ASSERT_EQ(serial[i], parallel[i]);
            ASSERT_EQ(serial[i], free[i]);
        }
    }

} // namespace
} // namespace mat
