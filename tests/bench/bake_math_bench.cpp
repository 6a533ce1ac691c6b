// Bake-math benchmark (not a test): times every numerical stage of the bake on a structured,
// jittered tet mesh of about 50k tets with 150 handles, and measures the effect of K (weights
// kept per node) on accuracy and on the runtime's sparse products.
//
//   bake_math_bench [shape=slab|cube] [handles=150] [threads=0 (all)] [alpha=0.5]
//
// slab: a 4 x 1 x 0.5 box (64 x 16 x 8 cells, 49k tets) with handles on its medial sheet
//       (z = 0.25), radius = distance to the boundary, like the medial vertices of a thin part.
// cube: a unit box (20 x 20 x 21 cells, 50k tets) with handles at random interior points, radius
//       = distance to the boundary: every handle near every node, the worst case for sparsity.
// Prints a plain table; compare figures run to run (the VM is noisy: +-10%).

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "common/parallel.hpp"
#include "common/sparse_cholesky.hpp"
#include "common/timer.hpp"
#include "preprocess/basis/handle_basis.hpp"
#include "preprocess/pd/pd_operators.hpp"
#include "preprocess/pd/reduced_operators.hpp"
#include "preprocess/weights/handle_regions.hpp"
#include "preprocess/weights/harmonic_weights.hpp"
#include "tests/support/grid_tets.hpp"

namespace {

using namespace mat;
using RowSparse = Eigen::SparseMatrix<double, Eigen::RowMajor>;

template <typename F> double median_seconds(int repeats, F&& f)
{
    std::vector<double> times;
    for (int r = 0; r < repeats; ++r) {
        Timer timer;
        f();
        times.push_back(timer.seconds());
    }
    std::sort(times.begin(), times.end());
    return times[times.size() / 2];
}

// Runtime kernels: plain CSR loops over B with 3 interleaved columns.
void basis_transpose_times(const RowSparse& b, const MatX3& y, MatX3& out)
{
    out.setZero();
    for (Index i = 0; i < b.outerSize(); ++i)
        for (RowSparse::InnerIterator it(b, i); it; ++it)
            out.row(it.col()) += it.value() * y.row(i);
}

void basis_times(const RowSparse& b, const MatX3& q, MatX3& out)
{
    for (Index i = 0; i < b.outerSize(); ++i) {
        Vec3 sum = Vec3::Zero();
        for (RowSparse::InnerIterator it(b, i); it; ++it)
            sum += it.value() * q.row(it.col()).transpose();
        out.row(i) = sum.transpose();
    }
}

double mib(std::size_t bytes)
{
    return double(bytes) / (1024.0 * 1024.0);
}

} // namespace

int main(int argc, char** argv)
{
    const std::string shape = argc > 1 ? argv[1] : "slab";
    const int num_handles = argc > 2 ? std::atoi(argv[2]) : 150;
    const int threads = argc > 3 ? std::atoi(argv[3]) : 0;
    const double alpha = argc > 4 ? std::atof(argv[4]) : 0.5;
    set_threads(threads);

    test::GridTetOptions options;
    Vec3 extent;
    if (shape == "cube") {
        options.nx = options.ny = 20;
        options.nz = 21;
        extent = Vec3(1.0, 1.0, 1.05);
    } else {
        options.nx = 64;
        options.ny = 16;
        options.nz = 8;
        extent = Vec3(4.0, 1.0, 0.5);
    }
    options.max_corner = extent;
    options.jitter = 0.15;
    Timer timer;
    const TetMesh mesh = test::make_grid_tets(options);
    std::printf("%s: %ld nodes, %ld tets (grid %dx%dx%d, jitter 0.15), %d handles, %d threads\n",
        shape.c_str(), long(mesh.num_vertices()), long(mesh.num_tets()), options.nx, options.ny,
        options.nz, num_handles, thread_count());

    // Medial-like spheres: radius = distance to the box boundary.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    MatX3 centers(num_handles, 3);
    VecX radii(num_handles);
    for (int j = 0; j < num_handles; ++j) {
        Vec3 c;
        if (shape == "cube")
            c = Vec3(0.08 + 0.84 * unit(rng), 0.08 + 0.84 * unit(rng), 0.08 + 0.89 * unit(rng));
        else
            c = Vec3(0.1 + 3.8 * unit(rng), 0.1 + 0.8 * unit(rng), 0.25);
        centers.row(j) = c.transpose();
        radii[j] = std::min(c.minCoeff(), (extent - c).minCoeff());
    }
    std::printf("\n%-42s %10s\n", "stage", "seconds");
    TetRestData rest;
    const double t_rest
        = median_seconds(5, [&] { rest = compute_tet_rest_data(mesh.positions, mesh.tets); });
    std::printf("%-42s %10.4f\n", "tet rest data (Dm^-1, volumes)", t_rest);
    Eigen::SparseMatrix<double> laplacian;
    const int all_threads = thread_count();
    set_threads(1);
    const double t_lap1 = median_seconds(
        5, [&] { laplacian = assemble_laplacian(mesh.num_vertices(), mesh.tets, rest); });
    set_threads(threads);
    const double t_lap = median_seconds(
        5, [&] { laplacian = assemble_laplacian(mesh.num_vertices(), mesh.tets, rest); });
    std::printf("%-42s %10.4f\n", "Laplacian assembly, 1 thread", t_lap1);
    std::printf("%-42s %10.4f   (nnz %ld)\n",
        ("Laplacian assembly, " + std::to_string(all_threads) + " threads").c_str(), t_lap,
        long(laplacian.nonZeros()));
    VecX masses;
    const double t_mass = median_seconds(
        5, [&] { masses = lumped_masses(mesh.num_vertices(), mesh.tets, rest.volumes); });
    std::printf("%-42s %10.4f\n", "lumped masses", t_mass);
    VecXi owner;
    const double t_regions = median_seconds(
        3, [&] { owner = assign_handle_regions(mesh.positions, centers, radii, alpha); });
    std::printf("%-42s %10.4f   (alpha %.2f: %ld constrained nodes)\n", "handle regions", t_regions,
        alpha, long((owner.array() >= 0).count()));

    std::printf("\nweights, K = kept per node (timings: factor / solves+top-K / whole call)\n");
    std::printf("%4s %8s %8s %8s %10s %10s %10s %10s %9s %9s\n", "K", "factor", "solve", "total",
        "max chg", "rms chg", "max drop", "nnz(W)", "B^T y ms", "B q ms");
    RowSparse chosen_weights;
    for (int k : { 4, 6, 8, 12, 16, 24 }) {
        HarmonicWeightOptions weight_options;
        weight_options.max_handles_per_node = k;
        Timer whole;
        const HarmonicWeights w
            = compute_harmonic_weights(laplacian, owner, num_handles, weight_options);
        const double t_whole = whole.seconds();
        const auto& d = w.diagnostics;
        const VecX scales = handle_support_scales(mesh.positions, w.weights, centers);
        const HandleBasis basis = build_handle_basis(mesh.positions, w.weights, centers, scales,
            Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(num_handles, false));
        MatX3 y = MatX3::Random(mesh.num_vertices(), 3);
        MatX3 reduced(basis.num_columns(), 3);
        MatX3 full(mesh.num_vertices(), 3);
        const double t_bt
            = median_seconds(51, [&] { basis_transpose_times(basis.basis, y, reduced); });
        const double t_b = median_seconds(51, [&] { basis_times(basis.basis, reduced, full); });
        std::printf("%4d %8.3f %8.3f %8.3f %10.2e %10.2e %10.2e %10ld %9.3f %9.3f\n", k,
            d.factor_seconds, d.solve_seconds, t_whole, d.max_sparsify_change,
            d.rms_sparsify_change, d.max_dropped_weight, long(w.weights.nonZeros()), 1e3 * t_bt,
            1e3 * t_b);
        if (k == 8) {
            chosen_weights = w.weights;
            std::printf("     raw range [%.3e, %.9f], partition error %.2e, clamp change %.2e, "
                        "nnz(L_ff factor) %ld\n",
                d.min_weight, d.max_weight, d.max_partition_error, d.max_clamp_change,
                long(d.factor_nonzeros));
        }
    }

    std::printf("\nbasis and reduced operators (K = 8)\n");
    for (double quadratic_fraction : { 0.0, 0.25 }) {
        Eigen::Matrix<bool, Eigen::Dynamic, 1> quadratic(num_handles);
        for (int j = 0; j < num_handles; ++j)
            quadratic[j] = j < quadratic_fraction * num_handles;
        VecX scales;
        HandleBasis basis;
        const double t_scales = median_seconds(
            3, [&] { scales = handle_support_scales(mesh.positions, chosen_weights, centers); });
        const double t_basis = median_seconds(3, [&] {
            basis = build_handle_basis(mesh.positions, chosen_weights, centers, scales, quadratic);
        });
        ReducedOperators reduced;
        const double t_reduce = median_seconds(
            3, [&] { reduced = reduce_operators(basis.basis, laplacian, masses); });
        ReducedSystemCheck check;
        const double t_check = median_seconds(
            3, [&] { check = check_reduced_system(reduced, 1.0, 1.0, 1.0 / 60.0); });
        std::printf("  %.0f%% quadratic handles: k = %ld, nnz(B) = %ld\n", 100 * quadratic_fraction,
            long(basis.num_columns()), long(basis.basis.nonZeros()));
        std::printf("  %-40s %10.4f\n", "support scales", t_scales);
        std::printf("  %-40s %10.4f\n", "basis B", t_basis);
        std::printf("  %-40s %10.4f\n", "B^T L B and B^T M B (sparse products)", t_reduce);
        std::printf("  %-40s %10.4f   (rcond %.2e)\n", "LLT of B^T (L + M/h^2) B, h = 1/60",
            t_check, check.reciprocal_condition);
    }
    // The runtime's full-space global step: factor L + M/h^2 once, then n x 3 solves.
    {
        const double h = 1.0 / 60.0;
        Eigen::SparseMatrix<double> system = laplacian;
        for (Index i = 0; i < system.rows(); ++i)
            system.coeffRef(i, i) += masses[i] / (h * h);
        SparseCholesky cholesky;
        const double t_factor
            = median_seconds(3, [&] { cholesky.compute(system, "full-space PD matrix"); });
        MatX3 rhs = MatX3::Random(system.rows(), 3);
        const double t_solve = median_seconds(21, [&] { cholesky.solve_in_place_rows(rhs); });
        std::printf("\nfull-space PD (runtime baseline): nnz(L) %ld (%s), factor %.4f s, n x 3 "
                    "solve %.2f ms\n",
            long(cholesky.factor_nonzeros()), cholesky.ordering().c_str(), t_factor, 1e3 * t_solve);
    }
    std::printf("\ntotal %.2f s, peak RSS %.0f MiB\n", timer.seconds(), mib(peak_rss_bytes()));
    return 0;
}
