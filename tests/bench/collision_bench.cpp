// Per-step cost of the collision world (docs/method.md, section 4) on a scene in contact:
//   collision_bench SCENE.json [STEPS] [REPEATS]
// Runs the scene's first STEPS steps (semi-reduced solver, with the scene's collision), then
// times REPEATS detect() calls on the final state for: the medial pipeline with the default
// bounds (exact per-vertex increments from the positions), the same with the handle bound from
// q, with all-pairs primitive testing (the reference code's broad phase), the lazy update, and a
// triangle-only broad phase (CGAL box_intersection_d over every triangle, one thread).
// The bounded pipeline is timed again without the triangle pairs ("contacts only": what a step of
// mat-run computes unless --check-collisions or --stats asks for them; its "missed" column counts
// every pair of the truth). Prints wall ms per phase, process CPU ms per call (all threads), the
// ratios, and how many of the ground truth's intersecting triangle pairs (between the first two
// bodies) each misses.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iterator>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "common/parallel.hpp"
#include "common/timer.hpp"
#include "formats/bake_io.hpp"
#include "runtime/collision/collision_world.hpp"
#include "runtime/measures/ground_truth.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/scene/scene_bodies.hpp"
#include "runtime/simulation.hpp"
#include "tests/bench/collision_bench_cgal.hpp"

namespace {

using namespace mat;

double cpu_seconds()
{
    timespec t {};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Timing {
    CollisionReport mean; ///< counts of the last call, seconds averaged
    double wall_ms = 0.0, cpu_ms = 0.0; ///< per call, excluding the response
    long missed = 0, found = 0;
};

Timing time_world(CollisionWorld& world, const std::vector<CollisionBodyState>& states, int repeats,
    const std::vector<TrianglePair>& truth)
{
    world.detect(states); // warm
    Timing t;
    const double cpu0 = cpu_seconds();
    Timer wall;
    double response = 0.0;
    for (int r = 0; r < repeats; ++r) {
        world.detect(states);
        const CollisionReport& rep = world.last_report();
        t.mean.bounds_seconds += rep.bounds_seconds / repeats;
        t.mean.hash_seconds += rep.hash_seconds / repeats;
        t.mean.primitive_seconds += rep.primitive_seconds / repeats;
        t.mean.triangle_seconds += rep.triangle_seconds / repeats;
        t.mean.response_seconds += rep.response_seconds / repeats;
        response += rep.response_seconds;
    }
    const double wall_total = wall.seconds();
    const double cpu_total = cpu_seconds() - cpu0;
    // CPU of the response (single-threaded merge) taken as its wall time.
    t.wall_ms = 1e3 * (wall_total - response) / repeats;
    t.cpu_ms = 1e3 * (cpu_total - response) / repeats;
    const CollisionReport& last = world.last_report();
    t.mean.primitive_candidates = last.primitive_candidates;
    t.mean.primitive_pairs = last.primitive_pairs;
    t.mean.triangle_tests = last.triangle_tests;
    t.mean.node_tests = last.node_tests;
    t.mean.intersecting_triangles = last.intersecting_triangles;
    t.mean.contacts = last.contacts;
    t.mean.max_penetration = last.max_penetration;
    std::vector<TrianglePair> found;
    for (const FacePair& p : world.intersecting_pairs())
        if (p[0] == 0 && p[2] == 1)
            found.push_back(p);
    std::vector<TrianglePair> missed;
    std::set_difference(
        truth.begin(), truth.end(), found.begin(), found.end(), std::back_inserter(missed));
    t.missed = static_cast<long>(missed.size());
    t.found = static_cast<long>(found.size());
    return t;
}

void print_row(const char* name, const Timing& t)
{
    const CollisionReport& m = t.mean;
    std::printf(
        "%-22s %7.3f %7.3f %7.3f %7.3f %8.3f | %8.3f %8.3f | %6d %6d %8ld %8ld %6d %6d %7ld\n",
        name, 1e3 * m.bounds_seconds, 1e3 * m.hash_seconds, 1e3 * m.primitive_seconds,
        1e3 * m.triangle_seconds, 1e3 * m.response_seconds, t.wall_ms, t.cpu_ms,
        m.primitive_candidates, m.primitive_pairs, m.triangle_tests, m.node_tests,
        m.intersecting_triangles, m.contacts, t.missed);
}

int run(int argc, char** argv)
{
    if (argc < 2) {
        std::fprintf(stderr, "usage: collision_bench SCENE.json [STEPS] [REPEATS]\n");
        return 2;
    }
    const int steps = argc > 2 ? std::atoi(argv[2]) : 25;
    const int repeats = argc > 3 ? std::atoi(argv[3]) : 50;
    const Scene scene = read_scene(argv[1]);
    MAT_CHECK(scene.objects.size() >= 2, "{}: the benchmark needs two objects", argv[1]);
    Simulation simulation(scene, load_bodies(scene, SolverKind::semi_reduced));
    for (int s = 0; s < steps; ++s)
        simulation.step();

    const std::vector<Body>& bodies = simulation.bodies();
    std::vector<CollisionBodyState> states(bodies.size());
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        const Body& body = simulation.bodies()[b];
        states[b].nodes = &body.state.positions;
        states[b].is_static = body.is_static;
        states[b].q = body.solver->reduced_coordinates();
    }
    const auto make = [&](RadiusUpdate bounds, bool all_pairs, bool from_positions = true) {
        CollisionSettings settings;
        settings.self = scene.solver.self_collision;
        settings.margin = scene.solver.collision_margin;
        settings.edges = scene.solver.edge_contacts;
        settings.bounds = bounds;
        CollisionVariants variants;
        variants.all_pairs = all_pairs;
        variants.bounds_from_positions = from_positions;
        CollisionWorld world(settings);
        world.set_variants_for_comparison(variants);
        for (const Body& body : bodies)
            world.add_body(body.model);
        return world;
    };
    CollisionWorld bounded = make(RadiusUpdate::bound, false);
    bounded.detect(states);
    std::vector<SurfaceMesh> surfaces(2);
    for (int b = 0; b < 2; ++b) {
        surfaces[b].positions = bounded.world_surface(b);
        surfaces[b].faces = bounded.faces(b);
    }
    GroundTruthOptions truth_options;
    truth_options.self_pairs = false;
    const std::vector<TrianglePair> truth = intersecting_triangle_pairs(surfaces, truth_options);

    std::printf("scene %s after %d steps, %d threads, %d repeats; primitives per body:", argv[1],
        steps, thread_count(), repeats);
    for (const Body& body : bodies)
        std::printf(" %ld", static_cast<long>(body.model->primitives().primitive_kind.size()));
    std::printf(
        "; ground truth: %zu intersecting triangle pairs between bodies 0 and 1\n", truth.size());
    std::printf("%-22s %7s %7s %7s %7s %8s | %8s %8s | %6s %6s %8s %8s %6s %6s %7s\n",
        "ms per step", "bounds", "hash", "prims", "tris", "response", "wall*", "cpu*", "cand",
        "pairs", "tritests", "nodetest", "inter", "contct", "missed");
    const Timing t_bounded = time_world(bounded, states, repeats, truth);
    print_row("medial, bounded", t_bounded);
    // What a step of mat-run pays: its triangle pairs are a measurement (--check-collisions,
    // --stats' last step of a frame), which no contact reads (NarrowPhase::set_triangle_pairs).
    CollisionWorld contacts_only = make(RadiusUpdate::bound, false);
    contacts_only.set_triangle_pairs(false);
    print_row("bounded, contacts only", time_world(contacts_only, states, repeats, truth));
    CollisionWorld q_bound = make(RadiusUpdate::bound, false, false);
    const Timing t_q_bound = time_world(q_bound, states, repeats, truth);
    print_row("medial, q-bound", t_q_bound);
    CollisionWorld all = make(RadiusUpdate::bound, true);
    const Timing t_all = time_world(all, states, repeats, truth);
    print_row("(a) all-pairs prims", t_all);
    CollisionWorld lazy = make(RadiusUpdate::lazy, false);
    const Timing t_lazy = time_world(lazy, states, repeats, truth);
    print_row("medial, lazy", t_lazy);

    // (b) Triangle-only broad phase (CGAL), on the surfaces of the bounded run.
    bench::TriangleBroadPhase cgal;
    const double cpu0 = cpu_seconds();
    Timer wall;
    for (int r = 0; r < repeats; ++r)
        cgal = bench::cgal_triangle_pairs(surfaces[0], surfaces[1]);
    const double cgal_wall = 1e3 * wall.seconds() / repeats;
    const double cgal_cpu = 1e3 * (cpu_seconds() - cpu0) / repeats;
    std::printf("(b) CGAL box_intersection_d over all triangles (1 thread): wall %.3f ms, cpu %.3f "
                "ms; %ld box pairs tested, %ld intersecting\n",
        cgal_wall, cgal_cpu, cgal.box_pairs, cgal.intersecting);
    std::printf(
        "* wall/cpu: bounds + hash + primitives + triangles per step (response excluded)\n");
    std::printf("ratio (a) all-pairs / bounded: wall %.2f, cpu %.2f\n",
        t_all.wall_ms / t_bounded.wall_ms, t_all.cpu_ms / t_bounded.cpu_ms);
    std::printf("ratio (b) CGAL triangles / bounded: wall %.2f, cpu %.2f\n",
        cgal_wall / t_bounded.wall_ms, cgal_cpu / t_bounded.cpu_ms);
    std::printf("missed intersecting triangle pairs vs ground truth: bounded %ld, q-bound %ld, "
                "lazy %ld (of %zu)\n",
        t_bounded.missed, t_q_bound.missed, t_lazy.missed, truth.size());
    // The radius increments of the two bounds, relative to the body's rest diagonal.
    for (int b = 0; b < 2; ++b) {
        const double diagonal = bodies[static_cast<std::size_t>(b)].model->rest_diagonal();
        const VecX& exact = bounded.bounds(b).increments();
        const VecX& bound = q_bound.bounds(b).increments();
        std::printf("body %d radius increments / diagonal: exact per-vertex mean %.5f max %.5f; "
                    "q-bound mean %.5f max %.5f\n",
            b, exact.mean() / diagonal, exact.maxCoeff() / diagonal, bound.mean() / diagonal,
            bound.maxCoeff() / diagonal);
    }
    return 0;
}

} // namespace

int main(int argc, char** argv)
{
    try {
        const char* threads = std::getenv("MAT_THREADS");
        mat::set_threads(threads != nullptr ? std::atoi(threads) : 2);
        return run(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "collision_bench: %s\n", e.what());
        return 1;
    }
}
