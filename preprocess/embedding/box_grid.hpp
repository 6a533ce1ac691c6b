#pragma once
// A uniform grid over axis-aligned boxes (CSR cell lists), for point queries against many small
// items (tets, triangles). Built once, read-only, safe for concurrent queries.

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

class BoxGrid {
public:
    /// boxes: one per item; items_per_cell: the average occupancy the cell size aims at.
    BoxGrid(const std::vector<Box3>& boxes, double items_per_cell = 2.0)
    {
        for (const Box3& box : boxes)
            m_box.extend(box);
        if (boxes.empty())
            m_box.extend(Vec3::Zero());
        const double volume = std::max(m_box.volume(), 1e-300);
        const double diagonal = std::max(m_box.diagonal().norm(), 1e-300);
        // Thin layouts (a surface's triangles) fill area, not volume: never let cells fall below
        // the mean item size.
        double mean_size = 0.0;
        for (const Box3& box : boxes)
            mean_size += box.diagonal().norm();
        mean_size /= std::max<double>(1.0, static_cast<double>(boxes.size()));
        const double by_volume = std::cbrt(
            volume * items_per_cell / std::max<double>(1.0, static_cast<double>(boxes.size())));
        m_cell = std::max({ by_volume, mean_size, 1e-9 * diagonal });
        for (int a = 0; a < 3; ++a)
            m_dims[a]
                = std::max<Index>(1, static_cast<Index>(std::ceil(m_box.sizes()(a) / m_cell)));
        const Index num_cells = m_dims[0] * m_dims[1] * m_dims[2];
        m_start.assign(static_cast<size_t>(num_cells + 1), 0);
        for (int pass = 0; pass < 2; ++pass) {
            std::vector<Index> cursor;
            if (pass == 1) {
                for (Index i = 0; i < num_cells; ++i)
                    m_start[static_cast<size_t>(i + 1)] += m_start[static_cast<size_t>(i)];
                cursor.assign(m_start.begin(), m_start.end() - 1);
                m_items.resize(static_cast<size_t>(m_start.back()));
            }
            for (size_t item = 0; item < boxes.size(); ++item) {
                const auto lo = cell_of(boxes[item].min()), hi = cell_of(boxes[item].max());
                for (Index i = lo[0]; i <= hi[0]; ++i)
                    for (Index j = lo[1]; j <= hi[1]; ++j)
                        for (Index k = lo[2]; k <= hi[2]; ++k) {
                            const size_t id
                                = static_cast<size_t>((i * m_dims[1] + j) * m_dims[2] + k);
                            if (pass == 0)
                                ++m_start[id + 1];
                            else
                                m_items[static_cast<size_t>(cursor[id]++)] = static_cast<int>(item);
                        }
            }
        }
    }

    std::array<Index, 3> cell_of(const Vec3& p) const
    {
        std::array<Index, 3> c;
        for (int a = 0; a < 3; ++a)
            c[a] = std::clamp<Index>(
                static_cast<Index>(std::floor((p(a) - m_box.min()(a)) / m_cell)), 0, m_dims[a] - 1);
        return c;
    }

    /// Calls visit(item) for the items of the cells at Chebyshev distance exactly `ring` from
    /// p's cell (ring 0: p's own cell). An item spanning several cells may be visited again.
    template <typename Visit> void visit_shell(const Vec3& p, Index ring, Visit&& visit) const
    {
        const auto c = cell_of(p);
        for (Index i = c[0] - ring; i <= c[0] + ring; ++i)
            for (Index j = c[1] - ring; j <= c[1] + ring; ++j)
                for (Index k = c[2] - ring; k <= c[2] + ring; ++k) {
                    if (std::max({ std::abs(i - c[0]), std::abs(j - c[1]), std::abs(k - c[2]) })
                        != ring)
                        continue;
                    if (i < 0 || j < 0 || k < 0 || i >= m_dims[0] || j >= m_dims[1]
                        || k >= m_dims[2])
                        continue;
                    const size_t id = static_cast<size_t>((i * m_dims[1] + j) * m_dims[2] + k);
                    for (Index s = m_start[id]; s < m_start[id + 1]; ++s)
                        visit(m_items[static_cast<size_t>(s)]);
                }
    }

    /// Any point in a cell beyond shell `ring` is at least ring * cell_size() from p.
    double cell_size() const { return m_cell; }
    Index max_ring() const { return std::max({ m_dims[0], m_dims[1], m_dims[2] }); }

private:
    Box3 m_box;
    double m_cell = 1.0;
    std::array<Index, 3> m_dims { 1, 1, 1 };
    std::vector<Index> m_start;
    std::vector<int> m_items;
};

} // namespace mat
