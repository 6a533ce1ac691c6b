#include <gtest/gtest.h>

#include <string>

#include <Eigen/LU>
#include <Eigen/SparseCholesky>

#include "common/error.hpp"
#include "common/parallel.hpp"
#include "preprocess/pd/pd_operators.hpp"
#include "preprocess/weights/handle_regions.hpp"
#include "preprocess/weights/harmonic_weights.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/grid_tets.hpp"

namespace mat {
namespace {

    struct Fixture {
        TetMesh mesh;
        Eigen::SparseMatrix<double> laplacian;
        MatX3 centers;
        VecX radii;
        VecXi owner;
    };

    Fixture make_fixture(double jitter, int cells = 8)
    {
        test::GridTetOptions options;
        options.nx = options.ny = options.nz = cells;
        options.jitter = jitter;
        options.seed = 12;
        Fixture f;
        f.mesh = test::make_grid_tets(options);
        f.laplacian = assemble_laplacian(f.mesh.num_vertices(), f.mesh.tets,
            compute_tet_rest_data(f.mesh.positions, f.mesh.tets));
        f.centers.resize(7, 3);
        f.centers << 0.2, 0.2, 0.2, 0.8, 0.2, 0.3, 0.5, 0.8, 0.5, 0.2, 0.7, 0.8, 0.8, 0.8, 0.8, 0.5,
            0.5, 0.5, 0.15, 0.5, 0.4;
        f.radii.resize(7);
        f.radii << 0.3, 0.25, 0.3, 0.2, 0.3, 0.15, 0.2;
        f.owner = assign_handle_regions(f.mesh.positions, f.centers, f.radii, 0.5);
        return f;
    }

    TEST(HandleRegions, BallsOverlapsAndEmptyHandles)
    {
        MatX3 nodes(6, 3);
        nodes << 0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0, 4, 0, 0, 5, 0, 0;
        MatX3 centers(4, 3);
        // Handle 0 (ball 1.0) covers nodes 0, 1. Handle 1 (ball 1.4) covers 2, 3. Handle 2's
        // ball holds no node: it takes its nearest, node 5. Handle 3 coincides with handle 2 and
        // cannot take node 5 (handle 2's only node): it takes node 4.
        centers << 0.2, 0, 0, 2.5, 0, 0, 4.6, 0.4, 0, 4.6, 0.4, 0;
        VecX radii(4);
        radii << 2.0, 2.8, 0.2, 0.2;
        VecXi owner = assign_handle_regions(nodes, centers, radii, 0.5);
        VecXi expected(6);
        expected << 0, 0, 1, 1, 3, 2;
        EXPECT_EQ(owner, expected);

        // Overlapping balls: node 1 is in both, relatively nearer to handle 1 (0.2/1 < 0.8/2).
        MatX3 two(2, 3);
        two << 0.2, 0, 0, 1.2, 0, 0;
        VecX two_radii(2);
        two_radii << 2.0, 1.0;
        expected << 0, 1, -1, -1, -1, -1;
        EXPECT_EQ(assign_handle_regions(nodes, two, two_radii, 0.5), expected);

        // A huge ball owns every node: an empty handle steals its nearest one.
        two << 2.5, 0, 0, 5.1, 0, 0;
        two_radii << 100.0, 0.01;
        expected << 0, 0, 0, 0, 0, 1;
        EXPECT_EQ(assign_handle_regions(nodes, two, two_radii, 0.5), expected);

        EXPECT_THROW(assign_handle_regions(nodes, centers, VecX::Constant(4, -1.0), 0.5), Error);
        EXPECT_THROW(assign_handle_regions(nodes, centers, radii, 0.0), Error);
        EXPECT_THROW(assign_handle_regions(nodes.topRows(3), centers, radii, 0.5), Error);
    }

    TEST(HandleRegions, EveryRegionGetsAWholeTet)
    {
        // 4 x 4 x 4 cells of 0.25; handle 0's ball covers the box, handles 1 and 2 sit beside a
        // node inside it with balls that hold no node: steps 1-3 leave them one node each, every
        // neighbour owned by handle 0.
        test::GridTetOptions grid;
        const TetMesh mesh = test::make_grid_tets(grid);
        MatX3 centers(3, 3);
        centers << 0.5, 0.5, 0.5, 0.51, 0.5, 0.5, 0.49, 0.51, 0.5;
        VecX radii(3);
        radii << 2.0, 0.01, 0.01;
        const VecXi steps_1_3 = assign_handle_regions(mesh.positions, centers, radii, 0.5);
        EXPECT_EQ((steps_1_3.array() == 1).count(), 1);
        EXPECT_EQ((steps_1_3.array() == 2).count(), 1);
        const WholeTetRegions regions
            = give_every_region_a_tet(steps_1_3, mesh.positions, mesh.tets, centers);
        EXPECT_EQ(regions.handles_given_tets, 2);
        std::vector<Index> whole_tets(3, 0);
        for (Index t = 0; t < mesh.num_tets(); ++t) {
            const int j = regions.owner(mesh.tets(t, 0));
            if (j >= 0
                && (mesh.tets.row(t).unaryExpr([&](int i) { return regions.owner(i); }).array()
                    == j)
                       .all())
                ++whole_tets[static_cast<size_t>(j)];
        }
        for (Index j = 0; j < 3; ++j)
            EXPECT_GE(whole_tets[static_cast<size_t>(j)], 1) << "handle " << j;
        // Handles that own a whole tet are left alone.
        EXPECT_EQ(give_every_region_a_tet(regions.owner, mesh.positions, mesh.tets, centers).owner,
            regions.owner);

        // One node per handle at every node: no tet can be given to all of them.
        test::GridTetOptions tiny;
        tiny.nx = tiny.ny = tiny.nz = 1;
        const TetMesh cube = test::make_grid_tets(tiny);
        test::expect_error_containing(
            [&] {
                give_every_region_a_tet(assign_handle_regions(cube.positions, cube.positions,
                                            VecX::Constant(8, 0.1), 0.5),
                    cube.positions, cube.tets, cube.positions);
            },
            { "no tet is left for handle 1", "--tet-size" });
    }

    TEST(HarmonicWeights, EveryHandleKeepsAnAffineFrameOnItsSupport)
    {
        // Without step 4 the hemmed-in handles' weights live on one node each: their columns
        // w [1, y] span 1 dimension instead of 4. With it, 4 each.
        test::GridTetOptions grid;
        const TetMesh mesh = test::make_grid_tets(grid);
        const Eigen::SparseMatrix<double> laplacian = assemble_laplacian(
            mesh.num_vertices(), mesh.tets, compute_tet_rest_data(mesh.positions, mesh.tets));
        MatX3 centers(3, 3);
        centers << 0.5, 0.5, 0.5, 0.51, 0.5, 0.5, 0.49, 0.51, 0.5;
        VecX radii(3);
        radii << 2.0, 0.01, 0.01;
        const VecXi steps_1_3 = assign_handle_regions(mesh.positions, centers, radii, 0.5);
        const auto affine_rank = [&](const VecXi& owner, Index j) {
            const MatX w = MatX(compute_harmonic_weights(laplacian, owner, 3).weights);
            MatX columns(w.rows(), 4);
            for (Index i = 0; i < w.rows(); ++i) {
                columns(i, 0) = w(i, j);
                columns.block<1, 3>(i, 1) = w(i, j) * (mesh.positions.row(i) - centers.row(j));
            }
            return Eigen::FullPivLU<MatX>(columns).setThreshold(1e-10).rank();
        };
        EXPECT_EQ(affine_rank(steps_1_3, 1), 1);
        const VecXi owner
            = give_every_region_a_tet(steps_1_3, mesh.positions, mesh.tets, centers).owner;
        for (Index j = 0; j < 3; ++j)
            EXPECT_EQ(affine_rank(owner, j), 4) << "handle " << j;
    }

    TEST(HarmonicWeights, UnsparsifiedWeightsSolveTheConstrainedLaplace)
    {
        // The regular Kuhn grid has no obtuse dihedral angle: an M-matrix, so the discrete
        // maximum principle keeps the weights in [0, 1] and no clamping happens.
        const Fixture f = make_fixture(0.0);
        HarmonicWeightOptions options;
        options.max_handles_per_node = 7;
        options.block_columns = 3; // exercise several blocks
        const HarmonicWeights result = compute_harmonic_weights(f.laplacian, f.owner, 7, options);
        const HarmonicWeightDiagnostics& d = result.diagnostics;
        EXPECT_LT(d.max_partition_error, 1e-10);
        EXPECT_GE(d.min_weight, -1e-14);
        EXPECT_LE(d.max_weight, 1.0 + 1e-14);
        EXPECT_LT(d.max_sparsify_change, 1e-15);
        EXPECT_EQ(d.num_free + d.num_constrained, f.mesh.num_vertices());

        // Brute force: solve L_ff w_f = -L_fc w_c with Eigen for each handle.
        const Index n = f.mesh.num_vertices();
        std::vector<Index> free_nodes;
        for (Index i = 0; i < n; ++i)
            if (f.owner[i] < 0)
                free_nodes.push_back(i);
        const MatX dense_l = MatX(f.laplacian);
        const auto nf = static_cast<Index>(free_nodes.size());
        MatX lff(nf, nf);
        for (Index a = 0; a < nf; ++a)
            for (Index b = 0; b < nf; ++b)
                lff(a, b) = dense_l(free_nodes[a], free_nodes[b]);
        const Eigen::LLT<MatX> llt(lff);
        const MatX w = MatX(result.weights);
        for (Index j = 0; j < 7; ++j) {
            VecX rhs = VecX::Zero(nf);
            for (Index a = 0; a < nf; ++a)
                for (Index c = 0; c < n; ++c)
                    if (f.owner[c] == j)
                        rhs[a] -= dense_l(free_nodes[a], c);
            const VecX expected = llt.solve(rhs);
            for (Index a = 0; a < nf; ++a)
                EXPECT_NEAR(w(free_nodes[a], j), expected[a], 1e-11);
        }
    }

    TEST(HarmonicWeights, PartitionOfUnityBoundsRegionsAndSparsity)
    {
        const Fixture f = make_fixture(0.18);
        const Index n = f.mesh.num_vertices();
        for (int k : { 2, 3, 7 }) {
            HarmonicWeightOptions options;
            options.max_handles_per_node = k;
            const HarmonicWeights result
                = compute_harmonic_weights(f.laplacian, f.owner, 7, options);
            const auto& w = result.weights;
            ASSERT_EQ(w.rows(), n);
            ASSERT_EQ(w.cols(), 7);
            EXPECT_LT(result.diagnostics.max_partition_error, 1e-10);
            EXPECT_EQ(result.diagnostics.nonzeros, w.nonZeros());
            for (Index i = 0; i < n; ++i) {
                double sum = 0.0;
                int count = 0;
                for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(w, i); it;
                     ++it) {
                    EXPECT_GT(it.value(), 0.0);
                    EXPECT_LE(it.value(), 1.0);
                    sum += it.value();
                    ++count;
                    if (f.owner[i] >= 0) {
                        EXPECT_EQ(it.col(), f.owner[i]);
                        EXPECT_EQ(it.value(), 1.0);
                    }
                }
                EXPECT_NEAR(sum, 1.0, 1e-14) << "node " << i;
                EXPECT_LE(count, k);
                EXPECT_GE(count, 1);
            }
        }
    }

    TEST(HarmonicWeights, ReportedSparsificationChangeIsTheTrueChange)
    {
        // Jittered: obtuse tets make slightly negative raw weights that get clamped.
        const Fixture f = make_fixture(0.18);
        HarmonicWeightOptions all;
        all.max_handles_per_node = 7;
        const HarmonicWeights reference = compute_harmonic_weights(f.laplacian, f.owner, 7, all);
        HarmonicWeightOptions three;
        three.max_handles_per_node = 3;
        const HarmonicWeights sparse = compute_harmonic_weights(f.laplacian, f.owner, 7, three);
        const MatX change = MatX(sparse.weights) - MatX(reference.weights);
        const double max_change = change.cwiseAbs().maxCoeff();
        const double rms = std::sqrt(change.rowwise().squaredNorm().mean());
        EXPECT_NEAR(sparse.diagnostics.max_sparsify_change, max_change, 1e-12);
        EXPECT_NEAR(sparse.diagnostics.rms_sparsify_change, rms, 1e-9);
        EXPECT_GT(max_change, 1e-4); // K = 3 of 7 really drops weight
        EXPECT_LT(reference.diagnostics.max_sparsify_change, 1e-15);
        EXPECT_GE(reference.diagnostics.max_clamp_change, -reference.diagnostics.min_weight);
    }

    TEST(HarmonicWeights, ResultDoesNotDependOnThreadCount)
    {
        const Fixture f = make_fixture(0.1, 6);
        set_threads(1);
        const HarmonicWeights one = compute_harmonic_weights(f.laplacian, f.owner, 7);
        set_threads(2);
        const HarmonicWeights two = compute_harmonic_weights(f.laplacian, f.owner, 7);
        set_threads(0);
        EXPECT_EQ(MatX(one.weights), MatX(two.weights));
    }

    TEST(HarmonicWeights, RejectsBadRegions)
    {
        const Fixture f = make_fixture(0.0, 4);
        VecXi owner = f.owner;
        EXPECT_THROW(compute_harmonic_weights(f.laplacian, owner, 8), Error); // handle 7 empty
        owner[0] = 9;
        EXPECT_THROW(compute_harmonic_weights(f.laplacian, f.owner.head(3), 7), Error);
        EXPECT_THROW(compute_harmonic_weights(f.laplacian, owner, 7), Error);

        // Two disjoint boxes, handles only in the first: the second box's nodes are unreachable.
        const Index n = f.mesh.num_vertices();
        Eigen::SparseMatrix<double> two(2 * n, 2 * n);
        std::vector<Eigen::Triplet<double>> entries;
        for (Index c = 0; c < n; ++c)
            for (Eigen::SparseMatrix<double>::InnerIterator it(f.laplacian, c); it; ++it) {
                entries.emplace_back(it.row(), c, it.value());
                entries.emplace_back(it.row() + n, c + n, it.value());
            }
        two.setFromTriplets(entries.begin(), entries.end());
        VecXi two_owner = VecXi::Constant(2 * n, -1);
        two_owner.head(n) = f.owner;
        test::expect_error_containing(
            [&] { compute_harmonic_weights(two, two_owner, 7); }, { "node " + std::to_string(n) });
    }

} // namespace
} // namespace mat
