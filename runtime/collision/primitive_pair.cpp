#include "runtime/collision/primitive_pair.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "common/error.hpp"
#include "runtime/collision/primitive_pair_kernels.hpp"

// The search (the math is derived at the top of primitive_pair_kernels.cpp). The minimum of the
// convex g = |c_a - c_b| - (r_a + r_b) over the product of the two parameter simplices is the
// least value over the corners and the closed-form critical points of the faces (section (2)),
// and a dual vector v with L(v) >= value certifies a candidate optimal (section (3)).
//  1. Corners: the best one, and its dual bound.
//  2. Greedy walk (an active-set method, like Wolfe's for the nearest point of a polytope): add
//     to the best candidate's face the sphere whose dual bound is lowest (the most violated
//     optimality condition) and move to that face's critical point if it improves; when that
//     point falls outside the face or does not exist (or the face would have 4 parameters),
//     pivot: the best of the faces that keep the new sphere and drop one other. Stop when the
//     bound certifies the best candidate; typically after one to three face solves.
//  3. Otherwise (under 1% of random pairs): every face, skipping those whose dual bound rules
//     them out. This alone is exact; 1 and 2 only save work.

namespace mat {

namespace {

    using detail::DualBound;
    using detail::PairCandidate;
    using detail::PairFrame;

    constexpr double k_infinity = std::numeric_limits<double>::infinity();
    /// Rounding allowance of the intersection decision, relative to the pair's extent.
    constexpr double k_touch_tolerance = 1e-14;
    /// Optimality gap at which deepest_penetration stops, relative to the pair's extent.
    constexpr double k_gap_tolerance = 1e-14;

    void check_primitive(const Primitive& p, const char* name)
    {
        if (p.count < 1 || p.count > 3)
            throw_error("primitive pair test: primitive {} has {} spheres (expected 1, 2 or 3)",
                name, p.count);
        for (int i = 0; i < p.count; ++i) {
            if (!p.centers[i].allFinite())
                throw_error(
                    "primitive pair test: primitive {}, sphere {}: non-finite center", name, i);
            if (!(p.radii[i] >= 0.0 && p.radii[i] < k_infinity))
                throw_error(
                    "primitive pair test: primitive {}, sphere {}: radius {} (expected finite "
                    ">= 0)",
                    name, i, p.radii[i]);
        }
    }

    /// True if b should be the first primitive of the canonical order (more spheres first, then
    /// the lexicographically smaller data), so that (a, b) and (b, a) compute the same thing.
    bool goes_first(const Primitive& b, const Primitive& a)
    {
        if (a.count != b.count)
            return b.count > a.count;
        for (int i = 0; i < a.count; ++i) {
            for (int k = 0; k < 3; ++k)
                if (a.centers[i][k] != b.centers[i][k])
                    return b.centers[i][k] < a.centers[i][k];
            if (a.radii[i] != b.radii[i])
                return b.radii[i] < a.radii[i];
        }
        return false;
    }

    /// The pair in canonical order and local coordinates.
    struct Pair : PairFrame {
        Vec3 origin = Vec3::Zero();
        bool swapped = false; ///< a is the caller's b
        /// max distance from the origin to a point of the balls: the scale of tolerances.
        double extent = 0.0;

        Pair(const Primitive& first, const Primitive& second)
        {
            check_primitive(first, "a");
            check_primitive(second, "b");
            swapped = goes_first(second, first);
            const Primitive& p = swapped ? second : first;
            const Primitive& q = swapped ? first : second;
            na = p.count;
            nb = q.count;
            origin = p.centers[0];
            for (int i = 0; i < na; ++i) {
                a[i] = p.centers[i] - origin;
                ra[i] = p.radii[i];
                extent = std::max(extent, a[i].norm() + ra[i]);
            }
            for (int j = 0; j < nb; ++j) {
                b[j] = q.centers[j] - origin;
                rb[j] = q.radii[j];
                extent = std::max(extent, b[j].norm() + rb[j]);
            }
        }
    };

    /// The best candidate of the search so far, and the dual bound from its dual vector.
    struct Search {
        PairCandidate best;
        DualBound bound;

        /// Takes c as the best candidate if it is lower.
        void consider(const Pair& q, const PairCandidate& c)
        {
            if (!(c.g < best.g))
                return;
            best = c;
            bound = DualBound(q, c.dual);
        }
    };

    /// Step 1: every corner.
    void consider_corners(const Pair& q, Search& search)
    {
        for (int i = 0; i < q.na; ++i)
            for (int j = 0; j < q.nb; ++j)
                search.consider(q, detail::corner_candidate(q, i, j));
    }

    /// The face that adds to the best candidate's face the sphere whose dual bound is lowest, in
    /// (next_a, next_b); next_a is 0 when every sphere is in already.
    void entering_face(const Pair& q, const Search& search, unsigned& next_a, unsigned& next_b)
    {
        const PairCandidate& best = search.best;
        const DualBound& bound = search.bound;
        next_a = 0;
        next_b = 0;
        double lowest = k_infinity;
        for (int i = 0; i < q.na; ++i) {
            const unsigned mask = best.mask_a | 1u << i;
            if (mask != best.mask_a && bound.face(mask, best.mask_b) < lowest) {
                lowest = bound.face(mask, best.mask_b);
                next_a = mask;
                next_b = best.mask_b;
            }
        }
        for (int j = 0; j < q.nb; ++j) {
            const unsigned mask = best.mask_b | 1u << j;
            if (mask != best.mask_b && bound.face(best.mask_a, mask) < lowest) {
                lowest = bound.face(best.mask_a, mask);
                next_a = best.mask_a;
                next_b = mask;
            }
        }
    }

    /// The pivot from the entering face (next_a, next_b) with k parameters: the best critical
    /// point of the faces that keep the entering sphere and leave out one sphere of best's face.
    PairCandidate best_pivot(
        const Pair& q, const PairCandidate& best, unsigned next_a, unsigned next_b, int k)
    {
        PairCandidate pivot, x;
        unsigned drop_a = 0, drop_b = 0;
        for (int side = 0; side < 2; ++side)
            for (int i = 0; i < 3; ++i) {
                const unsigned bit = 1u << i;
                if (!((side == 0 ? best.mask_a : best.mask_b) & bit))
                    continue; // only a sphere of the old face leaves
                const unsigned mask_a = side == 0 ? next_a & ~bit : next_a;
                const unsigned mask_b = side == 1 ? next_b & ~bit : next_b;
                if (mask_a == 0 || mask_b == 0
                    || !detail::face_critical_point(q, mask_a, mask_b, k - 1, x, drop_a, drop_b))
                    continue;
                detail::evaluate_candidate(q, x);
                if (x.g < pivot.g) {
                    pivot = x;
                    pivot.mask_a = mask_a;
                    pivot.mask_b = mask_b;
                }
            }
        return pivot;
    }

    /// One step of the greedy walk (step 2): x, the entering face's critical point or else the
    /// pivot; false when no sphere enters or x does not improve on the best candidate.
    bool walk_step(const Pair& q, const Search& search, PairCandidate& x)
    {
        const PairCandidate& best = search.best;
        unsigned next_a = 0, next_b = 0;
        entering_face(q, search, next_a, next_b);
        if (next_a == 0)
            return false;
        const int k = detail::popcount3(next_a) + detail::popcount3(next_b) - 2;
        unsigned drop_a = 0, drop_b = 0;
        if (k <= 3 && detail::face_critical_point(q, next_a, next_b, k, x, drop_a, drop_b)) {
            detail::evaluate_candidate(q, x);
            x.mask_a = next_a;
            x.mask_b = next_b;
            return x.g < best.g;
        }
        if (k >= 2) {
            // No critical point inside the face (or k = 4): pivot.
            x = best_pivot(q, best, next_a, next_b, k);
            return x.g < best.g;
        }
        return false;
    }

    /// Step 3: the critical point of every face, skipping those whose dual bound is >=
    /// threshold(best g); stops as soon as best g <= stop_at.
    template <typename Threshold>
    void consider_faces(const Pair& q, Search& search, Threshold threshold, double stop_at)
    {
        const unsigned full_a = (1u << q.na) - 1u, full_b = (1u << q.nb) - 1u;
        PairCandidate x;
        for (int k = 1; k <= 3; ++k)
            for (unsigned mask_a = 1; mask_a <= full_a; ++mask_a)
                for (unsigned mask_b = 1; mask_b <= full_b; ++mask_b) {
                    if (detail::popcount3(mask_a) + detail::popcount3(mask_b) - 2 != k)
                        continue;
                    if (search.bound.face(mask_a, mask_b) >= threshold(search.best.g))
                        continue;
                    unsigned drop_a = 0, drop_b = 0;
                    if (!detail::face_critical_point(q, mask_a, mask_b, k, x, drop_a, drop_b))
                        continue;
                    detail::evaluate_candidate(q, x);
                    x.mask_a = mask_a;
                    x.mask_b = mask_b;
                    search.consider(q, x);
                    if (search.best.g <= stop_at)
                        return;
                }
    }

    /// min g by the search above (steps 1 to 3). Faces whose dual bound (from the best
    /// candidate's dual vector) is >= threshold(best g) are skipped, and the search ends when
    /// the bound of the whole domain is; it also stops as soon as best g <= stop_at.
    template <typename Threshold>
    PairCandidate minimize(
        const Pair& q, const DualBound& initial, Threshold threshold, double stop_at)
    {
        Search search;
        search.bound = initial;
        // Step 1: the corners.
        consider_corners(q, search);
        if (search.best.g <= stop_at)
            return search.best;
        const unsigned full_a = (1u << q.na) - 1u, full_b = (1u << q.nb) - 1u;

        // Step 2: the greedy walk.
        for (int step = 0; step < 6; ++step) {
            if (search.bound.face(full_a, full_b) >= threshold(search.best.g))
                return search.best;
            PairCandidate x;
            if (!walk_step(q, search, x))
                break;
            search.consider(q, x);
            if (search.best.g <= stop_at)
                return search.best;
        }

        // Step 3: every face, skipping those the dual bound rules out.
        consider_faces(q, search, threshold, stop_at);
        return search.best;
    }

} // namespace

Primitive Primitive::sphere(const Vec3& c0, double r0)
{
    Primitive p;
    p.count = 1;
    p.centers[0] = c0;
    p.radii[0] = r0;
    return p;
}

Primitive Primitive::cone(const Vec3& c0, double r0, const Vec3& c1, double r1)
{
    Primitive p = sphere(c0, r0);
    p.count = 2;
    p.centers[1] = c1;
    p.radii[1] = r1;
    return p;
}

Primitive Primitive::slab(
    const Vec3& c0, double r0, const Vec3& c1, double r1, const Vec3& c2, double r2)
{
    Primitive p = cone(c0, r0, c1, r1);
    p.count = 3;
    p.centers[2] = c2;
    p.radii[2] = r2;
    return p;
}

Vec3 Primitive::center(const Vec3& weights) const
{
    Vec3 c = Vec3::Zero();
    for (int i = 0; i < std::clamp(count, 0, 3); ++i)
        c += weights[i] * centers[i];
    return c;
}

double Primitive::radius(const Vec3& weights) const
{
    double r = 0.0;
    for (int i = 0; i < std::clamp(count, 0, 3); ++i)
        r += weights[i] * radii[i];
    return r;
}

bool primitives_intersect(const Primitive& a, const Primitive& b)
{
    const Pair q(a, b); // checks both primitives
    // Two overlapping vertex spheres settle it at once (each lies in its primitive): a third of
    // the collision bench's candidates, most of its intersecting pairs.
    for (int i = 0; i < a.count; ++i)
        for (int j = 0; j < b.count; ++j) {
            const double reach = a.radii[i] + b.radii[j];
            if ((a.centers[i] - b.centers[j]).squaredNorm() <= reach * reach)
                return true;
        }
    const double tolerance = k_touch_tolerance * q.extent;

    // A separating plane across the axis between the centroids settles most distant pairs.
    Vec3 axis = Vec3::Zero();
    for (int i = 0; i < q.na; ++i)
        axis += q.a[i] / q.na;
    for (int j = 0; j < q.nb; ++j)
        axis -= q.b[j] / q.nb;
    const double axis_norm = axis.norm();
    DualBound initial;
    if (axis_norm > 0.0) {
        initial = DualBound(q, axis / axis_norm);
        if (initial.face(7u, 7u) > tolerance)
            return false;
    }
    // Faces whose bound exceeds the tolerance cannot hold a point with g <= tolerance.
    const double above_tolerance = std::nextafter(tolerance, k_infinity);
    const PairCandidate best = minimize(
        q, initial, [&](double) { return above_tolerance; }, tolerance);
    return best.g <= tolerance;
}

PrimitivePenetration deepest_penetration(const Primitive& a, const Primitive& b)
{
    const Pair q(a, b);
    const double gap = k_gap_tolerance * q.extent;
    // Faces whose bound is within `gap` of the best value cannot improve it by more than gap.
    const PairCandidate best = minimize(
        q, DualBound(), [&](double best_g) { return best_g - gap; }, -k_infinity);

    // Report in the caller's order and coordinates, recomputed from the weights.
    const Primitive& first = q.swapped ? b : a;
    const Primitive& second = q.swapped ? a : b;
    PrimitivePenetration out;
    out.weights_a = Vec3(best.wa[0], best.wa[1], best.wa[2]);
    out.weights_b = Vec3(best.wb[0], best.wb[1], best.wb[2]);
    out.center_a = first.center(out.weights_a);
    out.center_b = second.center(out.weights_b);
    out.radius_a = first.radius(out.weights_a);
    out.radius_b = second.radius(out.weights_b);
    if (q.swapped) {
        std::swap(out.weights_a, out.weights_b);
        std::swap(out.center_a, out.center_b);
        std::swap(out.radius_a, out.radius_b);
    }
    const Vec3 d = out.center_a - out.center_b;
    const double distance = d.norm();
    out.depth = out.radius_a + out.radius_b - distance;
    if (distance > 0.0) {
        out.normal = d / distance;
    } else {
        const Vec3 centroids
            = a.center(Vec3::Constant(1.0 / a.count)) - b.center(Vec3::Constant(1.0 / b.count));
        const double norm = centroids.norm();
        out.normal = norm > 0.0 ? Vec3(centroids / norm) : Vec3(Vec3::UnitZ());
    }
    return out;
}

} // namespace mat
