#pragma once
// Small geometric queries on the tets of a TetMesh.

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

/// det[x1-x0, x2-x0, x3-x0] of tet `t` (six times its signed volume): > 0 for a positively
/// oriented tet, 0 for a flat one. `t` must be a valid tet with valid vertex indices.
inline double tet_orientation(const TetMesh& mesh, Index t)
{
    const Vec3 x0 = mesh.positions.row(mesh.tets(t, 0));
    const Vec3 e1 = mesh.positions.row(mesh.tets(t, 1)).transpose() - x0;
    const Vec3 e2 = mesh.positions.row(mesh.tets(t, 2)).transpose() - x0;
    const Vec3 e3 = mesh.positions.row(mesh.tets(t, 3)).transpose() - x0;
    return e1.dot(e2.cross(e3));
}

} // namespace mat
