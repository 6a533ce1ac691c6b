#pragma once
// Triangle-level narrow phase (docs/method.md, section 4, step 5): an exact triangle-triangle
// intersection test, and the closest-point queries a contact response needs (vertex-triangle,
// edge-edge).
//
// What "exact" means here. Every decision of triangles_intersect is the sign of an orientation
// determinant (orient2d, orient3d) of input coordinates. Each sign is the sign of the exact real
// determinant of the given doubles: a floating-point evaluation is trusted only when its
// magnitude exceeds a forward error bound (Shewchuk's static filter), otherwise the determinant
// is evaluated again in exact expansion arithmetic (sums of non-overlapping doubles built with
// error-free transformations: two-sum and an fma two-product). The test therefore answers the
// question for the closed triangles whose corners are exactly the given doubles: touching at a
// point or along an edge counts as intersecting, coplanar overlap is found, degenerate
// (zero-area) triangles are treated as the segments or points they are.
// Failure modes: coordinates must be finite, and the exact expansions must neither overflow nor
// underflow: coordinates below ~1e100 in magnitude, and nonzero coordinate differences above
// ~1e-90 (the smallest components of a product of three differences are ~1e-32 of it and must
// stay normal doubles). Outside that range (or with NaN) the answer is unspecified, but the call
// returns normally.
// The closest-point queries are ordinary floating-point computations (not exact).

#include "common/eigen_types.hpp"

namespace mat {

/// Sign (-1, 0, +1) of det[b - a, c - a] on the (x, y) coordinates: +1 when a, b, c turn
/// counter-clockwise. Exact for finite inputs.
int orient2d(const Vec2& a, const Vec2& b, const Vec2& c);

/// Sign (-1, 0, +1) of det[a - d, b - d, c - d]: +1 when d lies below the plane through a, b, c
/// oriented so that a, b, c appear counter-clockwise from above (Shewchuk's convention), 0 when
/// the four points are coplanar. Exact for finite inputs.
int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// True when the closed triangles (a0, a1, a2) and (b0, b1, b2) share at least one point.
/// Exact (see above); handles coplanar and degenerate triangles. Triangles that share a vertex
/// always intersect: callers exclude adjacent pairs themselves.
bool triangles_intersect(
    const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1, const Vec3& b2);

/// True when the closed segment (a, b) and the closed triangle (t0, t1, t2) share a point.
/// Exact; handles degenerate segments and triangles.
bool segment_triangle_intersect(
    const Vec3& a, const Vec3& b, const Vec3& t0, const Vec3& t1, const Vec3& t2);

/// The point of a triangle closest to a query point.
struct PointTriangleClosest {
    Vec3 point = Vec3::Zero(); ///< the closest point of the triangle
    Vec3 barycentric = Vec3::Zero(); ///< its weights on (t0, t1, t2), >= 0, sum 1
    double squared_distance = 0.0;
};

/// Closest point of the closed triangle (t0, t1, t2) to p, by Voronoi-region tests
/// (Ericson, Real-Time Collision Detection, section 5.1.5). Degenerate triangles fall back to
/// the closest of their three edges.
PointTriangleClosest point_triangle_closest(
    const Vec3& p, const Vec3& t0, const Vec3& t1, const Vec3& t2);

/// The closest pair of points of two segments.
struct SegmentSegmentClosest {
    double s = 0.0; ///< parameter on the first segment: a0 + s (a1 - a0), in [0, 1]
    double t = 0.0; ///< parameter on the second segment: b0 + t (b1 - b0), in [0, 1]
    Vec3 point_a = Vec3::Zero();
    Vec3 point_b = Vec3::Zero();
    double squared_distance = 0.0;
};

/// Closest points of the closed segments (a0, a1) and (b0, b1) (Ericson, section 5.1.9).
/// Parallel and zero-length segments are handled; for parallel segments one of the closest
/// pairs is returned.
SegmentSegmentClosest segment_segment_closest(
    const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1);

} // namespace mat
