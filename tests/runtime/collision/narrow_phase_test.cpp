// The narrow phase against a brute-force reference that tests every colliding primitive pair on
// its own (the triangles and nodes of the two primitives inside the pair's region, grown by the
// margin): on two creatures placed into each other, with object and self pairs, the narrow phase
// finds every intersecting triangle pair the reference finds, each node's nearest triangle at
// least as near, reports only true intersections, and gives the same result on 1, 2 and 3
// threads; at rest, and moving with speculative contacts. Edge-edge candidates are checked against
// the rule of docs/method.md ("Edge contacts") over every pair of edges of the two bodies.

#include "runtime/collision/narrow_phase.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>

#include <tbb/task_arena.h>

#include "common/surface_embedding.hpp"
#include "runtime/collision/triangle_tests.hpp"
#include "runtime/pd/contact.hpp"
#include "tests/support/sample_bake.hpp"

namespace mat {
namespace {

    const BakeData& creature_bake()
    {
        return test::sample_bake("creature", 0.05);
    }

    /// One rigidly placed creature, with what NarrowPhaseBody points to.
    struct PlacedBody {
        MatX3 surface, nodes;
        MatX3i faces;
        VecXi node_indptr, node_list;
        std::vector<Box3> primitive_boxes; ///< #P, the rest primitives placed, not enlarged
        NarrowPhaseBody view;

        /// `spin` and `velocity`: with them, the nodes are the surface vertices (as in a run)
        /// and move rigidly at the velocity plus spin x (x - translation).
        PlacedBody(const Mat3& rotation, const Vec3& translation, const Vec3* spin = nullptr,
            const Vec3& velocity = Vec3::Zero())
        {
            const BakeData& bake = creature_bake();
            const auto place = [&](const MatX3& x) {
                MatX3 out(x.rows(), 3);
                for (Index i = 0; i < x.rows(); ++i)
                    out.row(i) = (rotation * Vec3(x.row(i).transpose()) + translation).transpose();
                return out;
            };
            nodes = place(bake.tet_mesh.positions);
            const SurfaceEmbedding embedding(bake);
            surface.resize(embedding.num_vertices(), 3);
            embedding.positions(nodes, surface);
            faces = embedding.faces();
            const MatX3 centers = place(bake.medial.centers);
            const MedialCollisionData& collision = bake.collision;
            const Index num_primitives = collision.primitive_kind.size();
            for (Index p = 0; p < num_primitives; ++p) {
                Box3 box;
                for (int i = 0; i < 3; ++i) {
                    const int s = collision.primitive_spheres(p, i);
                    if (s < 0)
                        continue;
                    const Vec3 c = centers.row(s).transpose();
                    box.extend(
                        Box3(c.array() - bake.medial.radii(s), c.array() + bake.medial.radii(s)));
                }
                primitive_boxes.push_back(box);
            }
            // Boundary nodes, each to the primitive of its nearest surface vertex (brute force).
            const std::vector<int> boundary = boundary_nodes(bake.tet_mesh.tets, nodes.rows());
            std::vector<int> primitive_of(boundary.size());
            node_indptr = VecXi::Zero(num_primitives + 1);
            for (std::size_t k = 0; k < boundary.size(); ++k) {
                Index nearest = 0;
                (surface.rowwise() - nodes.row(boundary[k]))
                    .rowwise()
                    .squaredNorm()
                    .minCoeff(&nearest);
                primitive_of[k] = collision.vertex_primitive(nearest);
                ++node_indptr(primitive_of[k] + 1);
            }
            for (Index p = 0; p < num_primitives; ++p)
                node_indptr(p + 1) += node_indptr(p);
            node_list.resize(static_cast<Index>(boundary.size()));
            VecXi fill = node_indptr.head(num_primitives);
            for (std::size_t k = 0; k < boundary.size(); ++k)
                node_list(fill(primitive_of[k])++) = boundary[k];
            if (spin != nullptr)
                use_vertices_as_nodes(*spin, velocity, translation);
            view.surface = &surface;
            view.faces = &faces;
            view.nodes = &nodes;
            view.face_indptr = &collision.face_primitives_indptr;
            view.face_list = &collision.face_primitives;
            view.node_indptr = &node_indptr;
            view.node_list = &node_list;
        }

        MatX3 velocities;

        void use_vertices_as_nodes(const Vec3& spin, const Vec3& velocity, const Vec3& centre)
        {
            const VecXi& primitive_of = creature_bake().collision.vertex_primitive;
            const Index num_primitives = node_indptr.size() - 1;
            nodes = surface;
            node_indptr = VecXi::Zero(num_primitives + 1);
            for (Index v = 0; v < primitive_of.size(); ++v)
                ++node_indptr(primitive_of(v) + 1);
            for (Index p = 0; p < num_primitives; ++p)
                node_indptr(p + 1) += node_indptr(p);
            node_list.resize(primitive_of.size());
            VecXi fill = node_indptr.head(num_primitives);
            for (Index v = 0; v < primitive_of.size(); ++v)
                node_list(fill(primitive_of(v))++) = static_cast<int>(v);
            velocities.resize(nodes.rows(), 3);
            for (Index v = 0; v < nodes.rows(); ++v)
                velocities.row(v)
                    = (velocity + spin.cross(Vec3(nodes.row(v).transpose()) - centre)).transpose();
            view.velocities = &velocities;
            view.nodes_are_vertices = true;
        }
    };

    bool boxes_overlap(const Box3& a, const Box3& b)
    {
        return !a.intersection(b).isEmpty();
    }

    Box3 face_box(const PlacedBody& body, int f)
    {
        Box3 box;
        for (int c = 0; c < 3; ++c)
            box.extend(Vec3(body.surface.row(body.faces(f, c)).transpose()));
        return box;
    }

    struct Reference {
        std::set<FacePair> intersecting;
        std::map<std::pair<int, int>, double> nearest; ///< (body, node) -> |signed distance|
    };

    /// Pair by pair, as the narrow phase did before it deduplicated (the definition it must
    /// cover).
    /// A node in front of a face further than the margin is a (speculative) candidate when it
    /// closes the distance within `lookahead` at the most it may approach (along the face's
    /// normal: its velocity relative to the closest point's, or either alone, where the other
    /// body stops), and is within the margin plus lookahead times its speed.
    bool speculative(const PlacedBody& x, int node, const PlacedBody& y, int f,
        const PointTriangleClosest& closest, const Vec3& unit, double signed_d, double margin,
        double lookahead)
    {
        if (x.view.velocities == nullptr || y.view.velocities == nullptr)
            return false;
        const Vec3 v = x.velocities.row(node).transpose();
        Vec3 v_point = Vec3::Zero();
        for (int c = 0; c < 3; ++c)
            v_point += closest.barycentric(c) * Vec3(y.velocities.row(y.faces(f, c)).transpose());
        const double approach
            = std::max({ 0.0, -unit.dot(v - v_point), -unit.dot(v), unit.dot(v_point) });
        return signed_d < margin + lookahead * v.norm() && signed_d < margin + lookahead * approach;
    }

    Reference reference(const std::vector<const PlacedBody*>& bodies,
        const std::vector<PrimitivePairRef>& pairs, double margin, double lookahead = 0.0)
    {
        Reference result;
        for (const PrimitivePairRef& pair : pairs) {
            const Box3 region(
                pair.region.min().array() - margin, pair.region.max().array() + margin);
            if (region.isEmpty())
                continue;
            const PlacedBody& a = *bodies[static_cast<std::size_t>(pair.body_a)];
            const PlacedBody& b = *bodies[static_cast<std::size_t>(pair.body_b)];
            const auto faces_in = [&](const PlacedBody& body, int p) {
                std::vector<int> out;
                const MedialCollisionData& collision = creature_bake().collision;
                for (int j = collision.face_primitives_indptr(p);
                     j < collision.face_primitives_indptr(p + 1); ++j)
                    if (boxes_overlap(face_box(body, collision.face_primitives(j)), region))
                        out.push_back(collision.face_primitives(j));
                return out;
            };
            const std::vector<int> faces_a = faces_in(a, pair.primitive_a);
            const std::vector<int> faces_b = faces_in(b, pair.primitive_b);
            const auto corner = [](const PlacedBody& body, int f, int c) {
                return Vec3(body.surface.row(body.faces(f, c)).transpose());
            };
            for (const int fa : faces_a)
                for (const int fb : faces_b) {
                    if (pair.body_a == pair.body_b) {
                        bool shared = false;
                        for (int u = 0; u < 3; ++u)
                            for (int v = 0; v < 3; ++v)
                                shared |= a.faces(fa, u) == b.faces(fb, v);
                        if (shared)
                            continue;
                    }
                    if (!boxes_overlap(face_box(a, fa), face_box(b, fb)))
                        continue;
                    if (triangles_intersect(corner(a, fa, 0), corner(a, fa, 1), corner(a, fa, 2),
                            corner(b, fb, 0), corner(b, fb, 1), corner(b, fb, 2))) {
                        FacePair key { pair.body_a, fa, pair.body_b, fb };
                        if (std::make_pair(pair.body_b, fb) < std::make_pair(pair.body_a, fa))
                            key = { pair.body_b, fb, pair.body_a, fa };
                        result.intersecting.insert(key);
                    }
                }
            const auto nodes_against = [&](const PlacedBody& x, int body_x, int prim_x,
                                           const PlacedBody& y, const std::vector<int>& faces_y) {
                for (int k = x.node_indptr(prim_x); k < x.node_indptr(prim_x + 1); ++k) {
                    const int node = x.node_list(k);
                    const Vec3 p = x.nodes.row(node).transpose();
                    if (!region.contains(p))
                        continue;
                    for (const int f : faces_y) {
                        const Box3 box = face_box(y, f);
                        const bool in_box
                            = Box3(box.min().array() - margin, box.max().array() + margin)
                                  .contains(p);
                        if (!in_box && lookahead == 0.0)
                            continue;
                        const PointTriangleClosest closest = point_triangle_closest(
                            p, corner(y, f, 0), corner(y, f, 1), corner(y, f, 2));
                        const Vec3 n = (corner(y, f, 1) - corner(y, f, 0))
                                           .cross(corner(y, f, 2) - corner(y, f, 0));
                        const double d = std::sqrt(closest.squared_distance);
                        const double signed_d = n.dot(p - closest.point) < 0.0 ? -d : d;
                        // Behind: within the face's box grown by the margin; in front: within
                        // the margin, or speculative.
                        if (signed_d < 0.0 ? !in_box
                                           : signed_d >= margin
                                    && !speculative(x, node, y, f, closest, n.normalized(),
                                        signed_d, margin, lookahead))
                            continue;
                        // Within one body a node behind a face counts within the margin only,
                        // and a vertex never pairs with a face it is a corner of.
                        if (&x == &y
                            && (d >= margin
                                || (x.view.nodes_are_vertices
                                    && (y.faces(f, 0) == node || y.faces(f, 1) == node
                                        || y.faces(f, 2) == node))))
                            continue;
                        auto [it, inserted] = result.nearest.emplace(
                            std::make_pair(body_x, node), std::abs(signed_d));
                        if (!inserted)
                            it->second = std::min(it->second, std::abs(signed_d));
                    }
                }
            };
            nodes_against(a, pair.body_a, pair.primitive_a, b, faces_b);
            nodes_against(b, pair.body_b, pair.primitive_b, a, faces_a);
        }
        return result;
    }

    /// Every pair of primitives with overlapping boxes, between the bodies and (one body's own,
    /// sharing no sphere) within body 0.
    std::vector<PrimitivePairRef> all_pairs(const PlacedBody& body0, const PlacedBody& body1)
    {
        const MedialCollisionData& collision = creature_bake().collision;
        const auto share_sphere = [&](int p, int q) {
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    if (collision.primitive_spheres(p, i) >= 0
                        && collision.primitive_spheres(p, i) == collision.primitive_spheres(q, j))
                        return true;
            return false;
        };
        std::vector<PrimitivePairRef> pairs;
        const int num_primitives = static_cast<int>(body0.primitive_boxes.size());
        for (int p = 0; p < num_primitives; ++p)
            for (int q = 0; q < num_primitives; ++q) {
                const Box3 cross = body0.primitive_boxes[static_cast<std::size_t>(p)].intersection(
                    body1.primitive_boxes[static_cast<std::size_t>(q)]);
                if (!cross.isEmpty())
                    pairs.push_back({ 0, p, 1, q, cross });
                const Box3 self = body0.primitive_boxes[static_cast<std::size_t>(p)].intersection(
                    body0.primitive_boxes[static_cast<std::size_t>(q)]);
                if (p < q && !self.isEmpty() && !share_sphere(p, q))
                    pairs.push_back({ 0, p, 0, q, self });
            }
        return pairs;
    }

    /// Runs the narrow phase on 1, 2 and 3 threads and checks it against the reference: every
    /// intersecting pair, each node's nearest triangle within the margin at least as near, only
    /// true intersections, candidates no further than `reach` and the same on every thread
    /// count. Returns the number of candidates.
    std::size_t check_against_reference(const PlacedBody& body0, const PlacedBody& body1,
        double margin, double lookahead, double reach)
    {
        const std::vector<const PlacedBody*> placed { &body0, &body1 };
        const std::vector<NarrowPhaseBody> views { body0.view, body1.view };
        const std::vector<PrimitivePairRef> pairs = all_pairs(body0, body1);
        const Reference expected = reference(placed, pairs, margin, lookahead);
        EXPECT_GT(expected.intersecting.size(), 20u);
        EXPECT_GT(expected.nearest.size(), 20u);

        NarrowPhase narrow;
        std::vector<FacePair> first_pairs;
        std::vector<NodeCandidate> first_candidates;
        for (const int threads : { 1, 2, 3 }) {
            tbb::task_arena arena(threads);
            arena.execute([&] { narrow.run(views, pairs, margin, lookahead); });
            const std::string what = "threads " + std::to_string(threads);
            const std::vector<FacePair>& found = narrow.intersecting();
            EXPECT_TRUE(std::is_sorted(found.begin(), found.end())) << what;
            EXPECT_TRUE(std::adjacent_find(found.begin(), found.end()) == found.end()) << what;
            for (const FacePair& pair : expected.intersecting)
                EXPECT_TRUE(std::binary_search(found.begin(), found.end(), pair))
                    << what << ": missed " << pair[0] << " " << pair[1] << " " << pair[2] << " "
                    << pair[3];
            for (const FacePair& pair : found) {
                const PlacedBody& a = *placed[static_cast<std::size_t>(pair[0])];
                const PlacedBody& b = *placed[static_cast<std::size_t>(pair[2])];
                const auto corner = [](const PlacedBody& body, int f, int c) {
                    return Vec3(body.surface.row(body.faces(f, c)).transpose());
                };
                EXPECT_TRUE(triangles_intersect(corner(a, pair[1], 0), corner(a, pair[1], 1),
                    corner(a, pair[1], 2), corner(b, pair[3], 0), corner(b, pair[3], 1),
                    corner(b, pair[3], 2)))
                    << what;
            }
            EXPECT_GE(narrow.triangle_tests(), static_cast<long>(found.size())) << what;

            const std::vector<NodeCandidate>& candidates = narrow.candidates();
            std::map<std::pair<int, int>, const NodeCandidate*> by_node;
            for (const NodeCandidate& c : candidates) {
                EXPECT_TRUE(by_node.emplace(std::make_pair(c.body, c.node), &c).second)
                    << what << ": node " << c.node << " twice";
                EXPECT_LT(c.distance, reach) << what;
                // The candidate's distance is that of its closest point.
                const Vec3 x
                    = placed[static_cast<std::size_t>(c.body)]->nodes.row(c.node).transpose();
                EXPECT_NEAR((x - c.closest).norm(), std::abs(c.distance), 1e-12) << what;
                // Its plane distance is the node's from the triangle's plane: no further than
                // the closest point, and on the same side.
                EXPECT_NEAR(c.normal.dot(x - c.closest), c.plane, 1e-12) << what;
                EXPECT_LE(std::abs(c.plane), std::abs(c.distance) + 1e-12) << what;
                EXPECT_GE(c.plane * c.distance, 0.0) << what;
            }
            for (const auto& [node, distance] : expected.nearest) {
                const auto it = by_node.find(node);
                if (it == by_node.end()) {
                    ADD_FAILURE() << what << ": no candidate for node " << node.second;
                    continue;
                }
                EXPECT_LE(std::abs(it->second->distance), distance + 1e-15) << what;
            }
            if (threads == 1) {
                first_pairs = found;
                first_candidates = candidates;
                continue;
            }
            EXPECT_EQ(found, first_pairs) << what;
            EXPECT_EQ(candidates.size(), first_candidates.size()) << what;
            for (std::size_t k = 0; k < std::min(candidates.size(), first_candidates.size()); ++k) {
                EXPECT_EQ(candidates[k].node, first_candidates[k].node) << what;
                EXPECT_EQ(candidates[k].face, first_candidates[k].face) << what;
                EXPECT_EQ(candidates[k].distance, first_candidates[k].distance) << what;
            }
        }
        // No pairs: nothing.
        narrow.run(views, {}, margin, lookahead);
        EXPECT_TRUE(narrow.intersecting().empty());
        EXPECT_TRUE(narrow.candidates().empty());
        EXPECT_EQ(narrow.triangle_tests(), 0);
        return first_candidates.size();
    }

    TEST(NarrowPhase, CoversThePairByPairReferenceAndIndependentOfThreads)
    {
        const PlacedBody body0(Mat3::Identity(), Vec3::Zero());
        const PlacedBody body1(
            Eigen::AngleAxisd(0.5, Vec3::UnitY()).toRotationMatrix(), Vec3(0.05, 0.4, 0.02));
        const double margin = 0.013;
        check_against_reference(body0, body1, margin, 0.0, margin);
    }

    // The same with the surface vertices as nodes, as in a run, and the bodies spinning towards
    // each other with a lookahead: the search for speculative contacts, bounded by each face's
    // and each grid column's motion, finds every node's nearest triangle within the margin or
    // within reach of its approach (the reference applies the rule to every face of each pair),
    // and more candidates come in than at rest.
    TEST(NarrowPhase, MovingBodiesFindEverySpeculativeContact)
    {
        const Mat3 turn = Eigen::AngleAxisd(0.5, Vec3::UnitY()).toRotationMatrix();
        const Vec3 at(0.05, 0.4, 0.02);
        const Vec3 spin0(0.0, 0.0, 2.0), spin1(1.0, -3.0, 0.5);
        const Vec3 none = Vec3::Zero();
        const PlacedBody still0(Mat3::Identity(), Vec3::Zero(), &none, Vec3::Zero());
        const PlacedBody still1(turn, at, &none, Vec3::Zero());
        const double margin = 0.013;
        const PlacedBody body0(Mat3::Identity(), Vec3::Zero(), &spin0, Vec3(0.0, 1.6, 0.0));
        const PlacedBody body1(turn, at, &spin1, Vec3(0.0, -1.6, 0.0));
        const double lookahead = 0.04;
        // Speeds: at most 1.6 m/s plus the spin times the creature's size (about 1 m).
        const double fastest = 2.0 * (1.6 + 3.2 * 1.0);
        const std::size_t at_rest = check_against_reference(still0, still1, margin, 0.0, margin);
        const std::size_t moving = check_against_reference(
            body0, body1, margin, lookahead, margin + lookahead * fastest);
        EXPECT_GT(moving, at_rest);
    }

    // Two bodies falling together, the one above the other (no approach at the start
    // velocities): the lower one may land and stop during the step, so the upper one's nodes
    // within reach of their own speed are candidates too (docs/method.md, "Speculative
    // contacts"), more than with both at rest.
    TEST(NarrowPhase, BodiesFallingTogetherAreCandidatesWithinTheirOwnReach)
    {
        const Mat3 turn = Eigen::AngleAxisd(0.5, Vec3::UnitY()).toRotationMatrix();
        const Vec3 at(0.05, 0.4, 0.02);
        const Vec3 none = Vec3::Zero();
        const Vec3 fall(0.0, -1.6, 0.0);
        const double margin = 0.013;
        const double lookahead = 0.04;
        const PlacedBody still0(Mat3::Identity(), Vec3::Zero(), &none, Vec3::Zero());
        const PlacedBody still1(turn, at, &none, Vec3::Zero());
        const PlacedBody falling0(Mat3::Identity(), Vec3::Zero(), &none, fall);
        const PlacedBody falling1(turn, at, &none, fall);
        const std::size_t at_rest = check_against_reference(still0, still1, margin, 0.0, margin);
        const std::size_t falling = check_against_reference(
            falling0, falling1, margin, lookahead, margin + lookahead * 2.0 * fall.norm());
        EXPECT_GT(falling, at_rest);
    }

    // One body falling (every node at the same velocity) has the self candidates it has at
    // rest: within one body the speculative reach is the approach at the start velocities,
    // never a part stopping while another goes on (docs/method.md, "Speculative contacts").
    // With the stop, every vertex in front of its own faces within its fall's reach was one.
    TEST(NarrowPhase, AFallingBodyHasTheSelfCandidatesItHasAtRest)
    {
        const Vec3 none = Vec3::Zero();
        const PlacedBody still(Mat3::Identity(), Vec3::Zero(), &none, Vec3::Zero());
        const PlacedBody falling(Mat3::Identity(), Vec3::Zero(), &none, Vec3(0.0, -3.0, 0.0));
        std::vector<PrimitivePairRef> pairs;
        for (const PrimitivePairRef& pair : all_pairs(still, still))
            if (pair.body_a == 0 && pair.body_b == 0)
                pairs.push_back(pair);
        ASSERT_GT(pairs.size(), 10u);
        const double margin = 0.013;
        const double lookahead = 0.04;
        NarrowPhase at_rest;
        at_rest.run({ still.view }, pairs, margin, lookahead);
        NarrowPhase in_fall;
        in_fall.run({ falling.view }, pairs, margin, lookahead);
        const std::vector<NodeCandidate>& expected = at_rest.candidates();
        const std::vector<NodeCandidate>& found = in_fall.candidates();
        EXPECT_GT(expected.size(), 0u);
        ASSERT_EQ(found.size(), expected.size());
        for (std::size_t k = 0; k < found.size(); ++k) {
            EXPECT_EQ(found[k].node, expected[k].node);
            EXPECT_EQ(found[k].face, expected[k].face);
            EXPECT_EQ(found[k].distance, expected[k].distance);
            EXPECT_LT(std::abs(found[k].distance), margin);
        }
    }

} // namespace
} // namespace mat

namespace mat {
namespace {

    /// The edge-edge rule of docs/method.md ("Edge contacts") for edge (a0, a1) of body `a`
    /// against edge (b0, b1) of body `b`, applied from scratch: closest points inside both,
    /// two sharp edges, the gap along the lines' normal turned by the outward directions, in
    /// front within reach of the approach and in both Voronoi regions, or crossed within the
    /// margin through a face.
    struct EdgeRule {
        const PlacedBody& a;
        const PlacedBody& b;
        const SurfaceEdges& edges_a;
        const SurfaceEdges& edges_b;
        double margin = 0.0;
        double lookahead = 0.0;
        double other_motion = 0.0; ///< body b's motion bound in the step
        double sharp_degrees = 20.0;

        Vec3 x(const PlacedBody& body, int v) const { return body.surface.row(v).transpose(); }
        Vec3 v(const PlacedBody& body, int i) const
        {
            return body.velocities.rows() > 0 ? Vec3(body.velocities.row(i).transpose())
                                              : Vec3::Zero();
        }
        Vec3 outward(const PlacedBody& body, const std::array<int, 2>& faces) const
        {
            Vec3 sum = Vec3::Zero();
            for (const int f : faces) {
                const Vec3 n = (x(body, body.faces(f, 1)) - x(body, body.faces(f, 0)))
                                   .cross(x(body, body.faces(f, 2)) - x(body, body.faces(f, 0)));
                sum += n.normalized();
            }
            return sum;
        }
        /// Whether d leaves each face of the edge across the edge.
        bool region(const PlacedBody& body, const std::array<int, 2>& ends,
            const std::array<int, 2>& faces, const Vec3& d) const
        {
            const Vec3 along = x(body, ends[1]) - x(body, ends[0]);
            for (const int f : faces)
                for (int c = 0; c < 3; ++c) {
                    const int w = body.faces(f, c);
                    if (w == ends[0] || w == ends[1])
                        continue;
                    Vec3 across = x(body, ends[0]) - x(body, w);
                    across -= across.dot(along) / along.squaredNorm() * along;
                    if (d.dot(across) < 0.0)
                        return false;
                }
            return true;
        }
        /// Convex, with its faces' normals at least sharp_degrees apart.
        bool sharp(const PlacedBody& body, const std::array<int, 2>& ends,
            const std::array<int, 2>& faces) const
        {
            const auto normal = [&](int f) {
                return (x(body, body.faces(f, 1)) - x(body, body.faces(f, 0)))
                    .cross(x(body, body.faces(f, 2)) - x(body, body.faces(f, 0)))
                    .normalized();
            };
            int third = -1;
            for (int c = 0; c < 3; ++c)
                if (body.faces(faces[1], c) != ends[0] && body.faces(faces[1], c) != ends[1])
                    third = body.faces(faces[1], c);
            return normal(faces[0]).dot(x(body, third) - x(body, ends[0])) < 0.0
                && normal(faces[0]).dot(normal(faces[1])) <= std::cos(sharp_degrees * M_PI / 180.0);
        }
        bool through(const PlacedBody& p, const std::array<int, 2>& ends, const PlacedBody& q,
            const std::array<int, 2>& faces) const
        {
            for (const int f : faces)
                if (segment_triangle_intersect(x(p, ends[0]), x(p, ends[1]), x(q, q.faces(f, 0)),
                        x(q, q.faces(f, 1)), x(q, q.faces(f, 2))))
                    return true;
            return false;
        }
        /// The signed gap if the pair qualifies (in front: within the margin plus the lookahead
        /// times the edge's speed plus the other body's motion bound, as the search).
        std::optional<double> gap(int ea, int eb) const
        {
            const auto& ia = edges_a.vertices[static_cast<std::size_t>(ea)];
            const auto& ib = edges_b.vertices[static_cast<std::size_t>(eb)];
            const double reach = margin
                + lookahead * std::max(v(a, ia[0]).norm(), v(a, ia[1]).norm()) + other_motion;
            // Two sharp edges only (these placements are rigid: sharp as at rest).
            if (!(sharp(a, ia, edges_a.faces[static_cast<std::size_t>(ea)])
                    && sharp(b, ib, edges_b.faces[static_cast<std::size_t>(eb)])))
                return std::nullopt;
            const Vec3 a0 = x(a, ia[0]), a1 = x(a, ia[1]), b0 = x(b, ib[0]), b1 = x(b, ib[1]);
            const Vec3 cross = (a1 - a0).cross(b1 - b0);
            if (!(cross.norm() > 1e-3 * (a1 - a0).norm() * (b1 - b0).norm()))
                return std::nullopt;
            const SegmentSegmentClosest c = segment_segment_closest(a0, a1, b0, b1);
            if (!(c.s > 1e-6 && c.s < 1.0 - 1e-6 && c.t > 1e-6 && c.t < 1.0 - 1e-6))
                return std::nullopt;
            Vec3 n = cross.normalized();
            const Vec3 turn = outward(b, edges_b.faces[static_cast<std::size_t>(eb)])
                - outward(a, edges_a.faces[static_cast<std::size_t>(ea)]);
            if (n.dot(turn) < 0.0)
                n = -n;
            const Vec3 d = (a0 + c.s * (a1 - a0)) - (b0 + c.t * (b1 - b0));
            const double g = n.dot(d);
            if (g < 0.0) {
                if (-g > margin
                    || !(through(a, ia, b, edges_b.faces[static_cast<std::size_t>(eb)])
                        || through(b, ib, a, edges_a.faces[static_cast<std::size_t>(ea)])))
                    return std::nullopt;
                return g;
            }
            // In front: each in the other's Voronoi region.
            if (!(region(b, ib, edges_b.faces[static_cast<std::size_t>(eb)], d)
                    && region(a, ia, edges_a.faces[static_cast<std::size_t>(ea)], -d)))
                return std::nullopt;
            const Vec3 va = (1.0 - c.s) * v(a, ia[0]) + c.s * v(a, ia[1]);
            const Vec3 vb = (1.0 - c.t) * v(b, ib[0]) + c.t * v(b, ib[1]);
            const double approach = std::max({ 0.0, -n.dot(va - vb), -n.dot(va), n.dot(vb) });
            if (g >= margin && (g >= reach || g >= margin + lookahead * approach))
                return std::nullopt;
            return g;
        }
    };

    // Edge contacts between two creatures (surface vertices as nodes, as in a run), at rest and
    // spinning towards each other with a lookahead, with the default sharp angle and with every
    // convex edge sharp (many more pairs in front): every candidate satisfies the rule of
    // docs/method.md (recomputed here from scratch), each edge has one, the same on 1, 2 and 3
    // threads; and no edge of the other body that the rule takes is nearer to a candidate's
    // edge than its candidate (the search's bounds drop nothing it needs).
    TEST(NarrowPhase, EdgeCandidatesFollowTheRuleAndAreTheNearest)
    {
        const Mat3 turn = Eigen::AngleAxisd(0.5, Vec3::UnitY()).toRotationMatrix();
        const Vec3 at(0.05, 0.4, 0.02);
        const double margin = 0.013;
        for (const double sharp : { NarrowPhase::default_sharp_edge_degrees, 0.0 })
            for (const bool moving : { false, true }) {
                const Vec3 spin0 = moving ? Vec3(0.0, 0.0, 2.0) : Vec3::Zero();
                const Vec3 spin1 = moving ? Vec3(1.0, -3.0, 0.5) : Vec3::Zero();
                const double lookahead = moving ? 0.04 : 0.0;
                const PlacedBody body0(Mat3::Identity(), Vec3::Zero(), &spin0,
                    moving ? Vec3(0.0, 1.6, 0.0) : Vec3::Zero());
                const PlacedBody body1(
                    turn, at, &spin1, moving ? Vec3(0.0, -1.6, 0.0) : Vec3::Zero());
                // Each body's motion bound in the step, as a run sets it: the lookahead times its
                // fastest vertex; its primitives grow by it (as the collision world's bounds do),
                // and every pair of the two bodies' primitives whose grown boxes overlap goes on.
                std::vector<NarrowPhaseBody> views { body0.view, body1.view };
                for (std::size_t b = 0; b < 2; ++b) {
                    const PlacedBody& body = b == 0 ? body0 : body1;
                    views[b].motion = lookahead * body.velocities.rowwise().norm().maxCoeff();
                }
                const auto grown_box = [](const Box3& box, double by) {
                    return Box3(box.min().array() - by, box.max().array() + by);
                };
                std::vector<PrimitivePairRef> pairs;
                for (int p = 0; p < static_cast<int>(body0.primitive_boxes.size()); ++p)
                    for (int q = 0; q < static_cast<int>(body1.primitive_boxes.size()); ++q) {
                        const Box3 cross
                            = grown_box(
                                body0.primitive_boxes[static_cast<std::size_t>(p)], views[0].motion)
                                  .intersection(
                                      grown_box(body1.primitive_boxes[static_cast<std::size_t>(q)],
                                          views[1].motion));
                        if (!cross.isEmpty())
                            pairs.push_back({ 0, p, 1, q, cross });
                    }
                NarrowPhase narrow;
                narrow.set_edge_contacts(true, sharp);
                std::vector<EdgeCandidate> first;
                for (const int threads : { 1, 2, 3 }) {
                    tbb::task_arena arena(threads);
                    arena.execute([&] { narrow.run(views, pairs, margin, lookahead); });
                    const std::vector<EdgeCandidate>& found = narrow.edge_candidates();
                    const std::string what = std::string(moving ? "moving" : "at rest")
                        + ", sharp at " + std::to_string(sharp) + " degrees, threads "
                        + std::to_string(threads);
                    if (threads > 1) {
                        ASSERT_EQ(found.size(), first.size()) << what;
                        for (std::size_t k = 0; k < found.size(); ++k) {
                            EXPECT_EQ(found[k].edge, first[k].edge) << what;
                            EXPECT_EQ(found[k].other_edge, first[k].other_edge) << what;
                            EXPECT_EQ(found[k].distance, first[k].distance) << what;
                        }
                        continue;
                    }
                    first = found;
                    // At 20 degrees these two smooth creatures have few sharp edges facing
                    // each other (none here); with every convex edge sharp, many.
                    if (sharp == 0.0) {
                        EXPECT_GT(found.size(), 10u) << what;
                    }
                    const EdgeRule rule { body0, body1, narrow.edges(0), narrow.edges(1), margin,
                        lookahead, views[1].motion, sharp };
                    const double reach = margin + views[0].motion + views[1].motion;
                    for (std::size_t k = 0; k < found.size(); ++k) {
                        const EdgeCandidate& c = found[k];
                        ASSERT_EQ(c.body, 0) << what;
                        ASSERT_EQ(c.other_body, 1) << what;
                        if (k > 0) {
                            EXPECT_LT(found[k - 1].edge, c.edge) << what;
                        }
                        const std::optional<double> gap = rule.gap(c.edge, c.other_edge);
                        ASSERT_TRUE(gap.has_value()) << what << ": edge " << c.edge;
                        EXPECT_NEAR(*gap, c.distance, 1e-12) << what;
                    }
                    // Every edge of body 0 that the rule pairs with an edge of body 1 has a
                    // candidate, and none nearer than it (every face of these placements lies in
                    // the regions of its primitives' pairs).
                    std::map<int, double> nearest;
                    const SurfaceEdges& e0 = narrow.edges(0);
                    const SurfaceEdges& e1 = narrow.edges(1);
                    const auto edge_box
                        = [](const PlacedBody& body, const std::array<int, 2>& ends) {
                              const Vec3 p = body.surface.row(ends[0]).transpose();
                              const Vec3 q = body.surface.row(ends[1]).transpose();
                              return Box3(p.cwiseMin(q), p.cwiseMax(q));
                          };
                    for (int ea = 0; ea < static_cast<int>(e0.vertices.size()); ++ea) {
                        const Box3 box = edge_box(body0, e0.vertices[static_cast<std::size_t>(ea)]);
                        const Box3 grown(box.min().array() - reach, box.max().array() + reach);
                        for (int eb = 0; eb < static_cast<int>(e1.vertices.size()); ++eb) {
                            if (!grown.intersects(
                                    edge_box(body1, e1.vertices[static_cast<std::size_t>(eb)])))
                                continue;
                            const std::optional<double> gap = rule.gap(ea, eb);
                            if (!gap.has_value())
                                continue;
                            const auto it = nearest.find(ea);
                            if (it == nearest.end() || std::abs(*gap) < it->second)
                                nearest[ea] = std::abs(*gap);
                        }
                    }
                    std::map<int, double> by_edge;
                    for (const EdgeCandidate& c : found)
                        by_edge[c.edge] = std::abs(c.distance);
                    for (const auto& [edge, distance] : nearest) {
                        const auto it = by_edge.find(edge);
                        if (it == by_edge.end()) {
                            ADD_FAILURE() << what << ": no candidate for edge " << edge;
                            continue;
                        }
                        EXPECT_LE(it->second, distance + 1e-12) << what << ": edge " << edge;
                    }
                    EXPECT_EQ(by_edge.size(), nearest.size()) << what;
                }
            }
    }

} // namespace
} // namespace mat
