#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include <Eigen/SparseCholesky>

#include "common/error.hpp"
#include "common/sparse_cholesky.hpp"
#include "tests/support/error_checks.hpp"

namespace mat {
namespace {

    // A random sparse SPD matrix: a random symmetric pattern made diagonally dominant.
    Eigen::SparseMatrix<double> random_spd(Index n, int per_row, std::uint32_t seed)
    {
        std::mt19937 rng(seed);
        std::uniform_int_distribution<Index> column(0, n - 1);
        std::uniform_real_distribution<double> value(-1.0, 1.0);
        std::vector<Eigen::Triplet<double>> entries;
        VecX row_sum = VecX::Zero(n);
        for (Index i = 0; i < n; ++i)
            for (int e = 0; e < per_row; ++e) {
                const Index j = column(rng);
                if (j == i)
                    continue;
                const double v = value(rng);
                entries.emplace_back(i, j, v);
                entries.emplace_back(j, i, v);
                row_sum[i] += std::abs(v);
                row_sum[j] += std::abs(v);
            }
        for (Index i = 0; i < n; ++i)
            entries.emplace_back(i, i, row_sum[i] + 0.1 + std::abs(value(rng)));
        Eigen::SparseMatrix<double> a(n, n);
        a.setFromTriplets(entries.begin(), entries.end());
        return a;
    }

    MatX random_dense(Index rows, Index cols, std::uint32_t seed)
    {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> value(-1.0, 1.0);
        MatX m(rows, cols);
        for (Index c = 0; c < cols; ++c)
            for (Index r = 0; r < rows; ++r)
                m(r, c) = value(rng);
        return m;
    }

    TEST(SparseCholesky, MatchesSimplicialLdltOnRandomSpdMatrices)
    {
        for (std::uint32_t seed = 1; seed <= 4; ++seed) {
            const Index n = 150 + 50 * seed;
            const Eigen::SparseMatrix<double> a = random_spd(n, 4, seed);
            const MatX rhs = random_dense(n, 5, seed + 100);
            Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> reference(a);
            ASSERT_EQ(reference.info(), Eigen::Success);
            const MatX expected = reference.solve(rhs);

            SparseCholesky cholesky;
            cholesky.compute(a, "random SPD");
            EXPECT_TRUE(cholesky.factored());
            EXPECT_EQ(cholesky.rows(), n);
            EXPECT_GE(cholesky.factor_nonzeros(), n);
            const MatX x = cholesky.solve(rhs);
            EXPECT_LT((x - expected).norm(), 1e-10 * expected.norm()) << "seed " << seed;
            EXPECT_LT((a * x - rhs).norm(), 1e-10 * rhs.norm());
        }
    }

    TEST(SparseCholesky, LowerTriangleAloneGivesTheSameSolution)
    {
        const Eigen::SparseMatrix<double> a = random_spd(300, 5, 7);
        const Eigen::SparseMatrix<double> lower = a.triangularView<Eigen::Lower>();
        const MatX rhs = random_dense(300, 3, 8);
        SparseCholesky full;
        full.compute(a, "full");
        SparseCholesky low;
        low.compute(lower, "lower");
        EXPECT_LT((full.solve(rhs) - low.solve(rhs)).norm(), 1e-12 * rhs.norm());
    }

    TEST(SparseCholesky, InPlaceSolvesReuseWorkspace)
    {
        const Index n = 250;
        const Eigen::SparseMatrix<double> a = random_spd(n, 4, 11);
        SparseCholesky cholesky;
        cholesky.compute(a, "in place");
        for (std::uint32_t trial = 0; trial < 3; ++trial) {
            const MatX rhs = random_dense(n, 3, 20 + trial);
            MatX x = rhs;
            cholesky.solve_in_place(x);
            EXPECT_LT((a * x - rhs).norm(), 1e-10 * rhs.norm());

            // Interleaved n x 3 data (positions) gives the same solution.
            MatX3 rows = rhs;
            cholesky.solve_in_place_rows(rows);
            EXPECT_LT((MatX(rows) - x).norm(), 1e-13 * x.norm());
        }
        // A column block of a larger matrix (outer stride != n).
        MatX big = random_dense(n, 6, 30);
        const MatX original = big;
        cholesky.solve_in_place(big.middleCols(2, 2));
        EXPECT_LT((a * big.middleCols(2, 2) - original.middleCols(2, 2)).norm(), 1e-10 * n);
        EXPECT_EQ(big.leftCols(2), original.leftCols(2));
    }

    TEST(SparseCholesky, RefactorKeepsTheAnalysis)
    {
        Eigen::SparseMatrix<double> a = random_spd(200, 4, 3);
        SparseCholesky cholesky;
        cholesky.compute(a, "refactor");
        a *= 2.0;
        cholesky.refactor(a);
        const MatX rhs = random_dense(200, 2, 4);
        EXPECT_LT((a * cholesky.solve(rhs) - rhs).norm(), 1e-10 * rhs.norm());
        EXPECT_THROW(cholesky.refactor(random_spd(100, 4, 3)), Error);
    }

    TEST(SparseCholesky, NotPositiveDefiniteNamesTheLabel)
    {
        Eigen::SparseMatrix<double> a = random_spd(120, 4, 5);
        a.coeffRef(60, 60) = -50.0;
        SparseCholesky cholesky;
        test::expect_error_containing([&] { cholesky.compute(a, "test matrix"); },
            { "test matrix", "not positive definite" });
        EXPECT_FALSE(cholesky.factored());
        EXPECT_THROW(cholesky.solve(MatX::Ones(120, 1)), Error);
    }

    TEST(SparseCholesky, RejectsBadInput)
    {
        SparseCholesky cholesky;
        EXPECT_THROW(cholesky.compute(Eigen::SparseMatrix<double>(3, 4), "non-square"), Error);
        Eigen::SparseMatrix<double> a = random_spd(50, 3, 9);
        a.coeffRef(10, 10) = std::numeric_limits<double>::quiet_NaN();
        EXPECT_THROW(cholesky.compute(a, "nan"), Error);
        cholesky.compute(random_spd(50, 3, 9), "ok");
        EXPECT_THROW(cholesky.solve(MatX::Ones(49, 1)), Error);
        MatX bad = MatX::Ones(50, 1);
        bad(3, 0) = std::numeric_limits<double>::infinity();
        EXPECT_THROW(cholesky.solve(bad), Error);
    }

    TEST(SparseCholesky, IsMovable)
    {
        const Eigen::SparseMatrix<double> a = random_spd(80, 3, 2);
        SparseCholesky first;
        first.compute(a, "move");
        SparseCholesky second = std::move(first);
        const MatX rhs = random_dense(80, 1, 3);
        EXPECT_LT((a * second.solve(rhs) - rhs).norm(), 1e-10 * rhs.norm());
    }

} // namespace
} // namespace mat
