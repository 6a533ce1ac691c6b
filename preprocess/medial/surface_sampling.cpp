#include "preprocess/medial/surface_sampling.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "common/error.hpp"

namespace mat {
namespace {

    struct Candidates {
        std::vector<Vec3> points;
        std::vector<int> faces;

        void add(const Vec3& p, Index face)
        {
            points.push_back(p);
            faces.push_back(static_cast<int>(face));
        }
    };

    // Every vertex once, the interior points of every edge once (k segments per edge), and the
    // interior points of each face's barycentric lattice.
    Candidates lattice_points(const SurfaceMesh& surface, double spacing)
    {
        Candidates out;
        const Index num_faces = surface.num_faces();
        std::vector<int> vertex_face(static_cast<std::size_t>(surface.num_vertices()), -1);
        for (Index f = num_faces - 1; f >= 0; --f)
            for (int k = 0; k < 3; ++k)
                vertex_face[static_cast<std::size_t>(surface.faces(f, k))] = static_cast<int>(f);
        for (Index v = 0; v < surface.num_vertices(); ++v)
            if (vertex_face[static_cast<std::size_t>(v)] >= 0)
                out.add(surface.positions.row(v).transpose(), vertex_face[static_cast<size_t>(v)]);

        auto segments = [&](const Vec3& a, const Vec3& b) {
            return std::max(1, static_cast<int>(std::ceil((b - a).norm() / spacing)));
        };
        std::unordered_map<std::uint64_t, bool> done_edges;
        for (Index f = 0; f < num_faces; ++f) {
            const std::array<int, 3> v { surface.faces(f, 0), surface.faces(f, 1),
                surface.faces(f, 2) };
            std::array<Vec3, 3> x;
            for (int k = 0; k < 3; ++k)
                x[static_cast<std::size_t>(k)] = surface.positions.row(v[k]).transpose();
            int lattice = 1;
            for (int k = 0; k < 3; ++k) {
                const int a = v[static_cast<std::size_t>(k)], b = v[(k + 1) % 3];
                const Vec3& xa = x[static_cast<std::size_t>(k)];
                const Vec3& xb = x[(k + 1) % 3];
                const int n = segments(xa, xb);
                lattice = std::max(lattice, n);
                const std::uint64_t key
                    = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(std::min(a, b))) << 32)
                    | static_cast<std::uint32_t>(std::max(a, b));
                if (!done_edges.emplace(key, true).second)
                    continue;
                // Edge points run from the smaller vertex index, so both faces agree.
                const Vec3& from = a < b ? xa : xb;
                const Vec3& to = a < b ? xb : xa;
                for (int i = 1; i < n; ++i)
                    out.add(from + (double(i) / n) * (to - from), f);
            }
            // Interior lattice points (i, j, lattice - i - j), all three strictly positive.
            for (int i = 1; i < lattice; ++i)
                for (int j = 1; i + j < lattice; ++j) {
                    const double a = double(i) / lattice, b = double(j) / lattice;
                    out.add(a * x[0] + b * x[1] + (1.0 - a - b) * x[2], f);
                }
        }
        return out;
    }

    // Per cell of a grid of the given size, the candidate closest to the cell center (ties to
    // the first). Returns the kept indices in increasing order.
    std::vector<int> thin_on_grid(const std::vector<Vec3>& points, const Vec3& origin, double cell)
    {
        using Key = std::tuple<std::int64_t, std::int64_t, std::int64_t>;
        struct KeyHash {
            std::size_t operator()(const Key& k) const
            {
                return static_cast<std::size_t>(std::get<0>(k) * 73856093LL
                    ^ std::get<1>(k) * 19349663LL ^ std::get<2>(k) * 83492791LL);
            }
        };
        std::unordered_map<Key, std::pair<double, int>, KeyHash> best;
        best.reserve(points.size());
        for (std::size_t i = 0; i < points.size(); ++i) {
            const Vec3 scaled = (points[i] - origin) / cell;
            const Vec3 floor = scaled.array().floor();
            const Key key { static_cast<std::int64_t>(floor(0)),
                static_cast<std::int64_t>(floor(1)), static_cast<std::int64_t>(floor(2)) };
            const double score = (scaled - floor - Vec3::Constant(0.5)).squaredNorm();
            auto [it, inserted] = best.try_emplace(key, score, static_cast<int>(i));
            if (!inserted && score < it->second.first)
                it->second = { score, static_cast<int>(i) };
        }
        std::vector<int> kept;
        kept.reserve(best.size());
        for (const auto& entry : best)
            kept.push_back(entry.second.second);
        std::sort(kept.begin(), kept.end());
        return kept;
    }

} // namespace

SurfaceSamples sample_surface(const SurfaceMesh& surface, Index target_count)
{
    MAT_CHECK(target_count > 0, "sample count {} must be positive", target_count);
    if (surface.num_faces() == 0)
        throw_error("surface sampling: the surface has no face");
    double area = 0.0;
    Box3 box;
    for (Index f = 0; f < surface.num_faces(); ++f) {
        const Vec3 a = surface.positions.row(surface.faces(f, 0));
        const Vec3 b = surface.positions.row(surface.faces(f, 1));
        const Vec3 c = surface.positions.row(surface.faces(f, 2));
        area += 0.5 * (b - a).cross(c - a).norm();
        box.extend(a).extend(b).extend(c);
    }
    if (!(area > 0))
        throw_error("surface sampling: the surface has zero area");
    // A barycentric lattice of spacing h holds about 1.155 area / h^2 points.
    SurfaceSamples samples;
    samples.spacing = std::sqrt(1.155 * area / double(target_count));
    Candidates candidates = lattice_points(surface, samples.spacing);

    std::vector<int> kept;
    if (candidates.points.size() > static_cast<std::size_t>(1.3 * double(target_count))) {
        // Grid cells about as many as target_count over the area: cell ~ spacing; shrink until
        // enough points survive (a grid cell holds more surface than a lattice point).
        double cell = samples.spacing;
        for (int attempt = 0; attempt < 8; ++attempt) {
            kept = thin_on_grid(candidates.points, box.min(), cell);
            if (kept.size() >= static_cast<std::size_t>(0.8 * double(target_count)))
                break;
            cell *= 0.85;
        }
    } else {
        // Drop exact duplicates only (coincident vertices), keeping the first.
        kept.resize(candidates.points.size());
        for (std::size_t i = 0; i < kept.size(); ++i)
            kept[i] = static_cast<int>(i);
    }
    // Pairwise distinct: sort by coordinates, drop repeats.
    std::sort(kept.begin(), kept.end(), [&](int a, int b) {
        const Vec3& pa = candidates.points[static_cast<std::size_t>(a)];
        const Vec3& pb = candidates.points[static_cast<std::size_t>(b)];
        return std::tie(pa(0), pa(1), pa(2), a) < std::tie(pb(0), pb(1), pb(2), b);
    });
    kept.erase(std::unique(kept.begin(), kept.end(),
                   [&](int a, int b) {
                       return candidates.points[static_cast<std::size_t>(a)]
                           == candidates.points[static_cast<std::size_t>(b)];
                   }),
        kept.end());
    std::sort(kept.begin(), kept.end());

    samples.points.resize(static_cast<Index>(kept.size()), 3);
    samples.faces.resize(static_cast<Index>(kept.size()));
    for (std::size_t i = 0; i < kept.size(); ++i) {
        samples.points.row(static_cast<Index>(i))
            = candidates.points[static_cast<std::size_t>(kept[i])].transpose();
        samples.faces(static_cast<Index>(i)) = candidates.faces[static_cast<std::size_t>(kept[i])];
    }
    return samples;
}

} // namespace mat
