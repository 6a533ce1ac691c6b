// Contact between free bodies conserves momentum (docs/method.md, "Contact"): two capsules in
// zero gravity, no ground and no friction, one shot head-on (or off-centre) at the other at rest.
// The contact stage pushes both bodies with equal and opposite forces, and each PD step keeps
// the sum of m x / h^2 (the elastic forces sum to zero over a body, in full space and in the
// handle basis alike, which reproduces translations), so the total linear momentum, and the
// angular momentum about the common centre of mass, stay what they were before the impact,
// in every solver mode; the heavier body keeps moving forward.

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/parallel.hpp"
#include "formats/bake_io.hpp"
#include "preprocess/bake/bake_pipeline.hpp"
#include "runtime/measures/body_measures.hpp"
#include "runtime/measures/collision_check.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/scene/scene_bodies.hpp"
#include "runtime/simulation.hpp"
#include "tests/support/sample_bake.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    struct MomentumParam {
        SolverKind solver;
        double mass_ratio; ///< mover density / target density
        double offset; ///< the mover's offset across the line of impact (m)
        double tolerance = 0.0; ///< time.tolerance (then at most 100 iterations a step)
        bool detect_in_step = false; ///< solver.detect_in_step "on"
    };

    class ContactMomentumTest : public test::ScratchDirTest,
                                public ::testing::WithParamInterface<MomentumParam> { };

    /// The scene: capsules along x (0.7 m long, radius 0.12 m), the mover 0.1 m short of the
    /// target at 1.5 m/s.
    std::string scene_text(const MomentumParam& p)
    {
        return fmt::format(R"({{
  "time": {{ "dt": 0.0166666667, "frames": 40, "iterations": {}, "tolerance": {} }},
  "gravity": [0, 0, 0],
  "solver": {{ "collision": "bounded", "collision_friction": 0.0, "detect_in_step": "{}" }},
  "objects": [
    {{ "name": "mover", "bake": "capsule.h5", "position": [-0.4, {}, 0], "velocity": [1.5, 0, 0],
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": {} }} }},
    {{ "name": "target", "bake": "capsule.h5", "position": [0.4, 0, 0],
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 }} }}
  ]
}})",
            p.tolerance > 0.0 ? 100 : 10, p.tolerance, p.detect_in_step ? "on" : "off", p.offset,
            1000.0 * p.mass_ratio);
    }

    struct Momenta {
        Vec3 linear = Vec3::Zero();
        Vec3 angular = Vec3::Zero(); ///< about the common centre of mass
        Vec3 body_linear[2] = { Vec3::Zero(), Vec3::Zero() };
    };

    Momenta momenta(const Simulation& simulation)
    {
        Momenta result;
        double mass = 0.0;
        Vec3 centre = Vec3::Zero();
        for (const Body& body : simulation.bodies()) {
            const VecX& m = body.model->pd().masses();
            mass += m.sum();
            centre += body.state.positions.transpose() * m;
        }
        centre /= mass;
        for (std::size_t b = 0; b < simulation.bodies().size(); ++b) {
            const Body& body = simulation.bodies()[b];
            const VecX& m = body.model->pd().masses();
            result.body_linear[b] = body.state.velocities.transpose() * m;
            result.linear += result.body_linear[b];
            for (Index i = 0; i < m.size(); ++i)
                result.angular += m(i)
                    * (body.state.positions.row(i).transpose() - centre)
                          .cross(body.state.velocities.row(i).transpose());
        }
        return result;
    }

    TEST_P(ContactMomentumTest, ImpactConservesMomentum)
    {
        const MomentumParam& p = GetParam();
        write_bake(path("capsule.h5"), test::sample_bake("capsule", 0.1));
        const Scene scene = read_scene(write_text("scene.json", scene_text(p)));
        Simulation simulation(scene, load_bodies(scene, p.solver));
        const Momenta before = momenta(simulation);
        const double p0 = before.linear.norm();
        ASSERT_GT(p0, 0.0);
        // Momenta right after the impact (the first step without contacts after some). Angular
        // momentum holds because the solver keeps it by default for bodies that only other
        // bodies push (solver.angular_momentum "keep", not set in the scene above): measured
        // 0.006-0.89% off here in the off-centre cases; with "free" (kept only out of contact)
        // 0.40-15.4%, 19 of the 21 past 2%, and with "integrator" 3.0-7.5% at mass ratio 1
        // (0.87% in full space at 0.1 m): the part implicit Euler and the iterations give the
        // elastic forces.
        int contact_steps = 0;
        Momenta after;
        for (int s = 0; s < scene.frames * scene.steps_per_frame; ++s) {
            simulation.step();
            // Contacts at the step's start or found during it (solver.detect_in_step).
            bool touching = simulation.collision()->last_report().contacts > 0;
            for (const Body& body : simulation.bodies())
                touching = touching || body.solver->last_report().contacts > 0;
            contact_steps += touching ? 1 : 0;
            if (contact_steps > 0 && !touching)
                break;
        }
        after = momenta(simulation);
        EXPECT_GT(contact_steps, 0) << "the bodies never met";
        // The target was really pushed (else conservation says nothing): at least 0.4 v0 head-on
        // (a perfectly inelastic impact of equal masses gives it 0.5 v0), 0.2 v0 off-centre.
        const double target_mass = simulation.bodies()[1].model->pd().masses().sum();
        EXPECT_GT(after.body_linear[1].x() / target_mass, (p.offset != 0.0 ? 0.2 : 0.4) * 1.5);
        EXPECT_LE((after.linear - before.linear).norm(), 0.01 * p0)
            << "before " << before.linear.transpose() << ", after " << after.linear.transpose();
        if (p.offset != 0.0) {
            // |L| at the start is the mover's offset times its momentum.
            const double l0 = before.angular.norm();
            ASSERT_GT(l0, 0.0);

            EXPECT_LE((after.angular - before.angular).norm(), 0.02 * l0)
                << "before " << before.angular.transpose() << ", after "
                << after.angular.transpose();
        }
        if (p.mass_ratio > 1.0) {
            EXPECT_GT(after.body_linear[0].x(), 0.0) << "the heavier mover bounced back";
        }
        if (p.tolerance > 0.0) {
            // The tolerance ended steps before the 100 iterations.
            const SolverTimings& timings = simulation.bodies()[0].solver->timings();
            EXPECT_LT(timings.iterations, 100 * timings.steps);
            EXPECT_GT(timings.iterations, 3 * timings.steps);
        }
    }

    std::vector<MomentumParam> params()
    {
        std::vector<MomentumParam> result;
        for (const SolverKind solver :
            { SolverKind::semi_reduced, SolverKind::full, SolverKind::hyper_reduced })
            for (const double ratio : { 1.0, 10.0, 100.0 })
                result.push_back({ solver, ratio, 0.0 });
        for (const SolverKind solver :
            { SolverKind::semi_reduced, SolverKind::full, SolverKind::hyper_reduced })
            for (const double offset : { 0.06, 0.1 })
                for (const double ratio : { 1.0, 10.0, 100.0 })
                    result.push_back({ solver, ratio, offset });
        // Iterations to a tolerance: the contact stage's last solve comes with the last
        // iteration, wherever it falls.
        for (const SolverKind solver :
            { SolverKind::semi_reduced, SolverKind::full, SolverKind::hyper_reduced })
            result.push_back({ solver, 10.0, 0.06, 1e-5 });
        // Contacts found again during the step (a hyper-reduced body never runs the key): the
        // impulses' moments of those found at the iterate are taken there, where their two
        // points are a closest pair (taken at the step's end instead, the pair's angular
        // momentum changed by 2.4-7.2% in these cases; docs/method.md).
        for (const SolverKind solver : { SolverKind::semi_reduced, SolverKind::full })
            for (const double ratio : { 1.0, 10.0, 100.0 })
                result.push_back({ solver, ratio, 0.06, 0.0, true });
        return result;
    }

    INSTANTIATE_TEST_SUITE_P(Contact, ContactMomentumTest, ::testing::ValuesIn(params()),
        [](const ::testing::TestParamInfo<MomentumParam>& info) {
            const MomentumParam& p = info.param;
            return std::string(p.solver == SolverKind::full        ? "full"
                           : p.solver == SolverKind::hyper_reduced ? "hyper"
                                                                   : "semi")
                + "_ratio" + std::to_string(static_cast<int>(p.mass_ratio))
                + (p.offset != 0.0
                        ? "_off_centre_" + std::to_string(static_cast<int>(p.offset * 100))
                        : "")
                + (p.tolerance > 0.0 ? "_tolerance" : "")
                + (p.detect_in_step ? "_detect_in_step" : "");
        });

    class ContactIslandTest : public test::ScratchDirTest { };

    // The contact island of "keep" (docs/method.md, "Angular momentum"): a capsule dropped onto
    // another that lies on the ground is pushed only by a stepped body, but its island holds the
    // ground, so it is world-held (the first rule of "keep" gave it the rotation, and a stiff crib
    // gained energy from it); two capsules meeting in the air are not.
    TEST_F(ContactIslandTest, TheGroundHoldsEveryBodyOfItsIsland)
    {
        write_bake(path("capsule.h5"), test::sample_bake("capsule", 0.1));
        const auto run = [&](double gravity, const char* ground, const char* upper) {
            const Scene scene = read_scene(write_text("scene.json",
                fmt::format(R"({{
  "time": {{ "dt": 0.0166666667, "frames": 30, "iterations": 10 }},
  "gravity": [0, {}, 0],
  "solver": {{ "collision": "bounded", "angular_momentum": "keep" }},
  "objects": [
    {{ "name": "lower", "bake": "capsule.h5", "position": [0, 0.125, 0],
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 }} }},
    {{ "name": "upper", "bake": "capsule.h5", "position": {}, "velocity": [0, -1, 0],
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 }} }}
  ]{}
}})",
                    gravity, upper, ground)));
            Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
            // Steps where the lower body pushed the upper one (a vertex of the upper against a
            // face of the lower, with a force), and those of them where the upper one was
            // world-held.
            std::array<int, 2> steps {};
            for (int s = 0; s < scene.frames * scene.steps_per_frame; ++s) {
                simulation.step();
                const StepReport& upper = simulation.bodies()[1].solver->last_report();
                EXPECT_FALSE(upper.world_contact); // nothing of the world reaches it
                if (upper.active_contacts > 0) {
                    ++steps[0];
                    steps[1] += upper.world_held ? 1 : 0;
                }
            }
            return steps;
        };
        // On the ground: the upper capsule (never pushed by the world itself) rests on the lower.
        const auto on_ground = run(-9.81,
            R"(,
  "colliders": [{ "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0] }])",
            "[0, 0.37, 0]");
        EXPECT_GT(on_ground[0], 10) << "the upper capsule never rested on the lower one";
        // Held whenever the lower one touches the ground (it does in all but the first steps).
        EXPECT_GE(on_ground[1], on_ground[0] - 2);
        // In the air, no gravity: the pair's island is free in every step they touch.
        const auto in_air = run(0.0, "", "[0, 0.37, 0]");
        EXPECT_GT(in_air[0], 0) << "the capsules never met";
        EXPECT_EQ(in_air[1], 0);
    }

} // namespace
} // namespace mat

namespace mat {
namespace {

    struct TunnelParam {
        SolverKind solver;
        double speed; ///< m/s
    };

    class ContactTunnelTest : public test::ScratchDirTest,
                              public ::testing::WithParamInterface<TunnelParam> { };

    // No tunnelling: the stability study's projectile (a capsule, E = 1e6 Pa) shot at 12 and
    // 30 m/s at a plate 16 cm thick pinned at both ends (the rounded bar, E = 1e5 Pa), at dt =
    // 1/30 s: 0.4 and 1 m per step, more than twice the plate's thickness. Speculative contacts
    // (a vertex is a candidate as far ahead as its approach speed takes it in the step) stop it:
    // its centroid stays in front of the plate's in every step, no vertex sinks 2 cm into the
    // plate, and no triangle pair intersects in the last 10 frames. With the compliance's give
    // capped in each step's last contact solve (solver.compliance_cap, 0.4% of the capsule's
    // diagonal beyond the skin; docs/method.md, "Compliance cap"), no vertex sinks more than
    // 0.5% of the capsule's diagonal (3.83 mm) in any mode. Measured here (the exhaustive check
    // of --check-collisions, x86-64-v3 build), the deepest vertex penetration during the impact
    // at 12 / 30 m/s: semi 3.06 / 3.07 mm, full 0.18 / 1.32 (3.07 / 3.17 before full space held
    // its planes, docs/method.md, "Full space holds its planes"), hyper 3.06 / 3.07; without the
    // cap semi 6.52 / 6.76, full (then) 3.17 / 6.54, hyper 6.50 / 7.20, so the reduced modes
    // fail without it.
    TEST_P(ContactTunnelTest, ProjectileIsStoppedByThePlate)
    {
        const TunnelParam& p = GetParam();
        write_bake(path("bar.h5"), test::sample_bake("rounded_bar", 0.1));
        write_bake(path("capsule.h5"), test::sample_bake("capsule", 0.1));
        const std::string text = fmt::format(R"({{
  "time": {{ "dt": 0.0333333333, "frames": 20, "iterations": 10 }},
  "gravity": [0, 0, 0],
  "solver": {{ "collision": "bounded" }},
  "objects": [
    {{ "name": "plate", "bake": "bar.h5",
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 }},
      "pins": [ {{ "box": {{ "min": [-1, -1, -1], "max": [-0.33, 1, 1] }} }},
                {{ "box": {{ "min": [0.33, -1, -1], "max": [1, 1, 1] }} }} ] }},
    {{ "name": "projectile", "bake": "capsule.h5", "position": [0, 0, 0.45],
      "rotation_degrees": [0, 90, 0], "velocity": [0, 0, {}],
      "material": {{ "youngs_modulus": 1e6, "poisson_ratio": 0.3, "density": 1000 }} }}
  ]
}})",
            -p.speed);
        const Scene scene = read_scene(write_text("scene.json", text));
        Simulation simulation(scene, load_bodies(scene, p.solver));
        const Body& projectile = simulation.bodies()[1];
        const int steps = scene.frames * scene.steps_per_frame;
        double max_penetration = 0.0;
        for (int s = 1; s <= steps; ++s) {
            simulation.step();
            // In front of the plate (which the impact bends back): every projectile vertex
            // stays in front of the plate's surface, at most the penetration below.
            const CollisionCheckCounts check = check_collisions(simulation);
            max_penetration = std::max(max_penetration, check.max_penetration);
            ASSERT_GT(projectile.state.positions.col(2).mean(),
                simulation.bodies()[0].state.positions.col(2).mean())
                << "step " << s;
            if (s > steps - 10) {
                EXPECT_EQ(check.far_pairs, 0) << "step " << s;
            }
        }
        EXPECT_LE(max_penetration, 0.005 * projectile.model->rest_diagonal());
    }

    std::vector<TunnelParam> tunnel_params()
    {
        std::vector<TunnelParam> result;
        for (const SolverKind solver :
            { SolverKind::semi_reduced, SolverKind::full, SolverKind::hyper_reduced })
            for (const double speed : { 12.0, 30.0 })
                result.push_back({ solver, speed });
        return result;
    }

    INSTANTIATE_TEST_SUITE_P(Contact, ContactTunnelTest, ::testing::ValuesIn(tunnel_params()),
        [](const ::testing::TestParamInfo<TunnelParam>& info) {
            const TunnelParam& p = info.param;
            return std::string(p.solver == SolverKind::full        ? "full"
                           : p.solver == SolverKind::hyper_reduced ? "hyper"
                                                                   : "semi")
                + "_" + std::to_string(static_cast<int>(p.speed)) + "_m_per_s";
        });

    /// A closed capsule along x, `radius` thick and 2 `half_length` + 2 `radius` long, as OBJ
    /// text: a ring of 12 vertices every 2.5 cm of the cylinder and 3 rings on each cap.
    std::string capsule_obj(double radius, double half_length)
    {
        constexpr int segments = 12;
        constexpr int cap_rings = 3;
        const int cylinder_rings = static_cast<int>(std::lround(2.0 * half_length / 0.025)) + 1;
        std::vector<std::array<double, 2>> rings; // (x, ring radius)
        for (int i = 1; i <= cap_rings; ++i) {
            const double phi = M_PI / 2.0 * i / (cap_rings + 1);
            rings.push_back({ -half_length - radius * std::cos(phi), radius * std::sin(phi) });
        }
        for (int i = 0; i < cylinder_rings; ++i)
            rings.push_back(
                { -half_length + 2.0 * half_length * i / (cylinder_rings - 1), radius });
        for (int i = cap_rings; i >= 1; --i) {
            const double phi = M_PI / 2.0 * i / (cap_rings + 1);
            rings.push_back({ half_length + radius * std::cos(phi), radius * std::sin(phi) });
        }
        std::string text = fmt::format("v {} 0 0\n", -half_length - radius);
        for (const auto& [x, r] : rings)
            for (int k = 0; k < segments; ++k) {
                const double a = 2.0 * M_PI * k / segments;
                text += fmt::format("v {} {} {}\n", x, r * std::cos(a), r * std::sin(a));
            }
        const int num_rings = static_cast<int>(rings.size());
        const int last = 2 + num_rings * segments; // 1-based, the +x pole
        text += fmt::format("v {} 0 0\n", half_length + radius);
        const auto at = [&](int ring, int k) { return 2 + ring * segments + k % segments; };
        for (int k = 0; k < segments; ++k)
            text += fmt::format("f 1 {} {}\n", at(0, k + 1), at(0, k));
        for (int ring = 0; ring + 1 < num_rings; ++ring)
            for (int k = 0; k < segments; ++k) {
                text += fmt::format(
                    "f {} {} {}\n", at(ring, k), at(ring, k + 1), at(ring + 1, k + 1));
                text += fmt::format(
                    "f {} {} {}\n", at(ring, k), at(ring + 1, k + 1), at(ring + 1, k));
            }
        for (int k = 0; k < segments; ++k)
            text += fmt::format(
                "f {} {} {}\n", last, at(num_rings - 1, k), at(num_rings - 1, k + 1));
        return text;
    }

    class ContactThinLimbTest : public test::ScratchDirTest,
                                public ::testing::WithParamInterface<SolverKind> { };

    // No tunnelling through a thin part: a limb 2 cm thick (a rod 0.42 m long, pinned at both
    // ends, E = 1e6 Pa; generated medial mesh of 12 spheres) hit in the middle by the stability
    // study's projectile (the capsule, 0.24 m thick) at 10 m/s, at dt = 1/30 s: 0.33 m per step,
    // 16 times the limb's thickness. The limb bends back and throws the projectile back: in every
    // step the projectile's centroid stays in front of the limb's middle, no vertex sinks half
    // the limb's thickness into the other body, and no triangle pair intersects in the last 10
    // of 30 frames (they part after about 12). Semi-reduced, no vertex sinks more than 0.5% of
    // the limb's diagonal (2.1 mm; it does not take solver.compliance_cap to hold: 1.37 mm
    // without the cap, 1.23 with it). Measured here: the deepest penetration (the exhaustive check
    // of --check-collisions, x86-64-v3 build) 1.23 mm semi-reduced, 2.91 mm full space, 1.25 mm
    // hyper-reduced (without the cap 1.37, 2.06 and 1.35 mm; with a -march=native build on a Zen
    // 4, before the cap: 2.6, 1.9 and 2.6 mm); the limb's middle bends back 0.24-0.35 m; the
    // projectile leaves at 1.5-2.2 m/s. Without
    // speculative contacts (no lookahead) the projectile passes through.
    TEST_P(ContactThinLimbTest, ThinLimbIsNotPassedThrough)
    {
        const std::string surface = write_text("limb.obj", capsule_obj(0.01, 0.2));
        BakeOptions options;
        options.surface = surface;
        options.spheres = 12;
        options.tet_size = 0.025;
        options.perturb_slivers = false;
        BakeReport report;
        write_bake(path("limb.h5"), run_bake(options, report));
        write_bake(path("capsule.h5"), test::sample_bake("capsule", 0.1));
        const std::string text = R"({
  "time": { "dt": 0.0333333333, "frames": 30, "iterations": 10 },
  "gravity": [0, 0, 0],
  "solver": { "collision": "bounded" },
  "objects": [
    { "name": "limb", "bake": "limb.h5",
      "material": { "youngs_modulus": 1e6, "poisson_ratio": 0.3, "density": 1000 },
      "pins": [ { "box": { "min": [-1, -1, -1], "max": [-0.18, 1, 1] } },
                { "box": { "min": [0.18, -1, -1], "max": [1, 1, 1] } } ] },
    { "name": "projectile", "bake": "capsule.h5", "position": [0, 0, 0.45],
      "rotation_degrees": [0, 90, 0], "velocity": [0, 0, -10],
      "material": { "youngs_modulus": 1e6, "poisson_ratio": 0.3, "density": 1000 } }
  ]
})";
        const Scene scene = read_scene(write_text("scene.json", text));
        Simulation simulation(scene, load_bodies(scene, GetParam()));
        const Body& limb = simulation.bodies()[0];
        const Body& projectile = simulation.bodies()[1];
        // The limb's middle: its nodes within 5 cm of the centre, at rest.
        std::vector<Index> middle;
        for (Index i = 0; i < limb.state.positions.rows(); ++i)
            if (std::abs(limb.state.positions(i, 0)) < 0.05)
                middle.push_back(i);
        ASSERT_GT(middle.size(), 10u);
        const int steps = scene.frames * scene.steps_per_frame;
        double max_penetration = 0.0;
        double deepest_middle = 0.0;
        for (int s = 1; s <= steps; ++s) {
            simulation.step();
            const CollisionCheckCounts check = check_collisions(simulation);
            max_penetration = std::max(max_penetration, check.max_penetration);
            double middle_z = 0.0;
            for (const Index i : middle)
                middle_z += limb.state.positions(i, 2) / static_cast<double>(middle.size());
            deepest_middle = std::min(deepest_middle, middle_z);
            ASSERT_GT(projectile.state.positions.col(2).mean(), middle_z) << "step " << s;
            if (s > steps - 10) {
                EXPECT_EQ(check.far_pairs, 0) << "step " << s;
            }
        }
        // It was hit (bent back by more than its thickness), and threw the projectile back.
        EXPECT_LT(deepest_middle, -0.05);
        EXPECT_GT(projectile.state.velocities.col(2).mean(), 0.0);
        EXPECT_LT(max_penetration, 0.01);
        if (GetParam() == SolverKind::semi_reduced) {
            EXPECT_LE(max_penetration, 0.005 * limb.model->rest_diagonal());
        }
    }

    INSTANTIATE_TEST_SUITE_P(Contact, ContactThinLimbTest,
        ::testing::Values(SolverKind::semi_reduced, SolverKind::full, SolverKind::hyper_reduced),
        [](const ::testing::TestParamInfo<SolverKind>& info) {
            return std::string(info.param == SolverKind::full ? "full"
                    : info.param == SolverKind::hyper_reduced ? "hyper"
                                                              : "semi");
        });

} // namespace
} // namespace mat

namespace mat {
namespace {

    class ContactFrictionTest : public test::ScratchDirTest,
                                public ::testing::WithParamInterface<SolverKind> { };

    // Friction acts on the motion relative to the other surface: a flat block (the rounded bar)
    // dropped onto a kinematic platform (another one) that moves along x at 0.5 m/s is taken
    // along by Coulomb friction (mu = 0.5: the platform's speed in about 0.1 s) and then rides
    // with it, its velocity within 2% of the platform's, on the platform. (A capsule would roll
    // sideways: rolling meets no friction.)
    TEST_P(ContactFrictionTest, BodyRidesAlongOnAMovingPlatform)
    {
        write_bake(path("bar.h5"), test::sample_bake("rounded_bar", 0.1));
        write_bake(path("capsule.h5"), test::sample_bake("capsule", 0.1));
        const std::string text = R"({
  "time": { "dt": 0.0166666667, "frames": 90, "iterations": 10 },
  "gravity": [0, -9.81, 0],
  "solver": { "collision": "bounded", "collision_friction": 0.5 },
  "objects": [
    { "name": "platform", "bake": "bar.h5", "motion": "kinematic", "velocity": [0.5, 0, 0],
      "rotation_degrees": [90, 0, 0] },
    { "name": "rider", "bake": "bar.h5", "position": [0, 0.165, 0], "rotation_degrees": [90, 0, 0],
      "material": { "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 } }
  ]
})";
        const Scene scene = read_scene(write_text("scene.json", text));
        Simulation simulation(scene, load_bodies(scene, GetParam()));
        const Body& platform = simulation.bodies()[0];
        const Body& rider = simulation.bodies()[1];
        const VecX& m = rider.model->pd().masses();
        const int steps = scene.frames * scene.steps_per_frame;
        double worst = 0.0;
        for (int s = 1; s <= steps; ++s) {
            simulation.step();
            if (s * scene.time.dt < 1.0)
                continue;
            // The last half second: the rider's mean velocity against the platform's.
            const Vec3 v = rider.state.velocities.transpose() * m / m.sum();
            worst = std::max(worst, (v - Vec3(0.5, 0.0, 0.0)).norm());
        }
        EXPECT_LT(worst, 0.02 * 0.5);
        // On the platform (its top at y = 0.08), not through it.
        EXPECT_GT(rider.state.positions.col(1).minCoeff(),
            platform.state.positions.col(1).maxCoeff() - 0.01);
    }

    /// The scene: a dense carrier (the rounded bar laid flat, 0.76 x 0.16 x 0.36 m, 4000
    /// kg/m^3) on a frictionless ground plane, sliding along x at 0.5 m/s, and a rider (the same
    /// bar at 1000 kg/m^3: a quarter of its mass) at rest on top of it; both start 0.1 mm clear
    /// of what they rest on. Friction between them is solver.collision_friction.
    std::string carrier_scene(double friction)
    {
        return fmt::format(R"({{
  "time": {{ "dt": 0.0166666667, "frames": 90, "iterations": 10 }},
  "gravity": [0, -9.81, 0],
  "solver": {{ "collision": "bounded", "collision_friction": {}, "sleep_speed": 0 }},
  "colliders": [ {{ "type": "plane", "friction": 0 }} ],
  "objects": [
    {{ "name": "carrier", "bake": "bar.h5", "position": [0, 0.0801, 0],
      "rotation_degrees": [90, 0, 0], "velocity": [0.5, 0, 0],
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 4000 }} }},
    {{ "name": "rider", "bake": "bar.h5", "position": [0, 0.2402, 0],
      "rotation_degrees": [90, 0, 0],
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 }} }}
  ]
}})",
            friction);
    }

    // The dynamic half: a rider at rest on a dense carrier that slides at 0.5 m/s on
    // frictionless ground. Friction between the bodies (mu = 0.3) brings the rider up to the
    // carrier's speed, and the carrier pays for it (no horizontal force acts on the pair): a
    // rigid pair would end at v m_c / (m_c + m_r) = 0.4 m/s after v / (mu g (1 + m_r / m_c))
    // = 0.136 s. The rider starts at rest, not at the carrier's speed, so that friction between
    // bodies must do the work, and at most mu g per second of it: 0.1 s in, the rider is still
    // more than 10% slower than the carrier (Coulomb: 0.294 against 0.426 m/s, 31%; measured
    // semi 28%, full 40%, hyper 28%). From 0.5 to 1.5 s the rider's mean velocity along x stays
    // within 2% of the carrier's; the soft pair (E = 1e5 Pa) first rings in shear about the
    // common speed (a period of about 0.27 s, halving every half period: 3% at 0.43 s), hence
    // the half second. Over the whole run the total momentum along x stays within 1% of its
    // start. Measured, the largest relative speed over 0.5-1.5 s and the momentum drift: semi
    // 1.48% (at 0.57 s), full 1.06% (0.58 s), hyper 1.23% (0.55 s); drift under 2e-12 in each,
    // both bodies at 0.400 m/s at the end. Without friction between the bodies
    // (collision_friction 0) the rider stays behind (under 3% of the carrier's speed at
    // 0.1-0.3 s), then falls off the carrier's back end: relative speeds of 188-202%.
    TEST_P(ContactFrictionTest, BodyRidesAlongOnAMovingDynamicCarrier)
    {
        write_bake(path("bar.h5"), test::sample_bake("rounded_bar", 0.1));
        const Scene scene = read_scene(write_text("scene.json", carrier_scene(0.3)));
        Simulation simulation(scene, load_bodies(scene, GetParam()));
        const Body& carrier = simulation.bodies()[0];
        const Body& rider = simulation.bodies()[1];
        const double carrier_mass = carrier.model->pd().masses().sum();
        const double rider_mass = rider.model->pd().masses().sum();
        const double p0 = momenta(simulation).linear.x();
        ASSERT_GT(p0, 0.0);
        const int steps = scene.frames * scene.steps_per_frame;
        const int early = static_cast<int>(std::lround(0.1 / scene.time.dt));
        double worst_relative = 0.0; // |v_rider - v_carrier| / |v_carrier| along x, 0.5-1.5 s
        double worst_drift = 0.0; // |p_x - p0| / p0
        for (int s = 1; s <= steps; ++s) {
            simulation.step();
            const Momenta now = momenta(simulation);
            worst_drift = std::max(worst_drift, std::abs(now.linear.x() - p0) / p0);
            const double v_carrier = now.body_linear[0].x() / carrier_mass;
            const double relative
                = std::abs(now.body_linear[1].x() / rider_mass - v_carrier) / std::abs(v_carrier);
            if (s == early) {
                EXPECT_GT(relative, 0.1) << "the rider caught up faster than friction allows";
            }
            if (s * scene.time.dt > 0.5 - 1e-9)
                worst_relative = std::max(worst_relative, relative);
        }
        EXPECT_LT(worst_relative, 0.02);
        EXPECT_LT(worst_drift, 0.01);
        // On the carrier (its top at y = 0.16), not through it; the carrier on the ground.
        EXPECT_GT(rider.state.positions.col(1).minCoeff(),
            carrier.state.positions.col(1).maxCoeff() - 0.01);
        EXPECT_GT(carrier.state.positions.col(1).minCoeff(), -0.001);
    }

    INSTANTIATE_TEST_SUITE_P(Contact, ContactFrictionTest,
        ::testing::Values(SolverKind::semi_reduced, SolverKind::full, SolverKind::hyper_reduced),
        [](const ::testing::TestParamInfo<SolverKind>& info) {
            return std::string(info.param == SolverKind::full ? "full"
                    : info.param == SolverKind::hyper_reduced ? "hyper"
                                                              : "semi");
        });

} // namespace
} // namespace mat

namespace mat {
namespace {

    std::string read_file_text(const std::string& path)
    {
        std::ifstream in(path);
        std::stringstream text;
        text << in.rdbuf();
        return text.str();
    }

    /// A collision sample's scene (samples/NAME/scene.json) on bakes written into the test's
    /// directory (the coarse creature, tets 4% of its diagonal, as `make -C samples` bakes it,
    /// and the capsule), with `solver_keys` (JSON members, e.g. "\"contact_normals\": \"step\"")
    /// added to its solver section.
    class SampleSceneTest : public test::ScratchDirTest {
    protected:
        Scene sample_scene(const std::string& name, const std::string& solver_keys = "")
        {
            if (!std::filesystem::exists(path("creature_coarse.h5")))
                write_bake(path("creature_coarse.h5"), test::sample_bake("creature", 0.04));
            if (!std::filesystem::exists(path("capsule.h5")))
                write_bake(path("capsule.h5"), test::sample_bake("capsule", 0.05));
            std::string text
                = read_file_text(std::string(MAT_SAMPLES_DIR) + "/" + name + "/scene.json");
            EXPECT_FALSE(text.empty()) << name;
            for (const std::string bake :
                { "../creature/creature_coarse.h5", "../capsule/capsule.h5" }) {
                const std::string local = bake.substr(bake.rfind('/') + 1);
                for (std::size_t at = text.find(bake); at != std::string::npos;
                     at = text.find(bake))
                    text.replace(at, bake.size(), local);
            }
            if (!solver_keys.empty()) {
                const std::string solver = "\"solver\": {";
                const std::size_t at = text.find(solver);
                EXPECT_NE(at, std::string::npos) << name << " has no solver section";
                if (at != std::string::npos)
                    text.insert(at + solver.size(), " " + solver_keys + ",");
            }
            return read_scene(write_text(name + ".json", text));
        }
    };

    struct SampleParam {
        const char* sample;
        SolverKind solver;
    };

    class CollisionSampleTest : public SampleSceneTest,
                                public ::testing::WithParamInterface<SampleParam> { };

    // Collision samples in full (samples/NAME/scene.json on the coarse creature, tets 4% of its
    // diagonal, as `make -C samples` bakes it), checked after every step against the exhaustive
    // ground truth (--check-collisions): the deepest vertex of one body inside another (or, with
    // self collision, inside its own body) stays within 0.5% of the smaller body's diagonal and
    // no triangle pair of two bodies (or of non-adjacent parts of one) intersects in the last 10
    // frames.
    // creatures_collide holds the bound with the defaults since the speculative contacts allow
    // for a body that stops during the step (docs/method.md, "Speculative contacts"; before, its
    // landing sank a vertex 8-10 mm, 0.63-0.76%, without solver.detect_in_step). The skin
    // (solver.contact_skin, docs/method.md, "Skin") keeps creatures_collide, drop_on_pile and
    // creature_stack free of intersecting pairs at rest (measured here: 0; without it they kept
    // 130-440, the vertex penetration there under 1.3 mm; deepest over the run now 0, 0 and 1.1
    // mm). The self skin that limb_self_contact sets (solver.self_skin 0.5, docs/method.md, "Self
    // skin") does the same for its curled limb (measured here: 0 self-intersecting pairs in its
    // last 10 frames and 0 self penetration; without it 308 pairs over them, 1.35 mm).
    TEST_P(CollisionSampleTest, PenetrationStaysWithinHalfAPercent)
    {
        const std::string name = GetParam().sample;
        const Scene scene = sample_scene(name);
        Simulation simulation(scene, load_bodies(scene, GetParam().solver));
        double smallest = std::numeric_limits<double>::infinity();
        for (const Body& body : simulation.bodies())
            smallest = std::min(smallest, body.model->rest_diagonal());
        const int steps = scene.frames * scene.steps_per_frame;
        const int last = std::max(0, steps - 10 * scene.steps_per_frame);
        double deepest = 0.0;
        long pairs = 0;
        for (int s = 1; s <= steps; ++s) {
            simulation.step();
            const CollisionCheckCounts check = check_collisions(simulation);
            deepest = std::max({ deepest, check.max_penetration, check.max_self_penetration });
            if (s > last)
                pairs += check.far_pairs;
        }
        EXPECT_LE(deepest, 0.005 * smallest) << name;
        EXPECT_EQ(pairs, 0) << name;
    }

    INSTANTIATE_TEST_SUITE_P(Samples, CollisionSampleTest,
        ::testing::Values(SampleParam { "creatures_collide", SolverKind::semi_reduced },
            SampleParam { "drop_on_pile", SolverKind::semi_reduced },
            SampleParam { "kinematic_sweep", SolverKind::semi_reduced },
            SampleParam { "creature_stack", SolverKind::semi_reduced },
            SampleParam { "limb_self_contact", SolverKind::semi_reduced },
            SampleParam { "creatures_collide", SolverKind::full },
            SampleParam { "drop_on_pile", SolverKind::full },
            SampleParam { "kinematic_sweep", SolverKind::full },
            SampleParam { "creature_stack", SolverKind::full },
            SampleParam { "limb_self_contact", SolverKind::full }),
        [](const ::testing::TestParamInfo<SampleParam>& info) {
            return std::string(info.param.sample)
                + (info.param.solver == SolverKind::full ? "_full" : "");
        });

    /// A run of a collision sample: the deepest vertex of one body inside another, the largest
    /// strain and the highest total energy over its steps, and its start energy.
    struct SampleRun {
        double deepest = 0.0;
        double strain = 0.0;
        double start_energy = 0.0;
        double highest_energy = 0.0;
        double diagonal = std::numeric_limits<double>::infinity(); ///< the smallest body's
    };

    /// The total energy (kinetic, gravity's potential, elastic) of every body of `simulation`;
    /// `strain` (if given) takes the largest strain among them.
    double total_energy(const Simulation& simulation, const Vec3& gravity, double* strain = nullptr)
    {
        double sum = 0.0;
        for (const Body& body : simulation.bodies()) {
            const BodyMeasures m = measure_body(body.model->pd(), body.state, gravity);
            sum += m.kinetic + m.potential + m.elastic;
            if (strain != nullptr)
                *strain = std::max(*strain, m.max_strain);
        }
        return sum;
    }

    SampleRun run_sample(const Scene& scene, SolverKind solver)
    {
        Simulation simulation(scene, load_bodies(scene, solver));
        const auto energy
            = [&](double& strain) { return total_energy(simulation, scene.gravity, &strain); };
        SampleRun run;
        for (const Body& body : simulation.bodies())
            run.diagonal = std::min(run.diagonal, body.model->rest_diagonal());
        run.start_energy = run.highest_energy = energy(run.strain);
        const int steps = scene.frames * scene.steps_per_frame;
        for (int s = 1; s <= steps; ++s) {
            simulation.step();
            const CollisionCheckCounts check = check_collisions(simulation);
            run.deepest = std::max(run.deepest, check.max_penetration);
            run.highest_energy = std::max(run.highest_energy, energy(run.strain));
        }
        return run;
    }

    // Contacts found again during the step (solver.detect_in_step "on"; docs/method.md,
    // "Contacts found again during the step"): the two creatures of creatures_collide, full
    // space, with planes that turn with the iterate and no skin (full space's defaults before
    // "Full space holds its planes", under which the landing no longer sinks without it either).
    // They land on the ground pressed together; what the landing pushes into the other body
    // during a step has no contact from the step's start, and sinks.
    // With the contacts found again at the iterate halfway through each step the deepest vertex
    // stays within 0.5% of the diagonal (measured 0.9-1.2 mm over five runs of the sample with
    // friction 0.3-0.312, on a 1.30 m creature); with the step start's contacts alone it sinks
    // past 0.6% (9.9-10.5 mm; 19-23 mm before the speculative contacts allowed for a body that
    // stops during the step, docs/method.md, "Speculative contacts"). The energy never rises
    // above its start either way.
    class DetectInStepTest : public SampleSceneTest { };

    TEST_F(DetectInStepTest, LandingBodiesDoNotSinkIntoEachOther)
    {
        const SampleRun again = run_sample(
            sample_scene("creatures_collide",
                R"("detect_in_step": "on", "contact_normals": "iterate", "contact_skin": 0)"),
            SolverKind::full);
        const SampleRun start = run_sample(
            sample_scene("creatures_collide",
                R"("detect_in_step": "off", "contact_normals": "iterate", "contact_skin": 0)"),
            SolverKind::full);
        EXPECT_LE(again.deepest, 0.005 * again.diagonal);
        EXPECT_GT(start.deepest, 0.006 * start.diagonal)
            << "the scene no longer tells the two apart";
        for (const SampleRun& run : { again, start })
            EXPECT_LE(run.highest_energy, run.start_energy * (1.0 + 1e-9));
    }

    // Subspace steps (solver.contact_subspace "on", opt-in; docs/method.md, "Subspace steps"):
    // the full-space creatures_collide whose vertices sink at the first impact without
    // detect_in_step (DetectInStepTest above: past 0.6% of the diagonal) holds them once its last
    // contact solves converge: measured 0.95 mm on the 1.30 m creature (0.83-1.03 mm in 8 of 10
    // runs with the friction varied; one of those ten crushed, which is why the steps are
    // opt-in). The energy never rises above its start.
    class SubspaceStepsTest : public SampleSceneTest { };

    TEST_F(SubspaceStepsTest, HoldTheFullSpaceImpactThatSinksWithoutThem)
    {
        const SampleRun run = run_sample(
            sample_scene("creatures_collide", R"("contact_subspace": "on")"), SolverKind::full);
        EXPECT_LE(run.deepest, 0.005 * run.diagonal);
        EXPECT_LE(run.highest_energy, run.start_energy * (1.0 + 1e-9));
    }

    // Deep vertices (docs/method.md, "Deep vertices"): a surface vertex more than the collision
    // margin behind its nearest face of another deformable body gets no contact. Hyper-reduced
    // creatures_collide crushed without that rule (strain 26.0 and a vertex 93 mm inside the
    // other creature; 3 of 10 runs with the friction varied); with it the largest strain of those
    // ten runs is 3.9, and the energy never rises above its start.
    class DeepVerticesTest : public SampleSceneTest { };

    TEST_F(DeepVerticesTest, HyperReducedLandingDoesNotCrush)
    {
        const SampleRun run
            = run_sample(sample_scene("creatures_collide"), SolverKind::hyper_reduced);
        EXPECT_LT(run.strain, 5.0);
        EXPECT_LE(run.highest_energy, run.start_energy * (1.0 + 1e-9));
    }

    // Self contacts that start behind (solver.self_push_speed, docs/method.md, "Self contacts
    // that start behind"): drop_on_pile with self collision on, semi-reduced. The bottom
    // creatures, pressed by the others, have vertices pushed behind their own faces in every
    // step; pushed back out at once, each push gave them speed, and the pile's total energy rose
    // step after step at rest, without a driver (by up to 18 J over its running lowest in four
    // runs with the friction varied, without the self skin; 244 J in this run with the skin,
    // now the default). Pushed out at no more than 2% of the diagonal per second the energy
    // never rises. The rise is the largest of the total energy over its lowest so far.
    class SelfPushTest : public SampleSceneTest {
    protected:
        double energy_rise(const Scene& scene, SolverKind solver = SolverKind::semi_reduced)
        {
            Simulation simulation(scene, load_bodies(scene, solver));
            double lowest = total_energy(simulation, scene.gravity);
            double rise = 0.0;
            for (int s = 1; s <= scene.frames * scene.steps_per_frame; ++s) {
                simulation.step();
                const double e = total_energy(simulation, scene.gravity);
                lowest = std::min(lowest, e);
                rise = std::max(rise, e - lowest);
            }
            return rise;
        }
    };

    TEST_F(SelfPushTest, PressedSelfContactsPumpNoEnergy)
    {
        const double limited
            = energy_rise(sample_scene("drop_on_pile", R"("self_collision": "on")"));
        const double at_once = energy_rise(
            sample_scene("drop_on_pile", R"("self_collision": "on", "self_push_speed": 1e9)"));
        std::cout << "energy rise: pushed out at once " << at_once << " J, limited " << limited
                  << " J\n";
        EXPECT_GT(at_once, 1.0) << "the scene no longer tells the two apart";
        EXPECT_LE(limited, 0.01);
    }

    // Full-space bodies push at a quarter of self_push_speed (docs/method.md, "Self collision on
    // by default"): drop_on_pile with the defaults (self collision on, self skin 0.5), full space.
    // At the full speed the pile's energy rose by 0.28-1.15 J over its running lowest in four runs
    // with the friction varied (0.78 J in this one); at a quarter it never rises.
    TEST_F(SelfPushTest, FullSpacePileAtAQuarterOfTheSpeed)
    {
        const Scene scene = sample_scene("drop_on_pile");
        ASSERT_TRUE(scene.solver.self_collision);
        const double quarter = energy_rise(scene, SolverKind::full);
        Scene fast = scene;
        fast.solver.self_push_speed *= 4.0;
        const double full_speed = energy_rise(fast, SolverKind::full);
        std::cout << "energy rise, full space: at the full speed " << full_speed
                  << " J, at a quarter " << quarter << " J\n";
        EXPECT_GT(full_speed, 0.1) << "the scene no longer tells the two apart";
        EXPECT_LE(quarter, 0.01);
    }

    // Preload in full space only (docs/method.md): creatures_collide with self collision on and
    // the self skin 0.5, semi-reduced, friction 0.306 (one of the four runs of the protocol in
    // which the landing crushed while semi-reduced bodies took the compliance preload: strain
    // 5.71, a vertex 31.9 mm inside the other creature). Without the preload, which semi-reduced
    // bodies no longer take, the strain stays below 2 and the deepest vertex within 0.5% of the
    // diagonal; the energy never rises above its start.
    class SelfSkinLandingTest : public SampleSceneTest { };

    TEST_F(SelfSkinLandingTest, SemiReducedLandingDoesNotCrush)
    {
        Scene scene
            = sample_scene("creatures_collide", R"("self_collision": "on", "self_skin": 0.5)");
        scene.solver.collision_friction = 0.306;
        const SampleRun run = run_sample(scene, SolverKind::semi_reduced);
        std::cout << "strain " << run.strain << ", deepest " << run.deepest << " m\n";
        EXPECT_LT(run.strain, 2.0);
        EXPECT_LE(run.deepest, 0.005 * run.diagonal);
        EXPECT_LE(run.highest_energy, run.start_energy * (1.0 + 1e-9));
    }

    // Hyper-reduced contact (docs/method.md, "Hyper-reduced contact"): in a scene whose objects
    // collide, a hyper-reduced body takes the speculative stop and samples 5k tets by default
    // instead of 4k. creatures_collide then holds the penetration bound of the other modes: over
    // 40 runs with the friction varied the deepest vertex was 1.42 mm (median; 3.03 mm largest)
    // and the largest strain 2.08 (2.76) on the 1.30 m creature (this run: 1.58 mm, strain 2.29,
    // when self collision was off by default; 0 mm and 2.32 with it on, under mat-run);
    // before, with 4k samples and the start velocities' approach alone, every one of the 40 went
    // deeper than 0.5% of the diagonal (6.5 mm; median 14.3 mm, strain 3.75; this run 7.99 mm,
    // strain 3.68). The energy never rises above its start.
    class HyperReducedContactTest : public SampleSceneTest { };

    TEST_F(HyperReducedContactTest, CollidingCreaturesStayWithinHalfAPercent)
    {
        const Scene scene = sample_scene("creatures_collide");
        // 5k where the objects collide; 4k with collision off (then they touch only the ground).
        Scene apart = scene;
        apart.solver.collision = CollisionMode::off;
        using Setting = std::pair<const Scene*, int>;
        for (const auto& [setting, factor] : { Setting { &scene, 5 }, Setting { &apart, 4 } })
            for (const Body& body : load_bodies(*setting, SolverKind::hyper_reduced)) {
                const Model& model = body.model->pd();
                EXPECT_EQ(body.solver->local_stage().num_tets(),
                    std::min<Index>(factor * model.num_columns(), model.num_tets()));
            }
        const SampleRun run = run_sample(scene, SolverKind::hyper_reduced);
        EXPECT_LE(run.deepest, 0.005 * run.diagonal);
        EXPECT_LT(run.strain, 3.0);
        EXPECT_LE(run.highest_energy, run.start_energy * (1.0 + 1e-9));
    }

    // The results of a step do not depend on the thread count, through an impact whose contact
    // solve forms W over thousands of rows in parallel loops: creatures_collide's two creatures
    // meet at step 8, and by step 16 a step covers about 2600 rows (semi-reduced). An entry of W
    // must come out the same whichever share of a loop computes it (docs/method.md, "Pages and
    // wake-ups"). This test passed also before that was so: on this project's 2-core machines
    // the loops happened to split alike on 1 and 2 threads.
    class ContactThreadsTest : public SampleSceneTest { };

    TEST_F(ContactThreadsTest, AnImpactGivesTheSameBitsOnOneAndTwoThreads)
    {
        const Scene scene = sample_scene("creatures_collide");
        std::array<std::vector<MatX3>, 2> positions;
        for (const int threads : { 1, 2 }) {
            set_threads(threads);
            Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
            long contacts = 0;
            for (int s = 1; s <= 18; ++s) {
                simulation.step();
                for (const Body& body : simulation.bodies())
                    contacts += body.solver->report().contacts;
            }
            EXPECT_GT(contacts, 10000) << "the creatures no longer meet in these steps";
            for (const Body& body : simulation.bodies())
                positions[static_cast<std::size_t>(threads - 1)].push_back(body.state.positions);
        }
        set_threads(0);
        ASSERT_EQ(positions[0].size(), 2u);
        ASSERT_EQ(positions[1].size(), 2u);
        for (std::size_t b = 0; b < positions[0].size(); ++b)
            EXPECT_TRUE(positions[0][b] == positions[1][b]) << "body " << b;
    }

    // Sweeps through the bodies (docs/method.md, "Sweeps through the bodies"): the same
    // Gauss-Seidel sweeps as on W's columns, with the working points moved through the bodies'
    // node displacements instead, so the two give the same step but for rounding. The step in
    // which creatures_collide's two creatures meet (semi-reduced), every solve swept one way,
    // then the other: measured 2.2e-15 of the diagonal apart. (A step later they are about 1e-3
    // apart, as far as a change of the friction by 1 part in 1e12 takes the scene there: the
    // impact amplifies any change of rounding.) Before the planes of the contacts swept through
    // the bodies turned with the iterate, they were 2.9e-3 apart already in this step.
    class SweepsThroughBodiesTest : public SampleSceneTest { };

    TEST_F(SweepsThroughBodiesTest, GiveTheStepOfTheSweepsOnWsColumns)
    {
        const Scene scene = sample_scene("creatures_collide");
        constexpr int meeting = 8; // the step whose detection first finds the two together
        std::array<std::vector<MatX3>, 2> positions; // per way, per body
        double diagonal = std::numeric_limits<double>::infinity();
        for (const int through : { 0, 1 }) {
            std::vector<Body> bodies = load_bodies(scene, SolverKind::semi_reduced);
            for (Body& body : bodies) {
                SolverOptions options = body.solver->options();
                options.contact.through_bodies
                    = through ? 0.0 : std::numeric_limits<double>::infinity();
                options.contact.subspace_every = 0; // not taken through the bodies
                body.solver = make_solver(SolverKind::semi_reduced, body.model->pd(), options);
                diagonal = std::min(diagonal, body.model->rest_diagonal());
            }
            Simulation simulation(scene, std::move(bodies));
            for (int s = 1; s <= meeting; ++s)
                simulation.step();
            int candidates = 0, pushing = 0;
            for (const Body& body : simulation.bodies()) {
                candidates += body.solver->report().contacts;
                pushing += body.solver->report().active_contacts;
            }
            EXPECT_GT(candidates, 100) << "the creatures no longer meet in this step";
            EXPECT_GT(pushing, 0) << "the creatures no longer meet in this step";
            for (const Body& body : simulation.bodies())
                positions[static_cast<std::size_t>(through)].push_back(body.state.positions);
        }
        ASSERT_EQ(positions[0].size(), 2u);
        ASSERT_EQ(positions[1].size(), 2u);
        bool identical = true;
        double apart = 0.0;
        for (std::size_t b = 0; b < positions[0].size(); ++b) {
            identical = identical && positions[0][b] == positions[1][b];
            apart
                = std::max(apart, (positions[0][b] - positions[1][b]).rowwise().norm().maxCoeff());
        }
        EXPECT_LE(apart, 1e-12 * diagonal);
        EXPECT_FALSE(identical) << "the setting no longer changes how the sweeps run";
    }

    // Planes that follow the iterate (solver.contact_normals "iterate", reduced objects'
    // default; docs/method.md, "Planes that follow the iterate"), on their own
    // (solver.detect_in_step off, so that the contacts are the step start's, and no skin, as full
    // space ran before "Full space holds its planes"): three creatures dropped in a stack onto the
    // ground, full space, where the faces under a vertex tilt as the soft bodies give within a
    // step. With each plane turned to its face's normal at every iteration the deepest vertex stays
    // within 0.2% of the diagonal and no tet is stretched by more than 25%; with the step-start
    // planes ("step") the same scene sinks a vertex past 0.3% (measured: 1.2 mm and strain 1.00
    // against 5.9 mm and 1.00, on a 1.30 m creature). The energy never rises above its start either
    // way. At 15 iterations a step, not the sample's 10: at 10, the top creature's limb landing on
    // the ground at 5.3 m/s is far from its converged step, and the smallest change before it
    // decides how that one step ends. A rotation of 0.0033 kg m^2/s added a step earlier
    // (angular_momentum "keep", before the top touches anything) turned its largest strain from
    // 0.60 into 1.99 (one inverted tet); at 15 iterations both settings give 1.00 (friction
    // times 1 to 1.03), at 20 0.99 (docs/method.md, "Angular momentum").
    class PlanesFollowIterateTest : public SampleSceneTest { };

    TEST_F(PlanesFollowIterateTest, StackedBodiesRestOnTheirFaces)
    {
        Scene follow_scene = sample_scene("creature_stack",
            R"("detect_in_step": "off", "contact_normals": "iterate", "contact_skin": 0)");
        Scene held_scene = sample_scene("creature_stack",
            R"("detect_in_step": "off", "contact_normals": "step", "contact_skin": 0)");
        follow_scene.time.iterations = held_scene.time.iterations = 15;
        const SampleRun follow = run_sample(follow_scene, SolverKind::full);
        const SampleRun held = run_sample(held_scene, SolverKind::full);
        EXPECT_LE(follow.deepest, 0.002 * follow.diagonal);
        EXPECT_LE(follow.strain, 1.25);
        EXPECT_GT(held.deepest, 0.003 * held.diagonal) << "the scene no longer tells the two apart";
        for (const SampleRun& run : { follow, held })
            EXPECT_LE(run.highest_energy, run.start_energy * (1.0 + 1e-9));
    }

    // Full space holds its planes (docs/method.md, "Full space holds its planes"): with
    // solver.contact_normals and solver.detect_in_step at "auto" (their defaults), a full-space
    // body holds its contacts' planes for the step, keeps the skin and has its contacts found
    // again halfway through the step; reduced bodies turn their planes and keep the step start's
    // contacts; the explicit choices set every mode alike. (What the full-space defaults do on
    // the samples is CollisionSampleTest's "_full" cases.)
    class FullSpacePlanesTest : public test::ScratchDirTest { };

    TEST_F(FullSpacePlanesTest, AutoChoosesByModeAndExplicitChoicesSetEveryMode)
    {
        write_bake(path("capsule.h5"), test::sample_bake("capsule", 0.1));
        const auto options = [&](const std::string& keys, SolverKind kind) {
            const std::string text = fmt::format(R"({{
  "time": {{ "dt": 0.0333333333, "frames": 1, "iterations": 10 }},
  "solver": {{ "collision": "bounded"{} }},
  "objects": [ {{ "name": "a", "bake": "capsule.h5" }},
               {{ "name": "b", "bake": "capsule.h5", "position": [0, 1, 0] }} ]
}})",
                keys);
            const Scene scene = read_scene(write_text("scene.json", text));
            return load_bodies(scene, kind).at(0).solver->options();
        };
        for (const SolverKind kind :
            { SolverKind::full, SolverKind::semi_reduced, SolverKind::hyper_reduced }) {
            const bool full = kind == SolverKind::full;
            const SolverOptions automatic = options("", kind);
            EXPECT_EQ(automatic.planes_follow_iterate, !full);
            EXPECT_EQ(automatic.detect_in_step, full);
            EXPECT_TRUE(automatic.contact_skin);
            EXPECT_EQ(automatic.self_planes_follow_iterate, kind == SolverKind::hyper_reduced);
            const SolverOptions turning
                = options(R"(, "contact_normals": "iterate", "detect_in_step": "off")", kind);
            EXPECT_TRUE(turning.planes_follow_iterate);
            EXPECT_FALSE(turning.detect_in_step);
            const SolverOptions held
                = options(R"(, "contact_normals": "step", "detect_in_step": "on")", kind);
            EXPECT_FALSE(held.planes_follow_iterate);
            EXPECT_TRUE(held.detect_in_step);
        }
    }

    // Self contacts hold their planes in full space (docs/method.md, "Self contacts hold their
    // planes in full space"): drop_on_pile with every friction times 1.05, full space. When a
    // full-space body's self contacts turned their planes with the iterate beside the self skin,
    // the pile's total energy rose 0.23 J above its lowest at frame 23 (and in 5 of the 8 runs of
    // friction times 1.04 to 1.11, by 0.16-0.36 J); with their planes held for the step it rose
    // by less than 0.005 J in each of the 12 runs of 1.00 to 1.11 (frame by frame, --stats), not
    // at all in this one. Nothing drives this scene: gravity, friction and the contacts can only
    // take energy out.
    class SelfPlanesHeldTest : public SampleSceneTest { };

    /// The total energy at the start, its lowest over the scene's steps, and its largest rise
    /// above the lowest so far.
    struct EnergyRun {
        double start = 0.0, lowest = 0.0, rise = 0.0;
    };

    EnergyRun run_for_energy(Simulation& simulation, const Scene& scene)
    {
        EnergyRun run;
        run.start = run.lowest = total_energy(simulation, scene.gravity);
        const int steps = scene.frames * scene.steps_per_frame;
        for (int s = 1; s <= steps; ++s) {
            simulation.step();
            const double energy = total_energy(simulation, scene.gravity);
            run.rise = std::max(run.rise, energy - run.lowest);
            run.lowest = std::min(run.lowest, energy);
        }
        return run;
    }

    TEST_F(SelfPlanesHeldTest, AFullSpacePileNeverGainsEnergy)
    {
        Scene scene = sample_scene("drop_on_pile");
        scene.solver.collision_friction = 0.3 * 1.05;
        for (ColliderSettings& collider : scene.colliders)
            collider.friction *= 1.05;
        Simulation simulation(scene, load_bodies(scene, SolverKind::full));
        const EnergyRun run = run_for_energy(simulation, scene);
        EXPECT_LT(run.lowest, 0.5 * run.start) << "the pile no longer falls";
        EXPECT_LE(run.rise, 1e-9 * run.start);
    }

    // Semi-reduced bodies hold their self contacts' planes too (docs/method.md, "Self contacts
    // hold their planes"): creatures_collide raised to 30 iterations a step. With the planes
    // turning with the iterate, the left creature crushed at rest after the impact (strain 13.0
    // at frame 60, rising from frame 28) while the total energy rose 19.4 J above its lowest;
    // with them held, strain 1.84 at most and no rise. Nothing drives this scene after the bodies
    // are thrown: gravity, friction and the contacts can only take energy out.
    TEST_F(SelfPlanesHeldTest, ASemiReducedRunAtThirtyIterationsNeverGainsEnergy)
    {
        Scene scene = sample_scene("creatures_collide");
        scene.time.iterations = 30;
        Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
        const EnergyRun run = run_for_energy(simulation, scene);
        EXPECT_LT(run.lowest, 0.5 * run.start) << "the bodies no longer collide";
        EXPECT_LE(run.rise, 1e-9 * run.start);
    }

    // The compliance preload only for contacts at rest (docs/method.md, "Compliance"): a contact
    // whose point starts a step deeper than 0.05% of the diagonal behind its plane takes no
    // preload. Without that rule, full-space creatures_collide with its friction at 0.303 crushed
    // slowly at rest: a contact that cannot be met (its vertex pushed deep into the other
    // body) took the last step's force as its preload every step, so its force grew step after
    // step; the two creatures' elastic energy rose from 49 J at frame 18 to 531 J at frame 60,
    // the total energy to 1.44 times its start, strain 12.4. With it: strain 1.91, the energy
    // never above its start. Which run crushes follows rounding, so a change elsewhere may make
    // this one pass without the rule; the energy bound holds for any run all the same. Run with
    // full space's settings of then (planes that turn, no skin, no second search; docs/method.md,
    // "Full space holds its planes"): with today's defaults this scene's largest strain is one
    // frame's 2.62 at the impact (0.97 the frames before and after).
    class PreloadAtRestTest : public SampleSceneTest { };

    TEST_F(PreloadAtRestTest, AContactThatCannotBeMetIsNotHardened)
    {
        Scene scene = sample_scene("creatures_collide",
            R"("contact_normals": "iterate", "detect_in_step": "off", "contact_skin": 0)");
        scene.solver.collision_friction = 0.3 * 1.01; // 0.303, as the runs measured
        const SampleRun run = run_sample(scene, SolverKind::full);
        EXPECT_LE(run.highest_energy, run.start_energy * (1.0 + 1e-9));
        EXPECT_LE(run.strain, 2.5);
    }

} // namespace
} // namespace mat

namespace mat {
namespace {

    struct RestParam {
        const char* sample;
        double tet_size;
    };

    class SelfCollisionRestTest : public test::ScratchDirTest,
                                  public ::testing::WithParamInterface<RestParam> { };

    // Self collision never pairs what is near in the rest shape (a vertex and the faces of its
    // own surface within two collision margins at rest): a sample at rest with self collision
    // on, no gravity and no ground has no contact and no energy for 100 steps.
    TEST_P(SelfCollisionRestTest, BodyAtRestStaysAtRest)
    {
        const RestParam& p = GetParam();
        write_bake(path("body.h5"), test::sample_bake(p.sample, p.tet_size));
        const Scene scene = read_scene(write_text("scene.json", R"({
  "time": { "dt": 0.0333333333, "frames": 100, "iterations": 10 },
  "gravity": [0, 0, 0],
  "solver": { "self_collision": "on" },
  "objects": [ { "name": "body", "bake": "body.h5",
    "material": { "youngs_modulus": 5e4, "poisson_ratio": 0.4, "density": 1000 } } ]
})"));
        Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
        ASSERT_NE(simulation.collision(), nullptr);
        const Body& body = simulation.bodies()[0];
        for (int s = 1; s <= 100; ++s) {
            simulation.step();
            ASSERT_EQ(simulation.collision()->last_report().contacts, 0) << "step " << s;
        }
        const BodyMeasures m = measure_body(body.model->pd(), body.state, scene.gravity);
        EXPECT_LT(m.kinetic + m.elastic, 1e-12);
    }

    INSTANTIATE_TEST_SUITE_P(Samples, SelfCollisionRestTest,
        ::testing::Values(RestParam { "creature", 0.04 }, RestParam { "creature", 0.05 },
            RestParam { "capsule", 0.1 }, RestParam { "rounded_bar", 0.1 },
            RestParam { "torus", 0.1 }),
        [](const ::testing::TestParamInfo<RestParam>& info) {
            return std::string(info.param.sample) + "_"
                + std::to_string(static_cast<int>(100 * info.param.tet_size));
        });

} // namespace
} // namespace mat

namespace mat {
namespace {

    struct SlopeParam {
        SolverKind solver;
        double friction; ///< the plane's Coulomb coefficient
    };

    class ContactSlopeTest : public test::ScratchDirTest,
                             public ::testing::WithParamInterface<SlopeParam> { };

    const double kSlope = 20.0 * M_PI / 180.0;

    /// The plane's normal, (-sin 20, cos 20, 0): the slope rises along +x.
    Vec3 slope_normal()
    {
        return Vec3(-std::sin(kSlope), std::cos(kSlope), 0.0);
    }

    /// The scene: the flat block (the rounded bar, 0.76 x 0.16 x 0.36 m once turned by 90
    /// degrees about x) at rest on a plane through the origin tilted by 20 degrees about z, its
    /// long side along the slope (it cannot roll), its bottom face 0.1 mm above the plane. Only
    /// the plane's friction acts (the block is alone: solver.collision_friction, between bodies,
    /// plays no part). No sleeping: a creep must show.
    std::string slope_scene(const SlopeParam& p)
    {
        const Vec3 n = slope_normal();
        const Vec3 centre = 0.0801 * n;
        return fmt::format(R"({{
  "time": {{ "dt": 0.0166666667, "frames": 72, "iterations": 10 }},
  "gravity": [0, -9.81, 0],
  "solver": {{ "sleep_speed": 0 }},
  "colliders": [ {{ "type": "plane", "normal": [{}, {}, 0], "friction": {} }} ],
  "objects": [
    {{ "name": "block", "bake": "bar.h5", "position": [{}, {}, 0], "rotation_degrees": [90, 0, 20],
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 }} }}
  ]
}})",
            n.x(), n.y(), p.friction, centre.x(), centre.y());
    }

    /// The acceleration c of the least-squares fit s = a + b t + c t^2 / 2 over the samples.
    double fitted_acceleration(const std::vector<double>& t, const std::vector<double>& s)
    {
        const Index k = static_cast<Index>(t.size());
        MatX a(k, 3);
        VecX b(k);
        for (Index i = 0; i < k; ++i) {
            const double ti = t[static_cast<std::size_t>(i)];
            a.row(i) << 1.0, ti, 0.5 * ti * ti;
            b(i) = s[static_cast<std::size_t>(i)];
        }
        return a.colPivHouseholderQr().solve(b)(2);
    }

    // Coulomb friction on a slope, against the rigid-body answer (the contact issue's check): a
    // block at rest on a 20 degree slope stays with mu = 0.5 (tan 20 = 0.364 < mu) and slides
    // with mu = 0.2 at g (sin 20 - mu cos 20) = 1.5115 m/s^2, within 5%. The block settles onto
    // the plane in the first 0.15 s, its mass-weighted centroid moving 1.0-2.8 mm down the slope
    // as the soft block sags and shears. Staying: over the next second (0.2-1.2 s) the centroid
    // moves less than 1 mm along the slope (0.13% of the block's length; sliding at mu = 0.2 it
    // moves 1.07 m in that second). Sliding: the acceleration of a least-squares quadratic fit
    // of the centroid's position along the slope over 0.3-1.2 s. Measured (the fitted
    // acceleration and its relative error at mu = 0.2; the largest displacement over 0.2-1.2 s
    // at mu = 0.5): semi 1.5115407 m/s^2 (3e-8), 20 um; full 1.5115380 (-1.8e-6), 52 um; hyper
    // 1.5115408 (5e-8), 11 um. Both checks fail without friction: with mu = 0 on the plane the
    // fit gives g sin 20 = 3.355 m/s^2 (+122%), and mu = 0.2 in the staying check moves the
    // block 1.07 m.
    TEST_P(ContactSlopeTest, BlockStaysOrSlidesAtTheCoulombAcceleration)
    {
        const SlopeParam& p = GetParam();
        write_bake(path("bar.h5"), test::sample_bake("rounded_bar", 0.1));
        const Scene scene = read_scene(write_text("scene.json", slope_scene(p)));
        Simulation simulation(scene, load_bodies(scene, p.solver));
        const Body& block = simulation.bodies()[0];
        const VecX& m = block.model->pd().masses();
        const Vec3 n = slope_normal();
        const Vec3 down_slope(-std::cos(kSlope), -std::sin(kSlope), 0.0);
        const auto along
            = [&]() { return down_slope.dot(block.state.positions.transpose() * m / m.sum()); };
        const double start = along();
        const int steps = scene.frames * scene.steps_per_frame;
        std::vector<double> times;
        std::vector<double> distances; // along the slope since the start, from 0.2 s on
        for (int s = 1; s <= steps; ++s) {
            simulation.step();
            if (s * scene.time.dt < 0.2 - 1e-9)
                continue;
            times.push_back(s * scene.time.dt);
            distances.push_back(along() - start);
        }
        // On the plane at the end, neither sunk into it nor off it.
        EXPECT_NEAR((block.state.positions * n).minCoeff(), 0.0, 0.001);
        if (p.friction > std::tan(kSlope)) {
            double creep = 0.0;
            for (const double d : distances)
                creep = std::max(creep, std::abs(d - distances.front()));
            EXPECT_LT(creep, 0.001) << "mu " << p.friction;
            return;
        }
        std::vector<double> t;
        std::vector<double> d;
        for (std::size_t i = 0; i < times.size(); ++i)
            if (times[i] > 0.3 - 1e-9) {
                t.push_back(times[i]);
                d.push_back(distances[i]);
            }
        const double expected = 9.81 * (std::sin(kSlope) - p.friction * std::cos(kSlope));
        const double acceleration = fitted_acceleration(t, d);
        EXPECT_NEAR(acceleration, expected, 0.05 * expected) << "mu " << p.friction;
    }

    INSTANTIATE_TEST_SUITE_P(Contact, ContactSlopeTest,
        ::testing::Values(SlopeParam { SolverKind::semi_reduced, 0.5 },
            SlopeParam { SolverKind::semi_reduced, 0.2 }, SlopeParam { SolverKind::full, 0.5 },
            SlopeParam { SolverKind::full, 0.2 }, SlopeParam { SolverKind::hyper_reduced, 0.5 },
            SlopeParam { SolverKind::hyper_reduced, 0.2 }),
        [](const ::testing::TestParamInfo<SlopeParam>& info) {
            return std::string(info.param.solver == SolverKind::full        ? "full"
                           : info.param.solver == SolverKind::hyper_reduced ? "hyper"
                                                                            : "semi")
                + (info.param.friction > 0.3 ? "_stays_mu_0_5" : "_slides_mu_0_2");
        });

} // namespace
} // namespace mat
