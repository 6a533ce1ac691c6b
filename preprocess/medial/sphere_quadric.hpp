#pragma once
// The spherical quadric error metric of Q-MAT (Li et al., ACM TOG 2015, section 4): the sum of
// squared distances from a sphere m = (c, r) to tangent planes n.x = d, each distance written
// (n, 1).m - d, which is zero when the sphere touches the plane from inside.

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "common/eigen_types.hpp"

namespace mat {

struct SphereQuadric {
    Mat4 a = Mat4::Zero();
    Vec4 b = Vec4::Zero();
    double c = 0.0;

    /// Adds the plane normal.x = offset (normal unit, pointing out of the solid).
    void add_plane(const Vec3& normal, double offset)
    {
        const Vec4 n(normal(0), normal(1), normal(2), 1.0);
        a.noalias() += n * n.transpose();
        b += offset * n;
        c += offset * offset;
    }

    /// Q-MAT eq. 5: m^T A m - 2 b^T m + c, clamped at 0 against rounding.
    double error(const Vec4& m) const { return std::max(0.0, m.dot(a * m) - 2 * b.dot(m) + c); }

    SphereQuadric operator+(const SphereQuadric& other) const
    {
        SphereQuadric sum = *this;
        sum.a += other.a;
        sum.b += other.b;
        sum.c += other.c;
        return sum;
    }

    /// The sphere of least error, Tikhonov-regularized towards `reference` so that directions
    /// the planes do not constrain (e.g. along a flat sheet) stay put.
    Vec4 minimizer(const Vec4& reference) const
    {
        const double epsilon = 1e-4 * a.trace() / 4.0 + 1e-300;
        return (a + epsilon * Mat4::Identity()).llt().solve(b + epsilon * reference);
    }
};

/// Stability ratio of an edge between spheres (Q-MAT section 5): (|c_i - c_j| - |r_i - r_j|) /
/// |c_i - c_j| in [0, 1]; 0 when one sphere holds the other (a spike of the sampled axis).
inline double stability_ratio(const Vec4& mi, const Vec4& mj)
{
    const double distance = (mi.head<3>() - mj.head<3>()).norm();
    if (!(distance > 0))
        return 0.0;
    return std::max(0.0, distance - std::abs(mi(3) - mj(3))) / distance;
}

} // namespace mat
