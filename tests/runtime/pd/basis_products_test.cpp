// The reduced global step's products with the handle basis, B^T y and X + B q, against Eigen's
// sparse products: in handle form (linear and mixed linear/quadratic handles of a real bake)
// and through the plain CSR fallback when the basis is not in that form; B^T y with y read from
// the local step's sums.
#include <random>

#include <gtest/gtest.h>

#include "common/parallel.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/basis_products.hpp"
#include "runtime/pd/local_step.hpp"
#include "tests/runtime/runtime_test_models.hpp"

namespace mat {
namespace {

    /// Both products against Eigen's on random y and q, and the same bits on 1 and 2 threads.
    void expect_products_match(const Model& model, BasisProducts& products)
    {
        const Index n = model.num_nodes(), k = model.num_columns();
        std::mt19937 rng(3);
        std::uniform_real_distribution<double> uniform(-1.0, 1.0);
        MatX3 y(n, 3), q(k, 3);
        for (Index i = 0; i < y.size(); ++i)
            y.data()[i] = uniform(rng);
        for (Index i = 0; i < q.size(); ++i)
            q.data()[i] = uniform(rng);
        const MatX3 expected_bty = model.basis().transpose() * y;
        const MatX3 expected_x = model.rest_positions() + model.basis() * q;
        MatX3 bty[2], x[2];
        for (const int threads : { 1, 2 }) {
            set_threads(threads);
            bty[threads - 1].resize(k, 3);
            x[threads - 1].resize(n, 3);
            products.transpose_times(y.data(), bty[threads - 1].data());
            products.reconstruct(q.data(), x[threads - 1].data());
        }
        set_threads(0);
        EXPECT_LT((bty[0] - expected_bty).norm(), 1e-12 * expected_bty.norm());
        EXPECT_LT((x[0] - expected_x).norm(), 1e-12 * expected_x.norm());
        EXPECT_EQ(bty[0], bty[1]);
        EXPECT_EQ(x[0], x[1]);

        // B^T of the local step's right-hand side read from its sums (base y) is B^T of the
        // assembled one, bit for bit, and so are the rows themselves.
        const MatX3 positions = x[0];
        LocalStep local(model, false);
        MatX3 assembled(n, 3);
        local.assemble(model, positions, y, assembled);
        LocalStep fused(model, false);
        fused.project(model, positions);
        const LocalSums sums = fused.sums(y.data());
        MatX3 rows(n, 3);
        for (Index i = 0; i < n; ++i) {
            double v[3];
            sums.row(i, v);
            rows.row(i) << v[0], v[1], v[2];
        }
        EXPECT_EQ(rows, assembled);
        MatX3 from_sums(k, 3), from_rows(k, 3);
        products.transpose_times(sums, from_sums.data());
        products.transpose_times(assembled.data(), from_rows.data());
        EXPECT_EQ(from_sums, from_rows);
    }

    TEST(BasisProducts, HandleFormMatchesTheSparseProducts)
    {
        for (const char* quadratic : { "none", "1", "all" }) {
            SCOPED_TRACE(quadratic);
            const BakeData bake = test::bake_cube("", quadratic);
            const Model model(bake, Material {}, ModelOptions {});
            BasisProducts products(model);
            EXPECT_TRUE(products.factored());
            expect_products_match(model, products);
        }
    }

    TEST(BasisProducts, FallsBackToCsrWhenTheBasisIsNotInHandleForm)
    {
        // One entry off by 1e-6 relative: no longer w p(y), so the plain products must be used.
        BakeData bake = test::shipped_cube_bake();
        bake.basis.valuePtr()[bake.basis.nonZeros() / 2] *= 1.0 + 1e-6;
        const Model model(bake, Material {}, ModelOptions {});
        BasisProducts products(model);
        EXPECT_FALSE(products.factored());
        expect_products_match(model, products);

        // The identity basis of the complete-basis tests has no handles at all.
        test::GridTetOptions grid;
        const Model identity(test::make_identity_bake(grid), Material {}, ModelOptions {});
        BasisProducts plain(identity);
        EXPECT_FALSE(plain.factored());
        expect_products_match(identity, plain);
    }

} // namespace
} // namespace mat
