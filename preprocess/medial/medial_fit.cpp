#include "preprocess/medial/medial_fit.hpp"

#include <atomic>
#include <cmath>
#include <vector>

#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"

namespace mat {

double winding_number(const SurfaceMesh& surface, const Eigen::Ref<const Vec3>& p)
{
    // Solid angle of each triangle seen from p (Van Oosterom and Strackee 1983), summed / 4 pi.
    double total = 0.0;
    for (Index f = 0; f < surface.num_faces(); ++f) {
        const Vec3 a = surface.positions.row(surface.faces(f, 0)).transpose() - p;
        const Vec3 b = surface.positions.row(surface.faces(f, 1)).transpose() - p;
        const Vec3 c = surface.positions.row(surface.faces(f, 2)).transpose() - p;
        const double la = a.norm(), lb = b.norm(), lc = c.norm();
        const double numerator = a.dot(b.cross(c));
        const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        total += 2.0 * std::atan2(numerator, denominator);
    }
    return total / (4.0 * M_PI);
}

void require_centers_inside(const MedialMesh& medial, const SurfaceMesh& surface,
    const std::string& medial_file, const std::string& surface_file)
{
    const Index num_spheres = medial.num_spheres();
    std::vector<double> winding(static_cast<size_t>(num_spheres));
    tbb::parallel_for(Index(0), num_spheres, [&](Index s) {
        winding[static_cast<size_t>(s)]
            = winding_number(surface, medial.centers.row(s).transpose());
    });
    for (Index s = 0; s < num_spheres; ++s)
        if (winding[static_cast<size_t>(s)] < 0.5)
            throw_error("{}: sphere {} (center {:.6g} {:.6g} {:.6g}) lies outside the surface {} "
                        "(winding number {:.3f})",
                medial_file, s, medial.centers(s, 0), medial.centers(s, 1), medial.centers(s, 2),
                surface_file, winding[static_cast<size_t>(s)]);
}

MedialCoverage measure_coverage(const MedialMesh& medial, const SurfaceMesh& surface)
{
    const MedialDistanceField field(medial);
    const Index n = surface.num_vertices();
    std::vector<double> distance(static_cast<size_t>(n));
    tbb::parallel_for(Index(0), n, [&](Index v) {
        distance[static_cast<size_t>(v)] = field(surface.positions.row(v).transpose());
    });
    MedialCoverage coverage;
    coverage.vertices = n;
    Box3 box;
    for (Index v = 0; v < n; ++v) {
        box.extend(surface.positions.row(v).transpose());
        const double d = distance[static_cast<size_t>(v)];
        if (d > 0) {
            ++coverage.uncovered;
            coverage.max_outside = std::max(coverage.max_outside, d);
        }
    }
    coverage.bbox_diagonal = n ? box.diagonal().norm() : 0.0;
    return coverage;
}

MedialMesh inflate_to_cover(const MedialMesh& medial, MedialCoverage& coverage)
{
    MedialMesh inflated = medial;
    // A hair more than the worst gap, so that rounding in later containment tests cannot miss.
    coverage.inflation = coverage.uncovered > 0
        ? coverage.max_outside + 1e-9 * std::max(coverage.bbox_diagonal, 1e-300)
        : 0.0;
    inflated.radii.array() += coverage.inflation;
    return inflated;
}

} // namespace mat
