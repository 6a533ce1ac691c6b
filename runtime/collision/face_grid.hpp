#pragma once
// The narrow phase's search structure over one body's active triangles (docs/method.md, section
// 4, step 5): each triangle is filed, by the low corner of its box, in a grid of columns across
// a sweep axis (cells no narrower than twice the widest box, at most 64 per side), and sorted
// along that axis within its column. A query box then visits the triangles whose boxes overlap it,
// looking only in the neighbouring columns and, within a column, from a binary search (or the
// start of a short column) to the first box past it; with AVX-512, eight boxes per comparison.
// Boxes of very different sizes are filed by size in up to four such grids (levels), each sized
// by its own widest box, so that a few long triangles do not widen every query's scan.
// A query may visit only the positions whose bit is set in a mask (read a word at a time before
// the boxes, without AVX-512), and only the positions after one of its own (each overlapping
// pair of one grid's items once).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "common/eigen_types.hpp"

namespace mat {

/// An active triangle or node with its box (a node: a point box).
struct GridItem {
    Box3 box;
    int index = 0; ///< face or node index in its body
    int column = 0; ///< a face's column in its FaceGrid
};

class FaceGrid {
public:
    /// The items to file, with their boxes; build() sorts them.
    std::vector<GridItem> items;

    /// Files `items` along sweep axis `axis`, sorted by (column, low end on the axis, index);
    /// the columns of a level of larger boxes come after those of the smaller ones.
    void build(int axis);
    /// The item filed at position k (the order of the visits' positions).
    const GridItem& at(std::size_t k) const { return items[k]; }

    /// Calls visit(index, position) for every item whose box overlaps `box` grown by
    /// `grow` on every side (non-finite coordinates fall in a level's first column).
    template <class Visit> void overlapping(const Box3& box, double grow, const Visit& visit) const
    {
        overlapping(
            box, grow, [grow](int) { return grow; }, visit);
    }
    /// The same with a grow per column: grow_of(column) in [0, max_grow] (negative: the column
    /// is skipped) for the items filed in that column (GridItem::column).
    template <class Grow, class Visit>
    void overlapping(
        const Box3& box, double max_grow, const Grow& grow_of, const Visit& visit) const
    {
        for (const Level& level : m_levels)
            overlapping_in(level, box, max_grow, grow_of, AllWords {}, -1, visit);
    }
    /// The same, visiting only the positions k whose bit (k % 64) of word k / 64 of `allowed`
    /// is set (one bit per position of `items`).
    template <class Grow, class Visit>
    void overlapping_allowed(const Box3& box, double max_grow, const Grow& grow_of,
        const std::uint64_t* allowed, const Visit& visit) const
    {
        const auto words = [allowed](int w) { return allowed[w]; };
        for (const Level& level : m_levels)
            overlapping_in(level, box, max_grow, grow_of, words, -1, visit);
    }
    /// The items after position `after` whose boxes overlap `box` and whose bit (k % 64) of
    /// words(k / 64) is set: each overlapping pair of items once, from the earlier one.
    template <class Words, class Visit>
    void overlapping_after(const Box3& box, int after, const Words& words, const Visit& visit) const
    {
        for (const Level& level : m_levels)
            overlapping_in(
                level, box, 0.0, [](int) { return 0.0; }, words, after, visit);
    }

    /// Number of columns; the items filed in column c are at positions [column_begin(c),
    /// column_begin(c + 1)).
    int num_columns() const { return static_cast<int>(m_column_start.size()) - 1; }
    int column_begin(int c) const { return m_column_start[static_cast<std::size_t>(c)]; }

private:
    /// Columns of at most this many items are scanned from their start, without a search.
    static constexpr int short_column = 32;
    /// Cells are at least this many times as wide as the widest box of their level: a
    /// vertex's search (which reaches a few margins, a margin being about a triangle) then
    /// visits fewer columns for a longer scan in each. Measured (narrow phase per step, 2
    /// threads, three dropped libcgal-demo meshes, docs/method.md): 1 -> 2 took bear_bis from
    /// 13.5 to 9.9 ms and turbine from 10.5 to 9.7; 3 and more were slower on turbine.
    static constexpr double cell_widths = 2.0;
    /// At most this many levels: the first takes the boxes up to twice the median size (their
    /// largest side), each next one up to level_ratio times as large, the last the rest.
    static constexpr int max_levels = 4;
    static constexpr double level_ratio = 4.0;

    /// One grid over the boxes of one size class, its columns numbered from first_column.
    struct Level {
        Box3 box;
        double width = 0.0; ///< largest extent of a box on the sweep axis
        double width_u = 0.0, width_v = 0.0; ///< ... on u = axis + 1 and v = axis + 2
        double origin_u = 0.0, origin_v = 0.0; ///< low corner of the grid
        double cell_u = 1.0, cell_v = 1.0; ///< cell sizes (>= cell_widths x the widths)
        int columns_u = 1, columns_v = 1;
        int first_column = 0;
    };

    void assign_levels();
    void size_columns(Level& level, int level_index);
    void sort_into_columns();
    void store_boxes();
    int column(const Level& level, double at_u, double at_v) const;
    /// No filter by words (overlapping_in's `words`): every position.
    struct AllWords {
        std::uint64_t operator()(int) const { return ~std::uint64_t { 0 }; }
    };
    /// Visits the items of one level (see overlapping): those at positions after `after` only
    /// whose bit is set in `words` (word index -> 64 bits of positions; AllWords: every
    /// position), read before their boxes.
    template <class Grow, class Words, class Visit>
    void overlapping_in(const Level& level, const Box3& box, double max_grow, const Grow& grow_of,
        const Words& words, int after, const Visit& visit) const;
    /// test(at) for the positions `at` from k to the first past `to` (keys sorted) below `end`
    /// whose bit is set in `words`, a word at a time.
    template <class Words, class Test>
    static void scan_words(
        int k, int end, double to, const double* keys, const Words& words, const Test& test)
    {
        while (k < end && keys[k] <= to) {
            const int word_end = std::min(end, (k / 64 + 1) * 64);
            for (std::uint64_t bits = words(k / 64) >> (k % 64); bits != 0; bits &= bits - 1) {
                const int at = k + static_cast<int>(__builtin_ctzll(bits));
                if (at >= word_end || keys[at] > to)
                    break;
                test(at);
            }
            k = word_end;
        }
    }
    /// Bits k .. k + 7 of `words` (positions below `end` only).
    template <class Words> static unsigned allowed_bits(const Words& words, int k, int end)
    {
        const int word = k / 64;
        const int shift = k % 64;
        std::uint64_t bits = words(word) >> shift;
        if (shift > 56 && word * 64 + 64 < end)
            bits |= words(word + 1) << (64 - shift);
        return static_cast<unsigned>(bits & 0xFFu);
    }

    int m_axis = 0;
    std::vector<Level> m_levels;
    std::vector<int> m_level; ///< per item (in the order given), its index in m_levels
    std::vector<Vec3> m_widths; ///< per level, the largest extent of its boxes on each axis
    std::vector<double> m_sizes; ///< workspace: the largest side of each box
    std::vector<double> m_median; ///< workspace of the median
    std::vector<int> m_column_start; ///< columns + 1, CSR into `items`
    /// The boxes in filed order, by axis, structure of arrays (the scans' loads).
    std::array<std::vector<double>, 3> m_lo, m_hi;
    std::vector<int> m_index;
    std::vector<int> m_fill; ///< columns, scatter cursors
    std::vector<GridItem> m_sorted; ///< workspace of the counting sort
    struct SortKey {
        double key; ///< the low end on the sweep axis (NaN: -infinity)
        int index; ///< the item's index, for ties
        int from; ///< the item's position before the sort
    };
    std::vector<SortKey> m_keys; ///< workspace of the sort
};

template <class Grow, class Words, class Visit>
void FaceGrid::overlapping_in(const Level& level, const Box3& box, double max_grow,
    const Grow& grow_of, const Words& words, int after, const Visit& visit) const
{
    constexpr bool every = std::is_same_v<Words, AllWords>;
    // The boxes that can overlap have their low corner in the columns from (box low -
    // grow - widest box) to (box high + grow), and in each column, their low end on the sweep
    // axis in the same range.
    const Box3 widest(box.min().array() - max_grow, box.max().array() + max_grow);
    if (!((widest.min().array() <= level.box.max().array()).all()
            && (level.box.min().array() <= widest.max().array()).all()))
        return;
    const int axis = m_axis;
    const int u = (axis + 1) % 3;
    const int v = (axis + 2) % 3;
    const auto index = [](double x, double origin, double cell, int count) {
        const double at = std::floor((x - origin) / cell);
        return !(at >= 0.0) ? 0 : at >= count - 1 ? count - 1 : static_cast<int>(at); // NaN: 0
    };
    const int u0
        = index(widest.min()(u) - level.width_u, level.origin_u, level.cell_u, level.columns_u);
    const int u1 = index(widest.max()(u), level.origin_u, level.cell_u, level.columns_u);
    const int v0
        = index(widest.min()(v) - level.width_v, level.origin_v, level.cell_v, level.columns_v);
    const int v1 = index(widest.max()(v), level.origin_v, level.cell_v, level.columns_v);
    const double width = level.width;
    const double* keys = m_lo[static_cast<std::size_t>(axis)].data();
    const double* lo_u = m_lo[static_cast<std::size_t>(u)].data();
    const double* lo_v = m_lo[static_cast<std::size_t>(v)].data();
    const double* hi_a = m_hi[static_cast<std::size_t>(axis)].data();
    const double* hi_u = m_hi[static_cast<std::size_t>(u)].data();
    const double* hi_v = m_hi[static_cast<std::size_t>(v)].data();
    const int* face = m_index.data();
    for (int cv = v0; cv <= v1; ++cv)
        for (int cu = u0; cu <= u1; ++cu) {
            const int c = level.first_column + cv * level.columns_u + cu;
            const int begin = m_column_start[static_cast<std::size_t>(c)];
            const int end = m_column_start[static_cast<std::size_t>(c + 1)];
            if (begin == end || end <= after + 1)
                continue;
            const double grow = grow_of(c);
            if (!(grow >= 0.0))
                continue;
            const Box3 grown(box.min().array() - grow, box.max().array() + grow);
            // `from` a few ulps low: a box whose key is just below it cannot then overlap after
            // rounding, so the scan from a short column's start and the search agree.
            const double from = grown.min()[axis] - width
                - 4.0 * std::numeric_limits<double>::epsilon()
                    * (std::abs(grown.min()[axis]) + width);
            const double to = grown.max()[axis];
            // A short column is scanned from its start (cheaper than the search).
            int k = end - begin <= short_column
                ? begin
                : static_cast<int>(std::lower_bound(keys + begin, keys + end, from) - keys);
            k = std::max(k, after + 1);
#if defined(__AVX512F__)
            const __m512d low_a = _mm512_set1_pd(grown.min()(axis)), high_a = _mm512_set1_pd(to);
            const __m512d low_u = _mm512_set1_pd(grown.min()(u));
            const __m512d high_u = _mm512_set1_pd(grown.max()(u));
            const __m512d low_v = _mm512_set1_pd(grown.min()(v));
            const __m512d high_v = _mm512_set1_pd(grown.max()(v));
            // Eight boxes at a time, in order, up to the first whose key is past `to`.
            for (; k < end; k += 8) {
                const __mmask8 live
                    = static_cast<__mmask8>(end - k >= 8 ? 0xFF : (1u << (end - k)) - 1u);
                const __mmask8 before = _mm512_mask_cmp_pd_mask(
                    live, _mm512_maskz_loadu_pd(live, keys + k), high_a, _CMP_LE_OQ);
                __mmask8 m = _mm512_mask_cmp_pd_mask(
                    before, low_a, _mm512_maskz_loadu_pd(live, hi_a + k), _CMP_LE_OQ);
                m = _mm512_mask_cmp_pd_mask(
                    m, _mm512_maskz_loadu_pd(live, lo_u + k), high_u, _CMP_LE_OQ);
                m = _mm512_mask_cmp_pd_mask(
                    m, low_u, _mm512_maskz_loadu_pd(live, hi_u + k), _CMP_LE_OQ);
                m = _mm512_mask_cmp_pd_mask(
                    m, _mm512_maskz_loadu_pd(live, lo_v + k), high_v, _CMP_LE_OQ);
                m = _mm512_mask_cmp_pd_mask(
                    m, low_v, _mm512_maskz_loadu_pd(live, hi_v + k), _CMP_LE_OQ);
                if constexpr (!every)
                    m = static_cast<__mmask8>(m & allowed_bits(words, k, end));
                for (unsigned bits = m; bits != 0; bits &= bits - 1) {
                    const int at = k + static_cast<int>(__builtin_ctz(bits));
                    visit(face[at], at);
                }
                if (before != live)
                    break;
            }
#else
            const auto overlaps = [&](int at) {
                return (grown.min()(axis) <= hi_a[at]) & (lo_u[at] <= grown.max()(u))
                    & (grown.min()(u) <= hi_u[at]) & (lo_v[at] <= grown.max()(v))
                    & (grown.min()(v) <= hi_v[at]);
            };
            if constexpr (every) {
                for (; k < end && keys[k] <= to; ++k)
                    if (overlaps(k))
                        visit(face[k], k);
            } else {
                // The allowed positions first, a word at a time: only their boxes are read.
                scan_words(k, end, to, keys, words, [&](int at) {
                    if (overlaps(at))
                        visit(face[at], at);
                });
            }
#endif
        }
}

} // namespace mat
