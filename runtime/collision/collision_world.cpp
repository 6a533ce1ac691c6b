#include "runtime/collision/collision_world.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/timer.hpp"
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

} // namespace

CollisionWorld::CollisionWorld(const CollisionSettings& settings)
    : m_settings(settings)
    , m_hash([&] {
        SpatialHashSettings hash;
        hash.self_pairs = settings.self;
        return hash;
    }())
{
    if (!(settings.margin >= 0.0) || !(settings.friction >= 0.0))
        throw_error("collision: margin {} and friction {} must be >= 0", settings.margin,
            settings.friction);
    m_narrow.set_edge_contacts(settings.edges);
}

void CollisionWorld::add_body(std::shared_ptr<const BodyModel> model)
{
    MAT_CHECK(model != nullptr, "collision: add_body without a model");
    Body body(std::move(model));
    // Every triangle inside each enlarged primitive that lists it (docs/method.md, section 4).
    body.bounds.cover_faces(
        body.model->primitives(), body.model->surface().faces(), body.model->rest_surface());

    // The contact points: the surface vertices, grouped by the primitive that encloses each.
    const Index num_primitives = body.model->primitives().primitive_kind.size();
    const VecXi& primitive = body.model->primitives().vertex_primitive;
    body.vertex_indptr = VecXi::Zero(num_primitives + 1);
    for (Index v = 0; v < primitive.size(); ++v)
        ++body.vertex_indptr(primitive(v) + 1);
    for (Index p = 0; p < num_primitives; ++p)
        body.vertex_indptr(p + 1) += body.vertex_indptr(p);
    body.vertex_list.resize(primitive.size());
    VecXi fill = body.vertex_indptr.head(num_primitives);
    for (Index v = 0; v < primitive.size(); ++v)
        body.vertex_list(fill(primitive(v))++) = static_cast<int>(v);
    m_bodies.push_back(std::move(body));
}

// A uniform grid of cell `radius` over the rest faces' boxes; each vertex looks in the cells
// around it for faces within `radius` that do not have it as a corner.
void CollisionWorld::find_rest_neighbours(std::size_t b, double radius)
{
    Body& body = m_bodies[b];
    body.rest_near_radius = radius;
    const MatX3& x = body.model->rest_surface();
    const MatX3i& faces = body.model->surface().faces();
    const Index vs = x.rows();
    std::vector<std::vector<int>> near(static_cast<std::size_t>(vs));
    if (radius > 0.0) {
        const auto cell
            = [&](double c) { return static_cast<std::int64_t>(std::floor(c / radius)); };
        const auto key = [](std::int64_t i, std::int64_t j, std::int64_t k) {
            return (i * 73856093) ^ (j * 19349663) ^ (k * 83492791);
        };
        std::unordered_map<std::int64_t, std::vector<int>> grid;
        for (Index f = 0; f < faces.rows(); ++f) {
            Vec3 lo = x.row(faces(f, 0)).transpose(), hi = lo;
            for (int c = 1; c < 3; ++c) {
                lo = lo.cwiseMin(x.row(faces(f, c)).transpose());
                hi = hi.cwiseMax(x.row(faces(f, c)).transpose());
            }
            for (std::int64_t i = cell(lo.x()); i <= cell(hi.x()); ++i)
                for (std::int64_t j = cell(lo.y()); j <= cell(hi.y()); ++j)
                    for (std::int64_t k = cell(lo.z()); k <= cell(hi.z()); ++k)
                        grid[key(i, j, k)].push_back(static_cast<int>(f));
        }
        tbb::parallel_for(tbb::blocked_range<Index>(0, vs, 256), [&](const auto& range) {
            for (Index v = range.begin(); v != range.end(); ++v) {
                const Vec3 p = x.row(v).transpose();
                std::vector<int>& list = near[static_cast<std::size_t>(v)];
                for (std::int64_t i = cell(p.x()) - 1; i <= cell(p.x()) + 1; ++i)
                    for (std::int64_t j = cell(p.y()) - 1; j <= cell(p.y()) + 1; ++j)
                        for (std::int64_t k = cell(p.z()) - 1; k <= cell(p.z()) + 1; ++k) {
                            const auto it = grid.find(key(i, j, k));
                            if (it == grid.end())
                                continue;
                            for (const int f : it->second) {
                                if (faces(f, 0) == v || faces(f, 1) == v || faces(f, 2) == v)
                                    continue;
                                const PointTriangleClosest closest = point_triangle_closest(p,
                                    x.row(faces(f, 0)).transpose(), x.row(faces(f, 1)).transpose(),
                                    x.row(faces(f, 2)).transpose());
                                if (closest.squared_distance < radius * radius)
                                    list.push_back(f);
                            }
                        }
                std::sort(list.begin(), list.end());
                list.erase(std::unique(list.begin(), list.end()), list.end());
            }
        });
    }
    body.rest_near_indptr = VecXi::Zero(vs + 1);
    for (Index v = 0; v < vs; ++v)
        body.rest_near_indptr(v + 1)
            = body.rest_near_indptr(v) + static_cast<int>(near[static_cast<std::size_t>(v)].size());
    body.rest_near_list.resize(body.rest_near_indptr(vs));
    for (Index v = 0; v < vs; ++v)
        std::copy(near[static_cast<std::size_t>(v)].begin(),
            near[static_cast<std::size_t>(v)].end(),
            body.rest_near_list.data() + body.rest_near_indptr(v));
}

void CollisionWorld::update_body(std::size_t b, const CollisionBodyState& state, double margin)
{
    Body& body = m_bodies[b];
    MAT_CHECK(state.nodes != nullptr, "collision: body {} has no positions", b);
    const MatX3& nodes = *state.nodes;
    body.surface.resize(body.model->surface().num_vertices(), 3);
    body.model->surface().positions(nodes, body.surface);
    const bool from_q = state.q != nullptr
        && (m_settings.bounds != RadiusUpdate::bound || !m_variants.bounds_from_positions);
    if (from_q) {
        body.bounds.update(*state.q, m_settings.bounds);
    } else {
        embed(nodes, body.model->pd().tets(), body.model->medial_tet(),
            body.model->medial_barycentric(), body.sphere_centers);
        body.bounds.update_from_positions(body.surface, body.sphere_centers, m_settings.bounds);
    }

    // World coordinates: x -> R x + t for the nodes and (in place) the surface.
    const Mat3& r = state.rotation;
    const Vec3& t = state.translation;
    body.nodes.resize(nodes.rows(), 3);
    tbb::parallel_for(tbb::blocked_range<Index>(0, nodes.rows(), 512), [&](const auto& range) {
        for (Index i = range.begin(); i != range.end(); ++i)
            body.nodes.row(i) = (r * Vec3(nodes.row(i).transpose()) + t).transpose();
    });
    MatX3& surface = body.surface;
    tbb::parallel_for(tbb::blocked_range<Index>(0, surface.rows(), 512), [&](const auto& range) {
        for (Index i = range.begin(); i != range.end(); ++i)
            surface.row(i) = (r * Vec3(surface.row(i).transpose()) + t).transpose();
    });
    if (state.velocities != nullptr) {
        MatX3& velocity = body.surface_velocity;
        velocity.resize(surface.rows(), 3);
        body.model->surface().interpolate(*state.velocities, velocity);
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, velocity.rows(), 512), [&](const auto& range) {
                for (Index i = range.begin(); i != range.end(); ++i)
                    velocity.row(i) = (r * Vec3(velocity.row(i).transpose())).transpose();
            });
    } else {
        body.surface_velocity.resize(0, 3);
    }

    // The body's primitives in the world, radii grown by half the margin, and their boxes.
    body.items.clear();
    body.primitives.clear();
    body.balls.clear();
    body.box.setEmpty();
    for (Index p = 0; p < body.bounds.num_primitives(); ++p) {
        BroadPhaseItem item;
        item.body = static_cast<int>(b);
        item.primitive = static_cast<int>(p);
        Primitive prim;
        prim.count = body.bounds.counts()(p);
        for (int i = 0; i < prim.count; ++i) {
            prim.centers[i] = r * body.bounds.centers().block<1, 3>(p, 3 * i).transpose() + t;
            prim.radii[i] = body.bounds.radii()(p, i) + 0.5 * margin + state.motion;
            item.box.extend(Box3(
                prim.centers[i].array() - prim.radii[i], prim.centers[i].array() + prim.radii[i]));
            item.spheres[i] = body.model->primitives().primitive_spheres(p, i);
        }
        // A ball holding the primitive (it holds each sphere, so their convex hull), for a
        // quick rejection before the exact test.
        Vec3 mean = Vec3::Zero();
        for (int i = 0; i < prim.count; ++i)
            mean += prim.centers[i] / prim.count;
        double reach = 0.0;
        for (int i = 0; i < prim.count; ++i)
            reach = std::max(reach, (prim.centers[i] - mean).norm() + prim.radii[i]);
        body.box.extend(item.box);
        body.items.push_back(item);
        body.primitives.push_back(prim);
        body.balls.emplace_back(mean.x(), mean.y(), mean.z(), reach);
    }
    body.has_bounds = true;
}

const BodyContacts& CollisionWorld::detect(const std::vector<CollisionBodyState>& states)
{
    update_bounds(states);
    return find_contacts(states);
}

const BodyContacts& CollisionWorld::detect_in_step(const std::vector<CollisionBodyState>& states)
{
    const CollisionReport start = m_report;
    m_kept_intersecting.swap(m_intersecting);
    m_redetected.assign(m_bodies.size(), 0);
    for (std::size_t b = 0; b < m_bodies.size(); ++b)
        if (!(states[b].reuse_bounds && m_bodies[b].has_bounds)) {
            m_redetected[b] = 1;
            m_bodies[b].step_surface = m_bodies[b].surface;
        }
    detect(states);
    for (std::size_t b = 0; b < m_bodies.size(); ++b)
        if (m_redetected[b])
            m_bodies[b].surface.swap(m_bodies[b].step_surface);
    m_intersecting.swap(m_kept_intersecting);
    const CollisionReport now = m_report;
    m_report = start;
    m_report.add_seconds(now);
    return m_contacts;
}

void CollisionWorld::update_bounds(const std::vector<CollisionBodyState>& states)
{
    MAT_CHECK(states.size() == m_bodies.size(), "collision: {} states for {} bodies", states.size(),
        m_bodies.size());
    m_report = CollisionReport {};
    if (m_bodies.empty())
        return;
    double diagonal = 0.0;
    for (const Body& body : m_bodies)
        diagonal = std::max(diagonal, body.model->rest_diagonal());
    m_margin = m_settings.margin * diagonal;

    // 1. Bounds, and the surfaces, nodes and primitives in world coordinates, except for the
    //    bodies that have not moved.
    //    The bodies in parallel (and each body's loops in parallel inside): a body's loops are
    //    too short to keep two threads busy, and its results do not depend on the split.
    Timer timer;
    m_updated.clear();
    for (std::size_t b = 0; b < m_bodies.size(); ++b)
        if (!(states[b].reuse_bounds && m_bodies[b].has_bounds))
            m_updated.push_back(b);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m_updated.size(), 1),
        [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t k = range.begin(); k != range.end(); ++k)
                update_body(m_updated[k], states[m_updated[k]], m_margin);
        });
    m_report.updated_bodies = static_cast<int>(m_updated.size());
    // Self collision: what is near at rest is never a contact (a body at rest stays at rest).
    if (m_settings.self)
        for (std::size_t b = 0; b < m_bodies.size(); ++b)
            if (m_bodies[b].rest_near_radius != rest_near_factor * m_margin)
                find_rest_neighbours(b, rest_near_factor * m_margin);
    m_report.bounds_seconds = timer.seconds();
}

const BodyContacts& CollisionWorld::find_contacts(const std::vector<CollisionBodyState>& states)
{
    MAT_CHECK(states.size() == m_bodies.size(), "collision: {} states for {} bodies", states.size(),
        m_bodies.size());
    m_contacts.clear();
    m_intersecting.clear();
    if (m_bodies.empty())
        return m_contacts;
    const double margin = m_margin;

    // 2. Object level: the pairs of bodies that go on, and the bodies to hash.
    Timer timer;
    select_object_pairs(states);
    // 3. Broad phase.
    broad_phase();
    m_report.hash_seconds = timer.seconds();
    // 4. Exact primitive tests.
    timer.restart();
    test_primitive_pairs(states);
    m_report.primitive_seconds = timer.seconds();

    // 5. Narrow phase.
    timer.restart();
    narrow_phase(states, margin);
    m_report.triangle_seconds = timer.seconds();

    // 6. Contacts.
    timer.restart();
    respond(states);
    m_report.response_seconds = timer.seconds();
    return m_contacts;
}

// Phase 2: the pairs of bodies whose boxes meet, one of them dynamic (or every pair without
// object culling), and the bodies to hash: those in such a pair, or awake with self collision.
void CollisionWorld::select_object_pairs(const std::vector<CollisionBodyState>& states)
{
    const std::size_t n_bodies = m_bodies.size();
    m_hashed.assign(n_bodies, 0);
    m_object_pair.assign(n_bodies * n_bodies, 0);
    for (std::size_t a = 0; a < n_bodies; ++a) {
        if (m_settings.self && !states[a].is_static)
            m_hashed[a] = 1;
        for (std::size_t b = a + 1; b < n_bodies; ++b) {
            if (states[a].is_static && states[b].is_static)
                continue;
            if (m_variants.object_culling && !m_bodies[a].box.intersects(m_bodies[b].box))
                continue;
            m_object_pair[a * n_bodies + b] = 1;
            m_hashed[a] = m_hashed[b] = 1;
            ++m_report.object_pairs;
        }
    }
    m_items.clear();
    m_primitives.clear();
    m_balls.clear();
    for (std::size_t b = 0; b < n_bodies; ++b) {
        if (!m_hashed[b])
            continue;
        ++m_report.hashed_bodies;
        const Body& body = m_bodies[b];
        m_items.insert(m_items.end(), body.items.begin(), body.items.end());
        m_primitives.insert(m_primitives.end(), body.primitives.begin(), body.primitives.end());
        m_balls.insert(m_balls.end(), body.balls.begin(), body.balls.end());
    }
}

// Phase 3: the spatial hash's candidate pairs over the hashed bodies' primitives (or every pair).
void CollisionWorld::broad_phase()
{
    if (m_items.empty()) {
        m_pairs.clear();
    } else if (m_variants.all_pairs) {
        m_pairs.clear();
        const int n = static_cast<int>(m_items.size());
        for (int i = 0; i < n; ++i)
            for (int j = i + 1; j < n; ++j)
                if ((m_settings.self || m_items[i].body != m_items[j].body)
                    && broad_phase_pair_allowed(m_items[i], m_items[j]))
                    m_pairs.emplace_back(i, j);
    } else {
        m_hash.build(m_items);
        m_hash.pairs(m_pairs);
    }
    m_report.primitive_candidates = static_cast<int>(m_pairs.size());
}

// Phase 4: the exact primitive test on the candidates whose bodies may collide, in parallel; the
// colliding pairs kept in candidate order.
void CollisionWorld::test_primitive_pairs(const std::vector<CollisionBodyState>& states)
{
    const std::size_t n_bodies = m_bodies.size();
    // Whether two items' bodies may collide: the same awake body with self-collision on, or
    // an object pair that goes on.
    const auto bodies_collide = [&](int a, int b) {
        if (a == b)
            return m_settings.self && !states[static_cast<std::size_t>(a)].is_static;
        const auto [lo, hi] = std::minmax(a, b);
        return m_object_pair[static_cast<std::size_t>(lo) * n_bodies + static_cast<std::size_t>(hi)]
            != 0;
    };

    m_hit.assign(m_pairs.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m_pairs.size(), 32),
        [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t k = range.begin(); k != range.end(); ++k) {
                const auto [i, j] = m_pairs[k];
                const BroadPhaseItem& a = m_items[static_cast<std::size_t>(i)];
                const BroadPhaseItem& b = m_items[static_cast<std::size_t>(j)];
                if (!bodies_collide(a.body, b.body))
                    continue;
                const Eigen::Vector4d& ball_a = m_balls[static_cast<std::size_t>(i)];
                const Eigen::Vector4d& ball_b = m_balls[static_cast<std::size_t>(j)];
                if ((ball_a.head<3>() - ball_b.head<3>()).norm() > ball_a(3) + ball_b(3))
                    continue;
                m_hit[k] = primitives_intersect(m_primitives[static_cast<std::size_t>(i)],
                    m_primitives[static_cast<std::size_t>(j)]);
            }
        });
    m_colliding.clear();
    for (std::size_t k = 0; k < m_pairs.size(); ++k)
        if (m_hit[k])
            m_colliding.push_back(m_pairs[k]);
    m_report.primitive_pairs = static_cast<int>(m_colliding.size());
}

void CollisionWorld::narrow_phase(const std::vector<CollisionBodyState>& states, double margin)
{
    m_views.resize(m_bodies.size());
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        const Body& body = m_bodies[b];
        NarrowPhaseBody& view = m_views[b];
        view.surface = &body.surface;
        view.faces = &body.model->surface().faces();
        view.nodes = &body.surface;
        view.face_indptr = &body.model->primitives().face_primitives_indptr;
        view.face_list = &body.model->primitives().face_primitives;
        view.node_indptr = &body.vertex_indptr;
        view.node_list = &body.vertex_list;
        view.nodes_are_vertices = true;
        view.rest_surface = &body.model->rest_surface();
        view.rest_near_indptr = body.rest_near_radius >= 0.0 ? &body.rest_near_indptr : nullptr;
        view.rest_near_list = &body.rest_near_list;
        view.is_static = states[b].is_static;
        view.motion = states[b].motion;
        view.velocities = body.surface_velocity.rows() > 0 ? &body.surface_velocity : nullptr;
    }
    m_pair_refs.clear();
    for (const auto& [i, j] : m_colliding) {
        const BroadPhaseItem& a = m_items[static_cast<std::size_t>(i)];
        const BroadPhaseItem& b = m_items[static_cast<std::size_t>(j)];
        m_pair_refs.push_back(
            { a.body, a.primitive, b.body, b.primitive, a.box.intersection(b.box) });
    }
    m_narrow.run(m_views, m_pair_refs, margin, m_lookahead, m_extra);
    m_intersecting = m_narrow.intersecting();
    m_report.triangle_tests = m_narrow.triangle_tests();
    m_report.node_tests = m_narrow.node_tests();
    m_report.edge_tests = m_narrow.edge_tests();
    m_report.intersecting_triangles = static_cast<int>(m_intersecting.size());
}

void CollisionWorld::respond(const std::vector<CollisionBodyState>& states)
{
    // One candidate per surface vertex (the nearest triangle), sorted by (body, vertex): the
    // vertex (its embedding's nodes and weights) against the triangle's closest point.
    for (const NodeCandidate& hit : m_narrow.candidates()) {
        m_report.max_penetration = std::max(m_report.max_penetration, -hit.plane);
        // A vertex more than the margin behind its nearest face of another deformable body has
        // passed through that face: its normal is no way out, and pushing along it squeezes the
        // part the vertex is in (docs/method.md, "Deep vertices"). A constant body's faces
        // cannot give way, so its contacts stay; within one body the narrow phase keeps such a
        // vertex out already.
        if (hit.body != hit.other_body
            && !states[static_cast<std::size_t>(hit.other_body)].is_static
            && hit.distance < -m_margin) {
            ++m_report.deep_vertices;
            continue;
        }
        const Body& other = m_bodies[static_cast<std::size_t>(hit.other_body)];
        const Eigen::Vector3i face = other.model->surface().faces().row(hit.face).transpose();
        add_vertex_terms(hit.body, hit.node, 1.0);
        for (int k = 0; k < 3; ++k)
            add_vertex_terms(hit.other_body, face(k), -hit.barycentric(k));
        // The face's corners, so that the contact stage can turn the plane with the iterate.
        const int face_first = static_cast<int>(m_contacts.face_terms.size());
        const SurfaceEmbedding& surface = other.model->surface();
        for (int k = 0; k < 3; ++k)
            for (int c = 0; c < BodyContacts::face_corner_terms; ++c)
                m_contacts.face_terms.push_back(ContactTerm {
                    hit.other_body, surface.nodes()(face(k), c), surface.weights()(face(k), c) });
        close_contact(hit.normal, hit.node, hit.body == hit.other_body, face_first);
    }
    // One per surface edge that has one (the nearest edge crossing it), sorted by (body, edge):
    // the edge's closest point against the other edge's, keyed after the body's vertices.
    for (const EdgeCandidate& hit : m_narrow.edge_candidates()) {
        const std::array<int, 2>& ends
            = m_narrow.edges(hit.body).vertices[static_cast<std::size_t>(hit.edge)];
        const std::array<int, 2>& other_ends
            = m_narrow.edges(hit.other_body).vertices[static_cast<std::size_t>(hit.other_edge)];
        add_vertex_terms(hit.body, ends[0], 1.0 - hit.s);
        add_vertex_terms(hit.body, ends[1], hit.s);
        add_vertex_terms(hit.other_body, other_ends[0], -(1.0 - hit.t));
        add_vertex_terms(hit.other_body, other_ends[1], -hit.t);
        const Body& self = m_bodies[static_cast<std::size_t>(hit.body)];
        const int key = static_cast<int>(self.model->surface().num_vertices()) + hit.edge;
        close_contact(hit.normal, key, hit.body == hit.other_body);
        ++m_report.edge_contacts;
    }
}

void CollisionWorld::add_vertex_terms(int body, int vertex, double weight)
{
    const SurfaceEmbedding& surface = m_bodies[static_cast<std::size_t>(body)].model->surface();
    for (int c = 0; c < 4; ++c) {
        const double w = weight * surface.weights()(vertex, c);
        if (w != 0.0)
            m_contacts.terms.push_back(ContactTerm { body, surface.nodes()(vertex, c), w });
    }
}

void CollisionWorld::close_contact(const Vec3& normal, int key, bool is_self, int face)
{
    PlaneCollider plane;
    plane.point = Vec3::Zero();
    plane.normal = normal;
    plane.friction = m_settings.friction;
    plane.offset = (is_self ? m_settings.self_skin : m_settings.skin) * m_margin;
    m_contacts.close(plane, key, is_self, face);
    ++m_report.contacts;
}

} // namespace mat
