// Sleeping bodies and object-level collision culling: a body at rest on the ground falls asleep
// (not stepped, zero velocities, bounds kept); another body falling onto it wakes it and it then
// moves; a scene where nothing sleeps runs the same with sleeping on and off; pinned targets
// that start moving wake a sleeping body; the collision world finds the same contacts with and
// without object-level culling, and hashes no body whose box meets no other.

#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "formats/bake_io.hpp"
#include "runtime/collision/collision_world.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/scene/scene_bodies.hpp"
#include "runtime/simulation.hpp"
#include "tests/runtime/simulation_test_bake.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    using SleepingTest = test::ScratchDirTest;

    // The capsule sample: axis along x, radius 0.12 m; stiff and damped so that it settles fast.
    constexpr const char* material
        = R"("material": {"youngs_modulus": 1e6, "poisson_ratio": 0.3, "density": 1000})";

    std::string capsule(
        const std::string& name, const std::string& position, const std::string& extra = "")
    {
        return fmt::format(R"({{"name": "{}", "bake": "capsule.h5", "position": {}, {}{}}})", name,
            position, material, extra);
    }

    std::string scene_text(const std::string& solver, const std::string& objects)
    {
        return fmt::format(R"({{"time": {{"dt": 0.02, "frames": 10}},
            "solver": {{"collision": "bounded", "damping": 0.1, "sleep_steps": 10{}}},
            "objects": [{}],
            "colliders": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}}]}})",
            solver, objects);
    }

    TEST_F(SleepingTest, BodyAtRestFallsAsleepAndStaysPut)
    {
        test::write_capsule_bake(path("capsule.h5"));
        const Scene scene
            = read_scene(write_text("scene.json", scene_text("", capsule("rest", "[0, 0.12, 0]"))));
        Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
        const Body& body = simulation.bodies()[0];
        int steps = 0;
        while (!body.asleep && steps < 100) {
            simulation.step();
            ++steps;
        }
        // Settling takes some steps, then 10 slow ones: asleep well before 100.
        ASSERT_TRUE(body.asleep);
        EXPECT_GE(steps, 10);
        EXPECT_LT(steps, 60);
        EXPECT_EQ(simulation.num_sleeping(), 1);
        EXPECT_EQ(body.state.velocities.norm(), 0.0);
        const MatX3 positions = body.state.positions;
        const long solver_steps = body.solver->timings().steps;
        for (int s = 0; s < 20; ++s)
            simulation.step();
        EXPECT_TRUE(body.asleep);
        EXPECT_EQ(body.solver->timings().steps, solver_steps); // not stepped
        EXPECT_EQ((body.state.positions - positions).norm(), 0.0);
    }

    TEST_F(SleepingTest, FallingBodyWakesASleeperWhichThenMoves)
    {
        test::write_capsule_bake(path("capsule.h5"));
        // The dropped capsule falls 2.4 m (about 0.75 s, 37 steps) across the sleeper's middle.
        const Scene scene = read_scene(write_text("scene.json",
            scene_text("",
                capsule("bottom", "[0, 0.12, 0]") + ", "
                    + capsule("dropped", "[0, 2.6, 0]", R"(, "rotation_degrees": [0, 90, 0])"))));
        Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
        const Body& bottom = simulation.bodies()[0];
        const Body& dropped = simulation.bodies()[1];
        int slept_at = -1, woke_at = -1, first_contact = -1;
        MatX3 asleep_positions;
        for (int s = 1; s <= 120 && (woke_at < 0 || first_contact < 0); ++s) {
            simulation.step();
            if (first_contact < 0 && simulation.collision()->last_report().contacts > 0)
                first_contact = s;
            if (bottom.asleep && slept_at < 0) {
                slept_at = s;
                asleep_positions = bottom.state.positions;
            }
            if (slept_at > 0 && woke_at < 0 && !bottom.asleep)
                woke_at = s;
        }
        ASSERT_GT(slept_at, 0) << "the bottom capsule never fell asleep";
        ASSERT_GT(woke_at, slept_at) << "the bottom capsule was never woken";
        EXPECT_FALSE(dropped.asleep);
        // Woken in time to take part in the first contacts: their boxes (grown by the margin)
        // meet before or when the collision world finds them.
        ASSERT_GT(first_contact, 0);
        EXPECT_LE(woke_at, first_contact);
        for (int s = 0; s < 10; ++s)
            simulation.step();
        // Pressed by the dropped capsule, it moves (down into the ground's compliance and
        // sideways), a displacement far above the sleeping threshold's.
        const double moved
            = (bottom.state.positions - asleep_positions).rowwise().norm().maxCoeff();
        EXPECT_GT(moved, 1e-3);
    }

    TEST_F(SleepingTest, SleepingOnOrOffRunsTheSameWhenNothingSleeps)
    {
        test::write_capsule_bake(path("capsule.h5"));
        // Two capsules thrown at each other in the air: nothing is ever slow enough to sleep.
        const std::string objects = capsule("left", "[-0.5, 1.5, 0]", R"(, "velocity": [1, 1, 0])")
            + ", "
            + capsule("right", "[0.5, 1.6, 0.05]",
                R"(, "velocity": [-1, 1, 0], "angular_velocity": [0, 0, 2])");
        const Scene on = read_scene(write_text("on.json", scene_text("", objects)));
        const Scene off
            = read_scene(write_text("off.json", scene_text(R"(, "sleep_speed": 0)", objects)));
        Simulation a(on, load_bodies(on, SolverKind::semi_reduced));
        Simulation b(off, load_bodies(off, SolverKind::semi_reduced));
        int contacts = 0;
        for (int s = 0; s < 30; ++s) {
            a.step();
            b.step();
            contacts = std::max(contacts, a.collision()->last_report().contacts);
            ASSERT_EQ(a.num_sleeping(), 0);
        }
        EXPECT_GT(contacts, 0); // they did meet
        for (std::size_t i = 0; i < 2; ++i) {
            EXPECT_EQ(a.bodies()[i].state.positions, b.bodies()[i].state.positions);
            EXPECT_EQ(a.bodies()[i].state.velocities, b.bodies()[i].state.velocities);
        }
    }

    TEST_F(SleepingTest, MovingPinsWakeASleepingBody)
    {
        test::write_capsule_bake(path("capsule.h5"));
        // The pinned end stays until t = 1 s, then rises 0.2 m by t = 1.2 s.
        const std::string pins = R"(, "pins": [{"box": {"min": [0.2, -1, -1], "max": [1, 1, 1]},
            "motion": [{"time": 1, "translation": [0, 0, 0]},
                       {"time": 1.2, "translation": [0, 0.2, 0]}]}])";
        const Scene scene = read_scene(
            write_text("scene.json", scene_text("", capsule("pinned", "[0, 0.12, 0]", pins))));
        Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
        const Body& body = simulation.bodies()[0];
        bool slept = false;
        while (simulation.time() < 1.0 - 1e-9) {
            simulation.step();
            slept = slept || body.asleep;
        }
        ASSERT_TRUE(slept);
        ASSERT_TRUE(body.asleep);
        const double top = body.state.positions.col(1).maxCoeff();
        simulation.step(); // the pins move during this step
        EXPECT_FALSE(body.asleep);
        for (int s = 0; s < 9; ++s) {
            simulation.step();
            EXPECT_FALSE(body.asleep);
        }
        EXPECT_GT(body.state.positions.col(1).maxCoeff(), top + 0.1);
    }

    /// A body's placed node positions: rest rotated about z by `degrees`, then moved by `offset`.
    MatX3 placed(const BakeData& bake, const Vec3& offset, double degrees)
    {
        const Mat3 r = Eigen::AngleAxisd(degrees * M_PI / 180.0, Vec3::UnitZ()).toRotationMatrix();
        MatX3 x = bake.tet_mesh.positions;
        for (Index i = 0; i < x.rows(); ++i)
            x.row(i) = (r * x.row(i).transpose() + offset).transpose();
        return x;
    }

    TEST_F(SleepingTest, ObjectCullingFindsTheSameContactsAndSkipsFarBodies)
    {
        const BakeData bake = read_bake(test::write_capsule_bake(path("capsule.h5")));
        // Two capsules crossing with some overlap, a third one touching nothing, a fourth one
        // static and apart, a fifth static one under the first.
        const std::vector<MatX3> nodes = { placed(bake, Vec3(0, 0, 0), 0),
            placed(bake, Vec3(0.1, 0.2, 0.0), 80), placed(bake, Vec3(3, 0, 0), 30),
            placed(bake, Vec3(-3, 0, 0), 0), placed(bake, Vec3(0, -0.23, 0), 5) };
        std::vector<CollisionBodyState> states(nodes.size());
        for (std::size_t b = 0; b < nodes.size(); ++b) {
            states[b].nodes = &nodes[b];
            states[b].is_static = b >= 3;
        }
        CollisionSettings settings;
        settings.self = false;
        CollisionWorld culled(settings);
        CollisionWorld all(settings);
        CollisionVariants no_culling;
        no_culling.object_culling = false;
        all.set_variants_for_comparison(no_culling);
        const auto model = BodyModel::from_bake(bake);
        for (std::size_t b = 0; b < nodes.size(); ++b) {
            culled.add_body(model);
            all.add_body(model);
        }
        const auto contacts_culled = culled.detect(states);
        const auto contacts_all = all.detect(states);
        const CollisionReport r = culled.last_report();
        // 0-1, 0-4 and perhaps 1-4; bodies 2 and 3 are apart from all.
        EXPECT_GE(r.object_pairs, 2);
        EXPECT_LE(r.object_pairs, 3);
        EXPECT_EQ(r.hashed_bodies, 3);
        EXPECT_EQ(all.last_report().hashed_bodies, 5);
        EXPECT_GT(r.contacts, 0);
        EXPECT_EQ(r.contacts, all.last_report().contacts);
        EXPECT_EQ(r.primitive_pairs, all.last_report().primitive_pairs);
        EXPECT_LE(r.primitive_candidates, all.last_report().primitive_candidates);
        EXPECT_EQ(culled.intersecting_pairs(), all.intersecting_pairs());
        EXPECT_EQ(contacts_culled.offsets, contacts_all.offsets);
        EXPECT_TRUE(contacts_culled.terms == contacts_all.terms);
        EXPECT_EQ(contacts_culled.count_for(2), 0);

        // Reused bounds: nothing recomputed for the bodies that have not moved, same result.
        for (auto& state : states)
            state.reuse_bounds = true;
        states[0].reuse_bounds = false;
        const auto again = culled.detect(states);
        EXPECT_EQ(culled.last_report().updated_bodies, 1);
        EXPECT_EQ(culled.last_report().contacts, r.contacts);
        for (std::size_t b = 0; b < nodes.size(); ++b)
            EXPECT_EQ(
                again.count_for(static_cast<int>(b)), contacts_all.count_for(static_cast<int>(b)));
    }

} // namespace
} // namespace mat
