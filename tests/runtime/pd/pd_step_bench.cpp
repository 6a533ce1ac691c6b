// Projective dynamics step benchmark (not a test): ms per step of the semi-reduced and the
// full-space solver on a jittered unit-cube grid of 20 x 20 x 20 cells (48k tets, 9261 nodes),
// 10 iterations per step, with linear handles (4 columns each) on a coarse lattice whose weights
// are normalized squared trilinear hats (8 handles per node, like a bake with K = 8).
//
//   pd_step_bench [handles_per_axis=5] [steps=10] [volume_tolerance=0.01]
//
// Prints a plain table; compare figures run to run (the VM is noisy: +-10%).

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <utility>
#include <vector>

#include "common/parallel.hpp"
#include "common/timer.hpp"
#include "preprocess/pd/pd_operators.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/solver.hpp"
#include "tests/runtime/runtime_test_models.hpp"

namespace {

using namespace mat;

/// Linear handles on an a x a x a lattice over the unit cube: column 4 j + c holds
/// w_j(x) * (1, x - c_j) with w_j the normalized squared trilinear hat of lattice point j.
SparseRowMatrix lattice_basis(const MatX3& positions, int a)
{
    const double spacing = 1.0 / (a - 1);
    std::vector<Eigen::Triplet<double>> triplets;
    for (Index i = 0; i < positions.rows(); ++i) {
        int cell[3];
        double frac[3];
        for (int d = 0; d < 3; ++d) {
            const double u = std::clamp(positions(i, d) / spacing, 0.0, a - 1.0);
            cell[d] = std::min(static_cast<int>(u), a - 2);
            frac[d] = u - cell[d];
        }
        // Squared trilinear hats, normalized: a partition of unity without linear precision
        // (trilinear hats reproduce x exactly, which makes the linear columns dependent).
        int handle[8];
        double weight[8];
        double total = 0.0;
        for (int corner = 0; corner < 8; ++corner) {
            int idx[3];
            double w = 1.0;
            for (int d = 0; d < 3; ++d) {
                const int bit = (corner >> d) & 1;
                idx[d] = cell[d] + bit;
                w *= bit ? frac[d] : 1.0 - frac[d];
            }
            handle[corner] = idx[0] + a * (idx[1] + a * idx[2]);
            weight[corner] = w * w;
            total += w * w;
        }
        for (int corner = 0; corner < 8; ++corner) {
            const int j = handle[corner];
            const double w = weight[corner] / total;
            const double c[3]
                = { (j % a) * spacing, ((j / a) % a) * spacing, (j / (a * a)) * spacing };
            triplets.emplace_back(i, 4 * j, w);
            for (int d = 0; d < 3; ++d)
                triplets.emplace_back(i, 4 * j + 1 + d, w * (positions(i, d) - c[d]));
        }
    }
    SparseRowMatrix basis(positions.rows(), 4 * a * a * a);
    basis.setFromTriplets(triplets.begin(), triplets.end());
    basis.prune(0.0);
    return basis;
}

/// Median ms per step, and the mean split per step (ms) from the solver's phase timings.
struct StepFigures {
    double median_ms = 0.0;
    double local_ms = 0.0, rhs_ms = 0.0, solve_ms = 0.0, reconstruct_ms = 0.0;
};

StepFigures measure(PdSolver& solver, const Model& model, const State& start, int steps)
{
    std::vector<double> times;
    State a = start, b;
    const SolverTimings before = solver.timings();
    for (int s = 0; s < steps; ++s) {
        Timer timer;
        solver.step(a, b);
        times.push_back(1e3 * timer.seconds());
        std::swap(a, b);
    }
    const SolverTimings& after = solver.timings();
    std::nth_element(times.begin(), times.begin() + steps / 2, times.end());
    StepFigures figures;
    figures.median_ms = times[steps / 2];
    figures.local_ms = 1e3 * (after.local - before.local) / steps;
    figures.rhs_ms = 1e3 * (after.rhs - before.rhs) / steps;
    figures.solve_ms = 1e3 * (after.solve - before.solve) / steps;
    figures.reconstruct_ms = 1e3 * (after.reconstruct - before.reconstruct) / steps;
    return figures;
}

} // namespace

int main(int argc, char** argv)
{
    const int handles_per_axis = argc > 1 ? std::atoi(argv[1]) : 5;
    const int steps = argc > 2 ? std::max(1, std::atoi(argv[2])) : 10;

    test::GridTetOptions grid;
    grid.nx = grid.ny = grid.nz = 20;
    grid.jitter = 0.15;
    BakeData bake = test::make_grid_bake(grid);
    const Index n = bake.tet_mesh.num_vertices();
    bake.basis = lattice_basis(bake.tet_mesh.positions, handles_per_axis);
    const Eigen::SparseMatrix<double> basis = bake.basis;
    const Eigen::SparseMatrix<double> laplacian = bake.laplacian;
    bake.reduced_laplacian = MatX(basis.transpose() * laplacian * basis);
    bake.reduced_mass = MatX(basis.transpose() * bake.lumped_mass.asDiagonal() * basis);

    Timer build;
    ModelOptions model_options;
    if (argc > 3)
        model_options.volume_tolerance = std::atof(argv[3]);
    const Model model(bake, Material {}, model_options);
    const double model_ms = 1e3 * build.seconds();
    State start = State::at_rest(model);
    for (Index i = 0; i < n; ++i) {
        const Vec3 p = start.positions.row(i).transpose() - Vec3(0.5, 0.5, 0.5);
        start.velocities.row(i) = Vec3(6.0 * p.x(), 0.0, 0.0).cross(p).transpose();
    }
    std::printf("tets %ld, nodes %ld, columns k = %ld, nnz(B) = %ld, model build %.1f ms\n",
        static_cast<long>(model.num_tets()), static_cast<long>(n),
        static_cast<long>(model.num_columns()), static_cast<long>(bake.basis.nonZeros()), model_ms);
    std::printf("ms per step (median) and its split (mean): local step, right-hand side (B^T y "
                "for reduced), solve, reconstruction (B q for reduced)\n");
    std::printf("%-8s %-8s %9s %9s %9s %9s %9s %12s\n", "solver", "threads", "step", "local", "rhs",
        "solve", "reconstr", "local ns/tet");
    for (const int threads : { 1, 2 }) {
        set_threads(threads);
        PdSolver reduced = semi_reduced_solver(model);
        PdSolver full = full_solver(model);
        const StepFigures r = measure(reduced, model, start, steps);
        const StepFigures f = measure(full, model, start, steps);
        for (const auto& [name, fig] : { std::pair { "reduced", r }, std::pair { "full", f } })
            std::printf("%-8s %-8d %9.2f %9.2f %9.2f %9.2f %9.2f %12.1f\n", name, threads,
                fig.median_ms, fig.local_ms, fig.rhs_ms, fig.solve_ms, fig.reconstruct_ms,
                1e6 * fig.local_ms
                    / (SolverOptions {}.iterations * static_cast<double>(model.num_tets())));
    }
    return 0;
}
