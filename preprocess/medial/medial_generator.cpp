#include "preprocess/medial/medial_generator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/medial_primitives.hpp"
#include "common/timer.hpp"
#include "common/union_find.hpp"
#include "formats/surface_validation.hpp"
#include "preprocess/medial/cgal_delaunay.hpp"
#include "preprocess/medial/medial_fit.hpp"
#include "preprocess/medial/medial_quality.hpp"
#include "preprocess/medial/medial_simplify.hpp"
#include "preprocess/medial/surface_distance.hpp"
#include "preprocess/medial/surface_sampling.hpp"
#include "preprocess/medial/voronoi_medial.hpp"

namespace mat {
namespace {

    /// The most surface samples (the initial complex has about 3.5 spheres per sample).
    constexpr Index k_max_samples = 500000;
    /// The most times the surface is sampled again, 4x more densely each time.
    constexpr int k_max_resamplings = 2;

    void check_options(const MedialGeneratorOptions& o)
    {
        if (o.spheres < 1)
            throw_error("medial generator: --spheres must be >= 1, got {}", o.spheres);
        if (o.samples < 100 || o.samples > k_max_samples)
            throw_error("medial generator: --samples must be in [100, {}], got {}", k_max_samples,
                o.samples);
        if (o.spheres > o.samples / 4)
            throw_error("medial generator: --spheres {} is more than a quarter of --samples {}; "
                        "ask for fewer spheres or more samples",
                o.spheres, o.samples);
        if (!(o.min_depth > 0 && o.min_depth < 0.01))
            throw_error("medial generator: min_depth must be in (0, 0.01), got {}", o.min_depth);
        if (!(o.max_protrusion > 0 && o.max_protrusion < 1))
            throw_error(
                "medial generator: max_protrusion must be in (0, 1), got {}", o.max_protrusion);
        if (!(o.stability >= 0 && o.stability < 1))
            throw_error("medial generator: stability must be in [0, 1), got {}", o.stability);
        if (!(o.min_slab_angle >= 0 && o.min_slab_angle < 60))
            throw_error(
                "medial generator: min_slab_angle must be in [0, 60), got {}", o.min_slab_angle);
        if (!(o.refine_factor >= 1))
            throw_error("medial generator: refine_factor must be >= 1, got {}", o.refine_factor);
        if (!(o.query_bound > 0))
            throw_error(
                "medial generator: --medial-query-bound must be > 0, got {}", o.query_bound);
        if (o.quality_samples < 1 || o.quality_directions < 1)
            throw_error("medial generator: quality samples and directions must be >= 1");
    }

    // Smallest interior angle of a triangle, degrees (0 if degenerate).
    double min_angle_degrees(const Vec3& a, const Vec3& b, const Vec3& c)
    {
        const std::array<Vec3, 3> x { a, b, c };
        double smallest = 180.0;
        for (int k = 0; k < 3; ++k) {
            const Vec3 u = x[(k + 1) % 3] - x[static_cast<std::size_t>(k)];
            const Vec3 v = x[(k + 2) % 3] - x[static_cast<std::size_t>(k)];
            const double nu = u.norm(), nv = v.norm();
            if (!(nu > 0 && nv > 0))
                return 0.0;
            smallest = std::min(
                smallest, std::acos(std::clamp(u.dot(v) / (nu * nv), -1.0, 1.0)) * 180.0 / M_PI);
        }
        return smallest;
    }

    // Connected pieces of the complex's spheres through its edges.
    Index count_pieces(const MedialComplex& complex)
    {
        UnionFind pieces(complex.num_spheres());
        for (const auto& e : complex.edges)
            pieces.unite(e[0], e[1]);
        Index count = 0;
        for (Index s = 0; s < complex.num_spheres(); ++s)
            count += pieces.find(s) == s ? 1 : 0;
        return count;
    }

    // One sphere holds the other: the cone is that sphere.
    bool cone_is_degenerate(const MedialMesh& m, int i, int j)
    {
        const double gap = (m.centers.row(i) - m.centers.row(j)).norm();
        return gap <= std::abs(m.radii(i) - m.radii(j)) * (1 + 1e-9) || !(gap > 0);
    }

    // Slivers (smallest angle below min_angle) and slabs whose third sphere lies inside the cone
    // of the other two become their edges; cones whose one sphere holds the other are dropped.
    MedialMesh remove_degenerate_primitives(
        const MedialMesh& mesh, double min_angle, Index& removed_slabs)
    {
        std::vector<std::array<int, 3>> slabs;
        std::vector<std::array<int, 2>> edges;
        for (Index c = 0; c < mesh.num_cones(); ++c)
            edges.push_back({ mesh.cones(c, 0), mesh.cones(c, 1) });
        removed_slabs = 0;
        for (Index l = 0; l < mesh.num_slabs(); ++l) {
            const std::array<int, 3> s { mesh.slabs(l, 0), mesh.slabs(l, 1), mesh.slabs(l, 2) };
            bool keep = min_angle_degrees(
                            mesh.centers.row(s[0]), mesh.centers.row(s[1]), mesh.centers.row(s[2]))
                >= min_angle;
            for (int k = 0; k < 3 && keep; ++k) {
                const int i = s[(k + 1) % 3], j = s[(k + 2) % 3], o = s[static_cast<size_t>(k)];
                const MedialCone cone(mesh.centers.row(i).transpose(), mesh.radii(i),
                    mesh.centers.row(j).transpose(), mesh.radii(j));
                if (cone.signed_distance(mesh.centers.row(o).transpose()) <= -mesh.radii(o))
                    keep = false;
            }
            if (keep) {
                slabs.push_back(s);
                continue;
            }
            ++removed_slabs;
            for (int k = 0; k < 3; ++k) {
                const int a = s[static_cast<size_t>(k)], b = s[(k + 1) % 3];
                edges.push_back({ std::min(a, b), std::max(a, b) });
            }
        }
        std::vector<std::array<int, 2>> slab_edges;
        for (const auto& s : slabs)
            for (int k = 0; k < 3; ++k) {
                const int a = s[static_cast<size_t>(k)], b = s[(k + 1) % 3];
                slab_edges.push_back({ std::min(a, b), std::max(a, b) });
            }
        std::sort(slab_edges.begin(), slab_edges.end());
        std::sort(edges.begin(), edges.end());
        edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
        std::vector<std::array<int, 2>> cones;
        for (const auto& e : edges)
            if (!std::binary_search(slab_edges.begin(), slab_edges.end(), e)
                && !cone_is_degenerate(mesh, e[0], e[1]))
                cones.push_back(e);
        MedialMesh out;
        out.centers = mesh.centers;
        out.radii = mesh.radii;
        out.cones.resize(static_cast<Index>(cones.size()), 2);
        for (std::size_t c = 0; c < cones.size(); ++c)
            out.cones.row(static_cast<Index>(c)) << cones[c][0], cones[c][1];
        out.slabs.resize(static_cast<Index>(slabs.size()), 3);
        for (std::size_t l = 0; l < slabs.size(); ++l)
            out.slabs.row(static_cast<Index>(l)) << slabs[l][0], slabs[l][1], slabs[l][2];
        return out;
    }

    struct InnerComplex {
        SurfaceSamples samples;
        MedialComplex complex;
        Index pieces = 0; ///< connected through the complex's edges
        int resamplings = 0;
    };

    // Step 2: the inner Voronoi complex of the surface samples. A part thinner than the sample
    // spacing leaves it in more pieces than the surface has components: sample 4x more densely
    // (twice at most). Edge collapses never join pieces, so more pieces than spheres asked is
    // refused here (docs/mat-bake.md, "Bounds").
    InnerComplex sample_inner_complex(const SurfaceMesh& surface, const SurfaceDistance& distance,
        const MedialGeneratorOptions& options, Index components, double diagonal)
    {
        Timer timer;
        InnerComplex inner;
        for (;; ++inner.resamplings) {
            const Index count = std::min(k_max_samples, options.samples << (2 * inner.resamplings));
            inner.samples = sample_surface(surface, count);
            const MatX4i tets = delaunay_tetrahedra(inner.samples.points);
            inner.complex = inner_voronoi_complex(
                inner.samples.points, tets, distance, options.min_depth * diagonal);
            inner.pieces = count_pieces(inner.complex);
            logger().debug("medial generator: {} samples (spacing {:.3g}), {} Delaunay tets, "
                           "inner Voronoi complex {} spheres, {} edges, {} triangles in {} pieces "
                           "({:.2f} s)",
                inner.samples.points.rows(), inner.samples.spacing, tets.rows(),
                inner.complex.num_spheres(), inner.complex.edges.size(),
                inner.complex.triangles.size(), inner.pieces, timer.seconds());
            if (inner.pieces <= components || inner.resamplings == k_max_resamplings
                || count == k_max_samples)
                break;
            logger().info("medial generator: the inner Voronoi complex of {} samples is in {} "
                          "pieces for {} surface components (parts thinner than the spacing "
                          "{:.3g}); sampling 4x more densely",
                inner.samples.points.rows(), inner.pieces, components, inner.samples.spacing);
        }
        if (inner.pieces > options.spheres)
            throw_error("{}: medial generator: {} pieces after {} resampling{} ({} samples, {} "
                        "surface component{}), past the bound of the {} spheres asked (no "
                        "collapse joins two pieces); the surface may intersect itself (run "
                        "mat-bake check) or have parts thinner than the spacing {:.3g}: ask for "
                        "at least {} spheres, more --samples, or give --medial FILE",
                options.surface_name, inner.pieces, inner.resamplings,
                inner.resamplings == 1 ? "" : "s", inner.samples.points.rows(), components,
                components == 1 ? "" : "s", options.spheres, inner.samples.spacing, inner.pieces);
        return inner;
    }

    // Step 3: edge collapses down to options.spheres, within the bound on surface queries.
    MedialMesh simplify(const InnerComplex& inner, const SurfaceDistance& distance,
        const MedialGeneratorOptions& options, double diagonal, Index components, MedialQuality& q)
    {
        Timer timer;
        SimplifyOptions simplify;
        simplify.target_spheres = options.spheres;
        simplify.min_depth = options.min_depth * diagonal;
        simplify.max_protrusion = options.max_protrusion * diagonal;
        simplify.stability_constant = std::pow(options.stability * diagonal, 2);
        simplify.refine_factor = options.refine_factor;
        simplify.max_surface_queries = static_cast<Index>(
            std::ceil(options.query_bound * double(inner.complex.num_spheres())));
        SimplifyReport report;
        MedialMesh medial
            = simplify_medial(inner.complex, inner.samples.points, distance, simplify, &report);
        q.relaxations = report.relaxations;
        q.surface_queries = report.surface_queries;
        logger().debug("medial generator: {} collapses ({} ranked by distance), {} refused, {} "
                       "surface queries ({:.2f} per initial sphere), {} relaxations (tolerance "
                       "{:.3g}) ({:.2f} s)",
            report.collapses, report.refine_collapses, report.rejected, report.surface_queries,
            double(report.surface_queries) / double(inner.complex.num_spheres()),
            report.relaxations, report.final_max_protrusion, timer.seconds());
        if (report.stopped_at_bound)
            throw_error("{}: medial generator: simplification stopped at {} spheres of the {} "
                        "asked after {} surface queries, past the bound of {} ({} per initial "
                        "sphere, --medial-query-bound); the surface may intersect itself (run "
                        "mat-bake check): ask for more spheres, raise --medial-query-bound, or "
                        "give --medial FILE",
                options.surface_name, medial.num_spheres(), options.spheres, report.surface_queries,
                simplify.max_surface_queries, options.query_bound);
        if (medial.num_spheres() > options.spheres)
            throw_error("{}: cannot reduce the medial mesh to {} spheres: {} remain in separate "
                        "parts (the surface has {} components; parts thinner than the sample "
                        "spacing {:.3g} also split it: try more spheres or more samples)",
                options.surface_name, options.spheres, medial.num_spheres(), components,
                inner.samples.spacing);
        return medial;
    }

} // namespace

std::string MedialQuality::summary() const
{
    return fmt::format("{} spheres, {} cones, {} slabs (from {} samples, {} initial spheres); "
                       "Hausdorff {:.3f}% of the diagonal (surface->envelope {:.3f}%, "
                       "envelope->surface {:.3f}%), coverage {:.2f}%, {:.2f} s",
        spheres, cones, slabs, samples, initial_spheres, hausdorff_percent(),
        100.0 * surface_to_envelope / bbox_diagonal, 100.0 * envelope_to_surface / bbox_diagonal,
        100.0 * coverage, seconds);
}

MedialMesh generate_medial_mesh(
    const SurfaceMesh& surface, const MedialGeneratorOptions& options, MedialQuality* quality)
{
    Timer timer;
    check_options(options);
    const SurfaceReport report = validate_surface(surface);
    require_closed_manifold(report, options.surface_name);
    const double diagonal = report.bbox.diagonal().norm();

    MedialQuality q;
    q.bbox_diagonal = diagonal;
    const SurfaceDistance distance(surface);
    const InnerComplex inner
        = sample_inner_complex(surface, distance, options, report.num_components, diagonal);
    const MedialComplex& complex = inner.complex;
    q.samples = inner.samples.points.rows();
    q.resamplings = inner.resamplings;
    q.pieces = inner.pieces;
    q.initial_spheres = complex.num_spheres();
    q.initial_edges = static_cast<Index>(complex.edges.size());
    q.initial_triangles = static_cast<Index>(complex.triangles.size());
    if (complex.num_spheres() == 0)
        throw_error("{}: no Voronoi vertex of {} surface samples lies inside the surface; it may "
                    "be too thin (try more samples)",
            options.surface_name, q.samples);
    if (complex.num_spheres() < options.spheres)
        logger().warn("medial generator: only {} candidate spheres for the {} asked; keeping all",
            complex.num_spheres(), options.spheres);
    MedialMesh medial = simplify(inner, distance, options, diagonal, report.num_components, q);
    medial = remove_degenerate_primitives(medial, options.min_slab_angle, q.removed_slivers);

    // The bake's own test: every center inside by winding number, every radius finite and > 0.
    std::vector<double> winding(static_cast<std::size_t>(medial.num_spheres()));
    tbb::parallel_for(Index(0), medial.num_spheres(), [&](Index s) {
        winding[static_cast<std::size_t>(s)]
            = winding_number(surface, medial.centers.row(s).transpose());
    });
    for (Index s = 0; s < medial.num_spheres(); ++s) {
        if (!(winding[static_cast<std::size_t>(s)] > 0.5) || !medial.centers.row(s).allFinite())
            throw_error("{}: generated sphere {} lies outside the surface (winding number {:.3f}); "
                        "the surface may have self-intersections",
                options.surface_name, s, winding[static_cast<std::size_t>(s)]);
        if (!(medial.radii(s) > 0 && std::isfinite(medial.radii(s))))
            throw_error(
                "{}: generated sphere {} has radius {}", options.surface_name, s, medial.radii(s));
    }

    const MedialFitMeasure fit = measure_medial_fit(
        medial, surface, distance, options.quality_samples, options.quality_directions);
    q.spheres = medial.num_spheres();
    q.cones = medial.num_cones();
    q.slabs = medial.num_slabs();
    q.hausdorff = fit.hausdorff;
    q.surface_to_envelope = fit.surface_to_envelope;
    q.envelope_to_surface = fit.envelope_to_surface;
    q.coverage = fit.coverage;
    q.seconds = timer.seconds();
    logger().info("medial generator: {}", q.summary());
    if (quality)
        *quality = q;
    return medial;
}

} // namespace mat
