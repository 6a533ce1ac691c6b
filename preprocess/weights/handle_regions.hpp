#pragma once
// Which tet-mesh nodes are pinned to which handle for the harmonic weights (docs/method.md,
// section 2, step 4): handle j's weight is exactly 1 on its region and 0 on every other handle's
// region.
//
// Rule (deterministic, documented in the bake report):
//  1. Node x is a candidate of handle j if ||x - c_j|| <= alpha * r_j.
//  2. A node that is a candidate of several handles goes to the one with the smallest
//     ||x - c_j|| / r_j (nearest relative to its radius); ties go to the lower handle index.
//  3. A handle left with no node (its shrunken ball holds none, or lost them all in 2) gets
//     its nearest node, unless that node is the only node of another region (then the next
//     nearest); empty handles are served in index order.
//  So no node belongs to two handles and every handle has at least one node.
//  4. (give_every_region_a_tet, which needs the tets) A handle whose region holds no whole tet
//     and whose nodes do not span 3D (spanning_nodes) gets the tet nearest its center (by
//     centroid) that shares no node with another handle's kept nodes; its 4 nodes join the
//     region. Handles keep their nearest whole tet, or else 4 spanning nodes of their region;
//     needy handles are served in index order. Regions that already span are left as they are.
//     The bake applies step 4 only when the basis of steps 1-3 is rank-deficient, so bakes
//     whose basis is fine do not change.
//  Why 4: at a region node only the owner's weight is nonzero (it is exactly 1), so the rows of
//  B there are [1, y] of that handle alone. 4 affinely independent such rows pin its 4 linear
//  coefficients, so B has full column rank for linear handles whatever the weights elsewhere
//  (sparsification included). A region of 1-3 nodes hemmed in by other regions leaves the
//  handle's weight on too few nodes: with >1000 spheres a tenth of the handles were like this
//  and B^T (L + M/h^2) B was singular. Quadratic handles (10 columns) are not covered by this.

#include <array>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// Assigns region nodes. `rest_positions`  #V x 3 tet-mesh nodes, `centers`  m x 3 handle
/// centers (medial sphere centers), `radii`  m (> 0), `alpha` > 0 shrinks the balls.
/// Returns  #V: the handle owning each node, or -1 for a free node.
/// Throws mat::Error if a radius is not positive or there are more handles than nodes.
VecXi assign_handle_regions(const Eigen::Ref<const MatX3>& rest_positions,
    const Eigen::Ref<const MatX3>& centers, const Eigen::Ref<const VecX>& radii,
    double alpha = 0.5);

/// The tet of 4 region nodes whose volume (times 6) must exceed this times the cube of its
/// first edge for the region to count as spanning 3D.
inline constexpr double min_spanning_volume_ratio = 0.01;

/// Whether the `nodes` (rows of `positions`) span 3D: a greedy choice of 4 of them (into `frame`)
/// whose tet is not flat (min_spanning_volume_ratio). False with fewer than 4 nodes.
bool spanning_nodes(const Eigen::Ref<const MatX3>& positions, const std::vector<Index>& nodes,
    std::array<Index, 4>& frame);

struct WholeTetRegions {
    VecXi owner; ///< #V: handle of each node or -1; every region spans 3D
    Index handles_given_tets = 0; ///< handles whose region did not span 3D after steps 1-3
};

/// Step 4 of the rule above. `region_owner`  #V (assign_handle_regions), `rest_positions`  #V x 3,
/// `tets`  #T x 4, `centers`  m x 3. Throws mat::Error naming the handle if no tet disjoint from
/// the other handles' kept nodes is left (too many handles for the tet mesh).
WholeTetRegions give_every_region_a_tet(const Eigen::Ref<const VecXi>& region_owner,
    const Eigen::Ref<const MatX3>& rest_positions, const Eigen::Ref<const MatX4i>& tets,
    const Eigen::Ref<const MatX3>& centers);

} // namespace mat
