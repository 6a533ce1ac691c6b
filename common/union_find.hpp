#pragma once
// Disjoint sets over the elements 0..n-1 (union-find), for connected components of a graph.

#include <algorithm>
#include <numeric>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// Union-find with path halving. The root of a set is always its smallest element, so roots
/// are deterministic and the first element met in increasing order is its set's root.
class UnionFind {
public:
    /// `n` singleton sets {0}, ..., {n-1}.
    explicit UnionFind(Index n)
        : m_parent(static_cast<std::size_t>(n))
    {
        std::iota(m_parent.begin(), m_parent.end(), Index(0));
    }

    Index size() const { return static_cast<Index>(m_parent.size()); }

    /// The root (smallest element) of the set holding `i`, 0 <= i < size().
    Index find(Index i)
    {
        while (m_parent[i] != i) {
            m_parent[i] = m_parent[m_parent[i]];
            i = m_parent[i];
        }
        return i;
    }

    /// Merges the sets holding `a` and `b`.
    void unite(Index a, Index b)
    {
        a = find(a);
        b = find(b);
        if (a != b)
            m_parent[std::max(a, b)] = std::min(a, b);
    }

private:
    std::vector<Index> m_parent;
};

} // namespace mat
