// The GPU step (--device cuda) against the CPU path on the sample creature: the same scene run
// both ways, 100 steps. Without a GPU (or in a build without CUDA) the comparisons skip with the
// reason, and the error a user gets is checked instead.

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "common/error.hpp"
#include "preprocess/meshing/cgal_mesh3.hpp"
#include "runtime/gpu/device_step.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/local_step.hpp"
#include "runtime/pd/solver.hpp"
#include "tests/support/sample_bake.hpp"

namespace mat {
namespace {

    const BakeData& creature()
    {
        return test::sample_bake("creature", k_default_tet_size);
    }

    double diagonal(const Model& model)
    {
        const MatX3& rest = model.rest_positions();
        return (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
    }

    /// Kinetic + gravitational + elastic energy of a state (the elastic part from the CPU's
    /// exact projections).
    double energy(const Model& model, const State& state, const Vec3& gravity)
    {
        double kinetic = 0.0, potential = 0.0;
        for (Index i = 0; i < model.num_nodes(); ++i) {
            kinetic += 0.5 * model.masses()(i) * state.velocities.row(i).squaredNorm();
            potential -= model.masses()(i) * gravity.dot(state.positions.row(i).transpose());
        }
        LocalStep local(model, true);
        local.set_energy(true);
        local.project(model, state.positions);
        return kinetic + potential + local.energy();
    }

    double max_distance(const State& a, const State& b)
    {
        return (a.positions - b.positions).rowwise().norm().maxCoeff();
    }

    struct RunResult {
        State state;
        double max_pin_error = 0.0; ///< over the steps
        double max_penetration = 0.0;
    };

    RunResult simulate(const Model& model, SolverOptions options, Device device, int steps)
    {
        options.device = device;
        // The GPU step does not keep angular momentum (docs/gpu.md): both paths run without.
        options.angular_momentum = AngularMomentum::integrator;
        const std::unique_ptr<PdSolver> solver
            = make_solver(SolverKind::semi_reduced, model, options);
        RunResult out;
        State next;
        out.state.positions = model.rest_positions();
        out.state.velocities = MatX3::Zero(model.num_nodes(), 3);
        // A spin about the centre: every handle's rotation is exercised.
        const Vec3 centre = model.rest_positions().colwise().mean().transpose();
        for (Index i = 0; i < model.num_nodes(); ++i)
            out.state.velocities.row(i)
                = Vec3(0.0, 2.0, 1.0).cross(model.rest_positions().row(i).transpose() - centre);
        for (const int i : model.pinned_nodes())
            out.state.velocities.row(i).setZero();
        for (int step = 0; step < steps; ++step) {
            solver->step(out.state, next);
            std::swap(out.state, next);
            // The GPU keeps the state between steps: brought over only when read (as the
            // simulation does), here every step only where pins are checked.
            if (model.pinned_nodes().empty())
                continue;
            solver->sync_state(out.state);
            const auto& pins = model.pinned_nodes();
            for (std::size_t p = 0; p < pins.size(); ++p)
                out.max_pin_error = std::max(out.max_pin_error,
                    (out.state.positions.row(pins[p]) - model.pin_targets().row(p)).norm());
            out.max_penetration
                = std::max(out.max_penetration, solver->last_report().max_penetration);
        }
        solver->sync_state(out.state);
        return out;
    }

    /// The creature of the free-spin tests: soft (E 5e4 Pa, nu 0.4), dt 1/30 s.
    Model spinning_creature()
    {
        ModelOptions model_options;
        model_options.time_step = 1.0 / 30.0;
        Material material;
        material.youngs_modulus = 5e4;
        material.poisson_ratio = 0.4;
        return Model(creature(), material, model_options);
    }

    class DeviceStep : public ::testing::Test {
    protected:
        void SetUp() override
        {
            const std::string reason = cuda_unavailable_reason();
            if (!reason.empty())
                GTEST_SKIP() << "no GPU step to compare: " << reason;
        }
    };

    TEST_F(DeviceStep, FreeSpinMatchesTheCpuPath)
    {
        const Model model = spinning_creature();
        SolverOptions options;
        options.iterations = 10;
        const RunResult cpu = simulate(model, options, Device::cpu, 100);
        const RunResult gpu = simulate(model, options, Device::cuda, 100);
        const double diag = diagonal(model);
        const double distance = max_distance(gpu.state, cpu.state);
        EXPECT_LE(distance, 1e-4 * diag);
        const double e_cpu = energy(model, cpu.state, options.gravity);
        const double e_gpu = energy(model, gpu.state, options.gravity);
        const double e_start = [&] {
            State start;
            start.positions = model.rest_positions();
            start.velocities = MatX3::Zero(model.num_nodes(), 3);
            return std::abs(energy(model, start, options.gravity));
        }();
        // Relative to the energy's size (the potential's zero is arbitrary): kinetic + elastic.
        const double scale = std::max(std::abs(e_cpu), e_start);
        EXPECT_LE(std::abs(e_gpu - e_cpu), 1e-3 * scale) << e_cpu << " vs " << e_gpu;
        std::printf("free spin, 100 steps: max node distance %.3g of the diagonal, energy %.9g "
                    "(CPU) vs %.9g (GPU)\n",
            distance / diag, e_cpu, e_gpu);
    }

    TEST_F(DeviceStep, ExactProjectionsMatchTheCpuPath)
    {
        // solver.projections exact: double Jacobi and QR on both sides.
        const Model model = spinning_creature();
        SolverOptions options;
        options.iterations = 10;
        options.exact_projections = true;
        const RunResult cpu = simulate(model, options, Device::cpu, 50);
        const RunResult gpu = simulate(model, options, Device::cuda, 50);
        const double distance = max_distance(gpu.state, cpu.state);
        EXPECT_LE(distance, 1e-4 * diagonal(model));
        std::printf("exact projections, free spin, 50 steps: max node distance %.3g of the "
                    "diagonal\n",
            distance / diagonal(model));
    }

    TEST_F(DeviceStep, PinsAndGroundMatchTheCpuPath)
    {
        // Hung by its highest nodes over a ground plane it sags onto.
        const BakeData& bake = creature();
        ModelOptions model_options;
        model_options.time_step = 1.0 / 30.0;
        const MatX3& rest = bake.tet_mesh.positions;
        const double top = rest.col(1).maxCoeff(), bottom = rest.col(1).minCoeff();
        for (Index i = 0; i < rest.rows(); ++i)
            if (rest(i, 1) > top - 0.05 * (top - bottom))
                model_options.pinned_nodes.push_back(static_cast<int>(i));
        ASSERT_GT(model_options.pinned_nodes.size(), 3u);
        Material material;
        material.youngs_modulus = 2e4;
        const Model model(bake, material, model_options);
        SolverOptions options;
        options.iterations = 10;
        PlaneCollider ground;
        ground.point = Vec3(0.0, bottom + 0.02 * (top - bottom), 0.0);
        ground.normal = Vec3(0.0, 1.0, 0.0);
        ground.friction = 0.3;
        options.planes.push_back(ground);
        const RunResult cpu = simulate(model, options, Device::cpu, 100);
        const RunResult gpu = simulate(model, options, Device::cuda, 100);
        const double diag = diagonal(model);
        const double distance = max_distance(gpu.state, cpu.state);
        EXPECT_LE(distance, 1e-4 * diag);
        // Pins held as on the CPU (the soft pins' lag, ~1e-8 of the size).
        EXPECT_LE(gpu.max_pin_error, cpu.max_pin_error + 1e-6 * diag);
        // The ground: touched, and held as on the CPU.
        EXPECT_GT(cpu.max_penetration, 0.0);
        EXPECT_LE(gpu.max_penetration, cpu.max_penetration + 1e-4 * diag);
        double lowest = 1e300;
        for (Index i = 0; i < model.num_nodes(); ++i)
            lowest = std::min(lowest, gpu.state.positions(i, 1) - ground.point.y());
        EXPECT_GE(lowest, -gpu.max_penetration - 1e-12);
        std::printf("pinned over the ground, 100 steps: max node distance %.3g of the diagonal, "
                    "pin error %.3g (CPU %.3g), penetration %.3g (CPU %.3g)\n",
            distance / diag, gpu.max_pin_error, cpu.max_pin_error, gpu.max_penetration,
            cpu.max_penetration);
    }

    TEST(DeviceStepErrors, OnlyTheSemiReducedSolverRunsThere)
    {
        const Model model(creature(), Material {}, ModelOptions {});
        SolverOptions options;
        options.device = Device::cuda;
        for (const SolverKind kind : { SolverKind::full, SolverKind::hyper_reduced })
            try {
                make_solver(kind, model, options);
                FAIL() << "a full or hyper-reduced solver on the GPU was made";
            } catch (const Error& e) {
                EXPECT_NE(std::string(e.what()).find("semi-reduced solver only"), std::string::npos)
                    << e.what();
            }
    }

    TEST(DeviceStepErrors, NoGpuIsOneClearError)
    {
        const std::string reason = cuda_unavailable_reason();
        if (reason.empty())
            GTEST_SKIP() << "this machine has a usable GPU";
        const Model model(creature(), Material {}, ModelOptions {});
        SolverOptions options;
        options.device = Device::cuda;
        try {
            make_solver(SolverKind::semi_reduced, model, options);
            FAIL() << "a GPU solver was made without a GPU";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("--device cuda: " + reason), std::string::npos)
                << e.what();
        }
    }

} // namespace
} // namespace mat
