#include "runtime/collision/spatial_hash.hpp"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

namespace {

    // Items per chunk of the pair search: the unit of parallel work and of output buffering.
    constexpr int chunk_items = 32;
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
    const std::size_t n = items.size();
    for (std::size_t i = 0; i < n; ++i)
        if (has_nan(items[i].box))
            throw_error("spatial hash: item {} (body {}, primitive {}) has a NaN box coordinate", i,
                items[i].body, items[i].primitive);
    m_slots.resize(n);
    m_body_major = true;
    for (std::size_t i = 0; i < n; ++i) {
        if (i > 0 && items[i].body < items[i - 1].body)
            m_body_major = false;
        Slot& slot = m_slots[i];
        slot.box = items[i].box;
        slot.body = items[i].body;
        slot.spheres = items[i].spheres;
        slot.state = 0;
    }
    m_oversize.clear();

    // Cell size: the median of the largest extents of the non-empty boxes.
    std::vector<double>& extents = m_extents;
    extents.clear();
    Box3 scene;
    for (std::size_t i = 0; i < n; ++i) {
        const Box3& box = items[i].box;
        if (box.isEmpty())
            continue;
        m_slots[i].state = 1;
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
    m_cell_size = h;

    // Cell ranges; boxes covering too many cells, or too far out, are oversize.
    double total_cells = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
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

    // A power-of-two table with at least twice as many buckets as entries.
    std::size_t table = 16;
    while (static_cast<double>(table) < 2.0 * total_cells)
        table *= 2;
    m_mask = table - 1;

    // Each item's distinct buckets (two of its cells may share one), each with the item's start
    // mask there (bit k: a cell of the item in this bucket is its first along axis k; OR-ed
    // over its cells in the bucket), then a CSR by (bucket, mask) with the items in increasing
    // order. A pair is reported from the cell c holding the low corner of the two boxes'
    // intersection, so along every axis where c is past the scanning item's first cell, the
    // other item must start at c: the groups without those bits need no scan.
    m_table = table;
    m_scratch.clear();
    m_item_offsets.assign(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t begin = m_scratch.size();
        if (m_slots[i].state == 1) {
            const Slot& r = m_slots[i];
            for (std::int64_t z = r.lo[2]; z <= r.hi[2]; ++z)
                for (std::int64_t y = r.lo[1]; y <= r.hi[1]; ++y)
                    for (std::int64_t x = r.lo[0]; x <= r.hi[0]; ++x) {
                        const std::size_t mask = (x == r.lo[0] ? 1u : 0u) | (y == r.lo[1] ? 2u : 0u)
                            | (z == r.lo[2] ? 4u : 0u);
                        m_scratch.push_back(bucket(x, y, z) * start_groups + mask);
                    }
            std::sort(m_scratch.begin() + static_cast<std::ptrdiff_t>(begin), m_scratch.end());
            // One key per bucket, masks OR-ed.
            std::size_t kept = begin;
            for (std::size_t e = begin; e < m_scratch.size(); ++e) {
                if (kept > begin
                    && m_scratch[kept - 1] / start_groups == m_scratch[e] / start_groups)
                    m_scratch[kept - 1] |= m_scratch[e] % start_groups;
                else
                    m_scratch[kept++] = m_scratch[e];
            }
            m_scratch.resize(kept);
        }
        m_item_offsets[i + 1] = m_scratch.size();
    }
    const std::size_t keys = table * start_groups;
    m_bucket_start.assign(keys + 1, 0);
    for (const std::size_t key : m_scratch)
        ++m_bucket_start[key + 1];
    for (std::size_t key = 0; key < keys; ++key)
        m_bucket_start[key + 1] += m_bucket_start[key];
    m_entries.resize(m_scratch.size());
    m_fill.assign(m_bucket_start.begin(), m_bucket_start.end() - 1);
    for (std::size_t i = 0; i < n; ++i) {
        const Slot& slot = m_slots[i];
        for (std::size_t e = m_item_offsets[i]; e < m_item_offsets[i + 1]; ++e)
            m_entries[static_cast<std::size_t>(m_fill[m_scratch[e]]++)]
                = { slot.lo, slot.box, static_cast<int>(i), slot.body, slot.spheres };
    }
}

void SpatialHash::item_pairs(int i, std::vector<ItemPair>& out) const
{
    const Slot& a = m_slots[static_cast<std::size_t>(i)];
    if (a.state == 0)
        return;
    const std::size_t first = out.size();
    const bool self = m_settings.self_pairs;
    const bool skip_own_body = !self && m_body_major;
    const auto consider = [&](int j) {
        const Slot& b = m_slots[static_cast<std::size_t>(j)];
        if (boxes_overlap(a.box, b.box) && (self || a.body != b.body)
            && tags_allowed(a.body, a.spheres, b.body, b.spheres))
            out.emplace_back(i, j);
    };

    if (a.state == 2) {
        // Oversize: against every later item.
        for (std::size_t j = static_cast<std::size_t>(i) + 1; j < m_slots.size(); ++j)
            if (m_slots[j].state != 0)
                consider(static_cast<int>(j));
        return;
    }

    for (std::int64_t z = a.lo[2]; z <= a.hi[2]; ++z)
        for (std::int64_t y = a.lo[1]; y <= a.hi[1]; ++y)
            for (std::int64_t x = a.lo[0]; x <= a.hi[0]; ++x) {
                const std::size_t b = bucket(x, y, z);
                // The start bits the other item needs here (see build()).
                const std::size_t required
                    = (x > a.lo[0] ? 1u : 0u) | (y > a.lo[1] ? 2u : 0u) | (z > a.lo[2] ? 4u : 0u);
                for (std::size_t group = 0; group < start_groups; ++group) {
                    if ((group & required) != required)
                        continue;
                    const std::size_t key = b * start_groups + group;
                    const auto begin = m_entries.begin() + m_bucket_start[key];
                    const auto end = m_entries.begin() + m_bucket_start[key + 1];
                    if (begin == end)
                        continue;
                    // Later items only; each pair is reported from the cell holding the low
                    // corner of the intersection of the two boxes (a cell both boxes cover).
                    auto it = std::upper_bound(
                        begin, end, i, [](int item, const Entry& e) { return item < e.item; });
                    // Without self pairs, items numbered body by body: skip to the later bodies.
                    if (skip_own_body)
                        it = std::upper_bound(it, end, a.body,
                            [](int body, const Entry& e) { return body < e.body; });
                    for (; it != end; ++it) {
                        // One branch for both tests (each alone is a coin toss for the
                        // predictor). Still needed: cells that share a bucket.
                        const bool canonical = (std::max(a.lo[0], it->lo[0]) == x)
                            & (std::max(a.lo[1], it->lo[1]) == y)
                            & (std::max(a.lo[2], it->lo[2]) == z);
                        if (canonical & boxes_overlap(a.box, it->box)
                                & (self | (a.body != it->body))
                            && tags_allowed(a.body, a.spheres, it->body, it->spheres))
                            out.emplace_back(i, it->item);
                    }
                }
            }
    for (auto it = std::upper_bound(m_oversize.begin(), m_oversize.end(), i);
         it != m_oversize.end(); ++it)
        consider(*it);
    std::sort(out.begin() + static_cast<std::ptrdiff_t>(first), out.end());
}

void SpatialHash::pairs(std::vector<ItemPair>& out)
{
    out.clear();
    const int n = static_cast<int>(m_slots.size());
    const int chunks = (n + chunk_items - 1) / chunk_items;
    if (static_cast<int>(m_chunk_pairs.size()) < chunks)
        m_chunk_pairs.resize(static_cast<std::size_t>(chunks));
    const auto run_chunk = [&](int c) {
        std::vector<ItemPair>& chunk = m_chunk_pairs[static_cast<std::size_t>(c)];
        chunk.clear();
        const int end = std::min(n, (c + 1) * chunk_items);
        for (int i = c * chunk_items; i < end; ++i)
            item_pairs(i, chunk);
    };
    if (n < m_settings.parallel_threshold) {
        for (int c = 0; c < chunks; ++c)
            run_chunk(c);
    } else {
        tbb::parallel_for(tbb::blocked_range<int>(0, chunks, 1), [&](const auto& range) {
            for (int c = range.begin(); c < range.end(); ++c)
                run_chunk(c);
        });
    }
    // Chunks hold increasing items and each item's pairs are sorted: concatenation is sorted.
    std::size_t total = 0;
    for (int c = 0; c < chunks; ++c)
        total += m_chunk_pairs[static_cast<std::size_t>(c)].size();
    out.reserve(total);
    for (int c = 0; c < chunks; ++c)
        out.insert(out.end(), m_chunk_pairs[static_cast<std::size_t>(c)].begin(),
            m_chunk_pairs[static_cast<std::size_t>(c)].end());
}

std::vector<ItemPair> SpatialHash::pairs()
{
    std::vector<ItemPair> out;
    pairs(out);
    return out;
}

} // namespace mat
