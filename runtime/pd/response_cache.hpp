#pragma once
// A body's contact responses (z_j = S^-1 b_j^T reduced, A^-1 e_j full; runtime/pd/
// contact_response.hpp), computed when the contact stage first asks for a node's and kept while
// the node keeps being asked for (docs/method.md, "W is never formed whole").

#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

class ResponseCache {
public:
    /// `rows`: the length of one response.
    ResponseCache(Index num_nodes, Index rows);
    /// A new step: forgets the nodes not asked for since the last call.
    void begin_step();
    /// Node's column; `fresh` is set when it was not kept, and the caller must fill it. The
    /// column stays where it is until the node is forgotten.
    Eigen::Ref<VecX> column(int node, bool& fresh);

private:
    static constexpr Index block_columns = 64;
    Index m_rows = 0;
    std::vector<int> m_slot; ///< node -> slot, -1 if absent
    std::vector<int> m_node_of; ///< slot -> node, -1 if free
    std::vector<char> m_asked; ///< slot asked for since begin_step()
    std::vector<int> m_free; ///< free slots
    std::vector<MatX> m_blocks; ///< the columns, block_columns per block (they never move)
};

} // namespace mat
