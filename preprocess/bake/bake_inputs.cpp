#include "preprocess/bake/bake_inputs.hpp"

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/timer.hpp"
#include "formats/surface_io.hpp"
#include "preprocess/medial/cgal_delaunay.hpp"
#include "preprocess/medial/medial_fit.hpp"

namespace mat {

CheckedSurface inspect_surface(const std::string& path)
{
    CheckedSurface checked;
    checked.surface = read_surface(path);
    checked.report = validate_surface(checked.surface);
    // The exact test needs a manifold mesh; an unusable surface is refused before it anyway.
    if (!checked.report.is_closed_manifold())
        return checked;
    Timer timer;
    const SelfIntersections found = find_self_intersections(checked.surface);
    SurfaceIssue& issue = checked.report.self_intersections;
    issue.count = found.count;
    issue.example = found.first_face;
    if (found)
        issue.description = fmt::format("faces {} and {}", found.first_face, found.second_face);
    checked.report.self_intersections_tested = true;
    logger().debug("{}: self-intersection test of {} faces: {} pairs ({:.3f} s)", path,
        checked.surface.num_faces(), found.count, timer.seconds());
    return checked;
}

void require_bake_surface(
    const CheckedSurface& checked, const std::string& path, const InputChecks& checks)
{
    require_closed_manifold(checked.report, path);
    const SurfaceIssue& issue = checked.report.self_intersections;
    if (!issue)
        return;
    if (!checks.allow_self_intersections)
        throw_error("{}: intersects itself: {} pair{} of faces intersect, e.g. {}; repair it, or "
                    "pass --allow-self-intersections to go on anyway",
            path, issue.count, issue.count == 1 ? "" : "s", issue.description);
    logger().warn("{}: intersects itself ({} pairs of faces, e.g. {}); going on as "
                  "--allow-self-intersections asks",
        path, issue.count, issue.description);
}

void require_bake_medial(const MedialMesh& medial, const std::string& medial_path,
    const SurfaceMesh& surface, const std::string& surface_path)
{
    if (medial.num_spheres() == 0)
        throw_error("{}: the medial mesh has no sphere", medial_path);
    require_centers_inside(medial, surface, medial_path, surface_path);
}

} // namespace mat
