#pragma once
// Embeds points in a tet mesh (docs/method.md, section 2, step 2): each point gets a tet and its
// barycentric coordinates there, so that any nodal field interpolates to the point.

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

struct TetEmbedding {
    VecXi tet; ///< #P tet index per point
    MatX barycentric; ///< #P x 4, sums to 1; all >= 0 (up to rounding) for an inside point
    Index outside_count = 0; ///< points inside no tet (extrapolated coordinates)
    double max_outside_distance = 0.0; ///< largest distance of such a point to the mesh
};

/// Embeds `points  #P x 3` in `mesh`. A point inside several tets (on shared faces) takes the
/// one where it is deepest. A point inside none takes, among the tets around the corners of the
/// mesh's nearest boundary face, the one whose smallest barycentric coordinate is largest (the
/// least extrapolated: the nearest tet is often a flat one at the boundary, whose coordinates
/// reach far below 0), with its coordinates extrapolated (some negative) so that affine fields
/// are still reproduced exactly. Deterministic and parallel.
TetEmbedding embed_points(const TetMesh& mesh, const Eigen::Ref<const MatX3>& points);

/// Barycentric coordinates of p in tet (a, b, c, d) (may be negative outside).
Vec4 tet_barycentric(const Eigen::Ref<const Vec3>& a, const Eigen::Ref<const Vec3>& b,
    const Eigen::Ref<const Vec3>& c, const Eigen::Ref<const Vec3>& d,
    const Eigen::Ref<const Vec3>& p);

/// Distance from p to the (solid) tet (a, b, c, d); 0 inside.
double point_tet_distance(const Eigen::Ref<const Vec3>& a, const Eigen::Ref<const Vec3>& b,
    const Eigen::Ref<const Vec3>& c, const Eigen::Ref<const Vec3>& d,
    const Eigen::Ref<const Vec3>& p);

} // namespace mat
