#include "runtime/pd/response_cache.hpp"

#include <algorithm>

#include "common/error.hpp"

namespace mat {

namespace {

    /// How many responses of `rows` doubles fit `bytes`.
    Index columns_in(std::size_t bytes, Index rows)
    {
        return static_cast<Index>(
            bytes / (sizeof(double) * static_cast<std::size_t>(std::max<Index>(1, rows))));
    }

} // namespace

ResponseCache::ResponseCache(Index num_nodes, Index rows, std::size_t budget_bytes)
    : m_block_columns(std::max<Index>(
        64, std::min({ num_nodes, huge_block_columns(rows), columns_in(budget_bytes, rows) })))
    , m_rows(rows)
    , m_capacity(std::max(m_block_columns, columns_in(budget_bytes, rows)))
    , m_slot(static_cast<std::size_t>(num_nodes), -1)
{
}

Index ResponseCache::kept() const
{
    return static_cast<Index>(m_node_of.size() - m_free.size());
}

void ResponseCache::begin_step()
{
    ++m_step;
    const Index excess = kept() - m_capacity;
    if (excess <= 0)
        return;
    // The kept slots, those asked for longest ago first (then by slot: the same order on any
    // run), and the first `excess` of them forgotten.
    m_order.clear();
    for (std::size_t s = 0; s < m_node_of.size(); ++s)
        if (m_node_of[s] >= 0)
            m_order.push_back(static_cast<int>(s));
    std::sort(m_order.begin(), m_order.end(), [this](int a, int b) {
        const long asked_a = m_asked[static_cast<std::size_t>(a)];
        const long asked_b = m_asked[static_cast<std::size_t>(b)];
        return asked_a != asked_b ? asked_a < asked_b : a < b;
    });
    for (Index k = 0; k < excess; ++k) {
        const int s = m_order[static_cast<std::size_t>(k)];
        m_slot[static_cast<std::size_t>(m_node_of[static_cast<std::size_t>(s)])] = -1;
        m_node_of[static_cast<std::size_t>(s)] = -1;
        m_free.push_back(s);
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
            m_blocks.emplace_back(m_rows, m_block_columns);
            m_node_of.resize(m_node_of.size() + static_cast<std::size_t>(m_block_columns), -1);
            m_asked.resize(m_node_of.size(), 0);
            for (int s = static_cast<int>(m_node_of.size()) - 1; s >= first; --s)
                m_free.push_back(s);
        }
        slot = m_free.back();
        m_free.pop_back();
        m_node_of[static_cast<std::size_t>(slot)] = node;
    }
    m_asked[static_cast<std::size_t>(slot)] = m_step;
    return Eigen::Map<VecX>(
        m_blocks[static_cast<std::size_t>(slot / m_block_columns)].col(slot % m_block_columns),
        m_rows);
}

} // namespace mat
