#include "preprocess/meshing/tet_quality.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mat {
namespace {

    /// The dihedral angle at edge (a, b) between the faces (a, b, c) and (a, b, d): the angle
    /// between c and d projected onto the plane orthogonal to the edge.
    double dihedral_at_edge(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d)
    {
        const Vec3 axis = (b - a).normalized();
        const Vec3 u = (c - a) - (c - a).dot(axis) * axis;
        const Vec3 v = (d - a) - (d - a).dot(axis) * axis;
        return std::atan2(u.cross(v).norm(), u.dot(v)) * 180.0 / M_PI;
    }

} // namespace

Eigen::Matrix<double, 6, 1> tet_dihedral_angles_degrees(const Eigen::Ref<const Vec3>& p0,
    const Eigen::Ref<const Vec3>& p1, const Eigen::Ref<const Vec3>& p2,
    const Eigen::Ref<const Vec3>& p3)
{
    Eigen::Matrix<double, 6, 1> angles;
    angles << dihedral_at_edge(p0, p1, p2, p3), dihedral_at_edge(p0, p2, p1, p3),
        dihedral_at_edge(p0, p3, p1, p2), dihedral_at_edge(p1, p2, p0, p3),
        dihedral_at_edge(p1, p3, p0, p2), dihedral_at_edge(p2, p3, p0, p1);
    return angles;
}

TetQuality tet_quality(const TetMesh& mesh)
{
    TetQuality quality;
    quality.num_tets = mesh.num_tets();
    quality.num_vertices = mesh.num_vertices();
    if (mesh.num_tets() == 0)
        return quality;
    quality.min_dihedral_degrees = std::numeric_limits<double>::infinity();
    quality.max_dihedral_degrees = -std::numeric_limits<double>::infinity();
    quality.min_volume = std::numeric_limits<double>::infinity();
    for (Index t = 0; t < mesh.num_tets(); ++t) {
        const Vec3 p0 = mesh.positions.row(mesh.tets(t, 0)).transpose();
        const Vec3 p1 = mesh.positions.row(mesh.tets(t, 1)).transpose();
        const Vec3 p2 = mesh.positions.row(mesh.tets(t, 2)).transpose();
        const Vec3 p3 = mesh.positions.row(mesh.tets(t, 3)).transpose();
        const auto angles = tet_dihedral_angles_degrees(p0, p1, p2, p3);
        quality.min_dihedral_degrees = std::min(quality.min_dihedral_degrees, angles.minCoeff());
        quality.max_dihedral_degrees = std::max(quality.max_dihedral_degrees, angles.maxCoeff());
        const double volume = (p1 - p0).cross(p2 - p0).dot(p3 - p0) / 6.0;
        quality.min_volume = std::min(quality.min_volume, volume);
        quality.total_volume += volume;
    }
    return quality;
}

double min_dihedral_angle_degrees(const TetMesh& mesh)
{
    return tet_quality(mesh).min_dihedral_degrees;
}

} // namespace mat
