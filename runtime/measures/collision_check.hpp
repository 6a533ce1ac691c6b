#pragma once
// mat-run --check-collisions (the recall check of docs/method.md, section 7): after each step,
// the collision world's intersecting triangle pairs are compared with the exhaustive ground truth
// (intersecting_triangle_pairs over every surface triangle pair) on the same surfaces, in world
// coordinates, as the world saw them at its last detect(). The pairs are split by where their
// triangles lie (each triangle belongs to the primitives enclosing its vertices):
//   - far: the two triangles are in different bodies, or in one body and in two primitives that
//     share no medial sphere. The pipeline tests every such primitive pair whose enlarged
//     primitives meet, and both triangles lie inside theirs, so it must find every far pair:
//     recall 100%.
//   - near: within one body, every primitive of one triangle is a primitive of the other or
//     shares a medial sphere with it. Self collision skips such primitive pairs by design
//     (adjacent primitives always overlap: testing them would test every triangle against its
//     neighbourhood), so these pairs are not looked for and their recall is about 0. They are
//     local folds of the surface, which the elastic energy resists, not contacts.
// Pairs between two bodies that are both static or kinematic are left out (the world skips
// them), and so are self pairs when self collision is off.
// The penetration depth is measured on the bodies' surfaces after the step (after the contact
// response): the largest distance from a surface vertex of one body that lies inside another
// body's closed surface to that surface. Self penetration (with self collision on): the vertices
// of a body that lie inside its own volume, found by the surface's generalized winding number
// (Jacobson et al. 2013: the solid angle of every triangle seen from the vertex, over 4 pi). At a
// vertex of an embedded closed surface it is the vertex's interior angle fraction, in (0, 1), and
// every other sheet of the surface that encloses the vertex adds 1: a vertex is inside its own
// body where it exceeds 1. It is inside a non-adjacent part, and counted, only where the far
// faces alone (no vertex of the face in the vertex's primitive or one sharing a sphere with it)
// also wind around it at least halfway (their winding number above 1/2): a local fold of adjacent
// parts (near pairs, not looked for) crumples a vertex's neighbourhood so that its winding
// number passes 1 by a little while no other part encloses it (on kinematic_sweep, semi-reduced:
// three vertices at 1.08-1.21, of which the far faces 0.06-0.19, each within 0.18 mm of a face;
// they had been reported 8.8-35 mm deep). Its depth is its distance to the nearest far face. It is
// computed only for a body with far self-intersecting pairs at the start of the step (without
// them the surface is embedded apart from local folds, and no vertex can be inside it; a self
// penetration that begins within a step is measured from the next step on), at O(#Vs x #F) cost.

#include <vector>

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"
#include "runtime/simulation.hpp"

namespace mat {

/// One step's comparison, or their sum over steps (add()).
struct CollisionCheckCounts {
    long far_pairs = 0; ///< ground-truth pairs in different bodies or non-adjacent primitives
    long far_found = 0; ///< of those, found by the world
    long near_pairs = 0; ///< ground-truth self pairs within one or in adjacent primitives
    long near_found = 0;
    long extra = 0; ///< pairs the world reported that the ground truth does not have
    long self_pairs = 0; ///< of the far pairs, those within one body
    double max_penetration = 0.0; ///< m, deepest vertex inside another body
    int penetrating_vertices = 0; ///< vertices inside another body (max over steps)
    double max_self_penetration = 0.0; ///< m, deepest vertex inside its own body
    int self_penetrating_vertices = 0; ///< vertices inside their own body (max over steps)
    long steps = 0;
    double seconds = 0.0; ///< time spent checking

    /// Counts are summed, the penetration and the vertex count are maxima.
    void add(const CollisionCheckCounts& other);
};

/// found / pairs, or 1 when there is no pair.
double recall(long found, long pairs);

/// True if faces fa and fb of one body lie in two primitives that share no medial sphere, i.e.
/// if some primitive of a vertex of fa and some primitive of a vertex of fb differ and share no
/// sphere.  faces  #F x 3,  vertex_primitive  #V,  primitive_spheres  #P x 3 (-1 unused).
bool faces_in_non_adjacent_primitives(const Eigen::Ref<const MatX3i>& faces,
    const Eigen::Ref<const VecXi>& vertex_primitive,
    const Eigen::Ref<const MatX3i>& primitive_spheres, int fa, int fb);

struct PenetrationDepth {
    double max_depth = 0.0; ///< m
    int vertices = 0; ///< vertices inside another surface
};

/// For every ordered pair of distinct closed surfaces (A, B): the vertices of A strictly inside
/// B (ray parity along +x, exact orientation predicates with a symbolic tie-break, so a ray
/// through an edge counts once) and their distance to B. A vertex on B counts as outside.
PenetrationDepth penetration_depth(const std::vector<SurfaceMesh>& surfaces);

/// The vertices of one closed surface inside its own volume (winding number above 1) and inside a
/// non-adjacent part (the far faces' winding number above 1/2), and the deepest one's distance
/// to a face of a non-adjacent part (see the file comment).
/// surface  #Vs x 3 positions and #F x 3 faces, vertex_primitive  #Vs, primitive_spheres  #P x 3.
PenetrationDepth self_penetration_depth(const SurfaceMesh& surface,
    const Eigen::Ref<const VecXi>& vertex_primitive,
    const Eigen::Ref<const MatX3i>& primitive_spheres);

/// The comparison above for `simulation` after a step (its collision world must exist).
CollisionCheckCounts check_collisions(const Simulation& simulation);

} // namespace mat
