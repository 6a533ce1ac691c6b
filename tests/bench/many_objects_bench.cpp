// Cost per step of a scene of many objects, split into solver, collision and other.
//   many_objects_bench SCENE.json WARMUP_STEPS STEPS [SOLVER]
// Steps the scene WARMUP_STEPS times untimed (the resting objects settle and, with sleeping on,
// fall asleep), then STEPS times timed, and prints one line: ms per step in total, in the
// solvers (the phases of SolverTimings summed over the bodies), in collision detection (the
// collision world's phases) and the rest (the simulation's own work: pins, sleeping, handing
// over contacts, the solvers' untimed remainder), with the bodies asleep and the collision
// world's object pairs and hashed bodies. Threads: MAT_THREADS (2 by default). Run by
// tests/bench/many_objects.sh.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "common/log.hpp"
#include "common/parallel.hpp"
#include "common/timer.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/scene/scene_bodies.hpp"
#include "runtime/simulation.hpp"

namespace {

double solver_seconds(const mat::Simulation& simulation)
{
    double seconds = 0.0;
    for (const mat::Body& body : simulation.bodies()) {
        const mat::SolverTimings& t = body.solver->timings();
        seconds += t.local + t.rhs + t.solve + t.reconstruct + t.contact;
    }
    return seconds;
}

double collision_seconds(const mat::CollisionReport& r)
{
    return r.bounds_seconds + r.hash_seconds + r.primitive_seconds + r.triangle_seconds
        + r.response_seconds;
}

} // namespace

int main(int argc, char** argv)
{
    if (argc < 4 || argc > 5) {
        std::fprintf(
            stderr, "usage: %s SCENE.json WARMUP_STEPS STEPS [semi|full|hyper]\n", argv[0]);
        return 2;
    }
    try {
        mat::logger().set_level(spdlog::level::warn);
        const char* threads = std::getenv("MAT_THREADS");
        mat::set_threads(threads != nullptr ? std::atoi(threads) : 2);
        const mat::Scene scene = mat::read_scene(argv[1]);
        const int warmup = std::atoi(argv[2]);
        const int steps = std::atoi(argv[3]);
        const std::string solver = argc == 5 ? argv[4] : "semi";
        if (warmup < 0 || steps < 1) {
            std::fprintf(stderr, "WARMUP_STEPS must be >= 0 and STEPS >= 1\n");
            return 2;
        }
        mat::Simulation simulation(scene, mat::load_bodies(scene, mat::parse_solver_kind(solver)));
        for (int s = 0; s < warmup; ++s)
            simulation.step();
        const int asleep_before = simulation.num_sleeping();
        const double solver_before = solver_seconds(simulation);
        double collision = 0.0, total = 0.0;
        long asleep_sum = 0;
        int object_pairs = 0, hashed_bodies = 0, updated_bodies = 0;
        for (int s = 0; s < steps; ++s) {
            mat::Timer timer;
            simulation.step();
            total += timer.seconds();
            asleep_sum += simulation.num_sleeping();
            if (const mat::CollisionWorld* world = simulation.collision()) {
                const mat::CollisionReport& r = world->last_report();
                collision += collision_seconds(r);
                object_pairs = std::max(object_pairs, r.object_pairs);
                hashed_bodies = std::max(hashed_bodies, r.hashed_bodies);
                updated_bodies = std::max(updated_bodies, r.updated_bodies);
            }
        }
        const double solver_time = solver_seconds(simulation) - solver_before;
        const double per_step = 1e3 / steps;
        std::printf("%s: %zu bodies, %d threads, steps %d..%d: ms/step total %.2f solver %.2f "
                    "collision %.2f other %.2f; asleep %d at the start, %.1f on average; at most "
                    "%d object pairs, %d hashed bodies, %d bounds updates per step\n",
            scene.file.c_str(), simulation.bodies().size(), mat::thread_count(), warmup,
            warmup + steps, total * per_step, solver_time * per_step, collision * per_step,
            (total - solver_time - collision) * per_step, asleep_before,
            static_cast<double>(asleep_sum) / steps, object_pairs, hashed_bodies, updated_bodies);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "many_objects_bench: %s\n", error.what());
        return 1;
    }
    return 0;
}
