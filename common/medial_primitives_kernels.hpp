#pragma once
// Internal kernels of the medial primitives: query-independent data of cones and slabs (tangent
// cones, tangent planes) and the exact distance computations. Users include
// common/medial_primitives.hpp; this header is for the library's own translation units (and
// collision code that wants the precomputed form). The derivation is at the top of
// medial_primitives_kernels.cpp.

#include <array>
#include <utility>

#include "common/medial_primitives.hpp"

namespace mat::detail {

/// Bounding box of `count` balls.
Box3 balls_bounds(const Vec3* centers, const double* radii, int count);

/// Query-independent data of a pair of spheres (a cone, or an edge of a slab).
struct PairData {
    Vec3 c0 = Vec3::Zero(), c1 = Vec3::Zero();
    double r0 = 0.0, r1 = 0.0;
    Vec3 d = Vec3::Zero(); ///< c1 - c0
    double length2 = 0.0; ///< |d|^2
    double dr = 0.0; ///< r1 - r0
    bool swallowed = true; ///< |d| <= |dr|: one ball contains the other
    Vec3 u = Vec3::UnitX(); ///< d / |d| (when !swallowed)
    double kappa = 0.0; ///< tangent-cone normals n satisfy n.u = kappa = -dr / |d|
    double sigma = 0.0; ///< sqrt(1 - kappa^2)

    PairData() = default;
    PairData(const Vec3& a, double ra, const Vec3& b, double rb);

    /// |p - c(t)| - r(t).
    double value(double t, const Vec3& p) const
    {
        return ((1.0 - t) * c0 + t * c1 - p).norm() - ((1.0 - t) * r0 + t * r1);
    }
    /// min over t in [0, 1] of |p - c(t)| - r(t), and its argmin t.
    std::pair<double, double> sphere_distance(const Vec3& p) const;
    /// The tangent-cone candidate normal for the query p (requires !swallowed).
    Vec3 circle_normal(const Vec3& p) const;
};

/// Exact signed distance from p to the cone's volume, with its parameter.
ConeDistance cone_distance(const PairData& cone, const Vec3& p);

/// A plane tangent to the three balls of a slab, with the dual basis of its triangle of tangent
/// points T_i = c_i + r_i n: a point x of the plane has barycentric coordinates
/// a = g0.(x - T2), b = g1.(x - T2).
struct TangentPlane {
    Vec3 normal = Vec3::UnitZ(); ///< unit, pointing out of the slab
    double support = 0.0; ///< normal.c_i + r_i, the same for the three spheres
    bool has_triangle = false; ///< false if the tangent points are collinear
    Vec3 origin = Vec3::Zero(); ///< T2
    Vec3 g0 = Vec3::Zero(), g1 = Vec3::Zero();
};

/// Query-independent data of a slab.
struct SlabData {
    std::array<Vec3, 3> c;
    std::array<double, 3> r = { 0.0, 0.0, 0.0 };
    std::array<PairData, 3> edges; ///< spheres (0,1), (1,2), (2,0)
    int num_planes = 0; ///< 0, 1 or 2 tangent planes
    std::array<TangentPlane, 2> planes;

    SlabData() = default;
    SlabData(const std::array<Vec3, 3>& centers, const std::array<double, 3>& radii);

    /// |p - c(a, b)| - r(a, b).
    double value(double a, double b, const Vec3& p) const
    {
        const double w = 1.0 - a - b;
        return (a * c[0] + b * c[1] + w * c[2] - p).norm() - (a * r[0] + b * r[1] + w * r[2]);
    }
    /// Exact signed distance from p to the slab's volume, with its parameter.
    SlabDistance distance(const Vec3& p) const;
};

/// Throws mat::Error unless `sphere` is a valid sphere index of `mesh`.
void check_sphere_index(const MedialMesh& mesh, const char* kind, Index element, Index sphere);

/// Throws mat::Error naming the first cone or slab with an out-of-range sphere index.
void check_mesh(const MedialMesh& mesh);

} // namespace mat::detail
