#pragma once
// Z-order (Morton) renumbering of tet meshes: neighbouring tets and vertices end up close in
// memory, which makes the per-tet gather/scatter loops of the bake and the solver 1.5-2x faster.

#include <cstdint>
#include <vector>

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

/// 63-bit Morton keys: each point quantized on a 2^21 grid spanning `box`, bits interleaved
/// x, y, z. Points outside the box are clamped onto it.
/// points  #P x 3
std::vector<std::uint64_t> morton_keys(const Eigen::Ref<const MatX3>& points, const Box3& box);

/// The order that sorts `keys` ascending, ties kept in index order: entry i is the old index of
/// the element that goes to position i.
std::vector<int> morton_sort_order(const std::vector<std::uint64_t>& keys);

/// The same mesh with vertices renumbered along the Z-curve of their positions and tets sorted
/// by the Morton key of their centroid (same grid). Tet orientation is kept.
TetMesh morton_reorder(const TetMesh& mesh);

} // namespace mat
