#include "tests/runtime/collision/primitive_pair_reference.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "common/medial_primitives_kernels.hpp"
#include "tests/support/golden_section.hpp"

namespace mat::test {

namespace {

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
        return test::golden_section_min(f, lo, hi, iterations);
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

} // namespace

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

double pair_size(const Primitive& a, const Primitive& b)
{
    const double size = std::max(diagonal(a), diagonal(b));
    return size > 0.0 ? size : (a.centers[0] - b.centers[0]).norm();
}

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

std::string check_pair(
    const Primitive& a, const Primitive& b, const Reference& reference, double exact_g)
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

std::string check_against_brute_force(const Primitive& a, const Primitive& b, double exact_g)
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

Primitive transformed(Primitive p, double scale, const Vec3& shift)
{
    for (int i = 0; i < p.count; ++i) {
        p.centers[i] = scale * p.centers[i] + shift;
        p.radii[i] *= scale;
    }
    return p;
}

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

} // namespace mat::test
