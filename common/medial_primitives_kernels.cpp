#include "common/medial_primitives_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.hpp"

// Derivation of the exact signed distance.
//
// Let K be the volume of a primitive with spheres (c_i, r_i), i = 1..k (k = 2 or 3), and S(l)
// the interpolated sphere at barycentric weights l. K = union of S(l) = convex hull of the k
// balls: S(l) = sum l_i B_i (Minkowski) lies in the hull, and a convex combination of points
// x_i in B_i lies in S(l) by the triangle inequality.
//
// (1) Outside: dist(p, K) = min_l dist(p, S(l)) = min_l |p - c(l)| - r(l) =: U. The function
//     F(l) = |c(l) - p| - r(l) is convex (norm of an affine map minus an affine map), so its
//     minimum over the simplex is an interior critical point or lies on a face. Cone: the
//     critical t of F solves (A t + B) = dr |v(t)| (v(t) = c(t) - p, A = |d|^2, B = v(0).d,
//     dr = r1 - r0), whose root is t = (dr sqrt(D / (A - dr^2)) - B) / A, D = |v(0) x d|^2,
//     when A > dr^2; when A <= dr^2 one ball contains the other and F is monotone, so the
//     bigger sphere wins. Slab: an interior critical point satisfies (c - p)/|c - p| = -n with
//     n.(c_i - c_j) = r_j - r_i, i.e. n is the normal of one of the (at most two) planes
//     tangent to the three balls; the sphere S(l) touches that plane at c(l) + r(l) n, which
//     is the foot of p on the plane, so l = barycentric coordinates of the foot in the
//     triangle of tangent points c_i + r_i n (and it is a critical point only if |c - p| =
//     n.p - h(n) + r(l) >= 0, h below). Being convex, F has no other minimum: when this point
//     exists the edges are skipped. Else the minimum is on the three edge cones. When the
//     triangle is degenerate F is affine along a segment of parameters with a constant center,
//     so the minimum is on an edge. Every candidate is evaluated with F itself, so a rounding
//     error in a candidate can only raise U, never make it smaller than the true minimum.
//
// (2) Both sides: K is convex with support function h(n) = max_i (n.c_i + r_i). For any convex
//     body, sd(p) = max over unit n of (n.p - h(n)) (outside: separating plane through the
//     closest point; inside: the largest ball around p in K touches a supporting plane). So
//     sd(p) = -min_{|n|=1} f(n), f(n) = max_i g_i(n), g_i(n) = n.(c_i - p) + r_i.
//     At a minimizer n* of f on the unit sphere let A be the set of active g_i:
//       |A| = 1: n* is a local minimum of g_i on the sphere: n = (p - c_i)/|p - c_i|. (If
//                p = c_i, g_i is constant; the region where i alone is active is then the
//                whole sphere, and any n does, or it is bounded by points of cases 2 and 3.)
//       |A| = 2: n* lies on the circle g_i = g_j, i.e. n.u = (r_i - r_j)/|c_j - c_i|
//                (u = (c_j - c_i)/|c_j - c_i|): the normals of the tangent cone of balls i, j.
//                There g_i = a + b cos(angle): its only local minimum is n = kappa u +
//                sqrt(1 - kappa^2) w, w the unit vector from the axis towards p (any w orthogonal
//                to u if p is on the axis: g_i is then constant on the circle).
//       |A| = 3: n* is one of the two normals of the planes tangent to the three balls (or,
//                when these constraints are dependent, a point of a circle of case 2).
//     These are at most 8 candidates (sphere patches, tangent-cone patches, the two flat faces
//     of the hull); min over candidates of f is exactly min f. Each candidate is normalized,
//     so f(candidate) >= min f: a rounding error in a candidate can only overstate the depth,
//     by that error, and never understate it. Note that inside, sd(p) differs from
//     U = min_l |p - c(l)| - r(l) (U is minus the depth in the deepest single sphere, sd is
//     minus the distance to the hull's boundary; U >= sd).
//
// We return U outside (U > 0) and min(U, -min_candidates f) inside: the sign is the sign of U,
// so containment (U <= 0) and the sign always agree.

namespace mat::detail {

namespace {

    constexpr double k_infinity = std::numeric_limits<double>::infinity();

    /// Any unit vector orthogonal to the unit vector u.
    Vec3 any_orthogonal(const Vec3& u)
    {
        const Vec3 axis = std::abs(u.x()) < 0.5 ? Vec3::UnitX()
            : std::abs(u.y()) < 0.5             ? Vec3::UnitY()
                                                : Vec3::UnitZ();
        return u.cross(axis).normalized();
    }

    /// (p - c)/|p - c|, or an arbitrary unit vector when p == c (see section (2), |A| = 1).
    Vec3 direction_from(const Vec3& c, const Vec3& p)
    {
        const Vec3 v = p - c;
        const double n = v.norm();
        return n > 0.0 ? Vec3(v / n) : Vec3(Vec3::UnitX());
    }

    /// f(n) = max_i n.(c_i - p) + r_i of section (2).
    template <int Count>
    double support_gap(const std::array<Vec3, Count>& c, const std::array<double, Count>& r,
        const Vec3& n, const Vec3& p)
    {
        double f = -k_infinity;
        for (int i = 0; i < Count; ++i)
            f = std::max(f, n.dot(c[i] - p) + r[i]);
        return f;
    }

} // namespace

Box3 balls_bounds(const Vec3* centers, const double* radii, int count)
{
    Box3 box;
    for (int i = 0; i < count; ++i) {
        box.extend(centers[i] - Vec3::Constant(radii[i]));
        box.extend(centers[i] + Vec3::Constant(radii[i]));
    }
    return box;
}

// ---- cones ----

PairData::PairData(const Vec3& a, double ra, const Vec3& b, double rb)
    : c0(a)
    , c1(b)
    , r0(ra)
    , r1(rb)
    , d(b - a)
    , length2(d.squaredNorm())
    , dr(rb - ra)
    , swallowed(length2 <= dr * dr)
{
    if (!swallowed) {
        const double length = std::sqrt(length2);
        u = d / length;
        kappa = std::clamp(-dr / length, -1.0, 1.0);
        sigma = std::sqrt(std::max(0.0, 1.0 - kappa * kappa));
    }
}

// Section (1): the critical point of the convex |p - c(t)| - r(t), clamped to [0, 1].
std::pair<double, double> PairData::sphere_distance(const Vec3& p) const
{
    double t;
    if (swallowed) {
        t = dr > 0.0 ? 1.0 : 0.0;
    } else {
        const Vec3 v0 = c0 - p;
        const double b = v0.dot(d);
        const double cross2 = v0.cross(d).squaredNorm();
        const double root = dr * std::sqrt(cross2 / (length2 - dr * dr));
        t = std::clamp((root - b) / length2, 0.0, 1.0);
    }
    return { value(t, p), t };
}

// Section (2), |A| = 2: n = kappa u + sigma w, w the unit vector from the axis towards p. When p
// is on the axis up to rounding, q_perp is noise that need not be orthogonal to u: project
// again, and fall back to any orthogonal direction (all are equivalent there). The candidate
// must be a unit vector: then f(n) >= min f, and rounding can never make the depth too large.
Vec3 PairData::circle_normal(const Vec3& p) const
{
    const Vec3 q = p - c0;
    Vec3 w = q - q.dot(u) * u;
    w -= w.dot(u) * u;
    const double norm = w.norm();
    w = norm > 1e-12 * q.norm() ? Vec3(w / norm) : any_orthogonal(u);
    return (kappa * u + sigma * w).normalized();
}

ConeDistance cone_distance(const PairData& cone, const Vec3& p)
{
    ConeDistance result;
    const auto [value, t] = cone.sphere_distance(p);
    result.sphere_distance = value;
    result.t = t;
    result.signed_distance = value;
    if (value > 0.0)
        return result;
    const std::array<Vec3, 2> c = { cone.c0, cone.c1 };
    const std::array<double, 2> r = { cone.r0, cone.r1 };
    double depth = std::min(support_gap<2>(c, r, direction_from(c[0], p), p),
        support_gap<2>(c, r, direction_from(c[1], p), p));
    if (!cone.swallowed)
        depth = std::min(depth, support_gap<2>(c, r, cone.circle_normal(p), p));
    result.signed_distance = std::min(value, -depth);
    return result;
}

// ---- slabs ----

SlabData::SlabData(const std::array<Vec3, 3>& centers, const std::array<double, 3>& radii)
    : c(centers)
    , r(radii)
    , edges { PairData(c[0], r[0], c[1], r[1]), PairData(c[1], r[1], c[2], r[2]),
        PairData(c[2], r[2], c[0], r[0]) }
{
    // Tangent planes: n.e_i = -rho_i (e_i = c_i - c2, rho_i = r_i - r2), |n| = 1. The in-plane
    // part solving the two equations is n0 = ((rho1 e0 - rho0 e1) x m) / |m|^2, m = e0 x e1
    // (cross products rather than the squared Gram system, for accuracy); then
    // n = n0 +- sqrt(1 - |n0|^2) m / |m|.
    const Vec3 e0 = c[0] - c[2];
    const Vec3 e1 = c[1] - c[2];
    const double rho0 = r[0] - r[2];
    const double rho1 = r[1] - r[2];
    const Vec3 m = e0.cross(e1);
    const double m2 = m.squaredNorm();
    if (!(m2 > 0.0) || !std::isfinite(m2))
        return; // collinear centers: the edges cover every case
    const Vec3 n0 = (rho1 * e0 - rho0 * e1).cross(m) / m2;
    const double n0_2 = n0.squaredNorm();
    if (!(n0_2 <= 1.0))
        return; // no plane touches the three balls: one pokes out of the others' hull
    const Vec3 m_unit = m / std::sqrt(m2);
    const double height = std::sqrt(1.0 - n0_2);
    for (const double sign : { 1.0, -1.0 }) {
        TangentPlane& plane = planes[num_planes++];
        plane.normal = (n0 + sign * height * m_unit).normalized();
        plane.support = support_gap<3>(c, r, plane.normal, Vec3::Zero());
        std::array<Vec3, 3> tangent;
        for (int i = 0; i < 3; ++i)
            tangent[i] = c[i] + r[i] * plane.normal;
        const Vec3 t0 = tangent[0] - tangent[2];
        const Vec3 t1 = tangent[1] - tangent[2];
        const Vec3 tm = t0.cross(t1);
        const double tm2 = tm.squaredNorm();
        plane.origin = tangent[2];
        plane.has_triangle = tm2 > 0.0 && std::isfinite(tm2);
        if (plane.has_triangle) {
            plane.g0 = t1.cross(tm) / tm2;
            plane.g1 = tm.cross(t0) / tm2;
        }
        if (height == 0.0)
            break; // the two planes coincide
    }
}

SlabDistance SlabData::distance(const Vec3& p) const
{
    SlabDistance result;
    // Section (1): an interior critical point on a tangent plane is the global minimum (F is
    // convex); it is one when p's foot lies in the triangle of tangent points and the sphere
    // there is on the far side of p's foot (|c - p| = n.p - h + r >= 0). Else the three edges.
    double best = k_infinity;
    Vec2 best_ab = Vec2::Zero();
    bool critical = false;
    for (int k = 0; k < num_planes && !critical; ++k) {
        const TangentPlane& plane = planes[k];
        if (!plane.has_triangle)
            continue;
        const Vec3 x = p - plane.origin;
        const double a = plane.g0.dot(x);
        const double b = plane.g1.dot(x);
        if (a >= 0.0 && b >= 0.0 && a + b <= 1.0) {
            const double v = value(a, b, p);
            if (v < best) {
                best = v;
                best_ab = Vec2(a, b);
            }
            const double radius = a * r[0] + b * r[1] + (1.0 - a - b) * r[2];
            critical = plane.normal.dot(p) - plane.support + radius >= 0.0;
        }
    }
    for (int e = 0; e < 3 && !critical; ++e) {
        const auto [value, t] = edges[e].sphere_distance(p);
        if (value < best) {
            best = value;
            best_ab = e == 0 ? Vec2(1.0 - t, t) : e == 1 ? Vec2(0.0, 1.0 - t) : Vec2(t, 0.0);
        }
    }
    result.sphere_distance = best;
    result.ab = best_ab;
    result.signed_distance = best;
    if (best > 0.0)
        return result;
    // Section (2): inside, the distance to the boundary of the hull.
    double depth = k_infinity;
    for (int i = 0; i < 3; ++i)
        depth = std::min(depth, support_gap<3>(c, r, direction_from(c[i], p), p));
    for (int e = 0; e < 3; ++e) {
        if (!edges[e].swallowed)
            depth = std::min(depth, support_gap<3>(c, r, edges[e].circle_normal(p), p));
    }
    for (int k = 0; k < num_planes; ++k)
        depth = std::min(depth, planes[k].support - planes[k].normal.dot(p));
    result.signed_distance = std::min(best, -depth);
    return result;
}

// ---- validation ----

void check_sphere_index(const MedialMesh& mesh, const char* kind, Index element, Index sphere)
{
    if (sphere < 0 || sphere >= mesh.num_spheres())
        throw_error("medial mesh: {} {} references sphere {}, but there are {} spheres", kind,
            element, sphere, mesh.num_spheres());
}

void check_mesh(const MedialMesh& mesh)
{
    if (mesh.radii.size() != mesh.num_spheres())
        throw_error("medial mesh: {} centers but {} radii", mesh.num_spheres(), mesh.radii.size());
    for (Index i = 0; i < mesh.num_spheres(); ++i) {
        if (!mesh.centers.row(i).allFinite() || !std::isfinite(mesh.radii(i))
            || mesh.radii(i) < 0.0)
            throw_error("medial mesh: sphere {} has center ({}, {}, {}) and radius {}; expected "
                        "finite values and a radius >= 0",
                i, mesh.centers(i, 0), mesh.centers(i, 1), mesh.centers(i, 2), mesh.radii(i));
    }
    for (Index i = 0; i < mesh.num_cones(); ++i)
        for (int k = 0; k < 2; ++k)
            check_sphere_index(mesh, "cone", i, mesh.cones(i, k));
    for (Index i = 0; i < mesh.num_slabs(); ++i)
        for (int k = 0; k < 3; ++k)
            check_sphere_index(mesh, "slab", i, mesh.slabs(i, k));
}

} // namespace mat::detail
