#pragma once
// Distance from points to a closed triangle surface: a bounding-volume hierarchy of the
// triangles for the closest point, and the sign from the angle-weighted pseudo-normal of the
// closest feature (face, edge or vertex), which is exact for a closed, manifold, outward surface
// (Baerentzen and Aanaes 2005).

#include <vector>

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

/// The closest point of a surface to a query point.
struct SurfaceClosestPoint {
    double distance = 0.0; ///< unsigned distance to the surface
    Vec3 point = Vec3::Zero(); ///< the closest surface point
    Index face = -1; ///< the face it lies on
};

/// Immutable after construction; every query is safe to call concurrently.
class SurfaceDistance {
public:
    /// Builds the hierarchy over the faces of `surface` (copied: no reference is kept). The
    /// surface should be closed, manifold and outward for signed_distance(); closest() works on
    /// any triangle soup. Throws mat::Error if it has no face.
    explicit SurfaceDistance(const SurfaceMesh& surface);

    SurfaceClosestPoint closest(const Eigen::Ref<const Vec3>& p) const;
    double unsigned_distance(const Eigen::Ref<const Vec3>& p) const;
    /// Negative inside, positive outside.
    double signed_distance(const Eigen::Ref<const Vec3>& p) const;

    /// True if some surface point lies within `radius` of p (faster than closest(): it stops at
    /// the first face found).
    bool any_within(const Eigen::Ref<const Vec3>& p, double radius) const;

    /// Bounding box of the surface.
    const Box3& bounds() const { return m_bounds; }

private:
    struct Node {
        Box3 box;
        int first = 0; ///< leaf: first entry of m_order; inner: index of the left child
        int count = 0; ///< leaf: number of faces; inner: 0
        int right = 0; ///< inner: index of the right child
    };
    /// Closest point on face f, with the feature: 0-2 vertex, 3-5 edge (v_k, v_k+1), 6 face.
    Vec3 closest_on_face(Index f, const Vec3& p, int& feature) const;
    int build(int begin, int end, const std::vector<Vec3>& centroids);
    void search(const Vec3& p, double& best_squared, Index& best_face, Vec3& best_point,
        int& best_feature) const;

    MatX3 m_positions; ///< #V x 3
    MatX3i m_faces; ///< #F x 3
    MatX3 m_face_normals; ///< #F x 3, unit
    MatX3 m_vertex_normals; ///< #V x 3, angle-weighted pseudo-normals
    MatX3 m_edge_normals; ///< (#F * 3) x 3, pseudo-normal of edge (v_k, v_k+1) of each face
    std::vector<int> m_order; ///< face indices, leaf ranges point into it
    std::vector<Node> m_nodes;
    Box3 m_bounds;
};

} // namespace mat
