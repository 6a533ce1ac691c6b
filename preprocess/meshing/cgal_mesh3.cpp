// The one translation unit that includes CGAL Mesh_3 (it compiles for over a minute): the
// polyhedral domain behind tetrahedralize() and the implicit domain behind
// mesh_implicit_surface(). Everything else in preprocess/ sees only cgal_mesh3.hpp.
//
// Determinism: the sequential tag (no TBB inside CGAL), the polyhedral domain's random generator
// seeded with 0 (Mesh_3 5.5 draws its initial surface points from it; it reads the global
// CGAL::get_default_random() only in its parallel code, which is reseeded anyway), initial points
// of the implicit domain from a grid instead of random rays, no perturbation, and exudation
// without a time limit.

#include "preprocess/meshing/cgal_mesh3.hpp"

#include <cmath>
#include <unordered_map>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/Random.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>
#include <CGAL/make_mesh_3.h>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/timer.hpp"
#include "preprocess/meshing/implicit_seeds.hpp"
#include "preprocess/meshing/mesh_measures.hpp"
#include "preprocess/meshing/morton_order.hpp"
#include "preprocess/meshing/zero_set_projection.hpp"

namespace mat {
namespace {

    using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
    using Point = Kernel::Point_3;
    namespace params = CGAL::parameters;

    // ---- Polyhedral domain (tetrahedralize) ----
    using PolygonMesh = CGAL::Surface_mesh<Point>;
    // One domain type, with or without detected features, so Mesh_3 is instantiated once here.
    using PolyhedralDomain = CGAL::Polyhedral_mesh_domain_with_features_3<Kernel, PolygonMesh>;
    using PolyhedralTr
        = CGAL::Mesh_triangulation_3<PolyhedralDomain, CGAL::Default, CGAL::Sequential_tag>::type;
    using PolyhedralC3t3 = CGAL::Mesh_complex_3_in_triangulation_3<PolyhedralTr,
        PolyhedralDomain::Corner_index, PolyhedralDomain::Curve_index>;
    using PolyhedralCriteria = CGAL::Mesh_criteria_3<PolyhedralTr>;

    // ---- Implicit domain (mesh_implicit_surface) ----
    using ImplicitFunction = std::function<double(const Point&)>;
    using ImplicitDomain = CGAL::Labeled_mesh_domain_3<Kernel>;
    using ImplicitTr
        = CGAL::Mesh_triangulation_3<ImplicitDomain, CGAL::Default, CGAL::Sequential_tag>::type;
    using ImplicitC3t3 = CGAL::Mesh_complex_3_in_triangulation_3<ImplicitTr>;
    using ImplicitCriteria = CGAL::Mesh_criteria_3<ImplicitTr>;

    /// The implicit domain with given initial surface points instead of Mesh_3's random ray
    /// shooting, which loops forever on an empty level set and may miss thin parts.
    class SeededImplicitDomain : public ImplicitDomain {
    public:
        using Seed = std::pair<Point, ImplicitDomain::Index>;

        SeededImplicitDomain(const ImplicitDomain& domain, std::vector<Seed> seeds)
            : ImplicitDomain(domain)
            , m_seeds(std::move(seeds))
        {
        }

        /// Mesh_3's Construct_initial_points concept: writes (point, index) pairs.
        struct InitialPoints {
            const std::vector<Seed>* seeds;

            template <class OutputIterator>
            OutputIterator operator()(OutputIterator output, int /*count*/ = 12) const
            {
                for (const Seed& seed : *seeds)
                    *output++ = seed;
                return output;
            }
        };

        InitialPoints construct_initial_points_object() const { return { &m_seeds }; }

    private:
        std::vector<Seed> m_seeds;
    };

    void check_positive(double value, const char* what)
    {
        if (!(std::isfinite(value) && value > 0.0))
            throw_error("meshing: {} must be finite and > 0, got {}", what, value);
    }

    void check_facet_angle(double angle)
    {
        if (!(angle >= 0.0 && angle <= 30.0))
            throw_error("meshing: facet_angle must lie in [0, 30] degrees (Mesh_3 may not "
                        "terminate above 30), got {}",
                angle);
    }

    PolygonMesh to_polygon_mesh(const SurfaceMesh& surface)
    {
        const Index num_vertices = surface.num_vertices();
        if (num_vertices < 4 || surface.num_faces() < 4)
            throw_error("tetrahedralize: the surface has {} vertices and {} faces, too few to "
                        "enclose a volume",
                num_vertices, surface.num_faces());
        PolygonMesh mesh;
        std::vector<PolygonMesh::Vertex_index> vertices(static_cast<std::size_t>(num_vertices));
        for (Index v = 0; v < num_vertices; ++v) {
            const auto p = surface.positions.row(v);
            if (!p.allFinite())
                throw_error("tetrahedralize: surface vertex {} is not finite", v);
            vertices[static_cast<std::size_t>(v)] = mesh.add_vertex(Point(p(0), p(1), p(2)));
        }
        for (Index f = 0; f < surface.num_faces(); ++f) {
            const auto face = surface.faces.row(f);
            for (int k = 0; k < 3; ++k)
                if (face(k) < 0 || face(k) >= num_vertices)
                    throw_error("tetrahedralize: surface face {} has vertex index {} out of "
                                "range [0, {})",
                        f, face(k), num_vertices);
            if (face(0) == face(1) || face(1) == face(2) || face(0) == face(2))
                throw_error("tetrahedralize: surface face {} repeats a vertex", f);
            const auto added = mesh.add_face(vertices[static_cast<std::size_t>(face(0))],
                vertices[static_cast<std::size_t>(face(1))],
                vertices[static_cast<std::size_t>(face(2))]);
            if (added == PolygonMesh::null_face())
                throw_error("tetrahedralize: surface face {} makes the surface non-manifold or "
                            "inconsistently oriented",
                    f);
        }
        if (!CGAL::is_closed(mesh))
            throw_error("tetrahedralize: the surface is not closed (it has boundary edges)");
        return mesh;
    }

    // Rejects meshing options, bounds or a function that Mesh_3 cannot work with.
    void check_implicit_inputs(const std::function<double(const Vec3&)>& signed_distance,
        const Box3& bounds, const ImplicitSurfaceOptions& options)
    {
        check_positive(options.facet_size, "facet_size");
        check_positive(options.facet_distance, "facet_distance");
        check_facet_angle(options.facet_angle);
        check_positive(options.relative_error_bound, "relative_error_bound");
        if (bounds.isEmpty() || !bounds.min().allFinite() || !bounds.max().allFinite())
            throw_error("mesh_implicit_surface: the bounding box is empty or not finite");
        if (!signed_distance)
            throw_error("mesh_implicit_surface: no signed distance function given");
    }

    // The initial surface points: the domain's crossings of the sign changes found on a grid of
    // spacing facet_size (and from the interior points), thinned to one per facet size.
    std::vector<SeededImplicitDomain::Seed> implicit_seeds(const ImplicitDomain& implicit_domain,
        const std::function<double(const Vec3&)>& signed_distance, const Box3& bounds,
        const ImplicitSurfaceOptions& options)
    {
        std::vector<SeededImplicitDomain::Seed> crossings;
        const auto intersects = implicit_domain.do_intersect_surface_object();
        const auto intersection = implicit_domain.construct_intersection_object();
        for (const SignChange& change : find_sign_changes(
                 signed_distance, bounds, options.facet_size, options.interior_points)) {
            const Kernel::Segment_3 segment(
                Point(change.inside.x(), change.inside.y(), change.inside.z()),
                Point(change.outside.x(), change.outside.y(), change.outside.z()));
            const auto patch = intersects(segment);
            if (!patch)
                continue;
            const auto crossing = intersection(segment);
            crossings.emplace_back(
                std::get<0>(crossing), implicit_domain.index_from_surface_patch_index(*patch));
        }
        // Seeds closer than a facet size would force tiny facets and needless refinement.
        MatX3 crossing_points(static_cast<Index>(crossings.size()), 3);
        for (std::size_t i = 0; i < crossings.size(); ++i) {
            const Point& p = crossings[i].first;
            crossing_points.row(static_cast<Index>(i)) << p.x(), p.y(), p.z();
        }
        std::vector<SeededImplicitDomain::Seed> seeds;
        for (const int kept : thin_out_points(crossing_points, options.facet_size))
            seeds.push_back(crossings[static_cast<std::size_t>(kept)]);
        if (seeds.empty())
            throw_error("mesh_implicit_surface: the function has no zero crossing on a grid of "
                        "spacing {} over the bounds nor from the interior points (is it negative "
                        "somewhere inside and positive on the bounds?)",
                options.facet_size);
        return seeds;
    }

    // The complex's facets as a surface, each oriented outward: away from its inside cell, or
    // along the function's gradient where both or neither cell is inside.
    SurfaceMesh complex_surface(
        const ImplicitC3t3& c3t3, const std::function<double(const Vec3&)>& signed_distance)
    {
        std::unordered_map<const void*, int> vertex_index;
        std::vector<Vec3> points;
        std::vector<Eigen::RowVector3i> faces;
        faces.reserve(c3t3.number_of_facets_in_complex());
        Index oriented_by_gradient = 0;
        for (auto facet = c3t3.facets_in_complex_begin(); facet != c3t3.facets_in_complex_end();
             ++facet) {
            auto cell = facet->first;
            int opposite = facet->second;
            const auto mirror = c3t3.triangulation().mirror_facet(*facet);
            const bool inside_first = c3t3.is_in_complex(cell);
            const bool inside_second = c3t3.is_in_complex(mirror.first);
            if (!inside_first && inside_second) {
                cell = mirror.first;
                opposite = mirror.second;
            }
            Eigen::RowVector3i face;
            Point corners[3];
            for (int k = 0; k < 3; ++k) {
                const auto vertex = cell->vertex((opposite + 1 + k) & 3);
                corners[k] = vertex->point().point();
                const auto [it, inserted]
                    = vertex_index.emplace(&*vertex, static_cast<int>(points.size()));
                if (inserted)
                    points.emplace_back(corners[k].x(), corners[k].y(), corners[k].z());
                face(k) = it->second;
            }
            bool outward;
            if (inside_first != inside_second) {
                // Outward: the inside cell's opposite vertex lies on the negative side.
                const Point& apex = cell->vertex(opposite)->point().point();
                outward
                    = CGAL::orientation(corners[0], corners[1], corners[2], apex) == CGAL::NEGATIVE;
            } else {
                // Both or neither cell labelled inside: orient along the function's gradient.
                ++oriented_by_gradient;
                const Vec3 a = points[static_cast<std::size_t>(face(0))];
                const Vec3 b = points[static_cast<std::size_t>(face(1))];
                const Vec3 c = points[static_cast<std::size_t>(face(2))];
                const Vec3 centroid = (a + b + c) / 3.0;
                const double h = 1e-3 * (b - a).norm() + 1e-12;
                const Vec3 normal = (b - a).cross(c - a);
                outward = signed_distance(centroid + h * normal.normalized())
                    > signed_distance(centroid - h * normal.normalized());
            }
            if (!outward)
                std::swap(face(1), face(2));
            faces.push_back(face);
        }
        if (oriented_by_gradient > 0)
            logger().debug("mesh_implicit_surface: {} facets oriented by the function's gradient",
                oriented_by_gradient);

        SurfaceMesh surface;
        surface.positions.resize(static_cast<Index>(points.size()), 3);
        for (std::size_t v = 0; v < points.size(); ++v)
            surface.positions.row(static_cast<Index>(v)) = points[v].transpose();
        surface.faces.resize(static_cast<Index>(faces.size()), 3);
        for (std::size_t f = 0; f < faces.size(); ++f)
            surface.faces.row(static_cast<Index>(f)) = faces[f];
        return surface;
    }

} // namespace

TetMesh tetrahedralize(const SurfaceMesh& surface, const TetrahedralizeOptions& options)
{
    check_positive(options.cell_size, "cell_size");
    check_positive(options.facet_size, "facet_size");
    check_positive(options.facet_distance, "facet_distance");
    check_facet_angle(options.facet_angle);
    if (!(options.cell_radius_edge_ratio >= 2.0 && std::isfinite(options.cell_radius_edge_ratio)))
        throw_error("tetrahedralize: cell_radius_edge_ratio must be >= 2 (Mesh_3 may not "
                    "terminate below), got {}",
            options.cell_radius_edge_ratio);

    Timer timer;
    const PolygonMesh polygon_mesh = to_polygon_mesh(surface);

    CGAL::get_default_random() = CGAL::Random(0);
    CGAL::Random random(0);
    PolyhedralDomain domain(polygon_mesh, &random);
    if (options.detect_features)
        domain.detect_features(options.feature_angle);

    // edge_size matters only for protected features; the facet size is the natural bound.
    const PolyhedralCriteria criteria(params::edge_size = options.facet_size,
        params::facet_angle = options.facet_angle, params::facet_size = options.facet_size,
        params::facet_distance = options.facet_distance,
        params::cell_radius_edge_ratio = options.cell_radius_edge_ratio,
        params::cell_size = options.cell_size);

    // Mesh_3's default exudation time limit is the refinement time, which makes the result
    // depend on the machine's load; no limit (0) keeps it deterministic.
    const auto exude = options.exude
        ? params::exude(params::time_limit = 0.0, params::sliver_bound = options.exude_sliver_bound)
        : params::no_exude();
    // Sliver perturbation (the perturber moves the vertices of tets whose smallest dihedral
    // angle is below the bound), also without a time limit: without it the coarse sample
    // creature keeps tets 20 times flatter than a regular one at the surface, and a contact
    // that presses such a tet inverts it (docs/method.md, section 2, step 1).
    const auto perturb = options.perturb ? params::perturb(params::time_limit = 0.0,
                             params::sliver_bound = options.perturb_sliver_bound)
                                         : params::no_perturb();
    const auto features
        = options.detect_features ? params::features(domain) : params::no_features();
    // The vertex bound stops the refinement where it stands (Mesh_3's forced stop); a mesh that
    // stays below it is the same as without it.
    params::internal::Mesh_3_options bound;
    bound.maximal_number_of_vertices
        = static_cast<std::size_t>(std::max<Index>(0, options.max_vertices));
    CGAL::Mesh_error_code error = CGAL::CGAL_MESH_3_NO_ERROR;
    bound.pointer_to_error_code = &error;
    const PolyhedralC3t3 c3t3
        = CGAL::make_mesh_3<PolyhedralC3t3>(domain, criteria, features, perturb, exude, bound);
    logger().debug("tetrahedralize: Mesh_3 triangulation of {} vertices ({:.2f} s)",
        c3t3.triangulation().number_of_vertices(), timer.seconds());
    if (error == CGAL::CGAL_MESH_3_MAXIMAL_NUMBER_OF_VERTICES_REACHED)
        throw_error("tetrahedralize: Mesh_3 reached {} vertices, the bound of --max-tet-vertices, "
                    "after {:.1f} s; use a larger --tet-size (cell size {:.4g}) or raise "
                    "--max-tet-vertices",
            c3t3.triangulation().number_of_vertices(), timer.seconds(), options.cell_size);

    if (c3t3.number_of_cells_in_complex() == 0)
        throw_error("tetrahedralize: CGAL Mesh_3 produced no tetrahedra (is the surface closed "
                    "and the cell size small enough? cell_size = {})",
            options.cell_size);

    // Compact re-indexing: only vertices used by cells of the complex, in first-use order.
    std::unordered_map<const void*, int> vertex_index;
    std::vector<Vec3> points;
    TetMesh mesh;
    mesh.tets.resize(static_cast<Index>(c3t3.number_of_cells_in_complex()), 4);
    Index t = 0;
    for (auto cell = c3t3.cells_in_complex_begin(); cell != c3t3.cells_in_complex_end();
         ++cell, ++t) {
        for (int k = 0; k < 4; ++k) {
            const auto vertex = cell->vertex(k);
            const auto [it, inserted]
                = vertex_index.emplace(&*vertex, static_cast<int>(points.size()));
            if (inserted) {
                const Point& p = vertex->point().point();
                points.emplace_back(p.x(), p.y(), p.z());
            }
            mesh.tets(t, k) = it->second;
        }
    }
    mesh.positions.resize(static_cast<Index>(points.size()), 3);
    for (std::size_t v = 0; v < points.size(); ++v)
        mesh.positions.row(static_cast<Index>(v)) = points[v].transpose();

    // Mesh_3 cells are positively oriented by an exact predicate; recheck in double precision
    // (what every later stage computes) and swap two vertices where rounding disagrees.
    const VecX volumes = tet_signed_volumes(mesh);
    Index flipped = 0;
    for (Index i = 0; i < mesh.num_tets(); ++i) {
        if (volumes(i) < 0.0) {
            std::swap(mesh.tets(i, 2), mesh.tets(i, 3));
            ++flipped;
        }
    }
    if (flipped > 0)
        logger().warn("tetrahedralize: {} tets were negatively oriented in double precision "
                      "and have been flipped",
            flipped);

    mesh = morton_reorder(mesh);
    logger().info("tetrahedralize: {} tets, {} vertices in {:.2f} s", mesh.num_tets(),
        mesh.num_vertices(), timer.seconds());
    return mesh;
}

SurfaceMesh mesh_implicit_surface(const std::function<double(const Vec3&)>& signed_distance,
    const Box3& bounds, const ImplicitSurfaceOptions& options)
{
    check_implicit_inputs(signed_distance, bounds, options);

    Timer timer;
    const ImplicitFunction function
        = [&signed_distance](const Point& p) { return signed_distance(Vec3(p.x(), p.y(), p.z())); };
    const Kernel::Iso_cuboid_3 cuboid(Point(bounds.min().x(), bounds.min().y(), bounds.min().z()),
        Point(bounds.max().x(), bounds.max().y(), bounds.max().z()));

    CGAL::get_default_random() = CGAL::Random(0);
    CGAL::Random random(0);
    const ImplicitDomain implicit_domain
        = ImplicitDomain::create_implicit_mesh_domain(function, cuboid,
            params::relative_error_bound = options.relative_error_bound, params::p_rng = &random);
    const SeededImplicitDomain domain(
        implicit_domain, implicit_seeds(implicit_domain, signed_distance, bounds, options));
    // Facet criteria only: the cells are a by-product, only the surface is kept.
    const ImplicitCriteria criteria(params::facet_angle = options.facet_angle,
        params::facet_size = options.facet_size, params::facet_distance = options.facet_distance);

    const ImplicitC3t3 c3t3 = CGAL::make_mesh_3<ImplicitC3t3>(
        domain, criteria, params::no_perturb(), params::no_exude(), params::manifold());
    if (c3t3.number_of_facets_in_complex() == 0)
        throw_error("mesh_implicit_surface: CGAL Mesh_3 found no zero level set inside the "
                    "bounds (is the function negative somewhere inside and positive on the "
                    "bounds?)");

    SurfaceMesh surface = complex_surface(c3t3, signed_distance);
    const double volume = surface_signed_volume(surface);
    if (volume < 0.0) {
        logger().warn(
            "mesh_implicit_surface: the surface came out inward (volume {}); flipped", volume);
        surface.faces.col(1).swap(surface.faces.col(2));
    }
    surface.positions = project_onto_zero_set(
        surface.positions, signed_distance, options.projection_steps, 0.1 * options.facet_size);

    logger().info("mesh_implicit_surface: {} faces, {} vertices in {:.2f} s", surface.num_faces(),
        surface.num_vertices(), timer.seconds());
    return surface;
}

} // namespace mat
