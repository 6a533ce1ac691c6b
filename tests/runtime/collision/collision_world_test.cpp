// The collision world on two creatures (the creature sample, coarsely baked) pressed into each
// other: its intersecting triangle pairs against the exhaustive ground truth, the hash against
// testing every primitive pair, results independent of the thread count, and no allocation
// per step once warm.

#include "runtime/collision/collision_world.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <string>

#include <tbb/task_arena.h>

#include "runtime/measures/ground_truth.hpp"
#include "tests/support/allocation_counter.hpp"
#include "tests/support/sample_bake.hpp"

namespace mat {
namespace {

    const BakeData& creature_bake()
    {
        return test::sample_bake("creature", 0.05);
    }

    /// The two bodies' node positions: body 0 at rest, body 1 the rest shape bent (a smooth
    /// non-affine map, so that the bounds matter); body 1 is placed above body 0, overlapping.
    struct TwoCreatures {
        MatX3 nodes0, nodes1;
        std::vector<CollisionBodyState> states;

        explicit TwoCreatures(double lift = 0.5)
        {
            const MatX3& rest = creature_bake().tet_mesh.positions;
            nodes0 = rest;
            nodes1 = rest;
            for (Index i = 0; i < rest.rows(); ++i) {
                const double x = rest(i, 0);
                nodes1(i, 1) += 0.15 * x * x; // bend
                nodes1(i, 2) += 0.05 * std::sin(4.0 * x);
            }
            states.resize(2);
            states[0].nodes = &nodes0;
            states[1].nodes = &nodes1;
            states[1].rotation = Eigen::AngleAxisd(0.5, Vec3::UnitY()).toRotationMatrix();
            states[1].translation = Vec3(0.05, lift, 0.02);
        }
    };

    CollisionWorld make_world(
        const CollisionSettings& settings, const CollisionVariants& variants = {})
    {
        CollisionWorld world(settings);
        world.set_variants_for_comparison(variants);
        world.add_body(BodyModel::from_bake(creature_bake()));
        world.add_body(BodyModel::from_bake(creature_bake()));
        return world;
    }

    void expect_same_contacts(const BodyContacts& a, const BodyContacts& b, const std::string& what)
    {
        ASSERT_EQ(a.size(), b.size()) << what;
        // Bitwise: the same candidates in the same order.
        EXPECT_EQ(a.offsets, b.offsets) << what;
        EXPECT_TRUE(a.terms == b.terms) << what;
        for (Index c = 0; c < a.size(); ++c) {
            EXPECT_EQ(a.planes[c].point, b.planes[c].point) << what;
            EXPECT_EQ(a.planes[c].normal, b.planes[c].normal) << what;
        }
    }

    TEST(CollisionWorld, FindsEveryIntersectingTrianglePairOfTheGroundTruth)
    {
        for (const double lift : { 0.4, 0.6 }) {
            CollisionSettings settings;
            settings.self = false;
            CollisionWorld world = make_world(settings);
            TwoCreatures scene(lift);
            world.detect(scene.states);
            std::vector<SurfaceMesh> surfaces(2);
            for (int b = 0; b < 2; ++b) {
                surfaces[b].positions = world.world_surface(b);
                surfaces[b].faces = world.faces(b);
            }
            GroundTruthOptions options;
            options.self_pairs = false; // the rest surfaces have none; self is tested below
            const std::vector<TrianglePair> truth = intersecting_triangle_pairs(surfaces, options);
            std::vector<TrianglePair> found;
            for (const FacePair& pair : world.intersecting_pairs())
                if (pair[0] != pair[2])
                    found.push_back(pair);
            EXPECT_GT(truth.size(), 20u) << "lift " << lift;
            EXPECT_EQ(found, truth) << "lift " << lift;
            const CollisionReport& report = world.last_report();
            EXPECT_EQ(report.intersecting_triangles, static_cast<int>(truth.size()));
            EXPECT_GT(report.contacts, 0);
            EXPECT_GT(report.max_penetration, 0.0);
            EXPECT_LE(report.primitive_pairs, report.primitive_candidates);
            EXPECT_GE(report.triangle_tests, report.intersecting_triangles);
            // Far apart: nothing.
            TwoCreatures apart(3.0);
            world.detect(apart.states);
            EXPECT_EQ(world.last_report().primitive_candidates, 0);
            EXPECT_EQ(world.last_report().contacts, 0);
        }
    }

    TEST(CollisionWorld, HashGivesTheSameResultAsTestingAllPrimitivePairs)
    {
        CollisionSettings settings;
        settings.self = true;
        CollisionWorld hashed = make_world(settings);
        CollisionVariants all_pairs;
        all_pairs.all_pairs = true;
        CollisionWorld all = make_world(settings, all_pairs);
        TwoCreatures scene;
        const auto contacts = hashed.detect(scene.states);
        const auto reference = all.detect(scene.states);
        expect_same_contacts(contacts, reference, "hash vs all pairs");
        EXPECT_EQ(hashed.intersecting_pairs(), all.intersecting_pairs());
        EXPECT_EQ(hashed.last_report().primitive_pairs, all.last_report().primitive_pairs);
        EXPECT_LT(
            hashed.last_report().primitive_candidates, all.last_report().primitive_candidates / 4);
    }

    // The intersecting triangle pairs are a measurement: without them (a run that reports
    // none) the contacts are the same to the bit, and the pairs and their count are empty.
    TEST(CollisionWorld, TrianglePairsOffLeaveTheContactsAsTheyAre)
    {
        CollisionSettings settings;
        settings.self = true;
        CollisionWorld with = make_world(settings);
        CollisionWorld without = make_world(settings);
        without.set_triangle_pairs(false);
        TwoCreatures scene;
        const BodyContacts contacts = with.detect(scene.states);
        const BodyContacts reference = without.detect(scene.states);
        expect_same_contacts(contacts, reference, "triangle pairs on vs off");
        EXPECT_GT(with.intersecting_pairs().size(), 20u);
        EXPECT_TRUE(without.intersecting_pairs().empty());
        EXPECT_EQ(without.last_report().intersecting_triangles, 0);
        EXPECT_EQ(without.last_report().triangle_tests, 0);
        EXPECT_EQ(without.last_report().contacts, with.last_report().contacts);
        without.set_triangle_pairs(true);
        without.detect(scene.states);
        EXPECT_EQ(without.intersecting_pairs(), with.intersecting_pairs());
    }

    TEST(CollisionWorld, ResultIndependentOfTheThreadCount)
    {
        for (const bool self : { false, true }) {
            CollisionSettings settings;
            settings.self = self;
            CollisionWorld world = make_world(settings);
            TwoCreatures scene;
            BodyContacts reference;
            std::vector<FacePair> reference_pairs;
            CollisionReport reference_report;
            for (const int threads : { 1, 2, 3 }) {
                tbb::task_arena arena(threads);
                BodyContacts contacts;
                arena.execute([&] { contacts = world.detect(scene.states); });
                const std::string what = "threads " + std::to_string(threads);
                if (threads == 1) {
                    reference = contacts;
                    reference_pairs = world.intersecting_pairs();
                    reference_report = world.last_report();
                    EXPECT_GT(reference_report.contacts, 10);
                    EXPECT_GT(reference_report.primitive_pairs, 10);
                    continue;
                }
                expect_same_contacts(contacts, reference, what);
                EXPECT_EQ(world.intersecting_pairs(), reference_pairs) << what;
                const CollisionReport& report = world.last_report();
                EXPECT_EQ(report.primitive_pairs, reference_report.primitive_pairs) << what;
                EXPECT_EQ(report.triangle_tests, reference_report.triangle_tests) << what;
                EXPECT_EQ(report.contacts, reference_report.contacts) << what;
                EXPECT_EQ(report.max_penetration, reference_report.max_penetration) << what;
            }
        }
    }

    TEST(CollisionWorld, StaticBodiesGetNoContactsAndStaticPairsAreSkipped)
    {
        CollisionWorld world = make_world({});
        TwoCreatures scene;
        scene.states[0].is_static = true;
        const auto& contacts = world.detect(scene.states);
        EXPECT_EQ(contacts.count_for(0), 0);
        EXPECT_GT(contacts.count_for(1), 0);
        scene.states[1].is_static = true;
        world.detect(scene.states);
        EXPECT_EQ(world.last_report().primitive_pairs, 0);
        EXPECT_EQ(world.last_report().contacts, 0);
    }

    // A surface vertex more than the margin behind its nearest face of another deformable body
    // has passed through that face and gets no contact (docs/method.md, "Deep vertices"); every
    // other candidate gets its contact, keyed by its vertex. The two creatures (both dynamic)
    // overlap deeply here.
    TEST(CollisionWorld, VerticesDeeperThanTheMarginBehindAnotherBodyGetNoContact)
    {
        CollisionWorld world = make_world({});
        TwoCreatures scene(0.3);
        const BodyContacts& contacts = world.detect(scene.states);
        std::set<std::pair<int, int>> keyed;
        for (Index c = 0; c < contacts.size(); ++c)
            keyed.insert({ contacts.first_body(c), contacts.keys[static_cast<std::size_t>(c)] });
        int deep = 0;
        int shallow = 0;
        for (const NodeCandidate& hit : world.node_candidates()) {
            const bool is_deep = hit.body != hit.other_body && hit.distance < -world.margin();
            deep += is_deep ? 1 : 0;
            shallow += is_deep ? 0 : 1;
            EXPECT_EQ(keyed.count({ hit.body, hit.node }), is_deep ? 0U : 1U)
                << "body " << hit.body << " vertex " << hit.node << " at " << hit.distance;
        }
        EXPECT_GT(deep, 0) << "the scene no longer has deep vertices";
        EXPECT_GT(shallow, 0);
        EXPECT_EQ(world.last_report().deep_vertices, deep);
    }

    /// Whether every surface vertex of body b lies in its primitive's enlarged sphere at its
    /// parameter (the bounds' contract), the body's solver coordinates being `surface`.
    int vertices_outside(const CollisionWorld& world, const MatX3& surface)
    {
        const MedialCollisionData& collision = creature_bake().collision;
        const MedialBounds& bounds = world.bounds(1);
        int outside = 0;
        for (Index v = 0; v < surface.rows(); ++v) {
            const int p = collision.vertex_primitive(v);
            Vec3 center = Vec3::Zero();
            double radius = 0.0;
            for (int i = 0; i < bounds.counts()(p); ++i) {
                const MedialSphere sphere = bounds.sphere(p, i);
                center += collision.vertex_parameter(v, i) * sphere.center;
                radius += collision.vertex_parameter(v, i) * sphere.radius;
            }
            outside += (surface.row(v).transpose() - center).norm() > radius + 1e-12;
        }
        return outside;
    }

    TEST(CollisionWorld, BoundsFromThePositionsByDefaultFromQOnRequest)
    {
        // Body 1 deformed through the reduced coordinates (nodes = X + B q, q random), placed
        // into body 0; body 0 at rest (q = 0).
        const BakeData& bake = creature_bake();
        std::mt19937 rng(11);
        std::normal_distribution<double> normal(0.0, 0.01);
        MatX q0 = MatX::Zero(bake.num_columns(), 3);
        MatX q1(bake.num_columns(), 3);
        for (Index i = 0; i < q1.rows(); ++i)
            for (int d = 0; d < 3; ++d)
                q1(i, d) = normal(rng);
        MatX3 nodes0 = bake.tet_mesh.positions;
        MatX3 nodes1 = bake.tet_mesh.positions + bake.basis * q1;
        std::vector<CollisionBodyState> states(2);
        states[0].nodes = &nodes0;
        states[0].q = &q0;
        states[1].nodes = &nodes1;
        states[1].q = &q1;
        const Vec3 translation(0.05, 0.45, 0.02);
        states[1].translation = translation;

        CollisionSettings settings;
        settings.self = false;
        CollisionWorld exact = make_world(settings);
        CollisionVariants handle_bound;
        handle_bound.bounds_from_positions = false;
        CollisionWorld from_q = make_world(settings, handle_bound);
        exact.detect(states);
        from_q.detect(states);

        std::vector<SurfaceMesh> surfaces(2);
        for (int b = 0; b < 2; ++b) {
            surfaces[b].positions = exact.world_surface(b);
            surfaces[b].faces = exact.faces(b);
        }
        GroundTruthOptions options;
        options.self_pairs = false;
        const std::vector<TrianglePair> truth = intersecting_triangle_pairs(surfaces, options);
        EXPECT_GT(truth.size(), 20u);
        EXPECT_EQ(exact.intersecting_pairs(), truth);
        EXPECT_EQ(from_q.intersecting_pairs(), truth);

        // Both enclose every vertex; the exact increments are the least that do, so no larger
        // than the bound's, and here much smaller.
        const MatX3 surface = exact.world_surface(1).rowwise() - translation.transpose();
        EXPECT_EQ(vertices_outside(exact, surface), 0);
        EXPECT_EQ(vertices_outside(from_q, surface), 0);
        const VecX& e = exact.bounds(1).increments();
        const VecX& b = from_q.bounds(1).increments();
        for (Index p = 0; p < e.size(); ++p)
            EXPECT_LE(e(p), b(p) + 1e-12) << "primitive " << p;
        EXPECT_LT(e.sum(), 0.5 * b.sum());
        EXPECT_GT(e.maxCoeff(), 0.0);
        EXPECT_LT(exact.last_report().primitive_pairs, from_q.last_report().primitive_pairs);
        // The sphere centers embedded in the tets agree with the medial basis.
        const MatX3 centers = bake.medial.centers + bake.medial_basis * q1;
        EXPECT_LE((exact.bounds(1).sphere_centers() - centers).cwiseAbs().maxCoeff(), 1e-9);

        // Lazy from the positions: centers moved, radii unchanged.
        settings.bounds = RadiusUpdate::lazy;
        CollisionWorld lazy = make_world(settings);
        states[0].q = states[1].q = nullptr;
        lazy.detect(states);
        EXPECT_EQ(lazy.bounds(1).increments().cwiseAbs().maxCoeff(), 0.0);
        EXPECT_LE((lazy.bounds(1).sphere_centers() - centers).cwiseAbs().maxCoeff(), 1e-9);
    }

    TEST(CollisionWorld, NoAllocationPerStepOnceWarm)
    {
        CollisionSettings settings;
        settings.self = true;
        CollisionWorld world = make_world(settings);
        TwoCreatures scene;
        tbb::task_arena arena(2);
        arena.execute([&] {
            for (int warm = 0; warm < 3; ++warm)
                world.detect(scene.states);
            const long before = test::allocation_count();
            for (int step = 0; step < 3; ++step)
                world.detect(scene.states);
            EXPECT_EQ(test::allocation_count() - before, 0);
        });
        EXPECT_GT(world.last_report().contacts, 0);
    }

} // namespace
} // namespace mat
