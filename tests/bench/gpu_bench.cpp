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
// The GPU runs once per variant of the engine's launch settings (Variant below: "default" is
// what mat-run uses); "vs cpu" is the max node distance to the CPU's after 3 steps over the
// diagonal.
// Each timing is the median of ROUNDS rounds of STEPS steps, after warm-up steps. The last
// positions of the CPU and GPU runs of the same steps are compared (max node distance over the
// bake's diagonal).
// Usage: gpu_bench [--steps S] [--rounds R] [--threads T] [--variant NAME] BAKE.h5...

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
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

/// The engine's launch settings (runtime/gpu/device_engine.cu reads them from the environment).
struct Variant {
    const char* name;
    const char* group; ///< MAT_CUDA_NODE_GROUP: threads per node (gather, reconstruction)
    const char* warps; ///< MAT_CUDA_SOLVE_WARPS: warps per row of the solve
    const char* segment; ///< MAT_CUDA_SEGMENT: entries per B^T y segment
    const char* blocks; ///< MAT_CUDA_LOCAL_BLOCKS: the local kernel's register cap
};

/// "default" is what mat-run uses; "g4s1" the first release's per-node and solve kernels.
constexpr Variant variants[] = {
    { "default", "8", "4", "512", "4" },
    { "g4s1", "4", "1", "512", "4" },
    { "g4s4", "4", "4", "512", "4" },
    { "g8s1", "8", "1", "512", "4" },
    { "seg256", "8", "4", "256", "4" },
    { "blocks3", "8", "4", "512", "3" },
    { "blocks5", "8", "4", "512", "5" },
};

/// One GPU variant on `model`: its line of the table, and its profiled phases.
void bench_gpu(const Model& model, SolverOptions options, const State& cpu_after_3, double cpu_ms,
    int steps, int rounds, const Variant& variant, bool first)
{
    setenv("MAT_CUDA_NODE_GROUP", variant.group, 1);
    setenv("MAT_CUDA_SOLVE_WARPS", variant.warps, 1);
    setenv("MAT_CUDA_SEGMENT", variant.segment, 1);
    setenv("MAT_CUDA_LOCAL_BLOCKS", variant.blocks, 1);
    options.device = Device::cuda;
    const std::unique_ptr<PdSolver> gpu = make_solver(SolverKind::semi_reduced, model, options);
    DeviceSemiStep& device = *gpu->device();
    if (first)
        std::printf("device: %s\n", device.description().c_str());
    const MatX3& rest = model.rest_positions();
    const double diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
    // Warm-up, and the comparison: the same 3 steps as the CPU's.
    State state = start_state(model);
    run_steps(*gpu, state, 3);
    const double distance
        = (state.positions - cpu_after_3.positions).rowwise().norm().maxCoeff() / diagonal;
    std::vector<double> gpu_ms, sync_ms;
    for (int r = 0; r < rounds; ++r) {
        gpu_ms.push_back(run_steps(*gpu, state, steps));
        sync_ms.push_back(run_steps(*gpu, state, steps, true));
    }
    // The phases: a profiled run.
    const DeviceTimings base = device.timings();
    device.set_profiling(true);
    run_steps(*gpu, state, steps);
    device.set_profiling(false);
    const DeviceTimings& t = device.timings();
    const auto phase
        = [&](double DeviceTimings::*field) { return 1e3 * (t.*field - base.*field) / steps; };
    const double local = phase(&DeviceTimings::local);
    std::printf("%-10s%10.3f%10.3f%10.3f%10.1f%12.4f%12.3g |%8.3f%8.3f%8.3f%8.3f%8.3f%8.3f\n",
        variant.name, cpu_ms, median(gpu_ms), median(sync_ms), cpu_ms / median(gpu_ms),
        1e6 * local / (static_cast<double>(model.num_tets()) * options.iterations), distance, local,
        phase(&DeviceTimings::gather), phase(&DeviceTimings::rhs), phase(&DeviceTimings::solve),
        phase(&DeviceTimings::reconstruct), phase(&DeviceTimings::begin_end));
    std::fflush(stdout);
}

void bench(const std::string& path, int steps, int rounds, const std::string& only)
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
    // The GPU step keeps the angular momentum implicit Euler gives (docs/gpu.md): the CPU path
    // runs the same physics, so that "vs cpu" compares like with like.
    options.angular_momentum = AngularMomentum::integrator;
    std::printf("== %s: %ld tets, %ld nodes, %ld handles, %ld columns\n", path.c_str(),
        static_cast<long>(model.num_tets()), static_cast<long>(model.num_nodes()),
        static_cast<long>(model.handle_centers().rows()), static_cast<long>(model.num_columns()));
    const std::unique_ptr<PdSolver> cpu = make_solver(SolverKind::semi_reduced, model, options);
    State state = start_state(model);
    run_steps(*cpu, state, 3);
    const State after_3 = state;
    std::vector<double> cpu_ms;
    const SolverTimings before = cpu->timings();
    for (int r = 0; r < rounds; ++r)
        cpu_ms.push_back(run_steps(*cpu, state, steps));
    const SolverTimings& after = cpu->timings();
    const double cpu_steps = static_cast<double>(after.steps - before.steps);
    std::printf("cpu phases ms/step: local %.3f  rhs %.3f  solve %.3f  reconstruct %.3f\n",
        1e3 * (after.local - before.local) / cpu_steps, 1e3 * (after.rhs - before.rhs) / cpu_steps,
        1e3 * (after.solve - before.solve) / cpu_steps,
        1e3 * (after.reconstruct - before.reconstruct) / cpu_steps);
    std::printf("%-10s%10s%10s%10s%10s%12s%12s | gpu phases ms/step, profiled: local, gather, "
                "B^T y, solve, reconstruct, begin/end\n",
        "variant", "cpu ms", "gpu ms", "gpu+sync", "cpu/gpu", "local ns", "vs cpu");
    bool first = true;
    for (const Variant& variant : variants)
        if (only.empty() || only == variant.name) {
            bench_gpu(model, options, after_3, median(cpu_ms), steps, rounds, variant, first);
            first = false;
        }
}

} // namespace

int main(int argc, char** argv)
{
    int steps = 20, rounds = 5, threads = 0;
    std::string only;
    std::vector<std::string> bakes;
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        if ((arg == "--steps" || arg == "--rounds" || arg == "--threads") && a + 1 < argc) {
            const int value = std::atoi(argv[++a]);
            (arg == "--steps" ? steps : arg == "--rounds" ? rounds : threads) = value;
        } else if (arg == "--variant" && a + 1 < argc)
            only = argv[++a];
        else
            bakes.push_back(arg);
    }
    const bool known = only.empty()
        || std::any_of(std::begin(variants), std::end(variants),
            [&](const Variant& v) { return only == v.name; });
    if (!known) {
        std::fprintf(stderr, "gpu_bench: unknown --variant %s; the variants:", only.c_str());
        for (const Variant& v : variants)
            std::fprintf(stderr, " %s", v.name);
        std::fprintf(stderr, "\n");
        return 2;
    }
    if (bakes.empty() || steps < 1 || rounds < 1) {
        std::fprintf(stderr,
            "usage: gpu_bench [--steps S] [--rounds R] [--threads T] [--variant NAME] "
            "BAKE.h5...\n");
        return 2;
    }
    try {
        set_threads(threads);
        std::printf("cpu threads: %d\n", thread_count());
        for (const std::string& bake : bakes)
            bench(bake, steps, rounds, only);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "gpu_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
