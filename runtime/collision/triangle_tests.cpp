// Triangle-level tests. The intersection test rests on one fact: two closed triangles intersect
// iff an edge of one meets the other triangle. (Their intersection is convex. If the triangles
// are not coplanar it is a segment of the line where their planes meet, the overlap of the two
// intervals each triangle cuts on that line; an end of the overlap is an end of one of the
// intervals, which lies on an edge of that triangle and inside the other. If they are coplanar,
// two convex polygons meet iff their edges cross or one holds a vertex of the other.) Before the
// edge tests, the plane-side rejection of Moller and of Devillers-Guigue: when all three corners
// of one triangle lie strictly on one side of the other's plane there is no intersection. Every
// decision is the exact sign of orient2d or orient3d.

#include "runtime/collision/triangle_tests.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

namespace mat {

namespace {

    // The two coordinates kept when dropping `axis`, in cyclic order, so that orient2d of the
    // projection has the sign of the normal's `axis` component.
    Vec2 drop(const Vec3& p, int axis)
    {
        return { p[(axis + 1) % 3], p[(axis + 2) % 3] };
    }

    // Exact sign of component `axis` of (b - a) x (c - a).
    int normal_sign(const Vec3& a, const Vec3& b, const Vec3& c, int axis)
    {
        return orient2d(drop(a, axis), drop(b, axis), drop(c, axis));
    }

    // An axis along which the (exact) normal of a, b, c is nonzero, trying the largest floating
    // component first; -1 when a, b, c are collinear (or coincide).
    int projection_axis(const Vec3& a, const Vec3& b, const Vec3& c)
    {
        const Vec3 n = (b - a).cross(c - a).cwiseAbs();
        // A 3-element sorting network: safe whatever the values (NaN included).
        std::array<int, 3> order = { 0, 1, 2 };
        if (n[order[1]] > n[order[0]])
            std::swap(order[0], order[1]);
        if (n[order[2]] > n[order[1]])
            std::swap(order[1], order[2]);
        if (n[order[1]] > n[order[0]])
            std::swap(order[0], order[1]);
        for (const int axis : order)
            if (normal_sign(a, b, c, axis) != 0)
                return axis;
        return -1;
    }

    // Whether p lies in the closed axis-aligned box of a and b (for p collinear with a, b).
    bool in_box(const Vec2& p, const Vec2& a, const Vec2& b)
    {
        return std::min(a.x(), b.x()) <= p.x() && p.x() <= std::max(a.x(), b.x())
            && std::min(a.y(), b.y()) <= p.y() && p.y() <= std::max(a.y(), b.y());
    }

    // Closed segments (a, b) and (c, d) in the plane, any of them possibly a point.
    bool segments_intersect_2d(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d)
    {
        const int o1 = orient2d(a, b, c);
        const int o2 = orient2d(a, b, d);
        const int o3 = orient2d(c, d, a);
        const int o4 = orient2d(c, d, b);
        if (o1 * o2 < 0 && o3 * o4 < 0)
            return true;
        return (o1 == 0 && in_box(c, a, b)) || (o2 == 0 && in_box(d, a, b))
            || (o3 == 0 && in_box(a, c, d)) || (o4 == 0 && in_box(b, c, d));
    }

    // p in the closed triangle (t0, t1, t2) of nonzero area.
    bool point_in_triangle_2d(const Vec2& p, const Vec2& t0, const Vec2& t1, const Vec2& t2)
    {
        const int s0 = orient2d(t0, t1, p);
        const int s1 = orient2d(t1, t2, p);
        const int s2 = orient2d(t2, t0, p);
        const bool negative = s0 < 0 || s1 < 0 || s2 < 0;
        const bool positive = s0 > 0 || s1 > 0 || s2 > 0;
        return !(negative && positive);
    }

    // Closed segment (a, b) and triangle (t0, t1, t2) of nonzero area, in the plane.
    bool segment_triangle_2d(
        const Vec2& a, const Vec2& b, const Vec2& t0, const Vec2& t1, const Vec2& t2)
    {
        return point_in_triangle_2d(a, t0, t1, t2) || segments_intersect_2d(a, b, t0, t1)
            || segments_intersect_2d(a, b, t1, t2) || segments_intersect_2d(a, b, t2, t0);
    }

    // Closed segments in space, any of them possibly a point.
    bool segments_intersect_3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d)
    {
        if (orient3d(a, b, c, d) != 0)
            return false;
        // Coplanar: project along an axis the plane's normal has a component on. The plane is
        // spanned by any non-collinear triple of the four points.
        int axis = projection_axis(a, b, c);
        if (axis < 0)
            axis = projection_axis(a, b, d);
        if (axis < 0)
            axis = projection_axis(a, c, d);
        if (axis < 0)
            axis = projection_axis(b, c, d);
        if (axis < 0) {
            // All four collinear: drop the axis of least spread, so that the axis along which
            // the line moves most is kept and the projection is one-to-one on the line.
            Vec3 lo = a.cwiseMin(b).cwiseMin(c).cwiseMin(d);
            Vec3 hi = a.cwiseMax(b).cwiseMax(c).cwiseMax(d);
            (hi - lo).minCoeff(&axis);
        }
        return segments_intersect_2d(drop(a, axis), drop(b, axis), drop(c, axis), drop(d, axis));
    }

    // Closed segment (a, b) against the triangle t of nonzero area with projection axis
    // `axis`; sa, sb are orient3d(t0, t1, t2, a) and (..., b).
    bool segment_triangle_signed(
        const Vec3& a, const Vec3& b, int sa, int sb, const std::array<Vec3, 3>& t, int axis)
    {
        if (sa * sb > 0)
            return false;
        if (sa == 0 && sb == 0)
            return segment_triangle_2d(
                drop(a, axis), drop(b, axis), drop(t[0], axis), drop(t[1], axis), drop(t[2], axis));
        // The segment meets the plane at one point; the line through it crosses the closed
        // triangle iff it passes on the same side of (or through) all three edges.
        const int s0 = orient3d(a, b, t[0], t[1]);
        const int s1 = orient3d(a, b, t[1], t[2]);
        const int s2 = orient3d(a, b, t[2], t[0]);
        const bool negative = s0 < 0 || s1 < 0 || s2 < 0;
        const bool positive = s0 > 0 || s1 > 0 || s2 > 0;
        return !(negative && positive);
    }

    // Edges of the degenerate triangle `d` (a segment or a point) against the triangle `t`.
    bool degenerate_triangle_intersect(const std::array<Vec3, 3>& d, const std::array<Vec3, 3>& t)
    {
        for (int i = 0; i < 3; ++i)
            if (segment_triangle_intersect(d[i], d[(i + 1) % 3], t[0], t[1], t[2]))
                return true;
        return false;
    }

    // Every edge of `e` against the triangle `t` (nonzero area, projection axis `axis`), given
    // the signs of e's corners relative to t's plane.
    bool edges_intersect(const std::array<Vec3, 3>& e, const std::array<int, 3>& signs,
        const std::array<Vec3, 3>& t, int axis)
    {
        for (int i = 0; i < 3; ++i) {
            const int j = (i + 1) % 3;
            if (segment_triangle_signed(e[i], e[j], signs[i], signs[j], t, axis))
                return true;
        }
        return false;
    }

    bool all_strictly_one_side(const std::array<int, 3>& s)
    {
        return (s[0] > 0 && s[1] > 0 && s[2] > 0) || (s[0] < 0 && s[1] < 0 && s[2] < 0);
    }

    // Closest point of segment (a, b) to p, as the parameter along it.
    double segment_point_parameter(const Vec3& p, const Vec3& a, const Vec3& b)
    {
        const Vec3 ab = b - a;
        const double length2 = ab.squaredNorm();
        if (!(length2 > 0.0))
            return 0.0;
        return std::clamp((p - a).dot(ab) / length2, 0.0, 1.0);
    }

    PointTriangleClosest make_closest(
        const Vec3& p, const Vec3& t0, const Vec3& t1, const Vec3& t2, const Vec3& weights)
    {
        PointTriangleClosest out;
        out.barycentric = weights;
        out.point = weights[0] * t0 + weights[1] * t1 + weights[2] * t2;
        out.squared_distance = (p - out.point).squaredNorm();
        return out;
    }

    // The closest of the three edges (for degenerate triangles).
    PointTriangleClosest closest_on_edges(
        const Vec3& p, const Vec3& t0, const Vec3& t1, const Vec3& t2)
    {
        const std::array<const Vec3*, 3> t = { &t0, &t1, &t2 };
        PointTriangleClosest best;
        best.squared_distance = std::numeric_limits<double>::infinity();
        for (int i = 0; i < 3; ++i) {
            const int j = (i + 1) % 3;
            const double s = segment_point_parameter(p, *t[i], *t[j]);
            Vec3 weights = Vec3::Zero();
            weights[i] = 1.0 - s;
            weights[j] = s;
            const PointTriangleClosest candidate = make_closest(p, t0, t1, t2, weights);
            if (candidate.squared_distance < best.squared_distance)
                best = candidate;
        }
        return best;
    }

} // namespace

bool segment_triangle_intersect(
    const Vec3& a, const Vec3& b, const Vec3& t0, const Vec3& t1, const Vec3& t2)
{
    const int axis = projection_axis(t0, t1, t2);
    if (axis < 0)
        return segments_intersect_3d(a, b, t0, t1) || segments_intersect_3d(a, b, t1, t2)
            || segments_intersect_3d(a, b, t2, t0);
    return segment_triangle_signed(
        a, b, orient3d(t0, t1, t2, a), orient3d(t0, t1, t2, b), { t0, t1, t2 }, axis);
}

bool triangles_intersect(
    const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1, const Vec3& b2)
{
    const std::array<Vec3, 3> a = { a0, a1, a2 };
    const std::array<Vec3, 3> b = { b0, b1, b2 };

    // Plane-side rejection first: it decides most pairs and needs no projection axis.
    const std::array<int, 3> b_signs
        = { orient3d(a0, a1, a2, b0), orient3d(a0, a1, a2, b1), orient3d(a0, a1, a2, b2) };
    if (all_strictly_one_side(b_signs))
        return false;
    const std::array<int, 3> a_signs
        = { orient3d(b0, b1, b2, a0), orient3d(b0, b1, b2, a1), orient3d(b0, b1, b2, a2) };
    if (all_strictly_one_side(a_signs))
        return false;

    const int a_axis = projection_axis(a0, a1, a2);
    const int b_axis = projection_axis(b0, b1, b2);
    if (a_axis < 0 && b_axis < 0) {
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (segments_intersect_3d(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]))
                    return true;
        return false;
    }
    if (a_axis < 0)
        return degenerate_triangle_intersect(a, b);
    if (b_axis < 0)
        return degenerate_triangle_intersect(b, a);
    return edges_intersect(a, a_signs, b, b_axis) || edges_intersect(b, b_signs, a, a_axis);
}

PointTriangleClosest point_triangle_closest(
    const Vec3& p, const Vec3& t0, const Vec3& t1, const Vec3& t2)
{
    const Vec3 e1 = t1 - t0;
    const Vec3 e2 = t2 - t0;
    const double area2 = e1.cross(e2).squaredNorm();
    // Below this the face region's weights lose all accuracy: treat the triangle as its edges.
    if (!(area2 > 1e-24 * e1.squaredNorm() * e2.squaredNorm()))
        return closest_on_edges(p, t0, t1, t2);

    // Voronoi regions of the corners, then of the edges, else the face (Ericson 5.1.5).
    const Vec3 p0 = p - t0;
    const double d1 = e1.dot(p0);
    const double d2 = e2.dot(p0);
    if (d1 <= 0.0 && d2 <= 0.0)
        return make_closest(p, t0, t1, t2, Vec3(1.0, 0.0, 0.0));
    const Vec3 p1 = p - t1;
    const double d3 = e1.dot(p1);
    const double d4 = e2.dot(p1);
    if (d3 >= 0.0 && d4 <= d3)
        return make_closest(p, t0, t1, t2, Vec3(0.0, 1.0, 0.0));
    const Vec3 p2 = p - t2;
    const double d5 = e1.dot(p2);
    const double d6 = e2.dot(p2);
    if (d6 >= 0.0 && d5 <= d6)
        return make_closest(p, t0, t1, t2, Vec3(0.0, 0.0, 1.0));

    // Edge regions: the signed areas (scaled) opposite each corner.
    const double w2 = d1 * d4 - d3 * d2; // opposite t2: edge t0 t1
    if (w2 <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        const double s = d1 / (d1 - d3);
        return make_closest(p, t0, t1, t2, Vec3(1.0 - s, s, 0.0));
    }
    const double w1 = d5 * d2 - d1 * d6; // opposite t1: edge t0 t2
    if (w1 <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        const double s = d2 / (d2 - d6);
        return make_closest(p, t0, t1, t2, Vec3(1.0 - s, 0.0, s));
    }
    const double w0 = d3 * d6 - d5 * d4; // opposite t0: edge t1 t2
    if (w0 <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
        const double s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return make_closest(p, t0, t1, t2, Vec3(0.0, 1.0 - s, s));
    }
    const double sum = w0 + w1 + w2;
    return make_closest(p, t0, t1, t2, Vec3(w0 / sum, w1 / sum, w2 / sum));
}

SegmentSegmentClosest segment_segment_closest(
    const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1)
{
    // The squared distance is a convex quadratic on [0, 1]^2: its minimum is the unconstrained
    // one (the closest points of the two lines) when that lies in the square, else it lies on
    // a side of the square, where one parameter is 0 or 1 and the other is a point-segment
    // projection. Ericson (5.1.9) visits these cases by clamping; comparing the candidates
    // instead also covers parallel and zero-length segments without special cases.
    const Vec3 da = a1 - a0;
    const Vec3 db = b1 - b0;
    const Vec3 r = a0 - b0;
    const double aa = da.squaredNorm();
    const double bb = db.squaredNorm();
    const double ab = da.dot(db);

    SegmentSegmentClosest best;
    best.squared_distance = std::numeric_limits<double>::infinity();
    const auto consider = [&](double s, double t) {
        const Vec3 pa = a0 + s * da;
        const Vec3 pb = b0 + t * db;
        const double d2 = (pa - pb).squaredNorm();
        if (d2 < best.squared_distance) {
            best.s = s;
            best.t = t;
            best.point_a = pa;
            best.point_b = pb;
            best.squared_distance = d2;
        }
    };

    // Nearly parallel lines give an inaccurate interior solution: it is still a pair of points
    // of the segments, kept only if it beats the sides of the square.
    const double denominator = aa * bb - ab * ab;
    if (denominator > 0.0) {
        const double s = (ab * db.dot(r) - bb * da.dot(r)) / denominator;
        const double t = (aa * db.dot(r) - ab * da.dot(r)) / denominator;
        if (s >= 0.0 && s <= 1.0 && t >= 0.0 && t <= 1.0) {
            consider(s, t);
            if (denominator > 1e-14 * aa * bb)
                return best;
        }
    }
    consider(0.0, segment_point_parameter(a0, b0, b1));
    consider(1.0, segment_point_parameter(a1, b0, b1));
    consider(segment_point_parameter(b0, a0, a1), 0.0);
    consider(segment_point_parameter(b1, a0, a1), 1.0);
    return best;
}

} // namespace mat
