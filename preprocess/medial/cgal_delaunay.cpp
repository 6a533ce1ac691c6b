// The small CGAL translation unit: a sequential Delaunay_triangulation_3 over the Epick kernel
// (exact predicates, so degenerate inputs are handled by symbolic perturbation and never crash),
// and the self-intersection test of a surface over the same kernel.

#include "preprocess/medial/cgal_delaunay.hpp"

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>
#include <CGAL/exceptions.h>

#include "common/error.hpp"

namespace mat {
namespace {

    using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
    using VertexBase = CGAL::Triangulation_vertex_base_with_info_3<int, Kernel>;
    using DataStructure = CGAL::Triangulation_data_structure_3<VertexBase>;
    using Delaunay = CGAL::Delaunay_triangulation_3<Kernel, DataStructure>;
    using Point = Kernel::Point_3;
    using PolygonMesh = CGAL::Surface_mesh<Point>;

} // namespace

MatX4i delaunay_tetrahedra(const Eigen::Ref<const MatX3>& points)
{
    const Index n = points.rows();
    if (n < 4)
        throw_error("Delaunay triangulation: {} points given, at least 4 are needed", n);
    std::vector<std::pair<Point, int>> input;
    input.reserve(static_cast<std::size_t>(n));
    for (Index i = 0; i < n; ++i)
        input.emplace_back(Point(points(i, 0), points(i, 1), points(i, 2)), static_cast<int>(i));
    Delaunay triangulation;
    try {
        triangulation.insert(input.begin(), input.end());
    } catch (const CGAL::Failure_exception& e) {
        throw_error("Delaunay triangulation of {} points failed: {}", n, e.what());
    }
    if (triangulation.dimension() < 3)
        throw_error("Delaunay triangulation: the {} points lie in one plane", n);

    std::vector<std::array<int, 4>> tets;
    tets.reserve(triangulation.number_of_finite_cells());
    for (auto cell = triangulation.finite_cells_begin(); cell != triangulation.finite_cells_end();
         ++cell) {
        std::array<int, 4> tet;
        for (int k = 0; k < 4; ++k)
            tet[static_cast<std::size_t>(k)] = cell->vertex(k)->info();
        std::sort(tet.begin(), tet.end());
        tets.push_back(tet);
    }
    std::sort(tets.begin(), tets.end());
    MatX4i result(static_cast<Index>(tets.size()), 4);
    for (std::size_t t = 0; t < tets.size(); ++t)
        for (int k = 0; k < 4; ++k)
            result(static_cast<Index>(t), k) = tets[t][static_cast<std::size_t>(k)];
    return result;
}

SelfIntersections find_self_intersections(const SurfaceMesh& surface)
{
    PolygonMesh mesh;
    for (Index v = 0; v < surface.num_vertices(); ++v)
        mesh.add_vertex(
            Point(surface.positions(v, 0), surface.positions(v, 1), surface.positions(v, 2)));
    using VertexIndex = PolygonMesh::Vertex_index;
    for (Index f = 0; f < surface.num_faces(); ++f) {
        const auto vertex = [&](int k) {
            return VertexIndex(static_cast<PolygonMesh::size_type>(surface.faces(f, k)));
        };
        if (mesh.add_face(vertex(0), vertex(1), vertex(2)) == PolygonMesh::null_face())
            throw_error("self-intersection test: face {} does not fit a manifold mesh", f);
    }
    // Faces keep their order (face f of the surface is face f of the mesh).
    std::vector<std::pair<PolygonMesh::Face_index, PolygonMesh::Face_index>> found;
    CGAL::Polygon_mesh_processing::self_intersections(mesh, std::back_inserter(found));
    SelfIntersections result;
    result.count = static_cast<Index>(found.size());
    for (const auto& [f, g] : found) {
        const Index a = std::min<Index>(f.idx(), g.idx()), b = std::max<Index>(f.idx(), g.idx());
        if (result.first_face < 0
            || std::make_pair(a, b) < std::make_pair(result.first_face, result.second_face)) {
            result.first_face = a;
            result.second_face = b;
        }
    }
    return result;
}

} // namespace mat
