// Point embedding in tets: inside points reproduce themselves from their barycentric
// coordinates; outside points take a tet near them that is never more extrapolated than the nearest
// one, compared against brute force.

#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "preprocess/embedding/tet_embedding.hpp"
#include "tests/support/grid_tets.hpp"

namespace mat {
namespace {

    TEST(Embedding, InsidePointsGetTheirTetAndExactBarycentrics)
    {
        test::GridTetOptions grid;
        grid.nx = grid.ny = grid.nz = 5;
        grid.jitter = 0.15;
        const TetMesh mesh = test::make_grid_tets(grid);
        std::mt19937 rng(3);
        std::uniform_real_distribution<double> uniform(0.0, 1.0);
        MatX3 points(500, 3);
        for (Index i = 0; i < points.rows(); ++i)
            points.row(i) << uniform(rng), uniform(rng), uniform(rng);
        const TetEmbedding embedding = embed_points(mesh, points);
        EXPECT_EQ(embedding.outside_count, 0);
        for (Index i = 0; i < points.rows(); ++i) {
            const Vec4 bary = embedding.barycentric.row(i).transpose();
            EXPECT_GE(bary.minCoeff(), -1e-12);
            EXPECT_NEAR(bary.sum(), 1.0, 1e-12);
            Vec3 rebuilt = Vec3::Zero();
            for (int k = 0; k < 4; ++k)
                rebuilt += bary(k) * mesh.positions.row(mesh.tets(embedding.tet(i), k)).transpose();
            EXPECT_LT((rebuilt - points.row(i).transpose()).norm(), 1e-12);
        }
    }

    TEST(Embedding, OutsidePointsUseATetNoMoreExtrapolatedThanTheNearest)
    {
        test::GridTetOptions grid;
        grid.nx = 4;
        grid.ny = 3;
        grid.nz = 2;
        grid.jitter = 0.1;
        const TetMesh mesh = test::make_grid_tets(grid);
        std::mt19937 rng(11);
        std::uniform_real_distribution<double> uniform(-0.6, 1.6);
        MatX3 points(300, 3);
        for (Index i = 0; i < points.rows(); ++i) {
            do {
                points.row(i) << uniform(rng), uniform(rng), uniform(rng);
            } while ((points.row(i).array() >= 0).all() && (points.row(i).array() <= 1).all());
        }
        const TetEmbedding embedding = embed_points(mesh, points);
        EXPECT_EQ(embedding.outside_count, points.rows());
        auto corner
            = [&](Index t, int k) { return mesh.positions.row(mesh.tets(t, k)).transpose(); };
        auto smallest_weight = [&](Index t, const Vec3& x) {
            return tet_barycentric(corner(t, 0), corner(t, 1), corner(t, 2), corner(t, 3), x)
                .minCoeff();
        };
        double max_distance = 0.0;
        int less_extrapolated = 0;
        for (Index i = 0; i < points.rows(); ++i) {
            const Vec3 x = points.row(i).transpose();
            double brute = std::numeric_limits<double>::infinity();
            Index nearest = 0;
            for (Index t = 0; t < mesh.num_tets(); ++t) {
                const double d
                    = point_tet_distance(corner(t, 0), corner(t, 1), corner(t, 2), corner(t, 3), x);
                if (d < brute) {
                    brute = d;
                    nearest = t;
                }
            }
            max_distance = std::max(max_distance, brute);
            // The tet taken is never more extrapolated than the nearest one.
            const Index t = embedding.tet(i);
            EXPECT_GE(smallest_weight(t, x), smallest_weight(nearest, x) - 1e-12) << "point " << i;
            less_extrapolated += smallest_weight(t, x) > smallest_weight(nearest, x) + 1e-9;
            EXPECT_NEAR(embedding.barycentric.row(i).minCoeff(), smallest_weight(t, x), 1e-12);
            // Extrapolated coordinates still reproduce the point (affine fields stay exact).
            Vec3 rebuilt = Vec3::Zero();
            for (int k = 0; k < 4; ++k)
                rebuilt += embedding.barycentric(i, k) * corner(t, k);
            EXPECT_LT((rebuilt - x).norm(), 1e-10);
        }
        // The nearest tet is often a flat one at a corner of the grid: a rounder one is found.
        EXPECT_GT(less_extrapolated, 0);
        EXPECT_NEAR(embedding.max_outside_distance, max_distance, 1e-12);
    }

    TEST(Embedding, PointTetDistanceIsZeroInsideAndEuclideanOutside)
    {
        const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), d(0, 0, 1);
        EXPECT_EQ(point_tet_distance(a, b, c, d, Vec3(0.1, 0.1, 0.1)), 0.0);
        EXPECT_NEAR(point_tet_distance(a, b, c, d, Vec3(-2, 0.2, 0.2)), 2.0, 1e-15);
        EXPECT_NEAR(point_tet_distance(a, b, c, d, Vec3(-1, -1, -1)), std::sqrt(3.0), 1e-15);
        EXPECT_NEAR(point_tet_distance(a, b, c, d, Vec3(1, 1, 1)), 2.0 / std::sqrt(3.0), 1e-15);
    }

} // namespace
} // namespace mat
