#include "runtime/pd/response_cache.hpp"

#include "common/error.hpp"

namespace mat {

ResponseCache::ResponseCache(Index num_nodes, Index rows)
    : m_rows(rows)
    , m_slot(static_cast<std::size_t>(num_nodes), -1)
{
}

void ResponseCache::begin_step()
{
    for (std::size_t s = 0; s < m_node_of.size(); ++s) {
        if (m_node_of[s] >= 0 && !m_asked[s]) {
            m_slot[static_cast<std::size_t>(m_node_of[s])] = -1;
            m_node_of[s] = -1;
            m_free.push_back(static_cast<int>(s));
        }
        m_asked[s] = 0;
    }
}

Eigen::Ref<VecX> ResponseCache::column(int node, bool& fresh)
{
    MAT_CHECK(node >= 0 && node < static_cast<int>(m_slot.size()),
        "response cache: node {} out of range", node);
    int& slot = m_slot[static_cast<std::size_t>(node)];
    fresh = slot < 0;
    if (fresh) {
        if (m_free.empty()) {
            // A new block of free slots, taken from the lowest.
            const int first = static_cast<int>(m_node_of.size());
            m_blocks.emplace_back(m_rows, block_columns);
            m_node_of.resize(m_node_of.size() + block_columns, -1);
            m_asked.resize(m_node_of.size(), 0);
            for (int s = static_cast<int>(m_node_of.size()) - 1; s >= first; --s)
                m_free.push_back(s);
        }
        slot = m_free.back();
        m_free.pop_back();
        m_node_of[static_cast<std::size_t>(slot)] = node;
    }
    m_asked[static_cast<std::size_t>(slot)] = 1;
    return m_blocks[static_cast<std::size_t>(slot / block_columns)].col(slot % block_columns);
}

} // namespace mat
