#include "preprocess/medial/voronoi_medial.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <tuple>

#include <tbb/parallel_for.h>

#include "common/union_find.hpp"

namespace mat {
namespace {

    // Face k of a sorted tet row: the other three vertices, still sorted.
    std::array<int, 3> tet_face(const Eigen::Ref<const MatX4i>& tets, Index t, int k)
    {
        std::array<int, 3> face {};
        int n = 0;
        for (int i = 0; i < 4; ++i)
            if (i != k)
                face[static_cast<std::size_t>(n++)] = tets(t, i);
        return face;
    }

    std::uint64_t pair_key(int a, int b)
    {
        return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(std::min(a, b))) << 32)
            | static_cast<std::uint32_t>(std::max(a, b));
    }

    // neighbors(t, k): the tet across the face opposite vertex k of t, -1 on the hull.
    MatX4i face_neighbors(const Eigen::Ref<const MatX4i>& tets)
    {
        struct Entry {
            std::array<int, 3> face;
            int tet;
            int k;
        };
        std::vector<Entry> entries;
        entries.reserve(static_cast<std::size_t>(4 * tets.rows()));
        for (Index t = 0; t < tets.rows(); ++t)
            for (int k = 0; k < 4; ++k)
                entries.push_back({ tet_face(tets, t, k), static_cast<int>(t), k });
        std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
            return std::tie(a.face, a.tet) < std::tie(b.face, b.tet);
        });
        MatX4i neighbors = MatX4i::Constant(tets.rows(), 4, -1);
        for (std::size_t i = 0; i + 1 < entries.size(); ++i)
            if (entries[i].face == entries[i + 1].face) {
                neighbors(entries[i].tet, entries[i].k) = entries[i + 1].tet;
                neighbors(entries[i + 1].tet, entries[i + 1].k) = entries[i].tet;
                ++i;
            }
        return neighbors;
    }

    // Circumcenter of a tet; non-finite when it is flat.
    Vec3 circumcenter(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d)
    {
        const Vec3 u = b - a, v = c - a, w = d - a;
        const double det = 2.0 * u.dot(v.cross(w));
        return a
            + (u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u)
                  + w.squaredNorm() * u.cross(v))
            / det;
    }

    // Inner tets separated by a few outer tets (where a part is thinner than the sampling, or
    // near a sharp edge) leave the complex in pieces that no collapse can join. Joins the pieces
    // with the shortest edges between inner tets at most k_bridge_hops outer tets apart whose
    // middle sphere stays inside the surface (Kruskal), as cones.
    constexpr int k_bridge_hops = 3;

    void bridge_components(MedialComplex& complex, const Eigen::Ref<const MatX4i>& tets,
        const MatX4i& neighbors, const std::vector<char>& inner, const std::vector<int>& sphere_of,
        const SurfaceDistance& surface, double min_depth)
    {
        const Index n = complex.num_spheres();
        UnionFind parts(n);
        for (const auto& e : complex.edges)
            parts.unite(e[0], e[1]);
        Index pieces = 0;
        for (Index s = 0; s < n; ++s)
            pieces += parts.find(s) == s ? 1 : 0;
        if (pieces <= 1)
            return;
        // Candidate pairs: inner tets reached from an inner tet through outer tets only.
        std::vector<std::tuple<double, int, int>> candidates;
        std::vector<int> frontier, next, seen;
        for (Index t = 0; t < tets.rows(); ++t) {
            const int from = sphere_of[static_cast<std::size_t>(t)];
            if (from < 0)
                continue;
            frontier.assign(1, static_cast<int>(t));
            seen.assign(1, static_cast<int>(t));
            for (int hop = 0; hop <= k_bridge_hops && !frontier.empty(); ++hop) {
                next.clear();
                for (int current : frontier)
                    for (int k = 0; k < 4; ++k) {
                        const int u = neighbors(current, k);
                        if (u < 0 || std::find(seen.begin(), seen.end(), u) != seen.end())
                            continue;
                        seen.push_back(u);
                        const int to = sphere_of[static_cast<std::size_t>(u)];
                        if (!inner[static_cast<std::size_t>(u)])
                            next.push_back(u);
                        else if (hop > 0 && to > from && parts.find(to) != parts.find(from))
                            candidates.emplace_back(
                                (complex.centers.row(from) - complex.centers.row(to)).norm(), from,
                                to);
                    }
                frontier.swap(next);
            }
        }
        std::sort(candidates.begin(), candidates.end());
        for (const auto& [length, a, b] : candidates) {
            if (parts.find(a) == parts.find(b))
                continue;
            const Vec3 middle = 0.5 * (complex.centers.row(a) + complex.centers.row(b)).transpose();
            const double radius = 0.5 * (complex.radii(a) + complex.radii(b));
            const double depth = -surface.signed_distance(middle);
            if (depth < min_depth || radius > depth + length)
                continue;
            parts.unite(a, b);
            complex.edges.push_back({ std::min(a, b), std::max(a, b) });
        }
    }

    /// Step 1's result, per tet: its circumcenter, its depth inside the surface (-1 where the
    /// circumcenter is not finite or outside the bounds) and whether that depth is > min_depth.
    struct Circumcenters {
        MatX3 centers;
        VecX depth;
        std::vector<char> inner;
    };

    // 1. Circumcenters, and their depth inside the surface (-signed distance).
    Circumcenters tet_circumcenters(const Eigen::Ref<const MatX3>& samples,
        const Eigen::Ref<const MatX4i>& tets, const SurfaceDistance& surface, double min_depth)
    {
        const Index num_tets = tets.rows();
        const Box3& bounds = surface.bounds();
        Circumcenters result { MatX3(num_tets, 3), VecX::Constant(num_tets, -1.0),
            std::vector<char>(static_cast<std::size_t>(num_tets)) };
        MatX3& centers = result.centers;
        VecX& depth = result.depth;
        tbb::parallel_for(Index(0), num_tets, [&](Index t) {
            const Vec3 center = circumcenter(samples.row(tets(t, 0)), samples.row(tets(t, 1)),
                samples.row(tets(t, 2)), samples.row(tets(t, 3)));
            centers.row(t) = center.transpose();
            if (center.allFinite() && bounds.contains(center))
                depth(t) = -surface.signed_distance(center);
        });
        for (Index t = 0; t < num_tets; ++t)
            result.inner[static_cast<std::size_t>(t)] = depth(t) > min_depth;
        return result;
    }

    /// Step 2's result: inner tets of one class share a circumcenter, and each class is a
    /// sphere; sphere_of[t] is tet t's sphere, -1 for an outer tet.
    struct TetSpheres {
        UnionFind classes;
        std::vector<int> sphere_of;
        int count = 0;
    };

    // 2. Merges face-adjacent inner tets with (numerically) the same circumcenter and numbers
    // the classes in the order of their first tet.
    TetSpheres merge_tets(
        const Circumcenters& tet_centers, const MatX4i& neighbors, double merge_distance)
    {
        const Index num_tets = neighbors.rows();
        const std::vector<char>& inner = tet_centers.inner;
        const MatX3& centers = tet_centers.centers;
        TetSpheres spheres { UnionFind(num_tets),
            std::vector<int>(static_cast<std::size_t>(num_tets), -1) };
        UnionFind& classes = spheres.classes;
        std::vector<int>& sphere_of = spheres.sphere_of;
        for (Index t = 0; t < num_tets; ++t)
            for (int k = 0; k < 4; ++k) {
                const int u = neighbors(t, k);
                if (u > t && inner[static_cast<std::size_t>(t)]
                    && inner[static_cast<std::size_t>(u)]
                    && (centers.row(t) - centers.row(u)).norm() <= merge_distance)
                    classes.unite(t, u);
            }
        for (Index t = 0; t < num_tets; ++t)
            if (inner[static_cast<std::size_t>(t)] && classes.find(t) == t)
                sphere_of[static_cast<std::size_t>(t)] = spheres.count++;
        for (Index t = 0; t < num_tets; ++t)
            if (inner[static_cast<std::size_t>(t)])
                sphere_of[static_cast<std::size_t>(t)]
                    = sphere_of[static_cast<std::size_t>(classes.find(t))];
        return spheres;
    }

    // The spheres (center and depth of their class's first tet) and their contact samples (the
    // corners of their tets, sorted, without repeats).
    void add_spheres(const Eigen::Ref<const MatX4i>& tets, const Circumcenters& tet_centers,
        TetSpheres& spheres, MedialComplex& complex)
    {
        const Index num_tets = tets.rows();
        const int num_spheres = spheres.count;
        complex.centers.resize(num_spheres, 3);
        complex.radii.resize(num_spheres);
        std::vector<std::vector<int>> contacts(static_cast<std::size_t>(num_spheres));
        for (Index t = 0; t < num_tets; ++t) {
            const int s = spheres.sphere_of[static_cast<std::size_t>(t)];
            if (s < 0)
                continue;
            if (spheres.classes.find(t) == t) {
                complex.centers.row(s) = tet_centers.centers.row(t);
                complex.radii(s) = tet_centers.depth(t);
            }
            for (int k = 0; k < 4; ++k)
                contacts[static_cast<std::size_t>(s)].push_back(tets(t, k));
        }
        complex.contact_offsets.assign(1, 0);
        for (std::vector<int>& list : contacts) {
            std::sort(list.begin(), list.end());
            list.erase(std::unique(list.begin(), list.end()), list.end());
            complex.contact_samples.insert(complex.contact_samples.end(), list.begin(), list.end());
            complex.contact_offsets.push_back(static_cast<int>(complex.contact_samples.size()));
        }
    }

    // 3. Voronoi edges: inner tets sharing a face.
    void add_voronoi_edges(
        const MatX4i& neighbors, const std::vector<int>& sphere_of, MedialComplex& complex)
    {
        for (Index t = 0; t < neighbors.rows(); ++t)
            for (int k = 0; k < 4; ++k) {
                const int u = neighbors(t, k);
                if (u <= t)
                    continue;
                const int a = sphere_of[static_cast<std::size_t>(t)];
                const int b = sphere_of[static_cast<std::size_t>(u)];
                if (a >= 0 && b >= 0 && a != b)
                    complex.edges.push_back({ std::min(a, b), std::max(a, b) });
            }
    }

    // Walks around the Delaunay edge (a, b) from tet `start` through the faces that contain it,
    // writing the spheres met to `ring`; true if the walk closes through `count` inner tets
    // (false for an outer tet, or the hull, on the ring).
    bool walk_edge_ring(const Eigen::Ref<const MatX4i>& tets, const MatX4i& neighbors,
        const std::vector<char>& inner, const std::vector<int>& sphere_of, int a, int b, int start,
        std::size_t count, std::vector<int>& ring)
    {
        ring.clear();
        int previous = -1, current = start;
        bool closed = false;
        for (std::size_t step = 0; step <= count; ++step) {
            if (current < 0 || !inner[static_cast<std::size_t>(current)])
                break;
            ring.push_back(sphere_of[static_cast<std::size_t>(current)]);
            int next = -1;
            for (int k = 0; k < 4; ++k) {
                const int opposite = tets(current, k);
                const int candidate = neighbors(current, k);
                if (opposite != a && opposite != b && candidate != previous) {
                    next = candidate;
                    break;
                }
            }
            previous = current;
            current = next;
            if (current == start) {
                closed = true;
                break;
            }
        }
        return closed && ring.size() == count;
    }

    // Drops repeats of merged spheres from a closed ring, then fans out the convex polygon into
    // triangles and their edges.
    void add_ring_triangles(std::vector<int>& ring, MedialComplex& complex)
    {
        ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
        while (ring.size() > 1 && ring.front() == ring.back())
            ring.pop_back();
        for (std::size_t i = 1; i + 1 < ring.size(); ++i) {
            std::array<int, 3> triangle { ring[0], ring[i], ring[i + 1] };
            std::sort(triangle.begin(), triangle.end());
            if (triangle[0] == triangle[1] || triangle[1] == triangle[2])
                continue;
            complex.triangles.push_back(triangle);
            complex.edges.push_back({ triangle[0], triangle[1] });
            complex.edges.push_back({ triangle[1], triangle[2] });
            complex.edges.push_back({ triangle[0], triangle[2] });
        }
    }

    // 4. Voronoi faces: the ring of tets around each Delaunay edge, when all are inner.
    void add_voronoi_faces(const Eigen::Ref<const MatX4i>& tets, const MatX4i& neighbors,
        const std::vector<char>& inner, const std::vector<int>& sphere_of, MedialComplex& complex)
    {
        const Index num_tets = tets.rows();
        std::vector<std::pair<std::uint64_t, int>> edge_tets;
        edge_tets.reserve(static_cast<std::size_t>(6 * num_tets));
        for (Index t = 0; t < num_tets; ++t) {
            if (!inner[static_cast<std::size_t>(t)])
                continue;
            for (int i = 0; i < 4; ++i)
                for (int j = i + 1; j < 4; ++j)
                    edge_tets.emplace_back(pair_key(tets(t, i), tets(t, j)), static_cast<int>(t));
        }
        std::sort(edge_tets.begin(), edge_tets.end());
        std::vector<int> ring;
        for (std::size_t begin = 0; begin < edge_tets.size();) {
            std::size_t end = begin;
            while (end < edge_tets.size() && edge_tets[end].first == edge_tets[begin].first)
                ++end;
            const int a = static_cast<int>(edge_tets[begin].first >> 32);
            const int b = static_cast<int>(edge_tets[begin].first & 0xffffffffu);
            const std::size_t count = end - begin;
            const int start = edge_tets[begin].second;
            begin = end;
            if (walk_edge_ring(tets, neighbors, inner, sphere_of, a, b, start, count, ring))
                add_ring_triangles(ring, complex);
        }
    }

    // Sorts the complex's edges and triangles and drops repeats.
    void sort_unique(MedialComplex& complex)
    {
        std::sort(complex.edges.begin(), complex.edges.end());
        complex.edges.erase(
            std::unique(complex.edges.begin(), complex.edges.end()), complex.edges.end());
        std::sort(complex.triangles.begin(), complex.triangles.end());
        complex.triangles.erase(std::unique(complex.triangles.begin(), complex.triangles.end()),
            complex.triangles.end());
    }

} // namespace

MedialComplex inner_voronoi_complex(const Eigen::Ref<const MatX3>& samples,
    const Eigen::Ref<const MatX4i>& tets, const SurfaceDistance& surface, double min_depth)
{
    const double diagonal = surface.bounds().diagonal().norm();
    const Circumcenters tet_centers = tet_circumcenters(samples, tets, surface, min_depth);
    const MatX4i neighbors = face_neighbors(tets);
    TetSpheres spheres = merge_tets(tet_centers, neighbors, 1e-9 * diagonal);

    MedialComplex complex;
    add_spheres(tets, tet_centers, spheres, complex);
    add_voronoi_edges(neighbors, spheres.sphere_of, complex);
    add_voronoi_faces(tets, neighbors, tet_centers.inner, spheres.sphere_of, complex);
    bridge_components(
        complex, tets, neighbors, tet_centers.inner, spheres.sphere_of, surface, min_depth);
    sort_unique(complex);
    return complex;
}

} // namespace mat
