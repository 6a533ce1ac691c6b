#include "preprocess/medial/medial_complex_graph.hpp"

#include <algorithm>

#include "common/error.hpp"

namespace mat {

MedialComplexGraph::MedialComplexGraph(const MedialComplex& complex)
{
    const Index n = complex.num_spheres();
    if (n >= (Index(1) << 21))
        throw_error("medial generator: {} initial spheres, at most {} are supported (use fewer "
                    "surface samples)",
            n, Index(1) << 21);
    const std::size_t size = static_cast<std::size_t>(n);
    m_spheres.resize(size);
    for (Index s = 0; s < n; ++s)
        m_spheres[static_cast<std::size_t>(s)] << complex.centers.row(s).transpose(),
            complex.radii(s);
    m_alive.assign(size, 1);
    m_version.assign(size, 0u);
    m_num_alive = n;
    m_neighbors.resize(size);
    m_sphere_slabs.resize(size);
    for (const auto& e : complex.edges) {
        m_neighbors[static_cast<std::size_t>(e[0])].push_back(e[1]);
        m_neighbors[static_cast<std::size_t>(e[1])].push_back(e[0]);
    }
    m_slabs = complex.triangles;
    m_slab_alive.assign(m_slabs.size(), 1);
    m_slab_index.reserve(m_slabs.size());
    for (std::size_t t = 0; t < m_slabs.size(); ++t) {
        m_slab_index.emplace(slab_key(m_slabs[t]), static_cast<int>(t));
        for (int v : m_slabs[t])
            m_sphere_slabs[static_cast<std::size_t>(v)].push_back(static_cast<int>(t));
    }
}

std::uint64_t MedialComplexGraph::slab_key(std::array<int, 3> t)
{
    std::sort(t.begin(), t.end());
    return (static_cast<std::uint64_t>(t[0]) << 42) | (static_cast<std::uint64_t>(t[1]) << 21)
        | static_cast<std::uint64_t>(t[2]);
}

std::vector<int> MedialComplexGraph::merged_neighbors(int a, int b) const
{
    std::vector<int> out;
    for (int s : { a, b })
        for (int k : neighbors(s))
            if (k != a && k != b)
                out.push_back(k);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

std::vector<std::array<int, 2>> MedialComplexGraph::merged_slab_partners(int a, int b) const
{
    std::vector<std::array<int, 2>> out;
    for (int s : { a, b })
        for (int t : m_sphere_slabs[static_cast<std::size_t>(s)]) {
            if (!m_slab_alive[static_cast<std::size_t>(t)])
                continue;
            std::array<int, 2> pair {};
            int count = 0;
            bool degenerate = false;
            for (int v : m_slabs[static_cast<std::size_t>(t)]) {
                if (v == a || v == b)
                    continue;
                if (count == 2) {
                    degenerate = true;
                    break;
                }
                pair[static_cast<std::size_t>(count++)] = v;
            }
            if (degenerate || count != 2)
                continue; // held both a and b: becomes an edge
            if (pair[0] > pair[1])
                std::swap(pair[0], pair[1]);
            out.push_back(pair);
        }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

std::vector<std::array<int, 2>> MedialComplexGraph::alive_edges() const
{
    std::vector<std::array<int, 2>> edges;
    for (int s = 0; s < num_spheres(); ++s)
        if (alive(s))
            for (int k : neighbors(s))
                if (s < k)
                    edges.push_back({ s, k });
    std::sort(edges.begin(), edges.end());
    return edges;
}

void MedialComplexGraph::remove_neighbor(int s, int value)
{
    auto& list = m_neighbors[static_cast<std::size_t>(s)];
    list.erase(std::remove(list.begin(), list.end(), value), list.end());
}

void MedialComplexGraph::collapse(int a, int b, const Vec4& m)
{
    MAT_CHECK(a < b && alive(a) && alive(b), "collapse of {} into {}", b, a);
    const std::size_t ia = static_cast<std::size_t>(a), ib = static_cast<std::size_t>(b);
    m_alive[ib] = 0;
    --m_num_alive;
    m_spheres[ia] = m;
    ++m_version[ia];
    ++m_version[ib];

    // Slabs of b move to a; those that degenerate or duplicate one of a's die.
    for (int t : m_sphere_slabs[ib]) {
        const std::size_t it = static_cast<std::size_t>(t);
        if (!m_slab_alive[it])
            continue;
        std::array<int, 3>& slab = m_slabs[it];
        m_slab_index.erase(slab_key(slab));
        std::replace(slab.begin(), slab.end(), b, a);
        if (std::count(slab.begin(), slab.end(), a) > 1
            || !m_slab_index.emplace(slab_key(slab), t).second) {
            m_slab_alive[it] = 0;
            continue;
        }
        m_sphere_slabs[ia].push_back(t);
    }
    m_sphere_slabs[ib] = std::vector<int>();
    auto& own = m_sphere_slabs[ia];
    own.erase(std::remove_if(own.begin(), own.end(),
                  [&](int t) { return !m_slab_alive[static_cast<std::size_t>(t)]; }),
        own.end());

    // Neighbors of b become neighbors of a.
    for (int k : m_neighbors[ib]) {
        if (k == a)
            continue;
        remove_neighbor(k, b);
        auto& list = m_neighbors[static_cast<std::size_t>(k)];
        if (std::find(list.begin(), list.end(), a) == list.end()) {
            list.push_back(a);
            m_neighbors[ia].push_back(k);
        }
    }
    m_neighbors[ib] = std::vector<int>();
    remove_neighbor(a, b);
}

MedialMesh MedialComplexGraph::to_medial_mesh() const
{
    std::vector<int> index(m_spheres.size(), -1);
    int count = 0;
    for (std::size_t s = 0; s < m_spheres.size(); ++s)
        if (m_alive[s])
            index[s] = count++;
    MedialMesh mesh;
    mesh.centers.resize(count, 3);
    mesh.radii.resize(count);
    for (std::size_t s = 0; s < m_spheres.size(); ++s)
        if (m_alive[s]) {
            mesh.centers.row(index[s]) = m_spheres[s].head<3>().transpose();
            mesh.radii(index[s]) = m_spheres[s](3);
        }
    std::vector<std::array<int, 3>> slabs;
    std::vector<std::array<int, 2>> slab_edges;
    for (std::size_t t = 0; t < m_slabs.size(); ++t) {
        if (!m_slab_alive[t])
            continue;
        std::array<int, 3> slab;
        for (int k = 0; k < 3; ++k)
            slab[static_cast<std::size_t>(k)]
                = index[static_cast<std::size_t>(m_slabs[t][static_cast<std::size_t>(k)])];
        std::sort(slab.begin(), slab.end());
        slabs.push_back(slab);
        slab_edges.push_back({ slab[0], slab[1] });
        slab_edges.push_back({ slab[1], slab[2] });
        slab_edges.push_back({ slab[0], slab[2] });
    }
    std::sort(slabs.begin(), slabs.end());
    std::sort(slab_edges.begin(), slab_edges.end());
    std::vector<std::array<int, 2>> cones;
    for (const auto& e : alive_edges()) {
        const std::array<int, 2> cone { index[static_cast<std::size_t>(e[0])],
            index[static_cast<std::size_t>(e[1])] };
        if (!std::binary_search(slab_edges.begin(), slab_edges.end(), cone))
            cones.push_back(cone);
    }
    std::sort(cones.begin(), cones.end());
    mesh.cones.resize(static_cast<Index>(cones.size()), 2);
    for (std::size_t c = 0; c < cones.size(); ++c)
        mesh.cones.row(static_cast<Index>(c)) << cones[c][0], cones[c][1];
    mesh.slabs.resize(static_cast<Index>(slabs.size()), 3);
    for (std::size_t s = 0; s < slabs.size(); ++s)
        mesh.slabs.row(static_cast<Index>(s)) << slabs[s][0], slabs[s][1], slabs[s][2];
    return mesh;
}

} // namespace mat
