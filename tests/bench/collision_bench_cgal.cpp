// The triangle-only broad phase the medial culling is compared with: CGAL's box_intersection_d
// over the boxes of every triangle of two surfaces (bipartite), then the exact triangle test on
// each overlapping pair. The one translation unit of the benchmarks that includes CGAL.

#include "tests/bench/collision_bench_cgal.hpp"

#include <vector>

#include <CGAL/Bbox_3.h>
#include <CGAL/box_intersection_d.h>

#include "runtime/collision/triangle_tests.hpp"

namespace mat::bench {

TriangleBroadPhase cgal_triangle_pairs(const SurfaceMesh& a, const SurfaceMesh& b)
{
    using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, int>;
    const auto boxes_of = [](const SurfaceMesh& mesh) {
        std::vector<Box> boxes;
        boxes.reserve(static_cast<std::size_t>(mesh.faces.rows()));
        for (Index f = 0; f < mesh.faces.rows(); ++f) {
            CGAL::Bbox_3 box;
            for (int c = 0; c < 3; ++c) {
                const auto p = mesh.positions.row(mesh.faces(f, c));
                box += CGAL::Bbox_3(p(0), p(1), p(2), p(0), p(1), p(2));
            }
            boxes.emplace_back(box, static_cast<int>(f));
        }
        return boxes;
    };
    std::vector<Box> boxes_a = boxes_of(a);
    std::vector<Box> boxes_b = boxes_of(b);
    TriangleBroadPhase result;
    const auto corner = [](const SurfaceMesh& mesh, int f, int c) {
        return Vec3(mesh.positions.row(mesh.faces(f, c)).transpose());
    };
    CGAL::box_intersection_d(boxes_a.begin(), boxes_a.end(), boxes_b.begin(), boxes_b.end(),
        [&](const Box& x, const Box& y) {
            ++result.box_pairs;
            const int fa = x.info(), fb = y.info();
            if (triangles_intersect(corner(a, fa, 0), corner(a, fa, 1), corner(a, fa, 2),
                    corner(b, fb, 0), corner(b, fb, 1), corner(b, fb, 2)))
                ++result.intersecting;
        });
    return result;
}

} // namespace mat::bench
