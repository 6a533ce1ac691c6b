#pragma once
// The connectivity of a medial complex under edge collapse: spheres, their neighbors (every
// edge, slab edges included) and the slabs, with the non-manifold bookkeeping of a collapse
// (slabs that degenerate or coincide are dropped, edges merged).

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"
#include "preprocess/medial/voronoi_medial.hpp"

namespace mat {

class MedialComplexGraph {
public:
    /// Takes the spheres, edges and triangles of `complex` (at most 2^21 spheres).
    explicit MedialComplexGraph(const MedialComplex& complex);

    int num_spheres() const { return static_cast<int>(m_spheres.size()); }
    Index num_alive() const { return m_num_alive; }
    bool alive(int s) const { return m_alive[static_cast<std::size_t>(s)] != 0; }
    /// Changes whenever the sphere changes (in a collapse).
    unsigned version(int s) const { return m_version[static_cast<std::size_t>(s)]; }
    /// (center, radius)
    const Vec4& sphere(int s) const { return m_spheres[static_cast<std::size_t>(s)]; }
    const std::vector<int>& neighbors(int s) const { return m_neighbors[static_cast<size_t>(s)]; }

    /// The neighbors the merged sphere of a and b would have, sorted.
    std::vector<int> merged_neighbors(int a, int b) const;
    /// The other two spheres (k < l) of every slab the merged sphere would have, sorted.
    std::vector<std::array<int, 2>> merged_slab_partners(int a, int b) const;
    /// Every edge (a < b) between alive spheres, sorted.
    std::vector<std::array<int, 2>> alive_edges() const;

    /// Merges b into a (neighbors, a < b) as the sphere m.
    void collapse(int a, int b, const Vec4& m);

    /// Alive spheres (by increasing index), cones (edges on no slab) and slabs, sorted.
    MedialMesh to_medial_mesh() const;

private:
    static std::uint64_t slab_key(std::array<int, 3> t);
    void remove_neighbor(int s, int value);

    std::vector<Vec4, Eigen::aligned_allocator<Vec4>> m_spheres;
    std::vector<char> m_alive;
    std::vector<unsigned> m_version;
    Index m_num_alive = 0;
    std::vector<std::vector<int>> m_neighbors;
    std::vector<std::vector<int>> m_sphere_slabs; ///< slab indices (some may be dead)
    std::vector<std::array<int, 3>> m_slabs;
    std::vector<char> m_slab_alive;
    std::unordered_map<std::uint64_t, int> m_slab_index; ///< alive slabs by sorted vertices
};

} // namespace mat
