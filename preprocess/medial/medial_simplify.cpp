#include "preprocess/medial/medial_simplify.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <queue>
#include <vector>

#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "preprocess/medial/local_envelope.hpp"
#include "preprocess/medial/medial_complex_graph.hpp"
#include "preprocess/medial/sphere_quadric.hpp"

namespace mat {
namespace {

    /// Phase 2 measures a collapse on at most about 2 x this many samples per sphere: the
    /// worst of the last measurement first, then a spread of the rest (a flat face can give
    /// one sphere thousands of samples, most at distance ~0).
    constexpr std::size_t k_sample_budget = 64;

    struct HeapEntry {
        double cost;
        int a, b; ///< a < b
        unsigned version_a, version_b; ///< the entry is stale once either sphere changed
        bool checked; ///< `merged` and `depth` hold the checked candidate
        std::array<double, 4> merged; ///< (center, radius)
        double depth; ///< a lower bound of the merged center's depth inside the surface

        bool operator>(const HeapEntry& other) const
        {
            if (cost != other.cost)
                return cost > other.cost;
            return a != other.a ? a > other.a : b > other.b;
        }
    };

    /// Candidate merged spheres, best first. Fixed-size storage: no over-aligned Eigen type in
    /// a standard container.
    struct Candidates {
        Mat4 spheres; ///< column k = candidate k
        std::array<double, 4> errors {};
        std::array<int, 4> order {}; ///< columns by increasing error
        int count = 0;

        bool empty() const { return count == 0; }
        double best_error() const { return errors[static_cast<std::size_t>(order[0])]; }
    };

    class Simplifier {
    public:
        Simplifier(const MedialComplex& complex, const Eigen::Ref<const MatX3>& samples,
            const SurfaceDistance& surface, const SimplifyOptions& options)
            : m_graph(complex)
            , m_samples(samples)
            , m_surface(surface)
            , m_options(options)
            , m_tolerance(options.max_protrusion)
        {
            const std::size_t n = static_cast<std::size_t>(complex.num_spheres());
            m_quadrics.resize(n);
            m_depth.assign(complex.radii.data(), complex.radii.data() + n);
            m_owned.resize(n);
            // Each sphere's quadric: the tangent planes at the samples it touches.
            for (std::size_t s = 0; s < n; ++s) {
                const Vec3 c = m_graph.sphere(static_cast<int>(s)).head<3>();
                for (int k = complex.contact_offsets[s]; k < complex.contact_offsets[s + 1]; ++k) {
                    const Vec3 p = samples.row(complex.contact_samples[static_cast<size_t>(k)]);
                    const Vec3 normal = (p - c).normalized();
                    if (normal.allFinite())
                        m_quadrics[s].add_plane(normal, normal.dot(p));
                }
            }
        }

        void run(SimplifyReport& report)
        {
            const double refine_from = m_options.refine_factor * double(m_options.target_spheres);
            if (double(m_graph.num_alive()) <= refine_from)
                start_refinement();
            push_all_edges();
            while (m_graph.num_alive() > m_options.target_spheres) {
                if (m_options.max_surface_queries > 0
                    && m_queries > m_options.max_surface_queries) {
                    report.stopped_at_bound = true;
                    break;
                }
                if (!m_refining && double(m_graph.num_alive()) <= refine_from) {
                    start_refinement();
                    push_all_edges();
                }
                if (m_heap.empty()) {
                    // Every remaining collapse was refused: relax the protrusion tolerance.
                    if (report.relaxations >= 60)
                        break;
                    ++report.relaxations;
                    m_tolerance *= 2.0;
                    if (push_all_edges() == 0)
                        break;
                    continue;
                }
                const HeapEntry entry = m_heap.top();
                m_heap.pop();
                if (!m_graph.alive(entry.a) || !m_graph.alive(entry.b)
                    || m_graph.version(entry.a) != entry.version_a
                    || m_graph.version(entry.b) != entry.version_b)
                    continue;
                Vec4 merged(entry.merged.data());
                double depth = entry.depth;
                // A checked entry was checked against the neighborhood of its time.
                if (!entry.checked || !primitives_inside(entry.a, entry.b, merged, depth)) {
                    double error = 0.0;
                    if (!choose(entry.a, entry.b, merged, depth, error)) {
                        ++report.rejected;
                        continue;
                    }
                    // The checks may have raised the cost: requeue unless still the cheapest.
                    const double cost = collapse_cost(entry.a, entry.b, error);
                    if (!entry.checked && !m_heap.empty() && cost > m_heap.top().cost) {
                        HeapEntry again = entry;
                        again.cost = cost;
                        again.checked = true;
                        Eigen::Map<Vec4>(again.merged.data()) = merged;
                        again.depth = depth;
                        m_heap.push(again);
                        continue;
                    }
                }
                collapse(entry.a, entry.b, merged, depth);
                ++report.collapses;
                report.refine_collapses += m_refining ? 1 : 0;
            }
            report.final_max_protrusion = m_tolerance;
            report.surface_queries = m_queries;
        }

        MedialMesh result() const { return m_graph.to_medial_mesh(); }

    private:
        // Phase 2: every sample goes to the alive sphere nearest to it (|p - c| - r).
        void start_refinement()
        {
            m_refining = true;
            m_heap = decltype(m_heap)();
            std::vector<int> alive;
            for (int s = 0; s < m_graph.num_spheres(); ++s)
                if (m_graph.alive(s))
                    alive.push_back(s);
            std::vector<int> nearest(static_cast<std::size_t>(m_samples.rows()), -1);
            tbb::parallel_for(Index(0), m_samples.rows(), [&](Index i) {
                const Vec3 p = m_samples.row(i).transpose();
                double best = std::numeric_limits<double>::infinity();
                for (int s : alive) {
                    const Vec4& m = m_graph.sphere(s);
                    const double d = (p - m.head<3>()).norm() - m(3);
                    if (d < best) {
                        best = d;
                        nearest[static_cast<std::size_t>(i)] = s;
                    }
                }
            });
            for (std::size_t i = 0; i < nearest.size(); ++i)
                if (nearest[i] >= 0)
                    m_owned[static_cast<std::size_t>(nearest[i])].push_back(static_cast<int>(i));
            tbb::parallel_for(
                std::size_t(0), alive.size(), [&](std::size_t k) { sort_owned(alive[k]); });
        }

        // Orders the samples of s by decreasing distance to its primitives, so that measuring
        // a collapse of s meets its worst samples first and can stop early.
        void sort_owned(int s)
        {
            std::vector<int>& owned = m_owned[static_cast<std::size_t>(s)];
            LocalEnvelope envelope = merged_envelope(s, s, m_graph.sphere(s));
            std::vector<double> errors;
            envelope.squared_distances(m_samples, owned, errors);
            std::vector<std::size_t> order(owned.size());
            for (std::size_t i = 0; i < order.size(); ++i)
                order[i] = i;
            std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
                return errors[x] > errors[y] || (errors[x] == errors[y] && owned[x] < owned[y]);
            });
            std::vector<int> sorted(owned.size());
            for (std::size_t i = 0; i < order.size(); ++i)
                sorted[i] = owned[order[i]];
            owned = std::move(sorted);
        }

        // The primitives the merged sphere m of a and b would have (a == b: those of a, as m).
        LocalEnvelope merged_envelope(int a, int b, const Vec4& m) const
        {
            // A cone on a slab's edge lies inside the slab: only the other edges make cones.
            const std::vector<int> neighbors = m_graph.merged_neighbors(a, b);
            const std::vector<std::array<int, 2>> slabs = m_graph.merged_slab_partners(a, b);
            std::vector<int> on_slabs;
            for (const auto& pair : slabs)
                on_slabs.insert(on_slabs.end(), pair.begin(), pair.end());
            std::sort(on_slabs.begin(), on_slabs.end());
            LocalEnvelope envelope(m);
            envelope.reserve(neighbors.size(), neighbors.size() + slabs.size());
            for (int k : neighbors) {
                envelope.add_sphere(m_graph.sphere(k));
                if (!std::binary_search(on_slabs.begin(), on_slabs.end(), k))
                    envelope.add_cone(m_graph.sphere(k));
            }
            for (const auto& pair : slabs)
                envelope.add_slab(m_graph.sphere(pair[0]), m_graph.sphere(pair[1]));
            return envelope;
        }

        // The error of merging a and b into m: the quadric's in phase 1, the largest squared
        // distance of the owned samples to the merged primitives in phase 2 (exact up to
        // `bound`, above which it may stop).
        double error(int a, int b, const SphereQuadric& q, const Vec4& m, double bound) const
        {
            if (!m_refining)
                return q.error(m);
            LocalEnvelope envelope = merged_envelope(a, b, m);
            const double first = envelope.max_squared_distance(
                m_samples, m_owned[static_cast<std::size_t>(a)], bound, k_sample_budget);
            if (first > bound)
                return first;
            return std::max(first,
                envelope.max_squared_distance(
                    m_samples, m_owned[static_cast<std::size_t>(b)], bound, k_sample_budget));
        }

        // The quadric's minimizer and the best point of the segment between the spheres, and in
        // phase 1 both ends too; sorted by error. Errors above `bound` may be lower bounds.
        Candidates candidates(
            int a, int b, double bound = std::numeric_limits<double>::infinity()) const
        {
            const SphereQuadric q
                = m_quadrics[static_cast<std::size_t>(a)] + m_quadrics[static_cast<std::size_t>(b)];
            const Vec4& ma = m_graph.sphere(a);
            const Vec4& mb = m_graph.sphere(b);
            Candidates list;
            double best = bound;
            auto add = [&](const Vec4& m) {
                if (!m.allFinite() || m(3) < m_options.min_depth)
                    return;
                const double e = error(a, b, q, m, best);
                best = std::min(best, e);
                list.spheres.col(list.count) = m;
                list.errors[static_cast<std::size_t>(list.count)] = e;
                list.order[static_cast<std::size_t>(list.count)] = list.count;
                ++list.count;
            };
            add(q.minimizer(0.5 * (ma + mb)));
            const Vec4 d = mb - ma;
            const double dad = d.dot(q.a * d);
            if (dad > 0)
                add(ma + std::clamp((q.b.dot(d) - d.dot(q.a * ma)) / dad, 0.0, 1.0) * d);
            if (!m_refining) {
                add(ma);
                add(mb);
            }
            std::sort(list.order.begin(), list.order.begin() + list.count, [&](int x, int y) {
                const double ex = list.errors[static_cast<std::size_t>(x)];
                const double ey = list.errors[static_cast<std::size_t>(y)];
                return ex < ey || (ex == ey && x < y);
            });
            return list;
        }

        double collapse_cost(int a, int b, double error) const
        {
            if (m_refining)
                return error;
            const double tau = stability_ratio(m_graph.sphere(a), m_graph.sphere(b));
            return (error + m_options.stability_constant) * tau * tau;
        }

        // Evaluates the edges (a < b) and queues them; in parallel in phase 2, where each
        // evaluation is costly (they are independent and queued in the given order).
        std::size_t push_edges(const std::vector<std::array<int, 2>>& edges)
        {
            // In phase 2 the cost is the error: an edge costlier than the cheapest queued one is
            // queued with a lower bound, which is enough, since every entry is evaluated again
            // when it comes out (and requeued if it got costlier).
            const double bound = m_refining && !m_heap.empty()
                ? m_heap.top().cost
                : std::numeric_limits<double>::infinity();
            std::vector<double> costs(edges.size(), -1.0);
            auto evaluate = [&](std::size_t e) {
                const Candidates list = candidates(edges[e][0], edges[e][1], bound);
                if (!list.empty())
                    costs[e] = collapse_cost(edges[e][0], edges[e][1], list.best_error());
            };
            if (m_refining)
                tbb::parallel_for(std::size_t(0), edges.size(), evaluate);
            else
                for (std::size_t e = 0; e < edges.size(); ++e)
                    evaluate(e);
            std::size_t pushed = 0;
            for (std::size_t e = 0; e < edges.size(); ++e) {
                if (costs[e] < 0)
                    continue;
                const int a = edges[e][0], b = edges[e][1];
                m_heap.push(
                    { costs[e], a, b, m_graph.version(a), m_graph.version(b), false, {}, 0.0 });
                ++pushed;
            }
            return pushed;
        }

        std::size_t push_all_edges() { return push_edges(m_graph.alive_edges()); }

        // Does the interpolated sphere (x, radius) cross the surface by at most the tolerance?
        // Its protrusion sd(x) + radius is bounded above through each corner v (sd is
        // 1-Lipschitz) by |x - c_v| - depth_v + radius; the surface is queried only when no
        // bound settles it.
        bool interpolated_inside(const Vec3& x, double radius, const Vec3* corners,
            const double* depths, int count) const
        {
            double bound = std::numeric_limits<double>::infinity();
            for (int k = 0; k < count; ++k)
                bound = std::min(bound, (x - corners[k]).norm() - depths[k]);
            if (bound + radius <= m_tolerance)
                return true;
            ++m_queries;
            // Equivalently: x is inside and the ball of radius (radius - tolerance) around it
            // misses the surface. When that ball overlaps a corner's empty ball (which lies
            // inside), emptiness alone decides; otherwise take the signed distance.
            const double empty = radius - m_tolerance;
            if (empty > 0 && bound < empty)
                return !m_surface.any_within(x, empty);
            return m_surface.signed_distance(x) + radius <= m_tolerance;
        }

        // Checks the middle of every cone and slab the merged sphere m (depth >= `depth`)
        // would have.
        bool primitives_inside(int a, int b, const Vec4& m, double depth) const
        {
            const Vec3 c = m.head<3>();
            for (int k : m_graph.merged_neighbors(a, b)) {
                const Vec4& mk = m_graph.sphere(k);
                const Vec3 corners[2] = { c, mk.head<3>() };
                const double depths[2] = { depth, m_depth[static_cast<std::size_t>(k)] };
                if (!interpolated_inside(
                        0.5 * (corners[0] + corners[1]), 0.5 * (m(3) + mk(3)), corners, depths, 2))
                    return false;
            }
            for (const auto& pair : m_graph.merged_slab_partners(a, b)) {
                const Vec4& m1 = m_graph.sphere(pair[0]);
                const Vec4& m2 = m_graph.sphere(pair[1]);
                const Vec3 corners[3] = { c, m1.head<3>(), m2.head<3>() };
                const double depths[3] = { depth, m_depth[static_cast<std::size_t>(pair[0])],
                    m_depth[static_cast<std::size_t>(pair[1])] };
                const Vec3 centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
                if (!interpolated_inside(
                        centroid, (m(3) + m1(3) + m2(3)) / 3.0, corners, depths, 3))
                    return false;
            }
            return true;
        }

        // The checked candidate of least error: center deep enough, radius clamped to the
        // tolerance, new cones and slabs within the tolerance.
        bool choose(int a, int b, Vec4& merged, double& merged_depth, double& merged_error) const
        {
            const SphereQuadric q
                = m_quadrics[static_cast<std::size_t>(a)] + m_quadrics[static_cast<std::size_t>(b)];
            const Candidates list = candidates(a, b);
            for (int k = 0; k < list.count; ++k) {
                const int column = list.order[static_cast<std::size_t>(k)];
                Vec4 m = list.spheres.col(column);
                const Vec3 c = m.head<3>();
                // The depth is 1-Lipschitz: the ends' depths bound it from below; query the
                // surface only when that bound cannot settle the checks.
                double depth = std::max(
                    m_depth[static_cast<std::size_t>(a)] - (c - m_graph.sphere(a).head<3>()).norm(),
                    m_depth[static_cast<std::size_t>(b)]
                        - (c - m_graph.sphere(b).head<3>()).norm());
                if (depth < m_options.min_depth || m(3) > depth + m_tolerance) {
                    ++m_queries;
                    depth = -m_surface.signed_distance(c);
                }
                if (!(depth >= m_options.min_depth))
                    continue;
                const double unclamped = m(3);
                m(3) = std::clamp(m(3), m_options.min_depth, depth + m_tolerance);
                if (!primitives_inside(a, b, m, depth))
                    continue;
                merged = m;
                merged_depth = depth;
                merged_error = m(3) == unclamped
                    ? list.errors[static_cast<std::size_t>(column)]
                    : error(a, b, q, m, std::numeric_limits<double>::infinity());
                return true;
            }
            return false;
        }

        // Merges b into a (a < b) as the sphere m, and requeues a's edges.
        void collapse(int a, int b, const Vec4& m, double depth)
        {
            const std::size_t ia = static_cast<std::size_t>(a), ib = static_cast<std::size_t>(b);
            m_graph.collapse(a, b, m);
            m_depth[ia] = depth;
            m_quadrics[ia] = m_quadrics[ia] + m_quadrics[ib];
            m_owned[ia].insert(m_owned[ia].end(), m_owned[ib].begin(), m_owned[ib].end());
            m_owned[ib] = std::vector<int>();
            if (m_refining)
                sort_owned(a);
            std::vector<std::array<int, 2>> edges;
            for (int k : m_graph.neighbors(a))
                edges.push_back({ std::min(a, k), std::max(a, k) });
            push_edges(edges);
        }

        MedialComplexGraph m_graph;
        MatX3 m_samples; ///< #P x 3 surface samples
        const SurfaceDistance& m_surface;
        SimplifyOptions m_options;
        double m_tolerance;
        bool m_refining = false;
        mutable Index m_queries = 0;
        std::vector<SphereQuadric, Eigen::aligned_allocator<SphereQuadric>> m_quadrics;
        std::vector<double> m_depth; ///< lower bounds of the centers' depths inside the surface
        std::vector<std::vector<int>> m_owned; ///< phase 2: the samples each sphere represents
        std::priority_queue<HeapEntry, std::vector<HeapEntry>, std::greater<HeapEntry>> m_heap;
    };

} // namespace

MedialMesh simplify_medial(const MedialComplex& complex, const Eigen::Ref<const MatX3>& samples,
    const SurfaceDistance& surface, const SimplifyOptions& options, SimplifyReport* report)
{
    MAT_CHECK(
        options.target_spheres >= 1, "target sphere count {} must be >= 1", options.target_spheres);
    MAT_CHECK(options.min_depth > 0 && options.max_protrusion > 0 && options.refine_factor >= 1,
        "min_depth {}, max_protrusion {} must be > 0 and refine_factor {} >= 1", options.min_depth,
        options.max_protrusion, options.refine_factor);
    SimplifyReport local;
    Simplifier simplifier(complex, samples, surface, options);
    simplifier.run(local);
    if (report)
        *report = local;
    return simplifier.result();
}

} // namespace mat
