#pragma once
// Narrow phase of the collision world (METHOD.md section 4, last step) for one pair of colliding
// medial primitives: only the surface triangles and boundary nodes of the two primitives that
// lie in the pair's overlap region (the intersection of the two enlarged primitives' boxes,
// grown by the contact margin) are tested:
//   - exact triangle-triangle intersection between the two triangle lists (box-filtered), each
//     intersecting pair recorded once per primitive pair;
//   - each node of one primitive against the triangles of the other: the closest triangle
//     within the margin (or behind it), one candidate per node and primitive pair.
// Reads flat per-step arrays only, writes into a caller-owned scratch (capacity reused: no
// allocation once warm), and is safe to call concurrently with distinct scratches.

#include <array>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// One body as the narrow phase reads it, world coordinates, for one step. Pointers, not owned.
struct NarrowPhaseBody {
    const MatX3* surface = nullptr; ///< #Vs x 3 surface vertex positions
    const MatX3i* faces = nullptr; ///< #F x 3
    const std::vector<Box3>* face_boxes = nullptr; ///< #F boxes of the triangles at `surface`
    const MatX3* face_normals = nullptr; ///< #F x 3 unit normals (+y for a degenerate face)
    const MatX3* nodes = nullptr; ///< n x 3 tet-mesh node positions
    const VecXi* face_indptr = nullptr; ///< #P + 1, CSR of the faces enclosed by each primitive
    const VecXi* face_list = nullptr;
    const VecXi* node_indptr = nullptr; ///< #P + 1, CSR of the boundary nodes of each primitive
    const VecXi* node_list = nullptr;
    bool is_static = false; ///< its nodes get no contacts
};

/// The closest triangle of another body to one node, found in one primitive pair.
struct NodeCandidate {
    int body = 0; ///< the node's body
    int node = 0;
    int pair = 0; ///< index of the primitive pair that found it (for a deterministic merge)
    int other_body = 0;
    double distance = 0.0; ///< signed: negative behind the triangle
    Vec3 closest = Vec3::Zero(); ///< closest point of the triangle
    Vec3 normal = Vec3::UnitY(); ///< the triangle's unit outward normal
};

/// (body_a, face_a, body_b, face_b) with (body_a, face_a) < (body_b, face_b).
using FacePair = std::array<int, 4>;

/// Per-thread output and workspace of narrow_phase_pair (clear() keeps the capacity).
struct NarrowPhaseScratch {
    std::vector<int> faces_a, faces_b; ///< the faces in the region, workspace
    std::vector<NodeCandidate> candidates;
    std::vector<FacePair> intersecting;
    long triangle_tests = 0;

    void clear()
    {
        candidates.clear();
        intersecting.clear();
        triangle_tests = 0;
    }
};

/// One colliding primitive pair (prim_a of body_a, prim_b of body_b): appends to `scratch` the
/// intersecting triangle pairs and the node candidates found in `region` (the intersection of
/// the two primitives' boxes) grown by `margin`. Triangles of one body that share a vertex are
/// never tested. `pair` tags the candidates.
void narrow_phase_pair(const NarrowPhaseBody& a, int body_a, int prim_a, const NarrowPhaseBody& b,
    int body_b, int prim_b, const Box3& region, double margin, int pair,
    NarrowPhaseScratch& scratch);

} // namespace mat
