#include "runtime/collision/collision_world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "common/error.hpp"
#include "common/timer.hpp"
#include "runtime/collision/primitive_pair.hpp"
#include "runtime/collision/triangle_tests.hpp"

namespace mat {

namespace {

    /// Medial sphere centers embedded in tets: out(i) = sum_c bary(i, c) nodes(tets(tet(i), c)).
    void embed(
        const MatX3& nodes, const MatX4i& tets, const VecXi& tet, const MatX& bary, MatX3& out)
    {
        out.resize(tet.size(), 3);
        for (Index i = 0; i < tet.size(); ++i) {
            Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
            for (int c = 0; c < 4; ++c)
                x += bary(i, c) * nodes.row(tets(tet(i), c));
            out.row(i) = x;
        }
    }

    /// Nearest point of `points` (#P x 3) to each query, by a uniform grid of cell `cell`
    /// searched in growing shells (exact: a shell is searched until it cannot hold a closer
    /// point).
    std::vector<int> nearest_points(
        const MatX3& points, const std::vector<Vec3>& queries, double cell)
    {
        std::unordered_map<std::int64_t, std::vector<int>> grid;
        const auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
            return (x * 73856093) ^ (y * 19349663) ^ (z * 83492791);
        };
        const auto cell_of = [&](const Vec3& p, int axis) {
            return static_cast<std::int64_t>(std::floor(p(axis) / cell));
        };
        for (Index i = 0; i < points.rows(); ++i) {
            const Vec3 p = points.row(i).transpose();
            grid[key(cell_of(p, 0), cell_of(p, 1), cell_of(p, 2))].push_back(static_cast<int>(i));
        }
        std::vector<int> result(queries.size(), -1);
        for (std::size_t q = 0; q < queries.size(); ++q) {
            const Vec3& p = queries[q];
            const std::int64_t cx = cell_of(p, 0), cy = cell_of(p, 1), cz = cell_of(p, 2);
            double best = std::numeric_limits<double>::infinity();
            for (int shell = 0; shell < 64; ++shell) {
                for (std::int64_t x = cx - shell; x <= cx + shell; ++x)
                    for (std::int64_t y = cy - shell; y <= cy + shell; ++y)
                        for (std::int64_t z = cz - shell; z <= cz + shell; ++z) {
                            if (std::max({ std::abs(x - cx), std::abs(y - cy), std::abs(z - cz) })
                                != shell)
                                continue;
                            const auto it = grid.find(key(x, y, z));
                            if (it == grid.end())
                                continue;
                            for (const int i : it->second) {
                                const double d = (points.row(i).transpose() - p).squaredNorm();
                                if (d < best || (d == best && i < result[q])) {
                                    best = d;
                                    result[q] = i;
                                }
                            }
                        }
                // Points outside the searched shells are at least shell * cell away.
                if (result[q] >= 0 && std::sqrt(best) <= shell * cell)
                    break;
            }
            if (result[q] < 0) // farther than 64 cells: brute force
                for (Index i = 0; i < points.rows(); ++i) {
                    const double d = (points.row(i).transpose() - p).squaredNorm();
                    if (d < best) {
                        best = d;
                        result[q] = static_cast<int>(i);
                    }
                }
        }
        return result;
    }

    Box3 triangle_box(const MatX3& x, const MatX3i& faces, Index f)
    {
        Box3 box;
        for (int c = 0; c < 3; ++c)
            box.extend(Vec3(x.row(faces(f, c)).transpose()));
        return box;
    }

    /// `box` grown by `grow` on every side.
    Box3 grown(const Box3& box, double grow)
    {
        return Box3(box.min().array() - grow, box.max().array() + grow);
    }

} // namespace

CollisionWorld::CollisionWorld(const CollisionSettings& settings)
    : m_settings(settings)
{
    if (!(settings.margin >= 0.0) || !(settings.friction >= 0.0))
        throw_error("collision: margin {} and friction {} must be >= 0", settings.margin,
            settings.friction);
}

void CollisionWorld::add_body(const BakeData& bake)
{
    Body body { MedialBounds(bake), bake.collision, SurfaceView(bake) };
    body.tets = bake.tet_mesh.tets;
    body.medial_tet = bake.medial_tet;
    body.medial_barycentric = bake.medial_barycentric;
    const MatX3& rest = bake.tet_mesh.positions;
    body.diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();

    // Boundary nodes, each assigned the primitive of its nearest surface vertex.
    const std::vector<int> boundary = boundary_nodes(body.tets, rest.rows());
    std::vector<Vec3> queries;
    queries.reserve(boundary.size());
    for (const int i : boundary)
        queries.push_back(rest.row(i).transpose());
    const std::vector<int> nearest
        = nearest_points(bake.surface.positions, queries, 0.02 * body.diagonal);
    const Index num_primitives = body.collision.primitive_kind.size();
    body.node_indptr = VecXi::Zero(num_primitives + 1);
    for (const int v : nearest)
        ++body.node_indptr(body.collision.vertex_primitive(v) + 1);
    for (Index p = 0; p < num_primitives; ++p)
        body.node_indptr(p + 1) += body.node_indptr(p);
    body.node_list.resize(static_cast<Index>(boundary.size()));
    VecXi fill = body.node_indptr.head(num_primitives);
    for (std::size_t b = 0; b < boundary.size(); ++b)
        body.node_list(fill(body.collision.vertex_primitive(nearest[b]))++) = boundary[b];
    m_bodies.push_back(std::move(body));
    m_contacts.resize(m_bodies.size());
}

const std::vector<std::vector<NodeContact>>& CollisionWorld::detect(
    const std::vector<CollisionBodyState>& states)
{
    MAT_CHECK(states.size() == m_bodies.size(), "collision: {} states for {} bodies", states.size(),
        m_bodies.size());
    m_report = CollisionReport {};
    for (auto& c : m_contacts)
        c.clear();
    if (!m_settings.enabled || m_bodies.empty())
        return m_contacts;
    double diagonal = 0.0;
    for (const Body& body : m_bodies)
        diagonal = std::max(diagonal, body.diagonal);
    const double margin = m_settings.margin * diagonal;

    // 1. Bounds, and the surfaces and nodes in world coordinates.
    Timer timer;
    m_items.clear();
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        Body& body = m_bodies[b];
        const CollisionBodyState& state = states[b];
        MAT_CHECK(state.nodes != nullptr, "collision: body {} has no positions", b);
        body.surface.resize(body.surface_view.num_vertices(), 3);
        body.surface_view.positions(*state.nodes, body.surface);
        if (state.q != nullptr) {
            body.bounds.update(*state.q, m_settings.bounds);
        } else {
            embed(*state.nodes, body.tets, body.medial_tet, body.medial_barycentric,
                body.sphere_centers);
            body.bounds.update_from_positions(body.surface, body.sphere_centers);
        }
        const Mat3& r = state.rotation;
        const Eigen::RowVector3d t = state.translation.transpose();
        body.surface = (body.surface * r.transpose()).rowwise() + t;
        body.nodes = ((*state.nodes) * r.transpose()).rowwise() + t;
        const MatX3i& faces = body.surface_view.faces();
        body.face_boxes.resize(faces.rows());
        for (Index f = 0; f < faces.rows(); ++f)
            body.face_boxes[f] = triangle_box(body.surface, faces, f);
        for (Index p = 0; p < body.bounds.num_primitives(); ++p) {
            BroadPhaseItem item;
            item.body = static_cast<int>(b);
            item.primitive = static_cast<int>(p);
            for (int i = 0; i < body.bounds.counts()(p); ++i) {
                const Vec3 c = r * body.bounds.centers().block<1, 3>(p, 3 * i).transpose()
                    + state.translation;
                const double radius = body.bounds.radii()(p, i) + 0.5 * margin;
                item.box.extend(Box3(c.array() - radius, c.array() + radius));
                item.spheres[i] = body.collision.primitive_spheres(p, i);
            }
            m_items.push_back(item);
        }
    }
    m_report.bounds_seconds = timer.seconds();

    // 2. Broad phase.
    timer.restart();
    m_hash.build(m_items);
    m_hash.pairs(m_pairs);
    m_report.primitive_candidates = static_cast<int>(m_pairs.size());
    m_report.hash_seconds = timer.seconds();

    // 3. Exact primitive tests (world coordinates, radii grown by half the margin).
    timer.restart();
    const auto world_primitive = [&](const BroadPhaseItem& item) {
        const Body& body = m_bodies[item.body];
        const CollisionBodyState& state = states[item.body];
        Primitive prim;
        prim.count = body.bounds.counts()(item.primitive);
        for (int i = 0; i < prim.count; ++i) {
            prim.centers[i] = state.rotation
                    * body.bounds.centers().block<1, 3>(item.primitive, 3 * i).transpose()
                + state.translation;
            prim.radii[i] = body.bounds.radii()(item.primitive, i) + 0.5 * margin;
        }
        return prim;
    };
    std::vector<ItemPair> colliding;
    for (const ItemPair& pair : m_pairs) {
        const BroadPhaseItem& a = m_items[pair.first];
        const BroadPhaseItem& b = m_items[pair.second];
        if (a.body == b.body && !m_settings.self)
            continue;
        if (states[a.body].is_static && states[b.body].is_static)
            continue;
        if (primitives_intersect(world_primitive(a), world_primitive(b)))
            colliding.push_back(pair);
    }
    m_report.primitive_pairs = static_cast<int>(colliding.size());
    m_report.primitive_seconds = timer.seconds();

    // 4. Narrow phase and 5. contacts: per node, the closest triangle of the other primitive.
    timer.restart();
    struct Best {
        double distance; ///< signed: negative behind the triangle
        Vec3 closest;
        Vec3 normal;
        int other_body;
    };
    std::vector<std::unordered_map<int, Best>> best(m_bodies.size());
    const auto face_normal = [](const MatX3& x, const MatX3i& faces, Index f) {
        const Vec3 a = x.row(faces(f, 0)).transpose();
        const Vec3 n = (Vec3(x.row(faces(f, 1)).transpose()) - a)
                           .cross(Vec3(x.row(faces(f, 2)).transpose()) - a);
        const double length = n.norm();
        return length > 0.0 ? Vec3(n / length) : Vec3::UnitY();
    };
    // Nodes of (body_a, prim_a) against the triangles of (body_b, prim_b).
    const auto nodes_against = [&](int body_a, int prim_a, int body_b, int prim_b) {
        if (states[body_a].is_static)
            return;
        const Body& a = m_bodies[body_a];
        const Body& b = m_bodies[body_b];
        const MatX3i& faces_b = b.surface_view.faces();
        const VecXi& indptr = b.collision.face_primitives_indptr;
        for (int k = a.node_indptr(prim_a); k < a.node_indptr(prim_a + 1); ++k) {
            const int node = a.node_list(k);
            const Vec3 x = a.nodes.row(node).transpose();
            for (int j = indptr(prim_b); j < indptr(prim_b + 1); ++j) {
                const int f = b.collision.face_primitives(j);
                if (!grown(b.face_boxes[f], margin).contains(x))
                    continue;
                const PointTriangleClosest closest
                    = point_triangle_closest(x, b.surface.row(faces_b(f, 0)).transpose(),
                        b.surface.row(faces_b(f, 1)).transpose(),
                        b.surface.row(faces_b(f, 2)).transpose());
                const Vec3 n = face_normal(b.surface, faces_b, f);
                const double distance = std::sqrt(closest.squared_distance);
                const double signed_distance
                    = n.dot(x - closest.point) < 0.0 ? -distance : distance;
                if (signed_distance >= margin)
                    continue;
                auto [it, inserted] = best[body_a].try_emplace(
                    node, Best { signed_distance, closest.point, n, body_b });
                if (!inserted && std::abs(signed_distance) < std::abs(it->second.distance))
                    it->second = Best { signed_distance, closest.point, n, body_b };
            }
        }
    };
    for (const ItemPair& pair : colliding) {
        const BroadPhaseItem& ia = m_items[pair.first];
        const BroadPhaseItem& ib = m_items[pair.second];
        const Body& a = m_bodies[ia.body];
        const Body& b = m_bodies[ib.body];
        const MatX3i& faces_a = a.surface_view.faces();
        const MatX3i& faces_b = b.surface_view.faces();
        // Triangle-triangle tests among the enclosed triangles (box-filtered).
        const VecXi& ia_ptr = a.collision.face_primitives_indptr;
        const VecXi& ib_ptr = b.collision.face_primitives_indptr;
        for (int j = ia_ptr(ia.primitive); j < ia_ptr(ia.primitive + 1); ++j) {
            const int fa = a.collision.face_primitives(j);
            const Box3& box_a = a.face_boxes[fa];
            for (int l = ib_ptr(ib.primitive); l < ib_ptr(ib.primitive + 1); ++l) {
                const int fb = b.collision.face_primitives(l);
                if (ia.body == ib.body) {
                    bool shared = false;
                    for (int u = 0; u < 3; ++u)
                        for (int v = 0; v < 3; ++v)
                            shared |= faces_a(fa, u) == faces_b(fb, v);
                    if (shared)
                        continue;
                }
                if (!box_a.intersects(b.face_boxes[fb]))
                    continue;
                ++m_report.triangle_tests;
                if (triangles_intersect(a.surface.row(faces_a(fa, 0)).transpose(),
                        a.surface.row(faces_a(fa, 1)).transpose(),
                        a.surface.row(faces_a(fa, 2)).transpose(),
                        b.surface.row(faces_b(fb, 0)).transpose(),
                        b.surface.row(faces_b(fb, 1)).transpose(),
                        b.surface.row(faces_b(fb, 2)).transpose()))
                    ++m_report.intersecting_triangles;
            }
        }
        nodes_against(ia.body, ia.primitive, ib.body, ib.primitive);
        nodes_against(ib.body, ib.primitive, ia.body, ia.primitive);
    }
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        std::vector<std::pair<int, Best>> sorted(best[b].begin(), best[b].end());
        std::sort(sorted.begin(), sorted.end(),
            [](const auto& x, const auto& y) { return x.first < y.first; });
        const Mat3& r = states[b].rotation;
        for (const auto& [node, hit] : sorted) {
            const bool other_dynamic = !states[hit.other_body].is_static;
            // The separating plane: through the midpoint when both sides move, else on the
            // other surface; its normal is the triangle's outward normal.
            const Vec3 point
                = other_dynamic ? Vec3(hit.closest + 0.5 * hit.distance * hit.normal) : hit.closest;
            NodeContact contact;
            contact.node = node;
            contact.plane.point = r.transpose() * (point - states[b].translation);
            contact.plane.normal = r.transpose() * hit.normal;
            contact.plane.friction = m_settings.friction;
            m_contacts[b].push_back(contact);
            m_report.max_penetration = std::max(m_report.max_penetration, -hit.distance);
        }
        m_report.contacts += static_cast<int>(sorted.size());
    }
    m_report.triangle_seconds = timer.seconds();
    return m_contacts;
}

} // namespace mat
