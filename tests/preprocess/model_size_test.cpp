// mat-bake --error (preprocess/model_size/): the chosen model is within E and the smaller
// candidates tried were not, a tighter E never gives a smaller model, and the local-step
// residual points at the handles where a bending load locks.

#include <algorithm>
#include <fstream>
#include <map>

#include <gtest/gtest.h>

#include "common/error.hpp"
#include "preprocess/model_size/model_size_search.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    const std::string bar_surface = std::string(MAT_SAMPLES_DIR) + "/rounded_bar/rounded_bar.obj";

    // A small, fast search: generated medial meshes from few samples, a coarse reference.
    ModelSizeOptions bar_search(double error_percent)
    {
        ModelSizeOptions options;
        options.error_percent = error_percent;
        options.bake.surface = bar_surface;
        options.bake.tet_size = 0.06;
        options.bake.generator.samples = 1500;
        options.max_spheres = 32;
        return options;
    }

    const ModelSizeResult& bar_result(double error_percent)
    {
        static std::map<double, ModelSizeResult> results;
        auto found = results.find(error_percent);
        if (found == results.end())
            found = results.emplace(error_percent, choose_model_size(bar_search(error_percent)))
                        .first;
        return found->second;
    }

    TEST(ModelSize, ParsesTheErrorOption)
    {
        EXPECT_DOUBLE_EQ(parse_error_percent("2"), 2.0);
        EXPECT_DOUBLE_EQ(parse_error_percent("2%"), 2.0);
        EXPECT_DOUBLE_EQ(parse_error_percent("0.5"), 0.5);
        for (const char* bad : { "", "%", "abc", "2x", "0", "-1", "nan", "inf", "100" })
            EXPECT_THROW(parse_error_percent(bad), Error) << bad;
    }

    TEST(ModelSize, ChosenModelIsWithinErrorAndSmallerCandidatesAreNot)
    {
        const double e = 5.0;
        const ModelSizeResult& result = bar_result(e);
        const ModelCandidate& chosen = result.chosen;
        EXPECT_FALSE(chosen.full_space);
        EXPECT_TRUE(chosen.within);
        EXPECT_LE(chosen.error.max_percent, e);
        EXPECT_GT(chosen.error.max_percent, 0.0);
        EXPECT_LE(chosen.error.rms_percent, chosen.error.max_percent);
        // The bake written is the chosen one.
        EXPECT_EQ(result.bake.num_handles(), chosen.spheres);
        EXPECT_EQ(3 * result.bake.num_columns(), chosen.dof);
        EXPECT_EQ(result.bake.tet_mesh.num_tets(), chosen.tets);
        EXPECT_NE(result.bake.options_json.find("model_size"), std::string::npos);
        // The reference is first; every reduced candidate with fewer DOF was over E, and at least
        // one was tried (the choice is minimal among the candidates).
        ASSERT_FALSE(result.tried.empty());
        EXPECT_EQ(result.tried.front().stage, "reference");
        EXPECT_TRUE(result.tried.front().full_space);
        int smaller = 0;
        for (const ModelCandidate& c : result.tried) {
            if (c.full_space || c.dof >= chosen.dof)
                continue;
            ++smaller;
            EXPECT_FALSE(c.within) << c.spheres << " spheres, " << c.quadratic << " quadratic";
            EXPECT_GT(c.error.max_percent, e);
        }
        EXPECT_GT(smaller, 0);
        // The tet size chosen kept the full-space model within E / 3 of the reference.
        for (const ModelCandidate& c : result.tried) {
            if (c.full_space && c.stage == "tet size" && c.tet_size <= chosen.tet_size) {
                EXPECT_LE(c.error.max_percent, e / 3.0);
            }
        }
    }

    TEST(ModelSize, TighterErrorNeverGivesASmallerModel)
    {
        const ModelSizeResult& loose = bar_result(5.0);
        const ModelSizeResult& tight = bar_result(3.0);
        EXPECT_LE(tight.chosen.error.max_percent, 3.0);
        EXPECT_GE(tight.chosen.dof, loose.chosen.dof);
        EXPECT_LE(tight.chosen.tet_size, loose.chosen.tet_size);
    }

    TEST(ModelSize, BadErrorIsOneClearError)
    {
        ModelSizeOptions options = bar_search(0.0);
        try {
            choose_model_size(options);
            FAIL() << "no error";
        } catch (const Error& error) {
            const std::string message = error.what();
            EXPECT_NE(message.find("--error"), std::string::npos) << message;
            EXPECT_EQ(message.find('\n'), std::string::npos) << message;
        }
    }

    using ModelSizeResidual = test::ScratchDirTest;

    // A cantilever along a chain of 5 handles: the bending moment is largest at the clamped root
    // and vanishes at the free tip, so the root handles' local-step residual is the largest and
    // the tip's the smallest.
    TEST_F(ModelSizeResidual, RanksTheHandlesWhereABendingLoadLocks)
    {
        const std::string medial = write_text("chain.ma",
            "5 4 0\n"
            "v -0.3 0 0 0.08\nv -0.15 0 0 0.08\nv 0 0 0 0.08\nv 0.15 0 0 0.08\nv 0.3 0 0 0.08\n"
            "e 0 1\ne 1 2\ne 2 3\ne 3 4\n");
        BakeOptions options;
        options.surface = bar_surface;
        options.medial = medial;
        options.tet_size = 0.05;
        BakeReport report;
        const BakeData bake = run_bake(options, report);
        ASSERT_EQ(bake.num_handles(), 5);

        Box3 box;
        for (Index v = 0; v < bake.surface.num_vertices(); ++v)
            box.extend(bake.surface.positions.row(v).transpose());
        std::vector<LoadCase> cases = standard_load_cases(box);
        const LoadCase& cantilever = cases[0];
        ASSERT_EQ(cantilever.axis, 0); // x is the bar's long axis
        StaticSolveOptions solve;
        calibrate_gravity(bake, box, cases, 0.1, solve);
        const StaticSolution reduced = solve_static(bake, box, cases[0], false, solve);
        const StaticSolution full = solve_static(bake, box, cases[0], true, solve);
        // The reduced model sags, less than the full one (it is stiffer), and not by nothing.
        const double sag_full
            = (full.positions - bake.tet_mesh.positions).rowwise().norm().maxCoeff();
        const double sag_reduced
            = (reduced.positions - bake.tet_mesh.positions).rowwise().norm().maxCoeff();
        EXPECT_GT(sag_reduced, 0.2 * sag_full);
        EXPECT_LT(sag_reduced, 1.05 * sag_full);

        const VecX residuals = handle_residuals(bake, reduced.positions);
        ASSERT_EQ(residuals.size(), 5);
        Index largest = 0, smallest = 0;
        residuals.maxCoeff(&largest);
        residuals.minCoeff(&smallest);
        // The first handle made quadratic is on the clamped side, and the clamped half holds more
        // residual than the free half.
        EXPECT_LE(largest, 1) << residuals.transpose();
        EXPECT_GE(smallest, 3) << residuals.transpose();
        EXPECT_GT(residuals(0) + residuals(1), residuals(3) + residuals(4))
            << residuals.transpose();
        // At rest nothing is strained.
        EXPECT_LT(handle_residuals(bake, bake.tet_mesh.positions).maxCoeff(), 1e-20);
    }

} // namespace
} // namespace mat
