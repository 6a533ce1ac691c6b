// Edge-edge candidates of the narrow phase (docs/method.md, "Edge contacts"): two sharp surface
// edges (convex, their faces at least the sharp angle apart at rest) whose closest points lie
// inside both, in front within the margin or what their approach closes in the step (each in
// the other's Voronoi region), or crossed by less than the margin through a face. A vertex-face
// contact holds a vertex out of a face; two edges that cross between their vertices (a ridge
// over a ridge, a blade across a rim) are seen by none of those, so each active sharp edge of a
// dynamic body looks for its nearest such edge of its partners.

#include <algorithm>
#include <cmath>
#include <limits>

#include "runtime/collision/narrow_phase.hpp"
#include "runtime/collision/triangle_tests.hpp"

namespace mat {

SurfaceEdges build_surface_edges(const MatX3i& faces)
{
    SurfaceEdges edges;
    const Index num_faces = faces.rows();
    edges.of_face.assign(static_cast<std::size_t>(num_faces), { -1, -1, -1 });
    // Sorted (low, high, face, corner) records: equal (low, high) runs are one edge.
    std::vector<std::array<int, 4>> records;
    records.reserve(3 * static_cast<std::size_t>(num_faces));
    for (Index f = 0; f < num_faces; ++f)
        for (int c = 0; c < 3; ++c) {
            const int u = faces(f, c);
            const int v = faces(f, (c + 1) % 3);
            records.push_back({ std::min(u, v), std::max(u, v), static_cast<int>(f), c });
        }
    std::sort(records.begin(), records.end());
    for (std::size_t i = 0; i < records.size();) {
        std::size_t j = i;
        const int edge = static_cast<int>(edges.vertices.size());
        edges.vertices.push_back({ records[i][0], records[i][1] });
        edges.faces.push_back({ -1, -1 });
        for (;
             j < records.size() && records[j][0] == records[i][0] && records[j][1] == records[i][1];
             ++j) {
            // A non-manifold edge keeps its first two faces.
            std::array<int, 2>& two = edges.faces.back();
            if (two[0] < 0)
                two[0] = records[j][2];
            else if (two[1] < 0)
                two[1] = records[j][2];
            edges.of_face[static_cast<std::size_t>(records[j][2])]
                         [static_cast<std::size_t>(records[j][3])]
                = edge;
        }
        i = j;
    }
    return edges;
}

namespace {

    Vec3 vertex(const NarrowPhaseBody& body, int v)
    {
        return body.surface->row(v).transpose();
    }

    Vec3 vertex_velocity(const NarrowPhaseBody& body, int v)
    {
        return body.velocities != nullptr ? Vec3(body.velocities->row(v).transpose())
                                          : Vec3::Zero();
    }

    /// The sum of the unit normals of an edge's faces: the edge's outward direction.
    Vec3 edge_outward(const NarrowPhaseBody& body, const std::array<int, 2>& faces)
    {
        Vec3 sum = Vec3::Zero();
        for (const int f : faces) {
            if (f < 0)
                continue;
            const Vec3 p0 = vertex(body, (*body.faces)(f, 0));
            const Vec3 n = (vertex(body, (*body.faces)(f, 1)) - p0)
                               .cross(vertex(body, (*body.faces)(f, 2)) - p0);
            const double length = n.norm();
            if (length > 0.0)
                sum += n / length;
        }
        return sum;
    }

    /// Whether `d` (from a point of edge (u, v) to a point off it) leaves each of the edge's
    /// faces across the edge: d . t >= 0 for each face's direction t in its plane, across the
    /// edge away from its third corner. Then the nearest part of the surface to the point is
    /// the edge, not one of its faces (the edge's Voronoi region; a concave edge has none):
    /// otherwise the contact is a face's, which the vertex-face contacts hold.
    bool in_edge_region(const NarrowPhaseBody& body, const std::array<int, 2>& ends,
        const std::array<int, 2>& faces, const Vec3& d)
    {
        const Vec3 u = vertex(body, ends[0]);
        const Vec3 along = vertex(body, ends[1]) - u;
        const double length2 = along.squaredNorm();
        if (!(length2 > 0.0))
            return false;
        for (const int f : faces) {
            if (f < 0)
                continue;
            int third = -1;
            for (int c = 0; c < 3; ++c) {
                const int w = (*body.faces)(f, c);
                if (w != ends[0] && w != ends[1])
                    third = w;
            }
            if (third < 0)
                return false;
            Vec3 across = u - vertex(body, third);
            across -= (across.dot(along) / length2) * along;
            if (d.dot(across) < 0.0)
                return false;
        }
        return true;
    }

    /// Whether edge `ends` of `body` passes through one of `faces` of `other` (exact).
    bool edge_through_faces(const NarrowPhaseBody& body, const std::array<int, 2>& ends,
        const NarrowPhaseBody& other, const std::array<int, 2>& faces)
    {
        for (const int f : faces)
            if (f >= 0
                && segment_triangle_intersect(vertex(body, ends[0]), vertex(body, ends[1]),
                    vertex(other, (*other.faces)(f, 0)), vertex(other, (*other.faces)(f, 1)),
                    vertex(other, (*other.faces)(f, 2))))
                return true;
        return false;
    }

    /// An edge's search among the edges of one partner body.
    struct EdgeQuery {
        Vec3 x0 = Vec3::Zero(), x1 = Vec3::Zero();
        Vec3 v0 = Vec3::Zero(), v1 = Vec3::Zero();
        Vec3 mean = Vec3::Zero(); ///< the ends' mean velocity
        double spread = 0.0; ///< how far an end's velocity is from it
        double speed = 0.0; ///< the faster end's speed
        Box3 box;
        double margin = 0.0;
        double near = 0.0; ///< the margin, plus the extra against a body that does not fall
        double reach = 0.0; ///< near, plus the edge's and the other body's motion in the step
        double hold = 0.0; ///< max(near, margin): taken whatever the motion
        double lookahead = 0.0;
        bool stopping = true; ///< either body may stop (two bodies; not within one)
    };

    /// The farthest from the query edge that an edge (or every edge of a set) moving as (mean
    /// velocity, fastest end's speed, spread about the mean) can take it: the margin, or near
    /// plus the lookahead times the most their points can approach each other, where either may
    /// stop (NarrowPhase::stopping_approach: the speeds' sum, or the largest of the means'
    /// difference plus both spreads and each fastest end's speed), with a relative slack of
    /// 1e-9 (an edge's points move between its ends' velocities).
    double edge_reach(const EdgeQuery& q, const Vec3& mean, double speed, double spread)
    {
        const double relative = (q.mean - mean).norm() + q.spread + spread;
        const double approach = std::min(
            q.speed + speed, q.stopping ? std::max({ relative, q.speed, speed }) : relative);
        return std::min(q.reach, (1.0 + 1e-9) * (q.hold + q.lookahead * approach) + 1e-9 * q.hold);
    }

    /// The distance between two boxes (0 if they overlap).
    double box_gap(const Box3& a, const Box3& b)
    {
        double squared = 0.0;
        for (Index i = 0; i < 3; ++i) {
            const double gap = std::max({ b.min()[i] - a.max()[i], a.min()[i] - b.max()[i], 0.0 });
            squared += gap * gap;
        }
        return std::sqrt(squared);
    }

    /// Edges closer to parallel than this (the sine of their angle) have no well-defined normal
    /// between them; their contact is the vertex-face one at the end of one of them.
    constexpr double min_sine = 1e-3;
    /// Closest points this close to an end (in the edge's parameter) are the vertex's.
    constexpr double end_parameter = 1e-6;

    /// The other body's edge (y0, y1), velocities w0, w1, against the query edge: the closest
    /// points inside both, and the signed gap along the lines' normal turned out of the other
    /// body (`outward()`: the other edge's outward direction less the query edge's). True, with
    /// `hit` (s, t, distance, normal), if it takes it.
    template <class Outward, class Regions, class Crossed>
    bool edge_edge_hit(const EdgeQuery& q, const Vec3& y0, const Vec3& y1, const Vec3& w0,
        const Vec3& w1, const Outward& outward, const Regions& regions, const Crossed& crossed,
        EdgeCandidate& hit)
    {
        const Vec3 a = q.x1 - q.x0;
        const Vec3 b = y1 - y0;
        const Vec3 cross = a.cross(b);
        const double length = cross.norm();
        if (!(length > min_sine * a.norm() * b.norm()))
            return false;
        const SegmentSegmentClosest closest = segment_segment_closest(q.x0, q.x1, y0, y1);
        if (!(closest.s > end_parameter && closest.s < 1.0 - end_parameter
                && closest.t > end_parameter && closest.t < 1.0 - end_parameter))
            return false;
        const Vec3 p = q.x0 + closest.s * a;
        const Vec3 r = y0 + closest.t * b;
        if ((p - r).squaredNorm() >= std::max(q.reach, q.margin) * std::max(q.reach, q.margin))
            return false;
        Vec3 normal = cross / length;
        const double side = normal.dot(outward());
        if (side == 0.0)
            return false;
        if (side < 0.0)
            normal = -normal;
        const double gap = normal.dot(p - r);
        // In front, only where the two are each other's nearest parts of the surfaces.
        if (gap >= 0.0 && !regions(p - r))
            return false;
        if (gap < 0.0) {
            // Crossed: within the margin only (further, the edge may be on the far side of a
            // thin part).
            if (-gap > q.margin || !crossed())
                return false;
        } else if (gap >= q.near) {
            const Vec3 v = (1.0 - closest.s) * q.v0 + closest.s * q.v1;
            const Vec3 w = (1.0 - closest.t) * w0 + closest.t * w1;
            const double approach
                = NarrowPhase::stopping_approach(normal.dot(v), normal.dot(w), q.stopping);
            if (gap >= q.reach || gap >= q.near + q.lookahead * approach)
                return false;
        }
        hit.s = closest.s;
        hit.t = closest.t;
        hit.distance = gap;
        hit.normal = normal;
        return true;
    }

} // namespace

void NarrowPhase::find_sharp_edges(const NarrowPhaseBody& body, BodyData& data) const
{
    data.edges = build_surface_edges(*body.faces);
    data.sharp_edges.clear();
    const MatX3& at_rest = body.rest_surface != nullptr ? *body.rest_surface : *body.surface;
    const auto x = [&](int v) { return Vec3(at_rest.row(v).transpose()); };
    const auto unit = [&](int f) -> Vec3 {
        const Vec3 n = (x((*body.faces)(f, 1)) - x((*body.faces)(f, 0)))
                           .cross(x((*body.faces)(f, 2)) - x((*body.faces)(f, 0)));
        const double length = n.norm();
        return length > 0.0 ? Vec3(n / length) : Vec3(Vec3::Zero());
    };
    for (std::size_t e = 0; e < data.edges.vertices.size(); ++e) {
        const std::array<int, 2>& two = data.edges.faces[e];
        const std::array<int, 2>& ends = data.edges.vertices[e];
        if (two[1] < 0)
            continue;
        const Vec3 n0 = unit(two[0]);
        const Vec3 n1 = unit(two[1]);
        if (n0.isZero() || n1.isZero() || n0.dot(n1) > m_sharp_cosine)
            continue;
        // Convex: the second face's third corner lies behind the first face's plane.
        for (int c = 0; c < 3; ++c) {
            const int w = (*body.faces)(two[1], c);
            if (w != ends[0] && w != ends[1] && n0.dot(x(w) - x(ends[0])) < 0.0)
                data.sharp_edges.push_back(static_cast<int>(e));
        }
    }
}

// The sharp edges of the active faces, with their grid.
void NarrowPhase::collect_active_edges(const NarrowPhaseBody& body, BodyData& data, int axis) const
{
    data.active_edges.clear();
    data.edge_grid.items.clear();
    for (const int e : data.sharp_edges) {
        bool active = false;
        for (const int f : data.edges.faces[static_cast<std::size_t>(e)])
            active |= f >= 0 && data.face_stamp[static_cast<std::size_t>(f)] == m_run;
        if (!active)
            continue;
        BodyData::ActiveEdge item;
        const std::array<int, 2>& ends = data.edges.vertices[static_cast<std::size_t>(e)];
        item.edge = e;
        item.x0 = vertex(body, ends[0]);
        item.x1 = vertex(body, ends[1]);
        item.v0 = vertex_velocity(body, ends[0]);
        item.v1 = vertex_velocity(body, ends[1]);
        item.motion.mean = 0.5 * (item.v0 + item.v1);
        item.motion.spread = 0.5 * (item.v1 - item.v0).norm();
        item.motion.speed = std::max(item.v0.norm(), item.v1.norm());
        item.box = Box3(item.x0.cwiseMin(item.x1), item.x0.cwiseMax(item.x1));
        item.outward = edge_outward(body, data.edges.faces[static_cast<std::size_t>(e)]);
        data.edge_grid.items.push_back({ item.box, static_cast<int>(data.active_edges.size()), 0 });
        data.active_edges.push_back(item);
    }
    data.edge_grid.build(axis);
    // Each column's box and motion: its edges' fastest end, the mean of their means, and how far
    // an end's velocity is from it at most.
    summarize_columns(
        data.edge_grid,
        [&](std::size_t k) -> const BodyData::FaceMotion& {
            return data.active_edges[static_cast<std::size_t>(data.edge_grid.at(k).index)].motion;
        },
        data.edge_columns);
}

void NarrowPhase::build_edge_work(const std::vector<NarrowPhaseBody>& bodies)
{
    m_edge_work.clear();
    for (std::size_t b = 0; b < m_bodies.size(); ++b)
        if (!bodies[b].is_static)
            for (std::size_t i = 0; i < m_bodies[b].active_edges.size(); ++i)
                m_edge_work.push_back({ static_cast<int>(b), static_cast<int>(i) });
}

bool NarrowPhase::own_edge_excluded(const NarrowPhaseBody& own, int body, int ea, int eb) const
{
    const SurfaceEdges& edges = m_bodies[static_cast<std::size_t>(body)].edges;
    const std::array<int, 2>& va = edges.vertices[static_cast<std::size_t>(ea)];
    const std::array<int, 2>& vb = edges.vertices[static_cast<std::size_t>(eb)];
    for (const int u : va)
        for (const int v : vb)
            if (u == v)
                return true;
    const std::array<int, 2>& fa = edges.faces[static_cast<std::size_t>(ea)];
    const std::array<int, 2>& fb = edges.faces[static_cast<std::size_t>(eb)];
    // Near at rest: a vertex of one edge and a face of the other (the vertices' lists).
    if (own.rest_near_indptr != nullptr) {
        const auto near = [&](int v, int f) {
            const int* begin = own.rest_near_list->data() + (*own.rest_near_indptr)(v);
            const int* end = own.rest_near_list->data() + (*own.rest_near_indptr)(v + 1);
            return f >= 0 && std::binary_search(begin, end, f);
        };
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j)
                if (near(va[static_cast<std::size_t>(i)], fb[static_cast<std::size_t>(j)])
                    || near(vb[static_cast<std::size_t>(i)], fa[static_cast<std::size_t>(j)]))
                    return true;
    }
    for (const int f : fa)
        for (const int g : fb)
            if (f >= 0 && g >= 0 && self_pair_allowed(body, f, g, false))
                return false;
    return true;
}

// A sharp edge searches its partners' sharp edges within its reach (their grid, each column and
// edge bounded by its motion): contacts in front, and crossed ones.
bool NarrowPhase::nearest_edge(const std::vector<NarrowPhaseBody>& bodies, double margin,
    double lookahead, double extra, Scratch& scratch, std::size_t k, EdgeCandidate& best) const
{
    const int be = m_edge_work[k][0];
    const BodyData& data = m_bodies[static_cast<std::size_t>(be)];
    const BodyData::ActiveEdge& own_edge
        = data.active_edges[static_cast<std::size_t>(m_edge_work[k][1])];
    const int ea = own_edge.edge;
    const NarrowPhaseBody& own = bodies[static_cast<std::size_t>(be)];
    const std::array<int, 2>& ends = data.edges.vertices[static_cast<std::size_t>(ea)];
    EdgeQuery query;
    query.x0 = own_edge.x0;
    query.x1 = own_edge.x1;
    query.v0 = own_edge.v0;
    query.v1 = own_edge.v1;
    query.mean = own_edge.motion.mean;
    query.spread = own_edge.motion.spread;
    query.speed = own_edge.motion.speed;
    query.box = own_edge.box;
    query.margin = margin;
    query.lookahead = lookahead;
    bool found = false;
    for (const int bf : data.partners) {
        const NarrowPhaseBody& other = bodies[static_cast<std::size_t>(bf)];
        // Each pair once: two dynamic bodies' from the lower one, one body's from the lower edge.
        if (bf < be && !other.is_static)
            continue;
        const BodyData& faces = m_bodies[static_cast<std::size_t>(bf)];
        if (faces.active_edges.empty())
            continue;
        query.near = margin + (own.is_static != other.is_static ? extra : 0.0);
        query.reach = query.near + lookahead * query.speed + other.motion;
        query.hold = std::max(query.near, margin);
        // Within one body, the approach at the start velocities only (as a vertex's).
        query.stopping = bf != be;
        // Each sharp partner edge whose box is within the reach of the two edges' motion, then
        // the exact rule.
        const auto test_edge = [&](const BodyData::ActiveEdge& edge) {
            const int eb = edge.edge;
            const double gap = box_gap(query.box, edge.box);
            // The box's distance is at most the edges' (their closest points' distance, the
            // gap's size): beyond the best hit so far, it loses.
            if ((found && gap > (1.0 + 1e-9) * std::abs(best.distance))
                || gap > edge_reach(query, edge.motion.mean, edge.motion.speed, edge.motion.spread))
                return;
            if (bf == be && (eb <= ea || own_edge_excluded(own, be, ea, eb)))
                return;
            ++scratch.edge_tests;
            const std::array<int, 2>& other_ends
                = faces.edges.vertices[static_cast<std::size_t>(eb)];
            const auto outward = [&]() -> Vec3 { return edge.outward - own_edge.outward; };
            const auto regions = [&](const Vec3& d) {
                return in_edge_region(
                           other, other_ends, faces.edges.faces[static_cast<std::size_t>(eb)], d)
                    && in_edge_region(
                        own, ends, data.edges.faces[static_cast<std::size_t>(ea)], -d);
            };
            const auto crossed = [&]() {
                return edge_through_faces(
                           own, ends, other, faces.edges.faces[static_cast<std::size_t>(eb)])
                    || edge_through_faces(
                        other, other_ends, own, data.edges.faces[static_cast<std::size_t>(ea)]);
            };
            EdgeCandidate hit;
            if (!edge_edge_hit(
                    query, edge.x0, edge.x1, edge.v0, edge.v1, outward, regions, crossed, hit))
                return;
            if (found
                && (std::abs(hit.distance) > std::abs(best.distance)
                    || (std::abs(hit.distance) == std::abs(best.distance)
                        && std::make_pair(bf, eb)
                            > std::make_pair(best.other_body, best.other_edge))))
                return;
            hit.body = be;
            hit.edge = ea;
            hit.other_body = bf;
            hit.other_edge = eb;
            best = hit;
            found = true;
        };
        const double most = edge_reach(query, faces.mean_velocity,
            std::numeric_limits<double>::infinity(), faces.velocity_spread);
        // Each column grows by the reach of its own edges' motion, and is skipped when its box
        // is beyond it.
        const auto column_grow = [&](int c) {
            const BodyData::ColumnMotion& column = faces.edge_columns[static_cast<std::size_t>(c)];
            const double reach
                = edge_reach(query, column.motion.mean, column.motion.speed, column.motion.spread);
            return box_gap(query.box, column.box) > reach ? -1.0 : std::min(reach, most);
        };
        faces.edge_grid.overlapping(query.box, most, column_grow,
            [&](int slot, int) { test_edge(faces.active_edges[static_cast<std::size_t>(slot)]); });
    }
    return found;
}

} // namespace mat
