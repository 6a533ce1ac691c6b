// Times MedialBounds updates on a bake and reports how tight each radius update is.
//   medial_bounds_bench BAKE.h5 [UPDATES]
// For a few random q (a large rigid motion plus per-handle perturbations) it prints, per mode:
// wall-clock ns per update with all threads, CPU ns per update on one thread (the figure to
// compare on a busy machine), the mean radius increment over the mean radius, how many surface
// vertices fall outside their primitive, and "(allocates)" if an update called operator new.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>

#include <tbb/task_arena.h>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"
#include "formats/bake_io.hpp"
#include "runtime/collision/medial_bounds.hpp"
#include "tests/support/allocation_counter.hpp"
#include "tests/support/medial_bounds_checks.hpp"

namespace {

using namespace mat;
using namespace mat::test;

// Wall-clock ns per update.
template <typename Update> double wall_ns_per_update(int updates, Update&& update)
{
    update();
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < updates; ++i)
        update();
    const auto stop = std::chrono::steady_clock::now();
    return std::chrono::duration<double, std::nano>(stop - start).count() / updates;
}

double thread_cpu_ns()
{
    timespec t {};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return 1e9 * static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec);
}

// CPU ns per update of the calling thread (meaningful when the updates run on it alone).
template <typename Update> double cpu_ns_per_update(int updates, Update&& update)
{
    update();
    const double start = thread_cpu_ns();
    for (int i = 0; i < updates; ++i)
        update();
    return (thread_cpu_ns() - start) / updates;
}

} // namespace

int main(int argc, char** argv)
{
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s BAKE.h5 [UPDATES]\n", argv[0]);
        return 2;
    }
    try {
        const BakeData bake = read_bake(argv[1]);
        const int updates = argc > 2 ? std::atoi(argv[2]) : 2000;
        MedialBounds bounds(bake);
        const Box3 box(bake.surface.positions.colwise().minCoeff().transpose(),
            bake.surface.positions.colwise().maxCoeff().transpose());
        const double diagonal = box.diagonal().norm();
        std::printf("%s: %ld spheres, %ld primitives, %ld bound entries (%ld with factor 0), %ld "
                    "surface vertices, k = %ld\n",
            argv[1], static_cast<long>(bounds.num_spheres()),
            static_cast<long>(bounds.num_primitives()),
            static_cast<long>(bake.collision.bound_handles.size()),
            static_cast<long>((bake.collision.bound_factors.array() == 0.0).count()),
            static_cast<long>(bake.surface.num_vertices()), static_cast<long>(bake.num_columns()));

        std::mt19937 rng(1);
        std::normal_distribution<double> normal;
        for (double amplitude : { 0.0, 0.01, 0.05 }) {
            const Vec3 axis = Vec3(normal(rng), normal(rng), normal(rng)).normalized();
            MatX3 q
                = affine_q(bake, Eigen::AngleAxisd(2.0, axis).toRotationMatrix() - Mat3::Identity(),
                    Vec3(normal(rng), normal(rng), normal(rng)) * diagonal);
            for (Index j = 0; j < bake.num_handles(); ++j) {
                const int offset = bake.handle_column_offsets(j);
                for (int term = 0; term < bake.handle_column_offsets(j + 1) - offset; ++term)
                    for (int d = 0; d < 3; ++d)
                        q(offset + term, d) += amplitude * normal(rng)
                            * (term == 0 ? diagonal : bake.handle_scales(j));
            }
            const MatX3 nodes = bake.tet_mesh.positions + bake.basis * q;
            MatX3 positions = MatX3::Zero(bake.surface.num_vertices(), 3);
            for (Index v = 0; v < positions.rows(); ++v)
                for (int k = 0; k < 4; ++k)
                    positions.row(v) += bake.surface_barycentric(v, k)
                        * nodes.row(bake.tet_mesh.tets(bake.surface_tet(v), k));
            const MatX3 centers = bake.medial.centers + bake.medial_basis * q;

            std::printf(
                "\namplitude %.2f (x diagonal %.3g, rotation 2 rad):\n", amplitude, diagonal);
            std::printf("  %-28s %13s %13s %14s %9s\n", "mode", "wall ns, all", "cpu ns, 1 thr",
                "mean delta/r", "outside");
            const double mean_radius = bake.medial.radii.mean();
            auto report = [&](const char* name, auto&& update) {
                const double all = wall_ns_per_update(updates, update);
                tbb::task_arena arena(1);
                double one = 0.0;
                arena.execute([&] { one = cpu_ns_per_update(updates, update); });
                const long before = test::allocation_count();
                update();
                const long allocations = test::allocation_count() - before;
                std::printf("  %-28s %13.0f %13.0f %14.4g %9d%s\n", name, all, one,
                    bounds.increments().mean() / mean_radius,
                    count_outside(bounds, bake, positions, 1e-12),
                    allocations ? " (allocates)" : "");
            };
            report("bound", [&] { bounds.update(q, RadiusUpdate::bound); });
            report("bound, no rigid removal",
                [&] { bounds.update(q, RadiusUpdate::bound_without_rigid_removal); });
            report("lazy", [&] { bounds.update(q, RadiusUpdate::lazy); });
            report("exact (from positions)",
                [&] { bounds.update_from_positions(positions, centers); });
        }
    } catch (const Error& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
