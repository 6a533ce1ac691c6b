#pragma once
// Structured tet meshes of a box for tests and benchmarks that must not depend on CGAL.

#include <cstdint>

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat::test {

struct GridTetOptions {
    int nx = 4; ///< cells along x
    int ny = 4; ///< cells along y
    int nz = 4; ///< cells along z
    Vec3 min_corner = Vec3::Zero();
    Vec3 max_corner = Vec3::Ones();
    /// Interior nodes are moved by up to jitter * cell size along each axis (uniformly random,
    /// seeded), which makes the mesh irregular with obtuse tets. Keep it <= 0.2 so every tet
    /// stays positively oriented (checked). Boundary nodes never move: the box volume is exact.
    double jitter = 0.0;
    std::uint32_t seed = 1;
};

/// A box split into nx*ny*nz cubes, each cut into 6 positively oriented tets around its main
/// diagonal (the Kuhn / Freudenthal split, conforming across cubes). Nodes are numbered
/// x fastest: node(i, j, k) = i + (nx+1) * (j + (ny+1) * k).
TetMesh make_grid_tets(const GridTetOptions& options);

/// Index of grid node (i, j, k) in a mesh made with `options`.
int grid_node(const GridTetOptions& options, int i, int j, int k);

/// Signed volumes of the tets  #T: det[x1-x0, x2-x0, x3-x0] / 6.
VecX signed_tet_volumes(const TetMesh& mesh);

} // namespace mat::test
