#pragma once
// Element quality of tet meshes: dihedral angles and volumes, for reports and tests.

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

/// A one-pass summary of a tet mesh's quality.
struct TetQuality {
    Index num_tets = 0;
    Index num_vertices = 0;
    double min_dihedral_degrees = 0.0; ///< over all tets and their 6 edges
    double max_dihedral_degrees = 0.0;
    double min_volume = 0.0; ///< signed; <= 0 means a degenerate or inverted tet
    double total_volume = 0.0;
};

/// The 6 interior dihedral angles of a tet, in degrees, at edges 01, 02, 03, 12, 13, 23.
/// p0..p3  the corners
Eigen::Matrix<double, 6, 1> tet_dihedral_angles_degrees(const Eigen::Ref<const Vec3>& p0,
    const Eigen::Ref<const Vec3>& p1, const Eigen::Ref<const Vec3>& p2,
    const Eigen::Ref<const Vec3>& p3);

/// The smallest dihedral angle over all tets, in degrees (0 for an empty mesh).
double min_dihedral_angle_degrees(const TetMesh& mesh);

/// Dihedral range, volumes and counts.
TetQuality tet_quality(const TetMesh& mesh);

} // namespace mat
