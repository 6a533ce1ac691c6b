#pragma once
// Volumes of surface and tet meshes.

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

/// The signed volume enclosed by a closed triangle surface (divergence theorem:
/// V = 1/6 sum_f p0 . (p1 x p2)); positive when faces are oriented outward.
double surface_signed_volume(const SurfaceMesh& surface);

/// The signed volume of each tet, det[x1-x0, x2-x0, x3-x0] / 6; returns #T.
VecX tet_signed_volumes(const TetMesh& mesh);

} // namespace mat
