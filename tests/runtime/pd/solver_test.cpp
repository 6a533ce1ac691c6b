// The projective dynamics solvers: rest, free fall against the closed-form implicit Euler
// trajectory, pins, the semi-reduced solver with a complete basis against the full-space one,
// convergence as handles are added, and independence of the thread count.

#include <cmath>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.hpp"
#include "common/parallel.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/solver.hpp"
#include "runtime/state.hpp"
#include "tests/runtime/pd/pd_test_support.hpp"
#include "tests/runtime/runtime_test_models.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    constexpr double dt = test::pd_dt;
    using test::run_steps;
    using test::twist_velocities;
    ModelOptions model_options()
    {
        return test::pd_model_options();
    }

    std::vector<int> nodes_with_x_below(const MatX3& positions, double x)
    {
        std::vector<int> nodes;
        for (Index i = 0; i < positions.rows(); ++i)
            if (positions(i, 0) < x)
                nodes.push_back(static_cast<int>(i));
        return nodes;
    }

    TEST(PdSolver, BodyAtRestStaysAtRest)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        SolverOptions options;
        options.gravity.setZero();
        PdSolver reduced = semi_reduced_solver(model, options);
        PdSolver full = full_solver(model, options);
        const State rest = State::at_rest(model);
        for (const State& end : { run_steps(reduced, rest, 5), run_steps(full, rest, 5) }) {
            EXPECT_LT((end.positions - rest.positions).cwiseAbs().maxCoeff(), 1e-10);
            EXPECT_LT(end.velocities.cwiseAbs().maxCoeff(), 1e-10);
        }
    }

    TEST(PdSolver, FreeFallFollowsImplicitEuler)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        SolverOptions options;
        options.gravity = Vec3(0.5, -9.81, 0.2);
        PdSolver reduced = semi_reduced_solver(model, options);
        PdSolver full = full_solver(model, options);
        const Eigen::RowVector3d v0(0.3, 1.0, -0.2);
        State start = State::at_rest(model);
        start.velocities.rowwise() = v0;
        State a = start, b = start, next;
        Eigen::RowVector3d v = v0, shift = Eigen::RowVector3d::Zero();
        for (int s = 0; s < 8; ++s) {
            // v_{n+1} = v_n + h g, x_{n+1} = x_n + h v_{n+1}.
            v += dt * options.gravity.transpose();
            shift += dt * v;
            reduced.step(a, next);
            std::swap(a, next);
            full.step(b, next);
            std::swap(b, next);
            for (const State* state : { &a, &b }) {
                MatX3 expected = start.positions;
                expected.rowwise() += shift;
                EXPECT_LT((state->positions - expected).cwiseAbs().maxCoeff(), 1e-9) << s;
                EXPECT_LT((state->velocities.rowwise() - v).cwiseAbs().maxCoeff(), 1e-9) << s;
            }
        }
    }

    /// A 1 x 0.25 x 0.25 bar of 4 x 2 x 2 cells with the identity basis.
    BakeData cantilever_bake()
    {
        test::GridTetOptions grid;
        grid.nx = 4;
        grid.ny = grid.nz = 2;
        grid.max_corner = Vec3(1.0, 0.25, 0.25);
        return test::make_identity_bake(grid);
    }

    TEST(PdSolver, PinnedNodesStayPut)
    {
        // A cantilever: the x = 0 face pinned, gravity along -y. The pin weight is 1e8 times the
        // largest diagonal entry, so a pinned node lags its target by ~1e-8 of the motion.
        const BakeData bake = cantilever_bake();
        ModelOptions options = model_options();
        options.pinned_nodes = nodes_with_x_below(bake.tet_mesh.positions, 1e-9);
        ASSERT_EQ(options.pinned_nodes.size(), 9u);
        Material soft;
        soft.youngs_modulus = 2e4;
        const Model model(bake, soft, options);
        PdSolver reduced = semi_reduced_solver(model);
        PdSolver full = full_solver(model);
        const State rest = State::at_rest(model);
        for (const State& end : { run_steps(reduced, rest, 20), run_steps(full, rest, 20) }) {
            const double sag = (end.positions - rest.positions).rowwise().norm().maxCoeff();
            EXPECT_GT(sag, 1e-3); // the free end moved
            for (const int i : options.pinned_nodes)
                EXPECT_LT((end.positions.row(i) - rest.positions.row(i)).norm(), 1e-7 * sag);
        }
    }

    double relative_difference(const MatX3& a, const MatX3& b, const MatX3& rest)
    {
        return (a - b).norm() / (b - rest).norm();
    }

    TEST(PdSolver, PinnedNodesFollowKinematicTargets)
    {
        // The pinned face of a cantilever is carried up and sideways along a prescribed path:
        // the pinned nodes track their moving targets, and the rest of the bar follows.
        const BakeData bake = cantilever_bake();
        ModelOptions options = model_options();
        options.pinned_nodes = nodes_with_x_below(bake.tet_mesh.positions, 1e-9);
        const Model model(bake, Material {}, options);
        SolverOptions no_gravity;
        no_gravity.gravity.setZero();
        for (const bool reduced_solver : { true, false }) {
            std::unique_ptr<PdSolver> solver;
            if (reduced_solver)
                solver = make_solver(SolverKind::semi_reduced, model, no_gravity);
            else
                solver = make_solver(SolverKind::full, model, no_gravity);
            State state = State::at_rest(model), next;
            MatX3 targets = model.pin_targets();
            for (int s = 1; s <= 30; ++s) {
                const Eigen::RowVector3d offset(0.0, 0.01 * s, 0.004 * s);
                targets = model.pin_targets().rowwise() + offset;
                solver->set_pin_targets(targets);
                solver->step(state, next);
                std::swap(state, next);
                for (std::size_t p = 0; p < options.pinned_nodes.size(); ++p)
                    EXPECT_LT((state.positions.row(options.pinned_nodes[p])
                                  - targets.row(static_cast<Index>(p)))
                                  .norm(),
                        1e-6)
                        << s;
            }
            // The rest of the bar was dragged along (the pinned end rose 0.3).
            const double mean_y = (state.positions.col(1) - model.rest_positions().col(1)).mean();
            EXPECT_GT(mean_y, 0.1);
            EXPECT_THROW(solver->set_pin_targets(MatX3::Zero(2, 3)), Error);
        }
    }

    TEST(PdSolver, CompleteBasisEqualsFullSpace)
    {
        test::GridTetOptions grid;
        grid.nx = grid.ny = grid.nz = 3;
        grid.jitter = 0.15;
        const BakeData bake = test::make_identity_bake(grid);
        for (const bool pinned : { false, true }) {
            ModelOptions options = model_options();
            if (pinned) {
                options.pinned_nodes = nodes_with_x_below(bake.tet_mesh.positions, 1e-9);
                options.pin_weight_scale = 1e4;
            }
            const Model model(bake, Material {}, options);
            PdSolver reduced = semi_reduced_solver(model);
            PdSolver full = full_solver(model);
            State start = State::at_rest(model);
            start.velocities = twist_velocities(start.positions);
            const State a = run_steps(reduced, start, 10);
            const State b = run_steps(full, start, 10);
            EXPECT_LT(relative_difference(a.positions, b.positions, start.positions), 1e-8)
                << "pinned " << pinned;
        }
    }

    using PdSolverBasis = test::ScratchDirTest;

    /// A medial mesh of `spheres` spheres on the cube's x axis joined by cones.
    std::string axis_medial_mesh(int spheres)
    {
        std::string text = fmt::format("{} {} 0\n", spheres, spheres - 1);
        for (int s = 0; s < spheres; ++s)
            text += fmt::format("v {} 0.5 0.5 0.3\n", 0.25 + 0.5 * s / (spheres - 1));
        for (int s = 0; s + 1 < spheres; ++s)
            text += fmt::format("e {} {}\n", s, s + 1);
        return text;
    }

    TEST_F(PdSolverBasis, ErrorDecreasesAsHandlesAreAdded)
    {
        std::vector<double> errors;
        for (const int spheres : { 2, 3, 5 }) {
            const std::string medial
                = write_text(fmt::format("axis{}.ma", spheres), axis_medial_mesh(spheres));
            const BakeData bake = test::bake_cube(medial);
            const Model model(bake, Material {}, model_options());
            PdSolver reduced = semi_reduced_solver(model);
            PdSolver full = full_solver(model);
            State start = State::at_rest(model);
            start.velocities = twist_velocities(start.positions);
            const State a = run_steps(reduced, start, 10);
            const State b = run_steps(full, start, 10);
            errors.push_back(relative_difference(a.positions, b.positions, start.positions));
        }
        const std::string trace = fmt::format(
            "relative errors with 2, 3, 5 spheres: {} {} {}", errors[0], errors[1], errors[2]);
        RecordProperty("relative_errors", trace);
        EXPECT_LT(errors[1], errors[0]) << trace;
        EXPECT_LT(errors[2], errors[1]) << trace;
        EXPECT_LT(errors[0], 1.0) << trace;
    }

    // The fast projections (the default) against the exact ones on a twisting cube: the same
    // trajectory up to the fast decomposition's accuracy, far below the reduction's error.
    TEST(PdSolver, FastProjectionsFollowTheExactOnes)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        State start = State::at_rest(model);
        start.velocities = twist_velocities(start.positions);
        SolverOptions exact, fast;
        exact.exact_projections = true;
        fast.exact_projections = false;
        PdSolver a = semi_reduced_solver(model, exact);
        PdSolver b = semi_reduced_solver(model, fast);
        PdSolver reference = full_solver(model, exact);
        const State end_exact = run_steps(a, start, 10);
        const State end_fast = run_steps(b, start, 10);
        const State end_full = run_steps(reference, start, 10);
        const double difference
            = relative_difference(end_fast.positions, end_exact.positions, start.positions);
        const double reduction
            = relative_difference(end_exact.positions, end_full.positions, start.positions);
        RecordProperty(
            "fast_vs_exact", fmt::format("{:.3g} (the reduction: {:.3g})", difference, reduction));
        EXPECT_GT(difference, 0.0); // the fast path did run
        EXPECT_LT(difference, 1e-5);
        EXPECT_LT(difference, 1e-3 * reduction);
    }

    TEST(PdSolver, ResultsDoNotDependOnTheThreadCount)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        State start = State::at_rest(model);
        start.velocities = twist_velocities(start.positions);
        std::vector<State> reduced_ends, full_ends;
        for (const int threads : { 1, 2 }) {
            set_threads(threads);
            PdSolver reduced = semi_reduced_solver(model);
            PdSolver full = full_solver(model);
            reduced_ends.push_back(run_steps(reduced, start, 5));
            full_ends.push_back(run_steps(full, start, 5));
        }
        set_threads(0);
        EXPECT_EQ(reduced_ends[0].positions, reduced_ends[1].positions);
        EXPECT_EQ(reduced_ends[0].velocities, reduced_ends[1].velocities);
        EXPECT_EQ(full_ends[0].positions, full_ends[1].positions);
    }

    TEST(PdSolver, RejectsBadInput)
    {
        const BakeData& bake = test::shipped_cube_bake();
        ModelOptions options = model_options();
        Material material;
        material.poisson_ratio = 0.5;
        EXPECT_THROW(Model(bake, material, options), Error);
        options.pinned_nodes = { 0, 0 };
        EXPECT_THROW(Model(bake, Material {}, options), Error);
        options.pinned_nodes = { static_cast<int>(bake.tet_mesh.num_vertices()) };
        EXPECT_THROW(Model(bake, Material {}, options), Error);
        const Model model(bake, Material {}, model_options());
        PdSolver reduced = semi_reduced_solver(model);
        State rest = State::at_rest(model), out;
        rest.positions.conservativeResize(3, 3);
        EXPECT_THROW(reduced.step(rest, out), Error);
    }

} // namespace
} // namespace mat
