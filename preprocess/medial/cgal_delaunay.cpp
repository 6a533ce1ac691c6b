// The one translation unit of the medial generator that includes CGAL: a sequential
// Delaunay_triangulation_3 over the Epick kernel (exact predicates, so degenerate inputs are
// handled by symbolic perturbation and never crash).

#include "preprocess/medial/cgal_delaunay.hpp"

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
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

} // namespace mat
