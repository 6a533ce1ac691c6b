// Primitive-pair tests against brute force: a dense grid of both parameter domains refined by a
// pattern search (g is convex, so the search reaches the minimum), on random pairs of every kind
// and on degenerate families (parallel and nearly parallel cones, touching spheres, nesting, zero
// radii, collinear slab centers, identical primitives, tiny and huge scales); closed forms where
// they exist (sphere against cone or slab through the library's point distance, capsules,
// segments, identical primitives).

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"
#include "common/medial_primitives_kernels.hpp"
#include "runtime/collision/primitive_pair.hpp"

namespace mat {
namespace {

#if defined(__SANITIZE_ADDRESS__)
    constexpr int k_fewer = 5; // sanitizer builds run several times slower: fewer random cases
#else
    constexpr int k_fewer = 1;
#endif

    constexpr double k_infinity = std::numeric_limits<double>::infinity();

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
        double normal() { return std::normal_distribution<double>()(m_gen); }
        int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(m_gen); }
        Vec3 box() { return Vec3(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)); }
        Vec3 unit() { return Vec3(normal(), normal(), normal()).normalized(); }

    private:
        std::mt19937_64 m_gen;
    };

    using Weights = std::array<double, 3>;

    /// f = |C|^2 - R^2 and g = |C| - R at weights, in the caller's coordinates.
    struct Value {
        double g;
        double f;
    };
    Value value(const Primitive& a, const Weights& wa, const Primitive& b, const Weights& wb)
    {
        double c[3] = { 0.0, 0.0, 0.0 };
        double r = 0.0;
        for (int i = 0; i < a.count; ++i) {
            for (int k = 0; k < 3; ++k)
                c[k] += wa[i] * a.centers[i][k];
            r += wa[i] * a.radii[i];
        }
        for (int j = 0; j < b.count; ++j) {
            for (int k = 0; k < 3; ++k)
                c[k] -= wb[j] * b.centers[j][k];
            r += wb[j] * b.radii[j];
        }
        const double c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        return { std::sqrt(c2) - r, c2 - r * r };
    }

    /// Diagonal of the bounding box of a primitive's balls.
    double diagonal(const Primitive& p)
    {
        Box3 box;
        for (int i = 0; i < p.count; ++i) {
            box.extend(p.centers[i] - Vec3::Constant(p.radii[i]));
            box.extend(p.centers[i] + Vec3::Constant(p.radii[i]));
        }
        return box.diagonal().norm();
    }
    /// Scale of relative tolerances: the larger bounding-box diagonal of the two primitives (for
    /// two points of zero radius, their distance).
    double pair_size(const Primitive& a, const Primitive& b)
    {
        const double size = std::max(diagonal(a), diagonal(b));
        return size > 0.0 ? size : (a.centers[0] - b.centers[0]).norm();
    }

    /// The best point found by brute force, and whether any sample had f < 0.
    struct Reference {
        double g = k_infinity;
        Weights wa {}, wb {};
        bool f_negative = false;
    };

    /// Grid of a primitive's weights: 1 point for a sphere, cone_steps + 1 for a cone, a
    /// triangular grid with slab_steps + 1 points per side for a slab.
    std::vector<Weights> grid_points(int count, int cone_steps, int slab_steps)
    {
        std::vector<Weights> out;
        if (count == 1)
            out.push_back({ 1.0, 0.0, 0.0 });
        if (count == 2)
            for (int i = 0; i <= cone_steps; ++i) {
                const double t = double(i) / cone_steps;
                out.push_back({ 1.0 - t, t, 0.0 });
            }
        if (count == 3)
            for (int i = 0; i <= slab_steps; ++i)
                for (int j = 0; i + j <= slab_steps; ++j) {
                    const double u = double(i) / slab_steps, v = double(j) / slab_steps;
                    out.push_back({ u, v, std::max(0.0, 1.0 - u - v) });
                }
        return out;
    }

    /// min of a convex (hence unimodal) function over [lo, hi] by golden-section search.
    template <typename F> double golden_min(F f, double lo, double hi, int iterations = 50)
    {
        const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
        double x1 = hi - ratio * (hi - lo), x2 = lo + ratio * (hi - lo);
        double f1 = f(x1), f2 = f(x2);
        for (int k = 0; k < iterations; ++k) {
            if (f1 <= f2) {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - ratio * (hi - lo);
                f1 = f(x1);
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + ratio * (hi - lo);
                f2 = f(x2);
            }
        }
        return std::min({ f1, f2, f(lo), f(hi) });
    }

    /// min over a primitive's weights of |p - c(w)| - r(w) and its argmin, through the
    /// library's exact point distance (an implementation independent of primitive_pair.cpp).
    class PointDistance {
    public:
        explicit PointDistance(const Primitive& p)
            : m_p(p)
        {
            if (p.count == 2)
                m_cone = detail::PairData(p.centers[0], p.radii[0], p.centers[1], p.radii[1]);
            if (p.count == 3)
                m_slab = detail::SlabData({ p.centers[0], p.centers[1], p.centers[2] },
                    { p.radii[0], p.radii[1], p.radii[2] });
        }
        Weights argmin(const Vec3& x) const
        {
            if (m_p.count == 1)
                return { 1.0, 0.0, 0.0 };
            if (m_p.count == 2) {
                const double t = m_cone.sphere_distance(x).second;
                return { 1.0 - t, t, 0.0 };
            }
            const Vec2 ab = m_slab.distance(x).ab;
            return { ab[0], ab[1], std::max(0.0, 1.0 - ab[0] - ab[1]) };
        }

    private:
        Primitive m_p;
        detail::PairData m_cone;
        detail::SlabData m_slab;
    };

    /// The reference minimum of g: a dense grid of both domains (whose samples also decide
    /// whether some f < 0), then, g being convex, a nested golden-section search over the
    /// weights of the primitive with fewer spheres, each point of which is minimized exactly over
    /// the other primitive's weights by the library's point distance (partial minimization
    /// keeps convexity).
    class BruteForce {
    public:
        BruteForce(const Primitive& a, const Primitive& b)
            : m_a(a)
            , m_b(b)
        {
        }

        double sample(const Weights& wa, const Weights& wb)
        {
            const Value v = value(m_a, wa, m_b, wb);
            m_best.f_negative = m_best.f_negative || v.f < 0.0;
            if (v.g < m_best.g) {
                m_best.g = v.g;
                m_best.wa = wa;
                m_best.wb = wb;
            }
            return v.g;
        }

        void grid(int cone_steps, int slab_steps)
        {
            const std::vector<Weights> ga = grid_points(m_a.count, cone_steps, slab_steps);
            const std::vector<Weights> gb = grid_points(m_b.count, cone_steps, slab_steps);
            for (const Weights& wa : ga)
                for (const Weights& wb : gb)
                    sample(wa, wb);
        }

        void search()
        {
            const bool a_outer = m_a.count <= m_b.count;
            const Primitive& outer = a_outer ? m_a : m_b;
            const PointDistance inner(a_outer ? m_b : m_a);
            auto h = [&](const Weights& w) {
                const Vec3 x = outer.center(Vec3(w[0], w[1], w[2]));
                const Weights wi = inner.argmin(x);
                return a_outer ? sample(w, wi) : sample(wi, w);
            };
            if (outer.count == 1)
                h({ 1.0, 0.0, 0.0 });
            if (outer.count == 2)
                golden_min([&](double t) { return h({ 1.0 - t, t, 0.0 }); }, 0.0, 1.0);
            if (outer.count == 3)
                golden_min(
                    [&](double u) {
                        return golden_min(
                            [&](double v) {
                                return h({ u, v, std::max(0.0, 1.0 - u - v) });
                            },
                            0.0, 1.0 - u);
                    },
                    0.0, 1.0);
        }

        const Reference& best() const { return m_best; }

    private:
        Primitive m_a, m_b;
        Reference m_best;
    };

    Reference brute_force(const Primitive& a, const Primitive& b)
    {
        BruteForce search(a, b);
        search.grid(60, 12);
        search.search();
        return search.best();
    }

    std::string describe(const Primitive& p)
    {
        std::ostringstream out;
        out.precision(17);
        out << "{";
        for (int i = 0; i < p.count; ++i)
            out << (i ? ", " : "") << "(" << p.centers[i].transpose() << " | " << p.radii[i] << ")";
        out << "}";
        return out.str();
    }

    /// Checks weights: >= 0, summing to 1, zero past the count.
    bool valid_weights(const Primitive& p, const Vec3& w)
    {
        double sum = 0.0;
        for (int i = 0; i < 3; ++i) {
            if (i >= p.count && w[i] != 0.0)
                return false;
            if (!(w[i] >= 0.0))
                return false;
            sum += w[i];
        }
        return std::abs(sum - 1.0) <= 1e-14;
    }

    /// Every property of the two functions on one pair; returns "" or what failed. `reference`
    /// is min g found by brute force (and whether a sample had f < 0); `exact_g`, when finite, is
    /// a closed-form min g.
    std::string check_pair(const Primitive& a, const Primitive& b, const Reference& reference,
        double exact_g = k_infinity)
    {
        std::ostringstream failure;
        failure.precision(17);
        const double size = pair_size(a, b);
        const bool hit = primitives_intersect(a, b);
        const PrimitivePenetration pen = deepest_penetration(a, b);

        if (!valid_weights(a, pen.weights_a) || !valid_weights(b, pen.weights_b))
            failure << "invalid weights " << pen.weights_a.transpose() << " / "
                    << pen.weights_b.transpose() << "; ";
        const Weights wa = { pen.weights_a[0], pen.weights_a[1], pen.weights_a[2] };
        const Weights wb = { pen.weights_b[0], pen.weights_b[1], pen.weights_b[2] };
        const double g = value(a, wa, b, wb).g;
        if (!(std::abs(pen.depth + g) <= 1e-12 * size))
            failure << "depth " << pen.depth << " but its weights give " << -g << "; ";
        if (!((pen.center_a - a.center(pen.weights_a)).norm() <= 1e-14 * size
                && (pen.center_b - b.center(pen.weights_b)).norm() <= 1e-14 * size
                && std::abs(pen.radius_a - a.radius(pen.weights_a)) <= 1e-14 * size
                && std::abs(pen.radius_b - b.radius(pen.weights_b)) <= 1e-14 * size))
            failure << "spheres differ from the weights; ";
        if (!(std::abs(pen.normal.norm() - 1.0) <= 1e-12))
            failure << "normal not unit; ";
        const Vec3 d = pen.center_a - pen.center_b;
        if (d.norm() > 1e-9 * size && !((pen.normal - d.normalized()).norm() <= 1e-9))
            failure << "normal not from b to a; ";

        if (reference.f_negative && !hit)
            failure << "false negative: brute force has f < 0 (g " << reference.g << "); ";
        if (hit && !(pen.depth >= -1e-12 * size))
            failure << "intersect but depth " << pen.depth << "; ";
        if (!hit && !(pen.depth < 1e-12 * size))
            failure << "no intersection but depth " << pen.depth << "; ";
        if (!(pen.depth >= -reference.g - 1e-9 * size))
            failure << "depth " << pen.depth << " below brute force " << -reference.g << "; ";
        // The reference itself must come close (a failure here means a weak brute force).
        if (!(pen.depth <= -reference.g + 1e-7 * size))
            failure << "brute force " << -reference.g << " far below depth " << pen.depth << "; ";
        if (std::isfinite(exact_g) && !(std::abs(pen.depth + exact_g) <= 1e-12 * size))
            failure << "depth " << pen.depth << " but closed form " << -exact_g << "; ";

        const bool hit_swapped = primitives_intersect(b, a);
        const PrimitivePenetration swapped = deepest_penetration(b, a);
        if (hit_swapped != hit || swapped.depth != pen.depth)
            failure << "not symmetric: " << hit << " " << pen.depth << " vs " << hit_swapped << " "
                    << swapped.depth << "; ";
        if (swapped.weights_a != pen.weights_b || swapped.weights_b != pen.weights_a)
            failure << "swapped weights differ; ";
        // The normal flips, except for the fallback +z when centers and centroids coincide.
        if (swapped.normal != -pen.normal && !(swapped.normal == pen.normal && d.norm() == 0.0))
            failure << "swapped normal does not flip; ";

        if (failure.tellp() > 0)
            failure << "\n  a = " << describe(a) << "\n  b = " << describe(b) << "\n  depth "
                    << pen.depth << " at " << pen.weights_a.transpose() << " / "
                    << pen.weights_b.transpose() << "\n  brute force " << -reference.g << " at "
                    << Vec3(reference.wa[0], reference.wa[1], reference.wa[2]).transpose() << " / "
                    << Vec3(reference.wb[0], reference.wb[1], reference.wb[2]).transpose();
        return failure.str();
    }

    std::string check_against_brute_force(
        const Primitive& a, const Primitive& b, double exact_g = k_infinity)
    {
        return check_pair(a, b, brute_force(a, b), exact_g);
    }

    Primitive random_primitive(int count, Rng& rng, double spread, double max_radius)
    {
        Primitive p;
        p.count = count;
        const int radius_mode = rng.integer(0, 3);
        const double common = rng.uniform(0.0, max_radius);
        for (int i = 0; i < count; ++i) {
            p.centers[i] = spread * rng.box();
            // 0: independent radii, 1: equal radii, 2: one large and the others small, 3: zero
            p.radii[i] = radius_mode == 0 ? rng.uniform(0.0, max_radius)
                : radius_mode == 1        ? common
                : radius_mode == 2        ? (i == 0 ? max_radius : 0.1 * rng.uniform(0, 1))
                                          : (rng.uniform() < 0.5 ? 0.0 : common);
        }
        return p;
    }

    /// Transforms every center by x -> scale x + shift and every radius by r -> scale r.
    Primitive transformed(Primitive p, double scale, const Vec3& shift)
    {
        for (int i = 0; i < p.count; ++i) {
            p.centers[i] = scale * p.centers[i] + shift;
            p.radii[i] *= scale;
        }
        return p;
    }

    /// A random pair of the given kinds, b placed at a random offset so that about half the
    /// pairs intersect.
    std::pair<Primitive, Primitive> random_pair(int count_a, int count_b, Rng& rng)
    {
        const Primitive a = random_primitive(count_a, rng, 1.0, 0.6);
        Primitive b = random_primitive(count_b, rng, rng.uniform(0.2, 1.2), 0.6);
        b = transformed(b, 1.0, rng.uniform(0.0, 2.5) * rng.unit());
        const Vec3 shift = 2.0 * rng.box();
        return { transformed(a, 1.0, shift), transformed(b, 1.0, shift) };
    }

    const char* kind_name(int count)
    {
        return count == 1 ? "sphere" : count == 2 ? "cone" : "slab";
    }

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
                        SCOPED_TRACE("scale " + std::to_string(scale));
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
                            + " gap " + std::to_string(gap));
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
            ASSERT_EQ(primitives_intersect(prim, s), exact_g <= 1e-14 * size || pen.depth >= 0.0)
                << describe(s) << " " << describe(prim);
        }
    }

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
} // namespace mat
