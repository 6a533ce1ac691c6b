// The hyper-reduced solver: with every tet sampled it is the semi-reduced solver; with fewer it
// stays at rest, approaches the semi-reduced trajectory as samples are added, and does not depend
// on the thread count; the farthest-point samples.

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/error.hpp"
#include "common/parallel.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/hyper_reduced.hpp"
#include "runtime/pd/local_step.hpp"
#include "runtime/pd/solver.hpp"
#include "runtime/state.hpp"
#include "tests/runtime/pd/pd_test_support.hpp"
#include "tests/runtime/runtime_test_models.hpp"

namespace mat {
namespace {

    using test::twist_velocities;
    ModelOptions model_options()
    {
        return test::pd_model_options();
    }

    /// max_i |a_i - b_i| over the size of `rest`'s bounding box.
    double relative_difference(const MatX3& a, const MatX3& b, const MatX3& rest)
    {
        const double size = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
        return (a - b).rowwise().norm().maxCoeff() / size;
    }

    TEST(HyperReducedSolver, EveryTetSampledIsTheSemiReducedSolver)
    {
        const BakeData& bake = test::shipped_cube_bake();
        for (const bool pinned : { false, true }) {
            ModelOptions options = model_options();
            if (pinned) {
                options.pin_weight_scale = 1.0; // soft, as on reduced bodies in scenes
                for (Index i = 0; i < bake.tet_mesh.positions.rows(); ++i)
                    if (bake.tet_mesh.positions(i, 0) < 0.2)
                        options.pinned_nodes.push_back(static_cast<int>(i));
            }
            const Model model(bake, Material {}, options);
            PdSolver semi = semi_reduced_solver(model);
            PdSolver hyper = hyper_reduced_solver(model, {}, model.num_tets());
            ASSERT_EQ(static_cast<Index>(hyper.local_stage().num_tets()), model.num_tets());
            State start = State::at_rest(model);
            start.velocities = twist_velocities(start.positions);
            const State a = test::run_steps(semi, start, 10);
            const State b = test::run_steps(hyper, start, 10);
            const double difference
                = relative_difference(a.positions, b.positions, start.positions);
            RecordProperty(pinned ? "pinned" : "free", fmt::format("{:.3g}", difference));
            EXPECT_LT(difference, 1e-6) << "pinned " << pinned;
            // It moved: the comparison is not between two bodies at rest.
            EXPECT_GT(relative_difference(a.positions, start.positions, start.positions),
                pinned ? 1e-3 : 1e-2);
        }
    }

    TEST(HyperReducedSolver, FewerSamplesStayCloseToSemiReduced)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        State start = State::at_rest(model);
        start.velocities = twist_velocities(start.positions);
        PdSolver semi = semi_reduced_solver(model);
        PdSolver full = full_solver(model);
        const State semi_end = test::run_steps(semi, start, 10);
        const State full_end = test::run_steps(full, start, 10);
        const double reduction
            = relative_difference(semi_end.positions, full_end.positions, start.positions);
        std::vector<double> errors;
        std::string trace
            = fmt::format("tets {} k {} semi-vs-full {:.3g}; hyper-vs-semi:", model.num_tets(),
                model.num_columns(), reduction);
        for (const Index samples :
            { 2 * model.num_columns(), 8 * model.num_columns(), model.num_tets() / 2 }) {
            PdSolver hyper = hyper_reduced_solver(model, {}, samples);
            const State end = test::run_steps(hyper, start, 10);
            ASSERT_TRUE(end.positions.allFinite());
            errors.push_back(
                relative_difference(end.positions, semi_end.positions, start.positions));
            trace
                += fmt::format(" {} samples {:.3g}", hyper.local_stage().num_tets(), errors.back());
        }
        RecordProperty("errors", trace);
        // More samples, closer to semi-reduced; 8k samples add less than the reduction's own
        // error.
        EXPECT_LT(errors[1], errors[0]) << trace;
        EXPECT_LT(errors[2], errors[1]) << trace;
        EXPECT_LT(errors[1], reduction) << trace;
    }

    TEST(HyperReducedSolver, BodyAtRestStaysAtRest)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        SolverOptions options;
        options.gravity.setZero();
        PdSolver hyper = hyper_reduced_solver(model, options);
        const State rest = State::at_rest(model);
        const State end = test::run_steps(hyper, rest, 5);
        EXPECT_LT((end.positions - rest.positions).cwiseAbs().maxCoeff(), 1e-10);
        EXPECT_LT(end.velocities.cwiseAbs().maxCoeff(), 1e-10);
    }

    TEST(HyperReducedSolver, ResultsDoNotDependOnTheThreadCount)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        State start = State::at_rest(model);
        start.velocities = twist_velocities(start.positions);
        std::vector<State> ends;
        for (const int threads : { 1, 2 }) {
            set_threads(threads);
            PdSolver hyper = hyper_reduced_solver(model);
            ends.push_back(test::run_steps(hyper, start, 5));
        }
        set_threads(0);
        EXPECT_EQ(ends[0].positions, ends[1].positions);
        EXPECT_EQ(ends[0].velocities, ends[1].velocities);
    }

    // The local step over a tet subset: compute_touched writes the sums of compute on the subset's
    // nodes and leaves every other row as it was.
    TEST(HyperReducedSolver, SubsetLocalStepWritesOnlyTheTouchedRows)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        const std::vector<int> subset = farthest_point_tets(model, 40);
        LocalStep a(model, true, subset), b(model, true, subset);
        MatX3 positions = model.rest_positions();
        positions += 0.05 * twist_velocities(positions);
        MatX3 full = MatX3::Zero(model.num_nodes(), 3);
        a.compute(model, positions, full);
        MatX3 touched = MatX3::Constant(model.num_nodes(), 3, 7.0);
        b.compute_touched(model, positions, touched);
        std::vector<char> in_subset(model.num_nodes(), 0);
        for (const int e : subset)
            for (int c = 0; c < 4; ++c)
                in_subset[model.tets()(e, c)] = 1;
        Index rows = 0;
        for (Index i = 0; i < model.num_nodes(); ++i) {
            if (in_subset[i]) {
                ++rows;
                EXPECT_EQ(touched.row(i), full.row(i)) << "node " << i;
            } else {
                EXPECT_EQ(touched.row(i), Eigen::RowVector3d::Constant(7.0)) << "node " << i;
                EXPECT_EQ(full.row(i), Eigen::RowVector3d::Zero()) << "node " << i;
            }
        }
        EXPECT_GT(rows, 40);
        EXPECT_GT(full.cwiseAbs().maxCoeff(), 0.0);
    }

    TEST(HyperReducedSolver, FarthestPointSamplesAreDistinctSortedAndSpread)
    {
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, model_options());
        const Index t = model.num_tets();
        const std::vector<int> samples = farthest_point_tets(model, 20);
        ASSERT_EQ(samples.size(), 20u);
        EXPECT_TRUE(std::is_sorted(samples.begin(), samples.end()));
        EXPECT_EQ(std::set<int>(samples.begin(), samples.end()).size(), samples.size());
        EXPECT_EQ(samples, farthest_point_tets(model, 20)); // deterministic
        // Spread: the samples' centroids reach into every octant of the cube.
        std::set<int> octants;
        for (const int e : samples) {
            Vec3 c = Vec3::Zero();
            for (int k = 0; k < 4; ++k)
                c += 0.25 * model.rest_positions().row(model.tets()(e, k)).transpose();
            octants.insert((c.x() > 0.5) + 2 * (c.y() > 0.5) + 4 * (c.z() > 0.5));
        }
        EXPECT_EQ(octants.size(), 8u);
        EXPECT_EQ(static_cast<Index>(farthest_point_tets(model, 10 * t).size()), t);
        EXPECT_EQ(farthest_point_tets(model, 0).size(), 1u);
        EXPECT_THROW(hyper_reduced_solver(model, {}, -1), Error);
    }

} // namespace
} // namespace mat
