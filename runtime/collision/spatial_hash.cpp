#include "runtime/collision/spatial_hash.hpp"

#include <algorithm>
#include <cmath>

#if defined(__AVX512F__) && defined(__AVX512VL__)
#include <immintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

namespace {

    // The pair search runs over this many ranges of buckets (each with its own output; one
    // more chunk takes the oversize items): the unit of parallel work.
    constexpr std::size_t bucket_chunks = 64;
    // Cell coordinates beyond this magnitude (in cells) go to the oversize list, so that the
    // integer arithmetic below never overflows.
    constexpr double max_cell_coordinate = 0x1p61;

    bool boxes_overlap(const Box3& a, const Box3& b)
    {
        return (a.min().x() <= b.max().x()) & (a.min().y() <= b.max().y())
            & (a.min().z() <= b.max().z()) & (b.min().x() <= a.max().x())
            & (b.min().y() <= a.max().y()) & (b.min().z() <= a.max().z());
    }

    bool has_nan(const Box3& box)
    {
        return box.min().array().isNaN().any() || box.max().array().isNaN().any();
    }

    bool tags_allowed(int body_a, const std::array<int, 3>& spheres_a, int body_b,
        const std::array<int, 3>& spheres_b)
    {
        if (body_a != body_b)
            return true;
        for (const int s : spheres_a)
            if (s >= 0 && (s == spheres_b[0] || s == spheres_b[1] || s == spheres_b[2]))
                return false;
        return true;
    }

    /// Throws naming the first item whose box has a NaN coordinate.
    void check_items(const std::vector<BroadPhaseItem>& items)
    {
        for (std::size_t i = 0; i < items.size(); ++i)
            if (has_nan(items[i].box))
                throw_error(
                    "spatial hash: item {} (body {}, primitive {}) has a NaN box coordinate", i,
                    items[i].body, items[i].primitive);
    }

} // namespace

bool broad_phase_pair_allowed(const BroadPhaseItem& a, const BroadPhaseItem& b)
{
    return tags_allowed(a.body, a.spheres, b.body, b.spheres);
}

std::vector<ItemPair> all_pairs_boxes(const std::vector<BroadPhaseItem>& items)
{
    std::vector<ItemPair> out;
    const int n = static_cast<int>(items.size());
    for (int i = 0; i < n; ++i) {
        if (items[i].box.isEmpty())
            continue;
        for (int j = i + 1; j < n; ++j)
            if (!items[j].box.isEmpty() && boxes_overlap(items[i].box, items[j].box)
                && broad_phase_pair_allowed(items[i], items[j]))
                out.emplace_back(i, j);
    }
    return out;
}

SpatialHash::SpatialHash(const SpatialHashSettings& settings)
    : m_settings(settings)
{
    MAT_CHECK(settings.max_cells_per_item >= 1, "max_cells_per_item must be >= 1, got {}",
        settings.max_cells_per_item);
    MAT_CHECK(settings.cell_size_factor > 0.0 || settings.cell_size > 0.0,
        "spatial hash needs cell_size_factor > 0 or cell_size > 0");
}

std::size_t SpatialHash::bucket(std::int64_t x, std::int64_t y, std::int64_t z) const
{
    // Multiply-add of the coordinates by odd constants, then a 64-bit finalizer (xor-shift,
    // multiply) so that neighbouring cells land in unrelated buckets.
    std::uint64_t h = static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull
        + static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full
        + static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull;
    h ^= h >> 32;
    h *= 0xD6E8FEB86659FD93ull;
    h ^= h >> 32;
    return static_cast<std::size_t>(h & m_mask);
}

void SpatialHash::build(const std::vector<BroadPhaseItem>& items)
{
    // Validate first, so that a throw leaves the previous build intact.
    check_items(items);
    copy_slots(items);
    m_oversize.clear();
    m_cell_size = choose_cell_size();
    const double total_cells = assign_cells(m_cell_size);
    size_table(total_cells);
    // An entry per (item, cell), keyed by (bucket, start mask), then a counting sort by key:
    // within a key the items increase.
    count_entries();
    scatter_entries();
}

void SpatialHash::copy_slots(const std::vector<BroadPhaseItem>& items)
{
    const std::size_t n = items.size();
    m_slots.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        Slot& slot = m_slots[i];
        slot.box = items[i].box;
        slot.body = items[i].body;
        slot.spheres = items[i].spheres;
        slot.state = items[i].box.isEmpty() ? 0 : 1;
    }
}

double SpatialHash::choose_cell_size()
{
    // The median of the largest extents of the non-empty boxes.
    std::vector<double>& extents = m_extents;
    extents.clear();
    Box3 scene;
    for (const Slot& slot : m_slots) {
        if (slot.state == 0)
            continue;
        const Box3& box = slot.box;
        const double extent = box.sizes().maxCoeff();
        if (std::isfinite(extent)) {
            extents.push_back(extent);
            scene.extend(box);
        }
    }
    double h = m_settings.cell_size;
    if (!(h > 0.0) && !extents.empty()) {
        const auto middle = extents.begin() + static_cast<std::ptrdiff_t>(extents.size() / 2);
        std::nth_element(extents.begin(), middle, extents.end());
        h = m_settings.cell_size_factor * *middle;
        // Points (or mostly points): spread them over about one cell each.
        if (!(h > 0.0) || !std::isfinite(h))
            h = scene.sizes().maxCoeff() / std::cbrt(static_cast<double>(extents.size()));
    }
    if (!(h > 0.0) || !std::isfinite(h))
        h = 1.0;
    return h;
}

double SpatialHash::assign_cells(double h)
{
    double total_cells = 0.0;
    for (std::size_t i = 0; i < m_slots.size(); ++i) {
        Slot& slot = m_slots[i];
        if (slot.state == 0)
            continue;
        const Box3& box = slot.box;
        double cells = 1.0;
        bool fits = true;
        for (int k = 0; k < 3; ++k) {
            const double lo = std::floor(box.min()[k] / h);
            const double hi = std::floor(box.max()[k] / h);
            if (!(std::abs(lo) < max_cell_coordinate && std::abs(hi) < max_cell_coordinate)) {
                fits = false;
                break;
            }
            slot.lo[static_cast<std::size_t>(k)] = static_cast<std::int64_t>(lo);
            slot.hi[static_cast<std::size_t>(k)] = static_cast<std::int64_t>(hi);
            cells *= hi - lo + 1.0;
        }
        if (!fits || cells > m_settings.max_cells_per_item) {
            slot.state = 2;
            m_oversize.push_back(static_cast<int>(i));
        } else {
            total_cells += cells;
        }
    }
    return total_cells;
}

void SpatialHash::size_table(double total_cells)
{
    // A power of two, at least twice the number of entries.
    std::size_t table = 16;
    while (static_cast<double>(table) < 2.0 * total_cells)
        table *= 2;
    m_mask = table - 1;
    m_table = table;
}

template <class Visit> void SpatialHash::for_each_cell(const Visit& visit) const
{
    for (std::size_t i = 0; i < m_slots.size(); ++i) {
        const Slot& r = m_slots[i];
        if (r.state != 1)
            continue;
        for (std::int64_t z = r.lo[2]; z <= r.hi[2]; ++z)
            for (std::int64_t y = r.lo[1]; y <= r.hi[1]; ++y)
                for (std::int64_t x = r.lo[0]; x <= r.hi[0]; ++x)
                    visit(i, x, y, z);
    }
}

void SpatialHash::count_entries()
{
    const std::size_t keys = m_table * start_groups;
    m_bucket_start.assign(keys + 1, 0);
    m_keys.clear();
    for_each_cell([&](std::size_t i, std::int64_t x, std::int64_t y, std::int64_t z) {
        const Slot& r = m_slots[i];
        const std::size_t mask
            = (x == r.lo[0] ? 1u : 0u) | (y == r.lo[1] ? 2u : 0u) | (z == r.lo[2] ? 4u : 0u);
        const std::size_t key = bucket(x, y, z) * start_groups + mask;
        m_keys.push_back(key);
        ++m_bucket_start[key + 1];
    });
    for (std::size_t key = 0; key < keys; ++key)
        m_bucket_start[key + 1] += m_bucket_start[key];
}

void SpatialHash::scatter_entries()
{
    m_entries.resize(m_keys.size());
    m_fill.assign(m_bucket_start.begin(), m_bucket_start.end() - 1);
    std::size_t e = 0;
    Entries& to = m_entries;
    for_each_cell([&](std::size_t i, std::int64_t x, std::int64_t y, std::int64_t z) {
        const Slot& r = m_slots[i];
        const std::size_t k = static_cast<std::size_t>(m_fill[m_keys[e++]]++);
        to.cell[0][k] = x;
        to.cell[1][k] = y;
        to.cell[2][k] = z;
        for (int a = 0; a < 3; ++a) {
            to.lo[static_cast<std::size_t>(a)][k] = r.box.min()[a];
            to.hi[static_cast<std::size_t>(a)][k] = r.box.max()[a];
        }
        to.item[k] = static_cast<int>(i);
        to.body[k] = r.body;
    });
}

void SpatialHash::Entries::resize(std::size_t n)
{
    for (int a = 0; a < 3; ++a) {
        cell[static_cast<std::size_t>(a)].resize(n);
        lo[static_cast<std::size_t>(a)].resize(n);
        hi[static_cast<std::size_t>(a)].resize(n);
    }
    item.resize(n);
    body.resize(n);
}

void SpatialHash::entry_pairs(int p, int first, int last, std::vector<ItemPair>& out) const
{
    // p and q pair when they are for the same cell (a bucket can hold several), their boxes
    // overlap and their bodies and spheres allow it; the start masks of their groups already
    // make the cell the canonical one.
    const Entries& e = m_entries;
    const bool self = m_settings.self_pairs;
    const std::size_t sp = static_cast<std::size_t>(p);
    const auto emit = [&](int q) {
        const std::size_t sq = static_cast<std::size_t>(q);
        const Slot& a = m_slots[static_cast<std::size_t>(e.item[sp])];
        const Slot& b = m_slots[static_cast<std::size_t>(e.item[sq])];
        if (tags_allowed(a.body, a.spheres, b.body, b.spheres))
            out.emplace_back(std::min(e.item[sp], e.item[sq]), std::max(e.item[sp], e.item[sq]));
    };
#if defined(__AVX512F__) && defined(__AVX512VL__)
    // Eight candidates at a time: one mask from the cell, box and body comparisons.
    __m512i cell[3];
    __m512d lo[3], hi[3];
    for (std::size_t a = 0; a < 3; ++a) {
        cell[a] = _mm512_set1_epi64(e.cell[a][sp]);
        lo[a] = _mm512_set1_pd(e.lo[a][sp]);
        hi[a] = _mm512_set1_pd(e.hi[a][sp]);
    }
    const __m256i body = _mm256_set1_epi32(e.body[sp]);
    for (int q = first; q < last; q += 8) {
        const __mmask8 live = static_cast<__mmask8>(last - q >= 8 ? 0xFF : (1u << (last - q)) - 1u);
        __mmask8 m = live;
        for (std::size_t a = 0; a < 3; ++a) {
            m = _mm512_mask_cmpeq_epi64_mask(
                m, cell[a], _mm512_maskz_loadu_epi64(live, e.cell[a].data() + q));
            // q.lo <= p.hi and p.lo <= q.hi
            m = _mm512_mask_cmp_pd_mask(
                m, _mm512_maskz_loadu_pd(live, e.lo[a].data() + q), hi[a], _CMP_LE_OQ);
            m = _mm512_mask_cmp_pd_mask(
                m, lo[a], _mm512_maskz_loadu_pd(live, e.hi[a].data() + q), _CMP_LE_OQ);
        }
        if (!self)
            m = _mm256_mask_cmpneq_epi32_mask(
                m, body, _mm256_maskz_loadu_epi32(live, e.body.data() + q));
        for (unsigned bits = m; bits != 0; bits &= bits - 1)
            emit(q + __builtin_ctz(bits));
    }
#else
    for (int q = first; q < last; ++q) {
        const std::size_t sq = static_cast<std::size_t>(q);
        bool hit = self || e.body[sp] != e.body[sq];
        for (std::size_t a = 0; a < 3; ++a)
            hit &= (e.cell[a][sp] == e.cell[a][sq]) & (e.lo[a][sq] <= e.hi[a][sp])
                & (e.lo[a][sp] <= e.hi[a][sq]);
        if (hit)
            emit(q);
    }
#endif
}

void SpatialHash::bucket_pairs(
    std::size_t first, std::size_t last, std::vector<ItemPair>& out) const
{
    const int* start = m_bucket_start.data();
    for (std::size_t b = first; b < last; ++b) {
        const int* group = start + b * start_groups; // group g: [group[g], group[g + 1])
        if (group[0] == group[start_groups])
            continue;
        // Mask 7 (the cell is the box's first on every axis) pairs with every group, itself
        // included (each pair once); otherwise g with h when g | h == 7, g < h.
        for (int p = group[7]; p < group[8]; ++p) {
            entry_pairs(p, p + 1, group[8], out);
            entry_pairs(p, group[0], group[7], out);
        }
        for (int g = 1; g < 7; ++g)
            for (int h = g + 1; h < 7; ++h)
                if ((g | h) == 7)
                    for (int p = group[g]; p < group[g + 1]; ++p)
                        entry_pairs(p, group[h], group[h + 1], out);
    }
}

void SpatialHash::oversize_pairs(std::vector<ItemPair>& out) const
{
    // Each oversize item against every other non-empty item, except the earlier oversize ones
    // (that pair comes from the earlier one).
    const bool self = m_settings.self_pairs;
    const int n = static_cast<int>(m_slots.size());
    for (const int o : m_oversize) {
        const Slot& a = m_slots[static_cast<std::size_t>(o)];
        for (int j = 0; j < n; ++j) {
            const Slot& b = m_slots[static_cast<std::size_t>(j)];
            if (b.state == 0 || j == o || (b.state == 2 && j < o))
                continue;
            if (boxes_overlap(a.box, b.box) && (self || a.body != b.body)
                && tags_allowed(a.body, a.spheres, b.body, b.spheres))
                out.emplace_back(std::min(o, j), std::max(o, j));
        }
    }
}

void SpatialHash::pairs(std::vector<ItemPair>& out)
{
    out.clear();
    const std::size_t chunks = bucket_chunks + 1;
    if (m_chunk_pairs.size() < chunks)
        m_chunk_pairs.resize(chunks);
    const auto run_chunk = [&](std::size_t c) {
        std::vector<ItemPair>& chunk = m_chunk_pairs[c];
        chunk.clear();
        if (c < bucket_chunks)
            bucket_pairs(c * m_table / bucket_chunks, (c + 1) * m_table / bucket_chunks, chunk);
        else
            oversize_pairs(chunk);
    };
    if (static_cast<int>(m_slots.size()) < m_settings.parallel_threshold) {
        for (std::size_t c = 0; c < chunks; ++c)
            run_chunk(c);
    } else {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& range) {
            for (std::size_t c = range.begin(); c < range.end(); ++c)
                run_chunk(c);
        });
    }
    // Sorted by (first, second): two stable counting sorts (by second item, then by first), each
    // pair found once.
    const std::size_t n = m_slots.size();
    std::size_t total = 0;
    for (std::size_t c = 0; c < chunks; ++c)
        total += m_chunk_pairs[c].size();
    m_unsorted.resize(total);
    out.resize(total);
    // visit(f) calls f on each pair of the source; key(pair) is the item to sort by.
    const auto counting_sort = [&](const auto& visit, std::vector<ItemPair>& target, auto key) {
        m_counts.assign(n + 1, 0);
        visit([&](const ItemPair& pair) { ++m_counts[static_cast<std::size_t>(key(pair)) + 1]; });
        for (std::size_t i = 0; i < n; ++i)
            m_counts[i + 1] += m_counts[i];
        visit([&](const ItemPair& pair) {
            target[static_cast<std::size_t>(m_counts[static_cast<std::size_t>(key(pair))]++)]
                = pair;
        });
    };
    counting_sort(
        [&](const auto& f) {
            for (std::size_t c = 0; c < chunks; ++c)
                for (const ItemPair& pair : m_chunk_pairs[c])
                    f(pair);
        },
        m_unsorted, [](const ItemPair& pair) { return pair.second; });
    counting_sort(
        [&](const auto& f) {
            for (const ItemPair& pair : m_unsorted)
                f(pair);
        },
        out, [](const ItemPair& pair) { return pair.first; });
}

std::vector<ItemPair> SpatialHash::pairs()
{
    std::vector<ItemPair> out;
    pairs(out);
    return out;
}

} // namespace mat
