#include "runtime/collision/face_grid.hpp"

namespace mat {

void FaceGrid::build(int axis)
{
    m_axis = axis;
    m_box = Box3();
    for (const GridItem& item : items)
        m_box.extend(item.box);
    size_columns();
    sort_into_columns();
    store_boxes();
}

int FaceGrid::column(double at_u, double at_v) const
{
    const auto clamp = [](double x, int count) {
        return !(x >= 0.0) ? 0 : x >= count - 1 ? count - 1 : static_cast<int>(x); // NaN: 0
    };
    return clamp(std::floor((at_v - m_origin_v) / m_cell_v), m_columns_v) * m_columns_u
        + clamp(std::floor((at_u - m_origin_u) / m_cell_u), m_columns_u);
}

void FaceGrid::size_columns()
{
    const int u = (m_axis + 1) % 3;
    const int v = (m_axis + 2) % 3;
    Vec3 width = Vec3::Zero();
    for (const GridItem& item : items)
        width = width.cwiseMax(item.box.sizes());
    m_width = width(m_axis);
    m_width_u = width(u);
    m_width_v = width(v);
    m_origin_u = m_box.isEmpty() ? 0.0 : m_box.min()(u);
    m_origin_v = m_box.isEmpty() ? 0.0 : m_box.min()(v);
    const double size_u = m_box.isEmpty() ? 0.0 : m_box.sizes()(u);
    const double size_v = m_box.isEmpty() ? 0.0 : m_box.sizes()(v);
    // Columns: no narrower than the widest box, at most max_columns per side.
    constexpr int max_columns = 64;
    m_cell_u = std::max({ width(u), size_u / max_columns, 1e-300 });
    m_cell_v = std::max({ width(v), size_v / max_columns, 1e-300 });
    const auto count = [](double size, double cell) {
        const double n = size / cell; // NaN with non-finite positions: 1 column
        if (!(n >= 0.0))
            return 1;
        return n < max_columns ? static_cast<int>(n) + 1 : max_columns;
    };
    m_columns_u = count(size_u, m_cell_u);
    m_columns_v = count(size_v, m_cell_v);
}

void FaceGrid::sort_into_columns()
{
    const int u = (m_axis + 1) % 3;
    const int v = (m_axis + 2) % 3;
    // Counting sort by column, then each column along the sweep axis.
    const int columns = m_columns_u * m_columns_v;
    m_column_start.assign(static_cast<std::size_t>(columns + 1), 0);
    for (GridItem& item : items) {
        item.column = column(item.box.min()(u), item.box.min()(v));
        ++m_column_start[static_cast<std::size_t>(item.column + 1)];
    }
    for (int c = 0; c < columns; ++c)
        m_column_start[static_cast<std::size_t>(c + 1)]
            += m_column_start[static_cast<std::size_t>(c)];
    m_fill.assign(m_column_start.begin(), m_column_start.end() - 1);
    m_sorted.resize(items.size());
    for (const GridItem& item : items)
        m_sorted[static_cast<std::size_t>(m_fill[static_cast<std::size_t>(item.column)]++)] = item;
    std::swap(items, m_sorted);
    const int axis = m_axis;
    for (int c = 0; c < columns; ++c)
        std::sort(items.begin() + m_column_start[static_cast<std::size_t>(c)],
            items.begin() + m_column_start[static_cast<std::size_t>(c + 1)],
            [axis](const GridItem& x, const GridItem& y) {
                return x.box.min()[axis] < y.box.min()[axis]
                    || (x.box.min()[axis] == y.box.min()[axis] && x.index < y.index);
            });
}

void FaceGrid::store_boxes()
{
    const std::size_t n = items.size();
    for (std::size_t a = 0; a < 3; ++a) {
        m_lo[a].resize(n);
        m_hi[a].resize(n);
    }
    m_index.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
        const GridItem& item = items[k];
        for (int a = 0; a < 3; ++a) {
            m_lo[static_cast<std::size_t>(a)][k] = item.box.min()[a];
            m_hi[static_cast<std::size_t>(a)][k] = item.box.max()[a];
        }
        m_index[k] = item.index;
    }
}

} // namespace mat
