#include "runtime/collision/face_grid.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace mat {

namespace {
    /// A box's key along the sweep axis: its low end, or -infinity where that is NaN (so that
    /// the keys are ordered; such a box overlaps nothing).
    double sweep_key(const Box3& box, int axis)
    {
        const double low = box.min()[axis];
        return std::isnan(low) ? -std::numeric_limits<double>::infinity() : low;
    }
} // namespace

void FaceGrid::build(int axis)
{
    m_axis = axis;
    assign_levels();
    int columns = 0;
    for (std::size_t l = 0; l < m_levels.size(); ++l) {
        size_columns(m_levels[l], static_cast<int>(l));
        m_levels[l].first_column = columns;
        columns += m_levels[l].columns_u * m_levels[l].columns_v;
    }
    sort_into_columns();
    store_boxes();
}

void FaceGrid::assign_levels()
{
    // Sizes: the largest side of each box; the median of the finite ones (a non-finite size
    // counts as infinite, and so falls in the last level).
    const std::size_t n = items.size();
    m_sizes.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
        const double size = items[k].box.isEmpty() ? 0.0 : items[k].box.sizes().maxCoeff();
        m_sizes[k] = size <= std::numeric_limits<double>::max()
            ? size
            : std::numeric_limits<double>::infinity();
    }
    m_median.assign(m_sizes.begin(), m_sizes.end());
    double first_limit = std::numeric_limits<double>::infinity();
    if (n > 0) {
        const auto middle = m_median.begin() + static_cast<std::ptrdiff_t>(n / 2);
        std::nth_element(m_median.begin(), middle, m_median.end());
        if (*middle > 0.0 && 2.0 * *middle <= std::numeric_limits<double>::max())
            first_limit = 2.0 * *middle;
    }
    // Each box's size class, then the classes that hold a box, in order, as levels.
    std::array<int, max_levels> present {};
    m_level.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
        int l = 0;
        for (double limit = first_limit; l < max_levels - 1 && !(m_sizes[k] <= limit);
             limit *= level_ratio)
            ++l;
        m_level[k] = l;
        present[static_cast<std::size_t>(l)] = 1;
    }
    std::array<int, max_levels> compact {};
    int levels = 0;
    for (int l = 0; l < max_levels; ++l)
        compact[static_cast<std::size_t>(l)] = present[static_cast<std::size_t>(l)] ? levels++ : -1;
    m_levels.assign(static_cast<std::size_t>(levels), Level {});
    m_widths.assign(static_cast<std::size_t>(levels), Vec3::Zero());
    for (std::size_t k = 0; k < n; ++k) {
        m_level[k] = compact[static_cast<std::size_t>(m_level[k])];
        const std::size_t l = static_cast<std::size_t>(m_level[k]);
        m_levels[l].box.extend(items[k].box);
        m_widths[l] = m_widths[l].cwiseMax(items[k].box.sizes());
    }
}

int FaceGrid::column(const Level& level, double at_u, double at_v) const
{
    const auto clamp = [](double x, int count) {
        return !(x >= 0.0) ? 0 : x >= count - 1 ? count - 1 : static_cast<int>(x); // NaN: 0
    };
    return level.first_column
        + clamp(std::floor((at_v - level.origin_v) / level.cell_v), level.columns_v)
        * level.columns_u
        + clamp(std::floor((at_u - level.origin_u) / level.cell_u), level.columns_u);
}

void FaceGrid::size_columns(Level& level, int level_index)
{
    const int u = (m_axis + 1) % 3;
    const int v = (m_axis + 2) % 3;
    const Vec3& width = m_widths[static_cast<std::size_t>(level_index)];
    level.width = width(m_axis);
    level.width_u = width(u);
    level.width_v = width(v);
    const Box3& box = level.box;
    level.origin_u = box.isEmpty() ? 0.0 : box.min()(u);
    level.origin_v = box.isEmpty() ? 0.0 : box.min()(v);
    const double size_u = box.isEmpty() ? 0.0 : box.sizes()(u);
    const double size_v = box.isEmpty() ? 0.0 : box.sizes()(v);
    // Columns: no narrower than cell_widths times the widest box, at most max_columns per side.
    constexpr int max_columns = 64;
    level.cell_u = std::max({ cell_widths * width(u), size_u / max_columns, 1e-300 });
    level.cell_v = std::max({ cell_widths * width(v), size_v / max_columns, 1e-300 });
    const auto count = [](double size, double cell) {
        const double n = size / cell; // NaN with non-finite positions: 1 column
        if (!(n >= 0.0))
            return 1;
        return n < max_columns ? static_cast<int>(n) + 1 : max_columns;
    };
    level.columns_u = count(size_u, level.cell_u);
    level.columns_v = count(size_v, level.cell_v);
}

void FaceGrid::sort_into_columns()
{
    const int u = (m_axis + 1) % 3;
    const int v = (m_axis + 2) % 3;
    // Counting sort by column, then each column along the sweep axis.
    const int columns = m_levels.empty()
        ? 0
        : m_levels.back().first_column + m_levels.back().columns_u * m_levels.back().columns_v;
    m_column_start.assign(static_cast<std::size_t>(columns + 1), 0);
    for (std::size_t k = 0; k < items.size(); ++k) {
        GridItem& item = items[k];
        item.column = column(
            m_levels[static_cast<std::size_t>(m_level[k])], item.box.min()(u), item.box.min()(v));
        ++m_column_start[static_cast<std::size_t>(item.column + 1)];
    }
    for (int c = 0; c < columns; ++c)
        m_column_start[static_cast<std::size_t>(c + 1)]
            += m_column_start[static_cast<std::size_t>(c)];
    // The sort keys (16 bytes, not the 56 of an item) scattered by column, each column sorted
    // by one task (a total order: the same for any thread count), then the items gathered.
    const int axis = m_axis;
    m_fill.assign(m_column_start.begin(), m_column_start.end() - 1);
    m_keys.resize(items.size());
    for (std::size_t k = 0; k < items.size(); ++k)
        m_keys[static_cast<std::size_t>(m_fill[static_cast<std::size_t>(items[k].column)]++)]
            = { sweep_key(items[k].box, axis), items[k].index, static_cast<int>(k) };
    tbb::parallel_for(
        tbb::blocked_range<int>(0, columns, 64), [&](const tbb::blocked_range<int>& range) {
            for (int c = range.begin(); c != range.end(); ++c)
                std::sort(m_keys.begin() + m_column_start[static_cast<std::size_t>(c)],
                    m_keys.begin() + m_column_start[static_cast<std::size_t>(c + 1)],
                    [](const SortKey& x, const SortKey& y) {
                        return x.key < y.key || (x.key == y.key && x.index < y.index);
                    });
        });
    m_sorted.resize(items.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, items.size(), 1024),
        [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t k = range.begin(); k != range.end(); ++k)
                m_sorted[k] = items[static_cast<std::size_t>(m_keys[k].from)];
        });
    std::swap(items, m_sorted);
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
            m_lo[static_cast<std::size_t>(a)][k]
                = a == m_axis ? sweep_key(item.box, a) : item.box.min()[a];
            m_hi[static_cast<std::size_t>(a)][k] = item.box.max()[a];
        }
        m_index[k] = item.index;
    }
}

} // namespace mat
