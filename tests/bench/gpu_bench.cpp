// The GPU step against the CPU path on the same machine (tests/bench/gpu_bench.sh; docs/gpu.md):
// per bake, the creature spinning in free fall (run_bench.sh's scene: E 5e4 Pa, nu 0.4, 1000
// kg/m^3, dt 1/30 s, 10 iterations, no ground), semi-reduced,
//   cpu:       the CPU path on THREADS threads (default: all cores), ms per step and its phases;
//   gpu:       PdSolver with --device cuda as mat-run steps a scene without collision detection
//              (the state stays on the GPU between steps);
//   gpu+sync:  the same with the state brought to the host after every step, as mat-run does
//              when collision detection (on the CPU) reads it;
//   phases:    the gpu steps again with a CUDA event after each phase (slower in all; the split,
//              and the local step's ns per tet per iteration, come from it).
// Each timing is the median of ROUNDS rounds of STEPS steps, after warm-up steps. The last
// positions of the CPU and GPU runs of the same steps are compared (max node distance over the
// bake's diagonal).
// Usage: gpu_bench [--steps S] [--rounds R] [--threads T] BAKE.h5...

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "common/parallel.hpp"
#include "common/timer.hpp"
#include "formats/bake_io.hpp"
#include "runtime/gpu/device_step.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/solver.hpp"

namespace {

using namespace mat;

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

State start_state(const Model& model)
{
    State state;
    state.positions = model.rest_positions();
    state.velocities.resize(model.num_nodes(), 3);
    const Vec3 centre = model.rest_positions().colwise().mean().transpose();
    for (Index i = 0; i < model.num_nodes(); ++i)
        state.velocities.row(i)
            = Vec3(0.0, 2.0, 1.0).cross(model.rest_positions().row(i).transpose() - centre);
    return state;
}

/// Steps `solver` `steps` times from `state` (updated, swapped as the simulation swaps it),
/// bringing it to the host after each step with `sync` and after the last one always; returns
/// ms per step.
double run_steps(PdSolver& solver, State& state, int steps, bool sync = false)
{
    State next;
    Timer timer;
    for (int s = 0; s < steps; ++s) {
        solver.step(state, next);
        std::swap(state, next);
        if (sync)
            solver.sync_state(state);
    }
    solver.sync_state(state);
    return 1e3 * timer.seconds() / steps;
}

void bench(const std::string& path, int steps, int rounds)
{
    const BakeData bake = read_bake(path);
    ModelOptions model_options;
    model_options.time_step = 1.0 / 30.0;
    Material material;
    material.youngs_modulus = 5e4;
    material.poisson_ratio = 0.4;
    const Model model(bake, material, model_options);
    SolverOptions options;
    options.iterations = 10;
    const MatX3& rest = model.rest_positions();
    const double diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
    std::printf("== %s: %ld tets, %ld nodes, %ld handles, %ld columns\n", path.c_str(),
        static_cast<long>(model.num_tets()), static_cast<long>(model.num_nodes()),
        static_cast<long>(model.handle_centers().rows()), static_cast<long>(model.num_columns()));

    const std::unique_ptr<PdSolver> cpu = make_solver(SolverKind::semi_reduced, model, options);
    options.device = Device::cuda;
    const std::unique_ptr<PdSolver> gpu = make_solver(SolverKind::semi_reduced, model, options);
    DeviceSemiStep& device = *gpu->device();
    std::printf("device: %s\n", device.description().c_str());
    // Warm-up (and the comparison: the same 3 steps both ways).
    State cpu_state = start_state(model), gpu_state = start_state(model);
    run_steps(*cpu, cpu_state, 3);
    run_steps(*gpu, gpu_state, 3);
    const double distance
        = (gpu_state.positions - cpu_state.positions).rowwise().norm().maxCoeff() / diagonal;
    std::vector<double> cpu_ms, gpu_ms, sync_ms;
    const SolverTimings before = cpu->timings();
    for (int r = 0; r < rounds; ++r) {
        cpu_ms.push_back(run_steps(*cpu, cpu_state, steps));
        gpu_ms.push_back(run_steps(*gpu, gpu_state, steps));
        sync_ms.push_back(run_steps(*gpu, gpu_state, steps, true));
    }
    const SolverTimings& after = cpu->timings();
    const double cpu_steps = static_cast<double>(after.steps - before.steps);
    // The phases: a profiled run.
    const DeviceTimings base = device.timings();
    device.set_profiling(true);
    run_steps(*gpu, gpu_state, steps);
    device.set_profiling(false);
    const DeviceTimings& t = device.timings();
    const auto phase
        = [&](double DeviceTimings::*field) { return 1e3 * (t.*field - base.*field) / steps; };
    const double local = phase(&DeviceTimings::local);
    std::printf("max node distance GPU - CPU after 3 steps: %.3g of the diagonal\n", distance);
    std::printf(
        "%-28s%10s%10s%10s%10s\n", "ms per step (median)", "cpu", "gpu", "gpu+sync", "cpu/gpu");
    std::printf("%-28s%10.3f%10.3f%10.3f%10.1f\n", "", median(cpu_ms), median(gpu_ms),
        median(sync_ms), median(cpu_ms) / median(gpu_ms));
    std::printf("cpu phases ms/step: local %.3f  rhs %.3f  solve %.3f  reconstruct %.3f\n",
        1e3 * (after.local - before.local) / cpu_steps, 1e3 * (after.rhs - before.rhs) / cpu_steps,
        1e3 * (after.solve - before.solve) / cpu_steps,
        1e3 * (after.reconstruct - before.reconstruct) / cpu_steps);
    std::printf("gpu phases ms/step (profiled): local %.3f  gather %.3f  B^T y %.3f  solve %.3f  "
                "reconstruct %.3f  begin/end %.3f\n",
        local, phase(&DeviceTimings::gather), phase(&DeviceTimings::rhs),
        phase(&DeviceTimings::solve), phase(&DeviceTimings::reconstruct),
        phase(&DeviceTimings::begin_end));
    std::printf("gpu local step: %.4f ns per tet per iteration\n",
        1e6 * local / (static_cast<double>(model.num_tets()) * options.iterations));
    std::fflush(stdout);
}

} // namespace

int main(int argc, char** argv)
{
    int steps = 20, rounds = 5, threads = 0;
    std::vector<std::string> bakes;
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        if ((arg == "--steps" || arg == "--rounds" || arg == "--threads") && a + 1 < argc) {
            const int value = std::atoi(argv[++a]);
            (arg == "--steps" ? steps : arg == "--rounds" ? rounds : threads) = value;
        } else
            bakes.push_back(arg);
    }
    if (bakes.empty() || steps < 1 || rounds < 1) {
        std::fprintf(
            stderr, "usage: gpu_bench [--steps S] [--rounds R] [--threads T] BAKE.h5...\n");
        return 2;
    }
    try {
        set_threads(threads);
        std::printf("cpu threads: %d\n", thread_count());
        for (const std::string& bake : bakes)
            bench(bake, steps, rounds);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "gpu_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
