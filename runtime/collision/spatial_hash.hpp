#pragma once
// Broad phase of the medial culling (docs/method.md, section 4, step 3): spatial hashing of the
// boxes of the enlarged medial primitives of every body. Each step the runtime hands one box per
// primitive; the hash returns the pairs of boxes that overlap, between bodies (object-object) and
// within a body between primitives that share no medial sphere (self).
//
// Cells are cubes of side h = cell_size_factor x the median of the items' largest box extents,
// so a typical box covers a few cells whatever the units. A box is entered in every cell it
// covers; the cells are hashed into a table whose size follows the number of entries, never the
// extent of the scene, so memory stays bounded when bodies fly apart. A box covering more than
// max_cells_per_item cells (or too far out for integer cell coordinates) goes to an oversize
// list that is checked against every item.
//
// A pair sharing several cells is reported once, from the cell that holds the low corner of the
// boxes' intersection: there, on every axis, one of the two boxes starts. Each entry records on
// which axes its cell is its box's first (its start mask, 0 to 7), and a bucket keeps its
// entries in 8 groups by start mask. The pairs are found bucket by bucket, between the groups
// whose masks together cover the three axes only (7 with every group; 1-6, 2-5, 3-4, 3-5, 3-6,
// 5-6): entries that cannot pair in this cell are never compared, and no search is needed.
//
// Results are sorted and unique and do not depend on the thread count. Buffers are members and
// are reused from one call to the next.

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// One primitive's box, tagged for the pair filter.
struct BroadPhaseItem {
    Box3 box; ///< closed box; an empty box (min > max on an axis) overlaps nothing
    int body = 0;
    int primitive = 0;
    /// The primitive's medial sphere indices, -1 where unused. Two items of the same body that
    /// share a sphere index (>= 0) are never paired.
    std::array<int, 3> spheres = { -1, -1, -1 };
};

/// Whether two items may form a candidate pair, boxes aside: different bodies, or the same body
/// and no shared sphere.
bool broad_phase_pair_allowed(const BroadPhaseItem& a, const BroadPhaseItem& b);

/// Candidate pair: indices into the item list, first < second.
using ItemPair = std::pair<int, int>;

struct SpatialHashSettings {
    /// Cell side as a multiple of the median largest box extent. On boxes spread over surfaces
    /// (as medial primitives are), 2 measured faster than 1 or 3.
    double cell_size_factor = 2.0;
    /// A fixed cell side (> 0) instead of the median rule.
    double cell_size = 0.0;
    /// Boxes covering more cells than this are checked against every item instead.
    int max_cells_per_item = 64;
    /// Below this many items the pair search runs on the calling thread (the result is the same
    /// either way).
    int parallel_threshold = 256;
    /// Whether pairs of items of the same body are reported (self-collision candidates).
    bool self_pairs = true;
};

class SpatialHash {
public:
    explicit SpatialHash(const SpatialHashSettings& settings = {});

    /// Builds the table over `items`. Throws mat::Error naming the item whose box has a NaN
    /// coordinate (the previous build then stays in place). Keeps no reference to `items`.
    void build(const std::vector<BroadPhaseItem>& items);

    /// The pairs of items of the last build() whose closed boxes overlap and that
    /// broad_phase_pair_allowed admits, sorted and unique. `out` is overwritten; its capacity is
    /// reused.
    void pairs(std::vector<ItemPair>& out);
    std::vector<ItemPair> pairs();

    /// Statistics of the last build().
    double cell_size() const { return m_cell_size; }
    std::size_t table_size() const { return m_table; }
    std::size_t num_entries() const { return m_entries.size(); }
    std::size_t num_oversize() const { return m_oversize.size(); }

private:
    struct Slot {
        Box3 box;
        int body;
        std::array<int, 3> spheres;
        std::array<std::int64_t, 3> lo; ///< lowest cell covered
        std::array<std::int64_t, 3> hi; ///< highest cell covered
        char state; ///< 0 empty box, 1 hashed, 2 oversize
    };

    /// The entries (one per cell of each hashed item) in bucket order, structure of arrays so
    /// that one entry is tested against several at once: its cell, box, item and body (the
    /// spheres, read on a hit only, stay in the item's slot).
    struct Entries {
        std::array<std::vector<std::int64_t>, 3> cell;
        std::array<std::vector<double>, 3> lo, hi;
        std::vector<int> item, body;

        std::size_t size() const { return item.size(); }
        void resize(std::size_t n);
    };

    /// Copies the items into m_slots: state 1 (hashed) for a non-empty box, 0 for an empty one.
    void copy_slots(const std::vector<BroadPhaseItem>& items);
    /// The cell side: the setting, or the median rule over the non-empty boxes.
    double choose_cell_size();
    /// Each hashed slot's cell range for cells of side h; a box covering too many cells (or too
    /// far out) becomes oversize. Returns the number of cells of the others.
    double assign_cells(double h);
    /// m_table and m_mask: a power of two, at least twice `total_cells`.
    void size_table(double total_cells);
    /// visit(i, x, y, z) for every cell of every hashed item, items in order.
    template <class Visit> void for_each_cell(const Visit& visit) const;
    /// m_keys (per entry, its (bucket, start mask) key) and m_bucket_start (the keys' offsets).
    void count_entries();
    /// m_entries: every entry at its key's place, items increasing within a key.
    void scatter_entries();
    std::size_t bucket(std::int64_t x, std::int64_t y, std::int64_t z) const;
    /// The pairs found in buckets [first, last), appended to `out` (unsorted).
    void bucket_pairs(std::size_t first, std::size_t last, std::vector<ItemPair>& out) const;
    /// The pairs of entry p with the entries [first, last) (all in one bucket), appended to `out`.
    void entry_pairs(int p, int first, int last, std::vector<ItemPair>& out) const;
    /// The pairs with an oversize item, appended to `out` (unsorted).
    void oversize_pairs(std::vector<ItemPair>& out) const;

    SpatialHashSettings m_settings;
    double m_cell_size = 0.0;
    std::vector<Slot> m_slots; ///< per item
    std::vector<int> m_oversize; ///< oversize items, increasing
    std::uint64_t m_mask = 0; ///< table size - 1 (a power of two)
    /// Groups per bucket: the 8 start masks.
    static constexpr std::size_t start_groups = 8;
    std::size_t m_table = 0; ///< buckets
    std::vector<int> m_bucket_start; ///< buckets x start_groups + 1, CSR over (bucket, mask)
    Entries m_entries; ///< by bucket and mask, increasing item within a group
    std::vector<double> m_extents; ///< largest box extents, for the median
    std::vector<std::size_t> m_keys; ///< per entry in item order, its (bucket, mask) key
    std::vector<int> m_fill; ///< per key, scatter cursors
    std::vector<std::vector<ItemPair>> m_chunk_pairs; ///< per chunk of buckets, reused
    std::vector<ItemPair> m_unsorted; ///< the chunks' pairs, then by second item (radix sort)
    std::vector<int> m_counts; ///< per item, the radix sort's counts
};

/// Reference: every allowed pair with overlapping closed boxes, by testing all n^2/2 pairs.
std::vector<ItemPair> all_pairs_boxes(const std::vector<BroadPhaseItem>& items);

} // namespace mat
