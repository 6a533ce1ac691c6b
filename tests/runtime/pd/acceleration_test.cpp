// The accelerated iteration (Anderson acceleration with its safeguard, docs/method.md,
// "Accelerated iterations") in every solver mode: closer to the converged step than plain PD at
// the same iteration count, the PD energy of the accepted iterates never rising within a step,
// the local step's energy against the brute-force measure, the hyper-reduced residual safeguard,
// momentum kept without external forces, independence of the thread count, plain steps in
// contact, and the Anderson extrapolation itself on a linear fixed-point map whose solution is
// known. Also the iterations to a tolerance: where they stop against the converged step.

#include <cmath>
#include <memory>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/error.hpp"
#include "common/parallel.hpp"
#include "runtime/measures/body_measures.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/anderson.hpp"
#include "runtime/pd/pd_energy.hpp"
#include "runtime/pd/solver.hpp"
#include "runtime/state.hpp"
#include "tests/runtime/pd/pd_test_support.hpp"
#include "tests/runtime/runtime_test_models.hpp"

namespace mat {
namespace {

    using test::run_steps;
    using test::twist_velocities;

    constexpr SolverKind all_kinds[]
        = { SolverKind::semi_reduced, SolverKind::full, SolverKind::hyper_reduced };

    const char* kind_name(SolverKind kind)
    {
        return kind == SolverKind::full        ? "full"
            : kind == SolverKind::semi_reduced ? "semi"
                                               : "hyper";
    }

    /// The shipped cube, pinned at x < 0.15 (a cantilever), stiff enough that plain PD converges
    /// slowly.
    const Model& test_model()
    {
        static const Model model = [] {
            const BakeData& bake = test::shipped_cube_bake();
            ModelOptions options = test::pd_model_options();
            // Soft pins, as the scenes give reduced bodies (solver.reduced_pin_stiffness): stiff
            // ones freeze every handle that reaches into the pinned region.
            options.pin_weight_scale = 1.0;
            for (Index i = 0; i < bake.tet_mesh.positions.rows(); ++i)
                if (bake.tet_mesh.positions(i, 0) < 0.15)
                    options.pinned_nodes.push_back(static_cast<int>(i));
            Material material;
            material.youngs_modulus = 1e6;
            material.poisson_ratio = 0.4;
            return Model(bake, material, options);
        }();
        return model;
    }

    /// Hyper-reduced with half the tets sampled (the automatic count samples them all here).
    std::unique_ptr<PdSolver> solver_of(SolverKind kind, const SolverOptions& options)
    {
        const Model& model = test_model();
        return make_solver(kind, model, options, model.num_tets() / 2);
    }

    SolverOptions options_with(int iterations, Acceleration acceleration)
    {
        SolverOptions options;
        options.iterations = iterations;
        options.acceleration = acceleration;
        return options;
    }

    State twisted_start()
    {
        State start = State::at_rest(test_model());
        start.velocities = twist_velocities(start.positions);
        return start;
    }

    double rms_distance(const MatX3& a, const MatX3& b)
    {
        return std::sqrt((a - b).rowwise().squaredNorm().mean());
    }

    TEST(Acceleration, CloserToTheConvergedStepThanPlainPd)
    {
        const State start = twisted_start();
        for (const SolverKind kind : all_kinds) {
            // Two steps: the second starts from a deformed, moving state.
            const State converged
                = run_steps(*solver_of(kind, options_with(400, Acceleration::none)), start, 2);
            for (const int iterations : { 8, 15 }) {
                const State plain = run_steps(
                    *solver_of(kind, options_with(iterations, Acceleration::none)), start, 2);
                auto solver = solver_of(kind, options_with(iterations, Acceleration::anderson));
                const State accelerated = run_steps(*solver, start, 2);
                const double plain_error = rms_distance(plain.positions, converged.positions);
                const double error = rms_distance(accelerated.positions, converged.positions);
                RecordProperty(fmt::format("{}_{}", kind_name(kind), iterations),
                    fmt::format("plain {:.3g}, anderson {:.3g}, accelerated {} refused {}",
                        plain_error, error, solver->timings().accelerated,
                        solver->timings().refused));
                EXPECT_GT(solver->timings().accelerated, 0) << kind_name(kind);
                EXPECT_LT(error, 0.5 * plain_error) << kind_name(kind) << " " << iterations;
            }
        }
    }

    /// The energies report().energy takes after each iterate() of one step of `solver` from
    /// `in`; `check(iteration, positions)` runs on each iterate the local step read.
    template <typename Check>
    std::vector<double> step_energies(PdSolver& solver, const State& in, const Check& check)
    {
        State out;
        std::vector<double> energies;
        solver.begin_step(in, out);
        for (int i = 0; i < solver.options().iterations; ++i) {
            const MatX3 iterate = out.positions;
            solver.iterate(i);
            energies.push_back(solver.last_report().energy);
            check(i, iterate, energies.back());
            solver.finish_iteration(i, i + 1 == solver.options().iterations);
        }
        solver.end_step();
        return energies;
    }

    TEST(Acceleration, AcceptedIteratesNeverRaiseTheEnergy)
    {
        // A local/global iteration never raises the PD energy (it minimizes over the projections,
        // then over the positions; a reduced solve over the subspace, from iteration 1, when the
        // iterate is in it), and the safeguard accepts an extrapolation only if it does not
        // either. The hyper-reduced fit is not a descent of any energy: not checked here.
        // Exact projections: the fast ones' energy is exact to about 1e-5 of the singular
        // values' spread only, which near convergence is more than an iteration's decrease.
        // Without the safeguard this case raises the energy (by 2.7e-5 relative in full space
        // with a window of 2, 4e-11 semi-reduced with 5): the test fails.
        const BakeData& bake = test::shipped_cube_bake();
        ModelOptions model_options = test::pd_model_options();
        model_options.volume_tolerance = 0.0;
        Material material;
        material.youngs_modulus = 1e6;
        material.poisson_ratio = 0.45;
        const Model model(bake, material, model_options);
        State start = State::at_rest(model);
        start.velocities = twist_velocities(start.positions);
        long refused = 0;
        for (const int window : { 2, 5 })
            for (const SolverKind kind : { SolverKind::semi_reduced, SolverKind::full }) {
                SolverOptions options = options_with(30, Acceleration::anderson);
                options.anderson_window = window;
                options.exact_projections = true;
                auto solver = make_solver(kind, model, options);
                const State state = run_steps(*solver, start, 1);
                const long refused_before = solver->timings().refused;
                const std::vector<double> energies
                    = step_energies(*solver, state, [](int, const MatX3&, double) {});
                refused += solver->timings().refused - refused_before;
                const int first = kind == SolverKind::full ? 0 : 1;
                for (std::size_t i = first + 1; i < energies.size(); ++i)
                    EXPECT_LE(energies[i], energies[i - 1] * (1.0 + 1e-12))
                        << kind_name(kind) << " window " << window << " iteration " << i;
                EXPECT_LT(energies.back(), 0.99 * energies[first]) << kind_name(kind);
            }
        EXPECT_GT(refused, 0); // the safeguard acted
    }

    TEST(Acceleration, EnergyIsThePdEnergyOfTheIterate)
    {
        // Exact projections: the local step's energy against measure_body's brute-force elastic
        // energy (one SVD per projection, double precision), plus inertia and pins.
        const Model& model = test_model();
        SolverOptions options = options_with(12, Acceleration::anderson);
        options.exact_projections = true;
        for (const SolverKind kind : { SolverKind::semi_reduced, SolverKind::full }) {
            auto solver = solver_of(kind, options);
            const State state = run_steps(*solver, twisted_start(), 1);
            int checked = 0;
            step_energies(*solver, state, [&](int, const MatX3& iterate, double energy) {
                const State at { iterate, MatX3::Zero(iterate.rows(), 3) };
                const double expected = measure_body(model, at, Vec3::Zero()).elastic
                    + inertia_energy(model, iterate, solver->inertia_target())
                    + pin_energy(model, iterate, solver->pin_targets());
                EXPECT_NEAR(energy, expected, 1e-9 * expected) << kind_name(kind);
                ++checked;
            });
            EXPECT_EQ(checked, 12);
        }
    }

    TEST(Acceleration, HyperReducedSafeguardIsTheResidual)
    {
        // The hyper-reduced fit is not the descent of an energy: its safeguard measure is the
        // fixed-point residual |G(q) - q|_W, which falls to the solver's precision as the step
        // converges (undefined at iteration 0: s is outside the subspace).
        auto solver
            = solver_of(SolverKind::hyper_reduced, options_with(25, Acceleration::anderson));
        const State state = run_steps(*solver, twisted_start(), 1);
        const std::vector<double> residuals
            = step_energies(*solver, state, [](int, const MatX3&, double) {});
        EXPECT_TRUE(std::isinf(residuals[0]));
        EXPECT_GT(residuals[1], 0.0);
        EXPECT_LT(residuals.back(), 1e-6 * residuals[1]);
        RecordProperty(
            "residuals", fmt::format("{:.3g} -> {:.3g}", residuals[1], residuals.back()));
    }

    TEST(Acceleration, KeepsMomentumWithoutExternalForces)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, test::pd_model_options());
        SolverOptions options = options_with(10, Acceleration::anderson);
        options.gravity.setZero();
        State start = State::at_rest(model);
        start.velocities = twist_velocities(start.positions);
        start.velocities.rowwise() += Eigen::RowVector3d(0.3, -0.2, 0.1);
        const auto momentum = [&](const State& s) -> Vec3 {
            return (model.masses().asDiagonal() * s.velocities).colwise().sum().transpose();
        };
        const double scale
            = (model.masses().asDiagonal() * start.velocities.rowwise().norm()).sum();
        for (const SolverKind kind : all_kinds) {
            auto solver = make_solver(kind, model, options, model.num_tets() / 2);
            const State end = run_steps(*solver, start, 10);
            EXPECT_GT(solver->timings().accelerated, 0) << kind_name(kind);
            EXPECT_LT((momentum(end) - momentum(start)).norm(), 1e-9 * scale) << kind_name(kind);
        }
    }

    TEST(Acceleration, ResultsDoNotDependOnTheThreadCount)
    {
        const State start = twisted_start();
        for (const SolverKind kind : all_kinds) {
            std::vector<State> ends;
            for (const int threads : { 1, 2 }) {
                set_threads(threads);
                ends.push_back(run_steps(
                    *solver_of(kind, options_with(12, Acceleration::anderson)), start, 3));
            }
            set_threads(0);
            EXPECT_EQ(ends[0].positions, ends[1].positions) << kind_name(kind);
            EXPECT_EQ(ends[0].velocities, ends[1].velocities) << kind_name(kind);
        }
    }

    TEST(Acceleration, ContactStepsRunPlain)
    {
        // A ground plane under the cube: every step has contact candidates, so the accelerated
        // solver takes the plain iteration and its steps are the plain solver's.
        SolverOptions plain = options_with(10, Acceleration::none);
        plain.planes.push_back(PlaneCollider { Vec3(0.0, 0.0, 0.0), Vec3(0.0, 1.0, 0.0), 0.5 });
        SolverOptions accelerated = plain;
        accelerated.acceleration = Acceleration::anderson;
        const State start = twisted_start();
        auto a = solver_of(SolverKind::semi_reduced, plain);
        auto b = solver_of(SolverKind::semi_reduced, accelerated);
        const State end_a = run_steps(*a, start, 3);
        const State end_b = run_steps(*b, start, 3);
        EXPECT_GT(b->last_report().contacts, 0);
        EXPECT_EQ(b->timings().accelerated + b->timings().refused, 0);
        EXPECT_EQ(end_a.positions, end_b.positions);
    }

    TEST(AndersonAcceleration, SolvesALinearFixedPointInFewIterations)
    {
        // G(u) = T u + c with a contraction T (spectral radius 0.95): plain iteration reduces
        // the error by 0.95 per step; Anderson with a window of the dimension is GMRES on
        // (I - T) u = c and converges in about dimension + 1 steps. Vectors of 5000 entries
        // (several blocks of the passes), T block diagonal with 4 x 4 blocks.
        constexpr Index n = 5000;
        Eigen::Matrix4d block;
        block << 0.95, 0.1, 0.0, 0.0, -0.1, 0.5, 0.2, 0.0, 0.0, 0.0, 0.3, -0.2, 0.05, 0.0, 0.0, 0.1;
        VecX c = VecX::LinSpaced(n, -1.0, 2.0);
        const auto apply = [&](const VecX& u) {
            VecX out(n);
            for (Index i = 0; i < n; i += 4)
                out.segment<4>(i) = block * u.segment<4>(i) + c.segment<4>(i);
            return out;
        };
        VecX solution(n);
        for (Index i = 0; i < n; i += 4)
            solution.segment<4>(i)
                = (Eigen::Matrix4d::Identity() - block).inverse() * c.segment<4>(i);
        AndersonAcceleration anderson;
        anderson.configure(n, 5, VecX::Ones(n));
        VecX u = VecX::Zero(n), plain = VecX::Zero(n);
        anderson.start(u.data());
        for (int k = 0; k < 8; ++k) {
            VecX g = apply(u);
            anderson.advance(g.data());
            u = g;
            plain = apply(plain);
        }
        const double error = (u - solution).norm() / solution.norm();
        const double plain_error = (plain - solution).norm() / solution.norm();
        RecordProperty("errors", fmt::format("anderson {:.3g}, plain {:.3g}", error, plain_error));
        EXPECT_LT(error, 1e-8);
        EXPECT_GT(plain_error, 0.1);
        // The fallback returns the last plain iterate G(u_prev) and clears the history.
        VecX last_plain = apply(u);
        VecX g = last_plain;
        anderson.advance(g.data());
        VecX back(n);
        anderson.fall_back(back.data());
        EXPECT_EQ(back, last_plain);
        EXPECT_EQ(anderson.history(), 0);
    }

} // namespace
} // namespace mat
namespace mat {
namespace {

    // Iterations to a tolerance (SolverOptions::tolerance; docs/method.md, "Iterations to a
    // tolerance"): a step stops once the iterate is estimated to be within the tolerance of the
    // converged step. Plain PD, two steps of the twisted cantilever, against 3000 iterations.
    // Measured (distance relative to the diagonal / tolerance): 0.6-0.7 semi- and
    // hyper-reduced, 3.1-3.6 full space (its slowest modes take over late, so the contraction the
    // estimate reads is below the one still to come).
    TEST(Tolerance, StopsNearTheConvergedStep)
    {
        const State start = twisted_start();
        const double diagonal = std::sqrt(3.0); // the unit cube's
        for (const SolverKind kind : all_kinds) {
            SCOPED_TRACE(kind_name(kind));
            const State converged
                = run_steps(*solver_of(kind, options_with(3000, Acceleration::none)), start, 2);
            double errors[2] = {};
            long iterations[2] = {};
            const double tolerances[2] = { 1e-4, 1e-6 };
            for (int t = 0; t < 2; ++t) {
                SolverOptions options = options_with(3000, Acceleration::none);
                options.tolerance = tolerances[t];
                const std::unique_ptr<PdSolver> solver = solver_of(kind, options);
                const State got = run_steps(*solver, start, 2);
                errors[t] = rms_distance(got.positions, converged.positions) / diagonal;
                iterations[t] = solver->timings().iterations;
                EXPECT_LE(errors[t], 5.0 * tolerances[t]) << "tolerance " << tolerances[t];
                EXPECT_LT(iterations[t], 2 * 3000) << "tolerance " << tolerances[t];
            }
            // A hundredth of the tolerance takes more iterations and lands closer.
            EXPECT_GT(iterations[1], iterations[0]);
            EXPECT_LT(errors[1], 0.05 * errors[0]);
        }
    }

} // namespace
} // namespace mat
