#pragma once
// A body's contact responses (z_j = S^-1 b_j^T reduced, A^-1 e_j full; runtime/pd/
// contact_response.hpp), computed when the contact stage first asks for a node's and kept for
// later steps while they fit a memory budget: a node that comes back into contact then costs
// nothing (docs/method.md, "W is never formed whole"). A response depends only on the node and
// the body's system, never on when it was computed, so keeping it changes no result.

#include <cstddef>
#include <vector>

#include "common/eigen_types.hpp"
#include "common/huge_pages.hpp"

namespace mat {

class ResponseCache {
public:
    /// `rows`: the length of one response. `budget_bytes`: how much the responses kept from
    /// earlier steps may take (the responses of the current step are kept whatever it is).
    ResponseCache(Index num_nodes, Index rows, std::size_t budget_bytes = default_budget);
    /// A new step: while more responses are kept than the budget allows, forgets those asked
    /// for longest ago.
    void begin_step();
    /// Node's column; `fresh` is set when it was not kept, and the caller must fill it. The
    /// column stays where it is until the node is forgotten.
    Eigen::Ref<VecX> column(int node, bool& fresh);
    /// Responses kept now.
    Index kept() const;

    static constexpr std::size_t default_budget = std::size_t { 64 } << 20;

private:
    /// Columns per block: at least 64, and as many as make huge_page_min_bytes where the body
    /// has that many nodes, so that a block is backed by huge pages (common/huge_pages.hpp).
    Index m_block_columns = 64;
    Index m_rows = 0;
    Index m_capacity = 0; ///< responses the budget holds (at least m_block_columns)
    long m_step = 0; ///< begin_step() calls so far
    std::vector<int> m_slot; ///< node -> slot, -1 if absent
    std::vector<int> m_node_of; ///< slot -> node, -1 if free
    std::vector<long> m_asked; ///< slot -> the step it was last asked for in
    std::vector<int> m_free; ///< free slots
    std::vector<int> m_order; ///< begin_step's scratch
    /// The columns, m_block_columns per block (they never move), in huge-page storage where a
    /// block is large enough: written column by column as nodes come into contact, its pages
    /// were the most page faults of an impact (docs/method.md, "Pages and wake-ups").
    std::vector<HugePageBlock> m_blocks;
};

} // namespace mat
