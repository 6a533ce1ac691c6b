#pragma once
// Which tet-mesh nodes are pinned to which handle for the harmonic weights (METHOD.md section 2,
// point 4): handle j's weight is exactly 1 on its region and 0 on every other handle's region.
//
// Rule (deterministic, documented in the bake report):
//  1. Node x is a candidate of handle j if ||x - c_j|| <= alpha * r_j.
//  2. A node that is a candidate of several handles goes to the one with the smallest
//     ||x - c_j|| / r_j (nearest relative to its radius); ties go to the lower handle index.
//  3. A handle left with no node (its shrunken ball holds none, or lost them all in 2) gets
//     its nearest node, unless that node is the only node of another region (then the next
//     nearest); empty handles are served in index order.
//  So no node belongs to two handles and every handle has at least one node.

#include "common/eigen_types.hpp"

namespace mat {

/// Assigns region nodes. `rest_positions`  #V x 3 tet-mesh nodes, `centers`  m x 3 handle
/// centers (medial sphere centers), `radii`  m (> 0), `alpha` > 0 shrinks the balls.
/// Returns  #V: the handle owning each node, or -1 for a free node.
/// Throws mat::Error if a radius is not positive or there are more handles than nodes.
VecXi assign_handle_regions(const Eigen::Ref<const MatX3>& rest_positions,
    const Eigen::Ref<const MatX3>& centers, const Eigen::Ref<const VecX>& radii,
    double alpha = 0.5);

} // namespace mat
