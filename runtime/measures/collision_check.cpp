#include "runtime/measures/collision_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/timer.hpp"
#include "runtime/collision/triangle_tests.hpp"
#include "runtime/measures/ground_truth.hpp"

namespace mat {

namespace {

    bool share_sphere(const Eigen::Ref<const MatX3i>& spheres, int p, int q)
    {
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (spheres(p, i) >= 0 && spheres(p, i) == spheres(q, j))
                    return true;
        return false;
    }

    /// Side of p (in the (y, z) plane) of the directed edge a -> b, perturbed so that it is
    /// never 0 for a proper edge: p moves by (eps, eps^2) (Simulation of Simplicity). 0 only for
    /// a degenerate (zero-length) projected edge.
    int perturbed_side(const Vec2& a, const Vec2& b, const Vec2& p)
    {
        const int side = orient2d(a, b, p);
        if (side != 0)
            return side;
        // det[b - a, delta] = (b - a).x eps^2 - (b - a).y eps
        const Vec2 d = b - a;
        if (d.y() != 0.0)
            return d.y() > 0.0 ? -1 : 1;
        if (d.x() != 0.0)
            return d.x() > 0.0 ? 1 : -1;
        return 0;
    }

    /// Triangles of a surface binned by their (y, z) box on a uniform grid (CSR).
    struct YzGrid {
        Vec2 lo = Vec2::Zero();
        double cell = 1.0;
        int nu = 1, nv = 1;
        VecXi indptr;
        std::vector<int> faces;

        int cell_u(double y) const
        {
            return std::clamp(static_cast<int>(std::floor((y - lo.x()) / cell)), 0, nu - 1);
        }
        int cell_v(double z) const
        {
            return std::clamp(static_cast<int>(std::floor((z - lo.y()) / cell)), 0, nv - 1);
        }
    };

    YzGrid build_grid(const SurfaceMesh& mesh, const Box3& box)
    {
        YzGrid grid;
        grid.lo = Vec2(box.min().y(), box.min().z());
        const Vec2 extent = Vec2(box.max().y(), box.max().z()) - grid.lo + Vec2::Constant(1e-300);
        const double cells
            = std::clamp(std::sqrt(static_cast<double>(mesh.num_faces())), 1.0, 256.0);
        grid.cell = std::max(extent.maxCoeff() / cells, 1e-300);
        grid.nu = std::max(1, static_cast<int>(std::ceil(extent.x() / grid.cell)));
        grid.nv = std::max(1, static_cast<int>(std::ceil(extent.y() / grid.cell)));
        grid.nu = std::min(grid.nu, 256);
        grid.nv = std::min(grid.nv, 256);
        const auto for_cells = [&](Index f, auto&& visit) {
            double ylo = std::numeric_limits<double>::infinity(), yhi = -ylo, zlo = ylo, zhi = -ylo;
            for (int k = 0; k < 3; ++k) {
                const auto x = mesh.positions.row(mesh.faces(f, k));
                ylo = std::min(ylo, x(1));
                yhi = std::max(yhi, x(1));
                zlo = std::min(zlo, x(2));
                zhi = std::max(zhi, x(2));
            }
            for (int u = grid.cell_u(ylo); u <= grid.cell_u(yhi); ++u)
                for (int v = grid.cell_v(zlo); v <= grid.cell_v(zhi); ++v)
                    visit(u * grid.nv + v);
        };
        grid.indptr = VecXi::Zero(grid.nu * grid.nv + 1);
        for (Index f = 0; f < mesh.num_faces(); ++f)
            for_cells(f, [&](int c) { ++grid.indptr(c + 1); });
        for (Index c = 0; c < grid.nu * grid.nv; ++c)
            grid.indptr(c + 1) += grid.indptr(c);
        grid.faces.resize(static_cast<std::size_t>(grid.indptr(grid.nu * grid.nv)));
        VecXi fill = grid.indptr.head(grid.nu * grid.nv);
        for (Index f = 0; f < mesh.num_faces(); ++f)
            for_cells(f, [&](int c) {
                grid.faces[static_cast<std::size_t>(fill(c)++)] = static_cast<int>(f);
            });
        return grid;
    }

    Box3 bounding_box(const MatX3& positions)
    {
        Box3 box;
        for (Index i = 0; i < positions.rows(); ++i)
            box.extend(Vec3(positions.row(i).transpose()));
        return box;
    }

    /// 1 inside, 0 outside, -1 on the surface (p on a triangle the ray meets).
    int inside(const SurfaceMesh& mesh, const YzGrid& grid, const Vec3& p, double far_x)
    {
        const Vec2 q(p.y(), p.z());
        const Vec3 far(far_x, p.y(), p.z());
        int crossings = 0;
        const int c = grid.cell_u(p.y()) * grid.nv + grid.cell_v(p.z());
        for (int k = grid.indptr(c); k < grid.indptr(c + 1); ++k) {
            const int f = grid.faces[static_cast<std::size_t>(k)];
            const Vec3 a = mesh.positions.row(mesh.faces(f, 0)).transpose();
            const Vec3 b = mesh.positions.row(mesh.faces(f, 1)).transpose();
            const Vec3 t = mesh.positions.row(mesh.faces(f, 2)).transpose();
            if (std::max({ a.x(), b.x(), t.x() }) < p.x())
                continue;
            const Vec2 a2(a.y(), a.z()), b2(b.y(), b.z()), t2(t.y(), t.z());
            const int s0 = perturbed_side(a2, b2, q);
            if (s0 == 0 || perturbed_side(b2, t2, q) != s0 || perturbed_side(t2, a2, q) != s0)
                continue;
            const int here = orient3d(a, b, t, p);
            if (here == 0)
                return -1;
            if (here != orient3d(a, b, t, far))
                ++crossings;
        }
        return crossings % 2;
    }

    double distance_to_surface(const SurfaceMesh& mesh, const Vec3& p)
    {
        double best = std::numeric_limits<double>::infinity();
        for (Index f = 0; f < mesh.num_faces(); ++f) {
            const PointTriangleClosest closest
                = point_triangle_closest(p, mesh.positions.row(mesh.faces(f, 0)).transpose(),
                    mesh.positions.row(mesh.faces(f, 1)).transpose(),
                    mesh.positions.row(mesh.faces(f, 2)).transpose());
            best = std::min(best, closest.squared_distance);
        }
        return std::sqrt(best);
    }

    /// The solid angle of triangle (a, b, c) seen from p, signed by the triangle's orientation
    /// (Van Oosterom and Strackee 1983); 0 for p in the triangle's plane (on the triangle it jumps
    /// between -2 pi and 2 pi: a point on the surface counts as on it, not inside).
    double solid_angle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c)
    {
        const Vec3 u = a - p, v = b - p, w = c - p;
        const double numerator = u.dot(v.cross(w));
        if (numerator == 0.0)
            return 0.0;
        const double lu = u.norm(), lv = v.norm(), lw = w.norm();
        const double denominator = lu * lv * lw + u.dot(v) * lw + u.dot(w) * lv + v.dot(w) * lu;
        return 2.0 * std::atan2(numerator, denominator);
    }

} // namespace

void CollisionCheckCounts::add(const CollisionCheckCounts& other)
{
    far_pairs += other.far_pairs;
    far_found += other.far_found;
    near_pairs += other.near_pairs;
    near_found += other.near_found;
    extra += other.extra;
    self_pairs += other.self_pairs;
    max_penetration = std::max(max_penetration, other.max_penetration);
    penetrating_vertices = std::max(penetrating_vertices, other.penetrating_vertices);
    max_self_penetration = std::max(max_self_penetration, other.max_self_penetration);
    self_penetrating_vertices
        = std::max(self_penetrating_vertices, other.self_penetrating_vertices);
    steps += other.steps;
    seconds += other.seconds;
}

double recall(long found, long pairs)
{
    return pairs > 0 ? static_cast<double>(found) / static_cast<double>(pairs) : 1.0;
}

bool faces_in_non_adjacent_primitives(const Eigen::Ref<const MatX3i>& faces,
    const Eigen::Ref<const VecXi>& vertex_primitive,
    const Eigen::Ref<const MatX3i>& primitive_spheres, int fa, int fb)
{
    for (int i = 0; i < 3; ++i) {
        const int p = vertex_primitive(faces(fa, i));
        for (int j = 0; j < 3; ++j) {
            const int q = vertex_primitive(faces(fb, j));
            if (p != q && !share_sphere(primitive_spheres, p, q))
                return true;
        }
    }
    return false;
}

PenetrationDepth penetration_depth(const std::vector<SurfaceMesh>& surfaces)
{
    PenetrationDepth result;
    std::vector<Box3> boxes;
    for (const SurfaceMesh& mesh : surfaces)
        boxes.push_back(bounding_box(mesh.positions));
    for (std::size_t b = 0; b < surfaces.size(); ++b) {
        const SurfaceMesh& target = surfaces[b];
        if (target.num_faces() == 0)
            continue;
        const Box3& box = boxes[b];
        const YzGrid grid = build_grid(target, box);
        const double far_x = box.max().x() + box.diagonal().norm() + 1.0;
        for (std::size_t a = 0; a < surfaces.size(); ++a) {
            if (a == b || !boxes[a].intersects(box))
                continue;
            const MatX3& positions = surfaces[a].positions;
            for (Index v = 0; v < positions.rows(); ++v) {
                const Vec3 p = positions.row(v).transpose();
                if (!box.contains(p) || inside(target, grid, p, far_x) != 1)
                    continue;
                ++result.vertices;
                result.max_depth = std::max(result.max_depth, distance_to_surface(target, p));
            }
        }
    }
    return result;
}

PenetrationDepth self_penetration_depth(const SurfaceMesh& surface,
    const Eigen::Ref<const VecXi>& vertex_primitive,
    const Eigen::Ref<const MatX3i>& primitive_spheres)
{
    const Index vs = surface.positions.rows();
    const Index nf = surface.num_faces();
    MAT_CHECK(vertex_primitive.size() == vs,
        "self penetration: {} vertex primitives for {} vertices", vertex_primitive.size(), vs);
    const auto corner = [&](Index f, int k) -> Vec3 {
        return surface.positions.row(surface.faces(f, k)).transpose();
    };
    // Per vertex: its depth if it is inside the body, else -1 (in parallel, then merged in order).
    std::vector<double> depth(static_cast<std::size_t>(vs), -1.0);
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, vs), [&](const tbb::blocked_range<Index>& range) {
            for (Index v = range.begin(); v != range.end(); ++v) {
                const Vec3 p = surface.positions.row(v).transpose();
                double angle = 0.0;
                for (Index f = 0; f < nf; ++f)
                    angle += solid_angle(p, corner(f, 0), corner(f, 1), corner(f, 2));
                if (angle / (4.0 * M_PI) <= 1.0)
                    continue;
                // The far faces (no corner in the vertex's primitive or one sharing a sphere with
                // it): their winding number, and the nearest.
                const int pv = vertex_primitive(v);
                double best = std::numeric_limits<double>::infinity();
                double far_angle = 0.0;
                for (Index f = 0; f < nf; ++f) {
                    bool far = true;
                    for (int k = 0; k < 3 && far; ++k) {
                        const int q = vertex_primitive(surface.faces(f, k));
                        far = q != pv && !share_sphere(primitive_spheres, pv, q);
                    }
                    if (!far)
                        continue;
                    far_angle += solid_angle(p, corner(f, 0), corner(f, 1), corner(f, 2));
                    best = std::min(best,
                        point_triangle_closest(p, corner(f, 0), corner(f, 1), corner(f, 2))
                            .squared_distance);
                }
                // Inside a non-adjacent part only where the far faces alone wind around it at
                // least halfway (see the header): not in a local fold of adjacent parts.
                if (far_angle / (4.0 * M_PI) <= 0.5)
                    continue;
                depth[static_cast<std::size_t>(v)] = std::sqrt(best);
            }
        });
    PenetrationDepth result;
    for (const double d : depth)
        if (d >= 0.0) {
            ++result.vertices;
            result.max_depth = std::max(result.max_depth, d);
        }
    return result;
}

CollisionCheckCounts check_collisions(const Simulation& simulation)
{
    Timer timer;
    const CollisionWorld* world = simulation.collision();
    MAT_CHECK(world != nullptr, "check_collisions: the scene has no collision world");
    const auto& bodies = simulation.bodies();
    const Index n = world->num_bodies();
    MAT_CHECK(n == static_cast<Index>(bodies.size()), "check_collisions: {} world bodies for {}", n,
        bodies.size());

    // The ground truth on the surfaces the world saw.
    std::vector<SurfaceMesh> surfaces(static_cast<std::size_t>(n));
    for (Index b = 0; b < n; ++b) {
        surfaces[b].positions = world->world_surface(b);
        surfaces[b].faces = world->faces(b);
    }
    GroundTruthOptions options;
    options.self_pairs = world->settings().self;
    const std::vector<TrianglePair> truth = intersecting_triangle_pairs(surfaces, options);
    const std::vector<FacePair>& found = world->intersecting_pairs();

    CollisionCheckCounts counts;
    counts.steps = 1;
    for (const TrianglePair& pair : truth) {
        const Body& a = bodies[static_cast<std::size_t>(pair[0])];
        const Body& b = bodies[static_cast<std::size_t>(pair[2])];
        // Pairs the world does not look for: between bodies that do not move (static, kinematic
        // or asleep), and within a sleeping body.
        if ((a.is_static || a.asleep) && (b.is_static || b.asleep))
            continue;
        const bool far = pair[0] != pair[2]
            || faces_in_non_adjacent_primitives(world->faces(pair[0]),
                a.model->primitives().vertex_primitive, a.model->primitives().primitive_spheres,
                pair[1], pair[3]);
        const bool hit = std::binary_search(found.begin(), found.end(), pair);
        (far ? counts.far_pairs : counts.near_pairs) += 1;
        counts.self_pairs += far && pair[0] == pair[2] ? 1 : 0;
        (far ? counts.far_found : counts.near_found) += hit ? 1 : 0;
    }
    for (const FacePair& pair : found)
        if (!std::binary_search(truth.begin(), truth.end(), pair))
            ++counts.extra;

    // Penetration after the step.
    for (Index b = 0; b < n; ++b) {
        const Body& body = bodies[static_cast<std::size_t>(b)];
        surfaces[b].positions.resize(body.model->surface().num_vertices(), 3);
        body.model->surface().positions(body.state.positions, surfaces[b].positions);
    }
    const PenetrationDepth depth = penetration_depth(surfaces);
    counts.max_penetration = depth.max_depth;
    counts.penetrating_vertices = depth.vertices;
    // Self penetration, for the bodies with far self pairs before the step.
    std::vector<char> self_pairs(static_cast<std::size_t>(n), 0);
    for (const TrianglePair& pair : truth)
        if (pair[0] == pair[2]) {
            const Body& body = bodies[static_cast<std::size_t>(pair[0])];
            if (!body.is_static && !body.asleep
                && faces_in_non_adjacent_primitives(world->faces(pair[0]),
                    body.model->primitives().vertex_primitive,
                    body.model->primitives().primitive_spheres, pair[1], pair[3]))
                self_pairs[static_cast<std::size_t>(pair[0])] = 1;
        }
    for (Index b = 0; b < n; ++b) {
        if (!self_pairs[static_cast<std::size_t>(b)])
            continue;
        const BodyModel& model = *bodies[static_cast<std::size_t>(b)].model;
        const PenetrationDepth self = self_penetration_depth(
            surfaces[b], model.primitives().vertex_primitive, model.primitives().primitive_spheres);
        counts.max_self_penetration = std::max(counts.max_self_penetration, self.max_depth);
        counts.self_penetrating_vertices += self.vertices;
    }
    counts.seconds = timer.seconds();
    return counts;
}

} // namespace mat
