// Bodies of a scene stepped together: a kinematic object follows its prescribed rigid motion
// exactly (constant velocity and spin, or keyframes), is not simulated, and pushes a dynamic
// body it sweeps into, with every intersecting triangle pair in different bodies found.

#include <cmath>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "runtime/measures/collision_check.hpp"
#include "runtime/scene/pin_motion.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/scene/scene_bodies.hpp"
#include "runtime/simulation.hpp"
#include "tests/runtime/simulation_test_bake.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    using SimulationTest = test::ScratchDirTest;

    Vec3 centroid(const MatX3& positions)
    {
        return positions.colwise().mean().transpose();
    }

    TEST_F(SimulationTest, KinematicObjectKeepsItsVelocityAndSpin)
    {
        test::write_capsule_bake(path("capsule.h5"));
        const std::string scene_path = write_text("scene.json", R"({
            "time": {"dt": 0.02, "frames": 5},
            "objects": [{"name": "k", "bake": "capsule.h5", "motion": "kinematic",
                "position": [0, 1, 0], "rotation_degrees": [0, 0, 30],
                "velocity": [0.5, 0, -0.25], "angular_velocity": [0, 2, 0]}]})");
        const Scene scene = read_scene(scene_path);
        Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
        const Body& body = simulation.bodies()[0];
        EXPECT_TRUE(body.is_kinematic);
        EXPECT_TRUE(body.is_static);
        const MatX3 placed = body.state.positions;
        const Vec3 centre = body.placed_centre;
        const auto expected = [&](Index i, double t) -> Vec3 {
            const Mat3 spin = Eigen::AngleAxisd(2 * t, Vec3::UnitY()).toRotationMatrix();
            return spin * (placed.row(i).transpose() - centre) + centre + t * Vec3(0.5, 0, -0.25);
        };
        for (int s = 0; s < 7; ++s)
            simulation.step();
        const double t = 7 * 0.02;
        double error = 0.0, velocity_error = 0.0;
        for (Index i = 0; i < placed.rows(); ++i) {
            error = std::max(
                error, (body.state.positions.row(i).transpose() - expected(i, t)).norm());
            // Velocities: the last step's displacement over dt.
            const Vec3 velocity = (expected(i, t) - expected(i, t - 0.02)) / 0.02;
            velocity_error = std::max(
                velocity_error, (body.state.velocities.row(i).transpose() - velocity).norm());
        }
        EXPECT_LT(error, 1e-12); // no gravity, no elasticity: exactly the prescribed motion
        EXPECT_LT(velocity_error, 1e-9);
    }

    TEST_F(SimulationTest, KinematicObjectFollowsItsKeyframes)
    {
        test::write_capsule_bake(path("capsule.h5"));
        const std::string scene_path = write_text("scene.json", R"({
            "time": {"dt": 0.05, "frames": 5},
            "objects": [{"name": "k", "bake": "capsule.h5", "motion": "kinematic",
                "keyframes": [{"time": 0, "translation": [0, 0.5, 0]},
                    {"time": 0.2, "translation": [1, 0.5, 0], "rotation_degrees": [0, 0, 90]}]}]})");
        const Scene scene = read_scene(scene_path);
        Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
        const Body& body = simulation.bodies()[0];
        const Vec3 rest_centroid = centroid(body.placed_rest);
        // Time 0: the first keyframe.
        EXPECT_TRUE(
            centroid(body.state.positions).isApprox(rest_centroid + Vec3(0, 0.5, 0), 1e-12));
        for (int s = 0; s < 2; ++s)
            simulation.step(); // t = 0.1: half way, turned by 45 degrees
        const PinTransform expected = kinematic_motion_at(*body.object, 0.1, body.placed_centre);
        const MatX3 moved = apply_pin_transform(expected, body.placed_rest);
        EXPECT_LT((moved - body.state.positions).cwiseAbs().maxCoeff(), 1e-12);
        const Vec3 arm
            = body.state.positions.row(0).transpose() - body.placed_centre - Vec3(0.5, 0.5, 0);
        const Vec3 rest_arm = body.placed_rest.row(0).transpose() - body.placed_centre;
        EXPECT_TRUE(arm.isApprox(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ()) * rest_arm, 1e-9));
        for (int s = 0; s < 4; ++s)
            simulation.step(); // past the last keyframe: it holds
        EXPECT_TRUE(body.state.velocities.isZero(1e-9));
    }

    TEST_F(SimulationTest, KinematicSweeperPushesADynamicBody)
    {
        test::write_capsule_bake(path("capsule.h5"));
        const std::string scene_path = write_text("scene.json", R"({
            "time": {"dt": 0.02, "frames": 30},
            "gravity": [0, 0, 0],
            "solver": {"collision": "bounded"},
            "objects": [
                {"name": "soft", "bake": "capsule.h5"},
                {"name": "sweeper", "bake": "capsule.h5", "motion": "kinematic",
                 "position": [-0.7, 0, 0], "rotation_degrees": [0, 0, 90],
                 "velocity": [0.5, 0, 0]}]})");
        const Scene scene = read_scene(scene_path);
        Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
        const Vec3 start = centroid(simulation.bodies()[0].state.positions);
        CollisionCheckCounts total;
        for (int s = 0; s < 40; ++s) {
            simulation.step();
            total.add(check_collisions(simulation));
        }
        const Vec3 end = centroid(simulation.bodies()[0].state.positions);
        EXPECT_GT(end.x() - start.x(), 0.05); // pushed along +x
        EXPECT_GT(total.far_pairs, 0); // they did touch
        EXPECT_EQ(total.far_found, total.far_pairs);
        EXPECT_EQ(total.extra, 0);
        EXPECT_TRUE(simulation.bodies()[0].state.positions.allFinite());
    }

} // namespace
} // namespace mat
