// The collision world on two creatures (the creature sample, coarsely baked) pressed into each
// other: its intersecting triangle pairs against the exhaustive ground truth, the hash against
// testing every primitive pair, results independent of the thread count, and no allocation
// per step once warm.

#include "runtime/collision/collision_world.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <tbb/task_arena.h>

#include "preprocess/bake/bake_pipeline.hpp"
#include "runtime/collision/ground_truth.hpp"
#include "tests/support/allocation_counter.hpp"

namespace mat {
namespace {

    const BakeData& creature_bake()
    {
        static const BakeData bake = [] {
            BakeOptions options;
            options.surface = std::string(MAT_SAMPLES_DIR) + "/creature/creature.obj";
            options.medial = std::string(MAT_SAMPLES_DIR) + "/creature/creature.ma";
            options.tet_size = 0.05;
            BakeReport report;
            return run_bake(options, report);
        }();
        return bake;
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

    CollisionWorld make_world(const CollisionSettings& settings)
    {
        CollisionWorld world(settings);
        world.add_body(creature_bake());
        world.add_body(creature_bake());
        return world;
    }

    void expect_same_contacts(const std::vector<std::vector<NodeContact>>& a,
        const std::vector<std::vector<NodeContact>>& b, const std::string& what)
    {
        ASSERT_EQ(a.size(), b.size()) << what;
        for (std::size_t body = 0; body < a.size(); ++body) {
            ASSERT_EQ(a[body].size(), b[body].size()) << what << ", body " << body;
            for (std::size_t k = 0; k < a[body].size(); ++k) {
                EXPECT_EQ(a[body][k].node, b[body][k].node) << what;
                // Bitwise: the same candidates merged in the same order.
                EXPECT_EQ(a[body][k].plane.point, b[body][k].plane.point) << what;
                EXPECT_EQ(a[body][k].plane.normal, b[body][k].plane.normal) << what;
            }
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
        settings.all_pairs = true;
        CollisionWorld all = make_world(settings);
        TwoCreatures scene;
        const auto contacts = hashed.detect(scene.states);
        const auto reference = all.detect(scene.states);
        expect_same_contacts(contacts, reference, "hash vs all pairs");
        EXPECT_EQ(hashed.intersecting_pairs(), all.intersecting_pairs());
        EXPECT_EQ(hashed.last_report().primitive_pairs, all.last_report().primitive_pairs);
        EXPECT_LT(
            hashed.last_report().primitive_candidates, all.last_report().primitive_candidates / 4);
    }

    TEST(CollisionWorld, ResultIndependentOfTheThreadCount)
    {
        for (const bool self : { false, true }) {
            CollisionSettings settings;
            settings.self = self;
            CollisionWorld world = make_world(settings);
            TwoCreatures scene;
            std::vector<std::vector<NodeContact>> reference;
            std::vector<FacePair> reference_pairs;
            CollisionReport reference_report;
            for (const int threads : { 1, 2, 3 }) {
                tbb::task_arena arena(threads);
                std::vector<std::vector<NodeContact>> contacts;
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
        EXPECT_TRUE(contacts[0].empty());
        EXPECT_FALSE(contacts[1].empty());
        scene.states[1].is_static = true;
        world.detect(scene.states);
        EXPECT_EQ(world.last_report().primitive_pairs, 0);
        EXPECT_EQ(world.last_report().contacts, 0);
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
