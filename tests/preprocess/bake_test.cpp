// The whole bake on a small shipped case (a unit cube with a 2-cone medial mesh): the checks of
// the bake (docs/method.md, section 2) on weights, basis, reduced matrices, collision bounds, the
// HDF5 round trip and determinism.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "formats/bake_io.hpp"
#include "formats/medial_io.hpp"
#include "preprocess/bake/bake_pipeline.hpp"
#include "preprocess/collision/bound_data.hpp"
#include "preprocess/weights/handle_regions.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    const std::string data_dir = std::string(MAT_TEST_DATA_DIR) + "/bake/";

    BakeOptions cube_options(const std::string& quadratic = "none")
    {
        BakeOptions options;
        options.surface = data_dir + "cube.obj";
        options.medial = data_dir + "cube.ma";
        options.tet_size = 0.15;
        options.quadratic = quadratic;
        return options;
    }

    const BakeData& cube_bake()
    {
        static const BakeData bake = [] {
            BakeReport report;
            return run_bake(cube_options(), report);
        }();
        return bake;
    }

    std::string read_bytes(const std::string& path)
    {
        std::ifstream in(path, std::ios::binary);
        return { std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>() };
    }

    void expect_same_sparse(const SparseRowMatrix& a, const SparseRowMatrix& b, const char* what)
    {
        ASSERT_EQ(a.rows(), b.rows()) << what;
        ASSERT_EQ(a.cols(), b.cols()) << what;
        EXPECT_EQ(MatX(a), MatX(b)) << what;
    }

    void expect_same_bake(const BakeData& a, const BakeData& b)
    {
        EXPECT_EQ(a.surface_hash, b.surface_hash);
        EXPECT_EQ(a.medial_hash, b.medial_hash);
        EXPECT_EQ(a.options_json, b.options_json);
        EXPECT_EQ(a.tet_mesh.positions, b.tet_mesh.positions);
        EXPECT_EQ(a.tet_mesh.tets, b.tet_mesh.tets);
        EXPECT_EQ(a.dm_inverse, b.dm_inverse);
        EXPECT_EQ(a.rest_volumes, b.rest_volumes);
        EXPECT_EQ(a.lumped_mass, b.lumped_mass);
        EXPECT_EQ(a.surface.positions, b.surface.positions);
        EXPECT_EQ(a.surface.faces, b.surface.faces);
        EXPECT_EQ(a.surface_tet, b.surface_tet);
        EXPECT_EQ(a.surface_barycentric, b.surface_barycentric);
        EXPECT_EQ(a.surface_outside_count, b.surface_outside_count);
        EXPECT_EQ(a.medial.centers, b.medial.centers);
        EXPECT_EQ(a.medial.radii, b.medial.radii);
        EXPECT_EQ(a.medial.cones, b.medial.cones);
        EXPECT_EQ(a.medial.slabs, b.medial.slabs);
        EXPECT_EQ(a.medial_input_radii, b.medial_input_radii);
        EXPECT_EQ(a.medial_inflation, b.medial_inflation);
        EXPECT_EQ(a.medial_tet, b.medial_tet);
        EXPECT_EQ(a.medial_barycentric, b.medial_barycentric);
        EXPECT_EQ(a.handle_centers, b.handle_centers);
        EXPECT_EQ(a.handle_scales, b.handle_scales);
        EXPECT_EQ(a.handle_quadratic, b.handle_quadratic);
        EXPECT_EQ(a.handle_column_offsets, b.handle_column_offsets);
        expect_same_sparse(a.weights, b.weights, "weights");
        expect_same_sparse(a.basis, b.basis, "basis");
        expect_same_sparse(a.medial_basis, b.medial_basis, "medial basis");
        expect_same_sparse(a.laplacian, b.laplacian, "laplacian");
        EXPECT_EQ(a.reduced_laplacian, b.reduced_laplacian);
        EXPECT_EQ(a.reduced_mass, b.reduced_mass);
        const MedialCollisionData &ca = a.collision, &cb = b.collision;
        EXPECT_EQ(ca.primitive_kind, cb.primitive_kind);
        EXPECT_EQ(ca.primitive_spheres, cb.primitive_spheres);
        EXPECT_EQ(ca.vertex_primitive, cb.vertex_primitive);
        EXPECT_EQ(ca.vertex_parameter, cb.vertex_parameter);
        EXPECT_EQ(ca.face_primitives_indptr, cb.face_primitives_indptr);
        EXPECT_EQ(ca.face_primitives, cb.face_primitives);
        EXPECT_EQ(ca.bound_indptr, cb.bound_indptr);
        EXPECT_EQ(ca.bound_handles, cb.bound_handles);
        EXPECT_EQ(ca.bound_factors, cb.bound_factors);
    }

    TEST(Bake, WeightsArePartitionOfUnityBoundedAndOneOnTheirRegion)
    {
        const BakeData& bake = cube_bake();
        const MatX w(bake.weights);
        ASSERT_EQ(w.cols(), 3);
        EXPECT_LT((w.rowwise().sum().array() - 1.0).abs().maxCoeff(), 1e-12);
        EXPECT_GE(w.minCoeff(), 0.0);
        EXPECT_LE(w.maxCoeff(), 1.0 + 1e-15);
        // The bake's region rule, recomputed: each handle is exactly 1 on its own region.
        const VecXi regions = assign_handle_regions(
            bake.tet_mesh.positions, bake.handle_centers, bake.medial_input_radii, 0.5);
        Index region_nodes = 0;
        for (Index i = 0; i < regions.size(); ++i) {
            if (regions(i) < 0)
                continue;
            ++region_nodes;
            for (Index j = 0; j < w.cols(); ++j)
                EXPECT_EQ(w(i, j), j == regions(i) ? 1.0 : 0.0) << "node " << i << " handle " << j;
        }
        EXPECT_GE(region_nodes, 3);
    }

    TEST(Bake, BasisReproducesAffineAndQuadraticFields)
    {
        BakeReport linear_report;
        run_bake(cube_options("none"), linear_report);
        EXPECT_LT(linear_report.linear_precision_error, 1e-12);
        EXPECT_LT(linear_report.quadratic_precision_error, 0.0); // no quadratic handle
        BakeReport quadratic_report;
        const BakeData quadratic = run_bake(cube_options("all"), quadratic_report);
        EXPECT_EQ(quadratic.num_columns(), 30);
        EXPECT_LT(quadratic_report.linear_precision_error, 1e-12);
        EXPECT_GE(quadratic_report.quadratic_precision_error, 0.0);
        EXPECT_LT(quadratic_report.quadratic_precision_error, 1e-10);
        // Mixed: only handle 1 quadratic.
        BakeReport mixed_report;
        const BakeData mixed = run_bake(cube_options("1"), mixed_report);
        EXPECT_EQ(mixed.num_columns(), 4 + 10 + 4);
        EXPECT_EQ(mixed.handle_quadratic, (VecXi(3) << 0, 1, 0).finished());
    }

    TEST(Bake, ReducedMatricesAreSymmetricPositiveDefinite)
    {
        const BakeData& bake = cube_bake();
        const MatX& l = bake.reduced_laplacian;
        const MatX& m = bake.reduced_mass;
        EXPECT_EQ(l, l.transpose());
        EXPECT_EQ(m, m.transpose());
        Eigen::LLT<MatX> mass(m);
        EXPECT_EQ(mass.info(), Eigen::Success);
        const MatX system = 1e5 * l + 1000.0 * 900.0 * m; // E, density / dt^2 at dt = 1/30
        Eigen::LLT<MatX> full(system);
        EXPECT_EQ(full.info(), Eigen::Success);
        // L is only semi-definite: translations are in its null space.
        const Eigen::SelfAdjointEigenSolver<MatX> eigen(l);
        EXPECT_GT(eigen.eigenvalues().minCoeff(), -1e-12 * eigen.eigenvalues().maxCoeff());
    }

    TEST(Bake, CollisionBoundEnclosesDeformedSurface)
    {
        const BakeData& bake = cube_bake();
        const MedialCollisionData& c = bake.collision;
        const SparseRowMatrix surface_basis = interpolate_rows(
            bake.basis, bake.tet_mesh.tets, bake.surface_tet, bake.surface_barycentric);
        std::mt19937 rng(5);
        std::normal_distribution<double> normal(0.0, 1.0);
        const Index k = bake.num_columns();
        Index lazy_misses = 0;
        double tightest = 0.0; // max over vertices of (|x' - c'| - r) / (bound - r)
        for (int trial = 0; trial < 20; ++trial) {
            MatX3 q(k, 3);
            for (Index i = 0; i < k; ++i)
                for (int d = 0; d < 3; ++d)
                    q(i, d) = 0.2 * normal(rng);
            const MatX3 x = bake.surface.positions + surface_basis * q;
            const MatX3 centers = bake.medial.centers + bake.medial_basis * q;
            for (Index v = 0; v < bake.surface.num_vertices(); ++v) {
                const int p = c.vertex_primitive(v);
                Vec3 center = Vec3::Zero();
                double radius = 0.0;
                for (int s = 0; s < 3; ++s) {
                    const int sphere = c.primitive_spheres(p, s);
                    if (sphere < 0)
                        continue;
                    center += c.vertex_parameter(v, s) * centers.row(sphere).transpose();
                    radius += c.vertex_parameter(v, s) * bake.medial.radii(sphere);
                }
                double bound = radius;
                for (int e = c.bound_indptr(p); e < c.bound_indptr(p + 1); ++e) {
                    const int j = c.bound_handles(e);
                    const Index first = bake.handle_column_offsets(j);
                    const Index count = bake.handle_column_offsets(j + 1) - first;
                    const MatX qj = q.block(first, 0, count, 3);
                    bound += c.bound_factors(e) * Eigen::JacobiSVD<MatX>(qj).singularValues()(0);
                }
                const double distance = (x.row(v).transpose() - center).norm();
                EXPECT_LE(distance, bound + 1e-12) << "vertex " << v << " trial " << trial;
                lazy_misses += distance > radius ? 1 : 0;
                tightest = std::max(tightest, (distance - radius) / (bound - radius));
            }
        }
        // The terms matter: moving the spheres alone ("lazy") lets vertices out, and the bound is
        // not vacuous (some vertex uses a good part of its margin).
        EXPECT_GT(lazy_misses, 0);
        EXPECT_GT(tightest, 0.3);
        std::printf("lazy misses %lld, tightest margin use %.3f\n",
            static_cast<long long>(lazy_misses), tightest);
    }

    TEST(Bake, FileRoundTripsEveryDatasetAndBakesAreDeterministic)
    {
        const std::string dir = std::string(MAT_BINARY_DIR) + "/tests/";
        const std::string first = dir + "bake_test_first.h5", second = dir + "bake_test_second.h5";
        write_bake(first, cube_bake());
        const BakeData read = read_bake(first);
        expect_same_bake(cube_bake(), read);

        BakeReport report;
        const BakeData again = run_bake(cube_options(), report);
        expect_same_bake(cube_bake(), again);
        write_bake(second, again);
        EXPECT_EQ(read_bytes(first), read_bytes(second));
    }

    TEST(Bake, ReadingRefusesNumbersOnlyADamagedFileHolds)
    {
        const std::string path = std::string(MAT_BINARY_DIR) + "/tests/bake_test_damaged.h5";
        const auto expect_refused = [&](const BakeData& bake, const std::string& part) {
            write_bake(path, bake);
            test::expect_error_containing([&] { read_bake(path); }, { path, part });
        };
        BakeData bake = cube_bake();
        bake.tet_mesh.positions(3, 1) = std::nan("");
        expect_refused(bake, "mesh/rest_positions: entry (3, 1) = nan is not finite");
        bake = cube_bake();
        bake.lumped_mass(0) = -1.0;
        expect_refused(bake, "mesh/lumped_mass: entry 0 = -1, expected a finite value > 0");
        bake = cube_bake();
        bake.weights.valuePtr()[2] = HUGE_VAL;
        expect_refused(bake, "weights/data: entry 2 = inf is not finite");
        bake = cube_bake();
        bake.medial.radii(1) = 0.0;
        expect_refused(bake, "medial/radii: entry 1 = 0, expected a finite value > 0");
    }

    TEST(Bake, ParsesQuadraticSelection)
    {
        EXPECT_EQ(parse_quadratic("all", 3).count(), 3);
        EXPECT_EQ(parse_quadratic("none", 3).count(), 0);
        const auto some = parse_quadratic("0,2", 3);
        EXPECT_TRUE(some(0) && !some(1) && some(2));
        EXPECT_THROW(parse_quadratic("0,x", 3), Error);
        EXPECT_THROW(parse_quadratic("3", 3), Error);
        EXPECT_THROW(parse_quadratic("-1", 3), Error);
    }

    TEST(Bake, SmallSpheresInsideABigOneKeepTheBasisFullRank)
    {
        // Two tiny spheres beside the cube's middle sphere (the near-duplicates of a >1000-sphere
        // generated medial mesh). Their balls hold no node, so each gets one node inside the
        // middle sphere's region, hemmed in by it: weight on that node alone, 3 of its 4 columns
        // dependent, and the bake used to stop with "not positive definite". Now it bakes again
        // with those two regions widened to a whole tet.
        MedialMesh medial = read_medial(data_dir + "cube.ma");
        medial.centers.conservativeResize(5, 3);
        medial.radii.conservativeResize(5);
        medial.centers.row(3) << 0.51, 0.5, 0.5;
        medial.centers.row(4) << 0.49, 0.51, 0.5;
        medial.radii.tail(2).setConstant(0.01);
        const std::string path = testing::TempDir() + "bake_test_small_spheres.ma";
        write_medial(path, medial);
        BakeOptions options = cube_options();
        options.medial = path;
        options.tet_size = 0.03;
        BakeReport report;
        const BakeData bake = run_bake(options, report);
        std::remove(path.c_str());
        EXPECT_EQ(report.handles_given_tets, 2);
        EXPECT_EQ(bake.num_columns(), 20);
        EXPECT_GT(report.reduced_reciprocal_condition, 1e-10);
        // Every handle is exactly 1 on the 4 nodes of a whole tet.
        const VecXi regions = give_every_region_a_tet(
            assign_handle_regions(bake.tet_mesh.positions, bake.handle_centers,
                bake.medial_input_radii, options.region_alpha),
            bake.tet_mesh.positions, bake.tet_mesh.tets, bake.handle_centers)
                                  .owner;
        for (Index j = 0; j < 5; ++j) {
            bool whole = false;
            for (Index t = 0; t < bake.tet_mesh.num_tets() && !whole; ++t)
                whole = (bake.tet_mesh.tets.row(t)
                             .unaryExpr([&](int i) { return regions(i); })
                             .array()
                    == j)
                            .all();
            EXPECT_TRUE(whole) << "handle " << j;
        }
    }

    // `text` (cube.obj or cube.ma) with every number of its 'v' lines multiplied by `factor`.
    std::string scale_v_lines(const std::string& text, double factor)
    {
        std::istringstream lines(text);
        std::string line, out;
        while (std::getline(lines, line)) {
            if (line.rfind("v ", 0) == 0) {
                std::istringstream values(line.substr(2));
                line = "v";
                for (double value = 0; values >> value;)
                    line += fmt::format(" {:.17g}", value * factor);
            }
            out += line + "\n";
        }
        return out;
    }

    using BakeUnits = test::ScratchDirTest;

    // --unit (docs/mat-bake.md, "Units"): the cube and its medial mesh written in millimetres and
    // baked with --unit mm give the rest geometry of the same files in metres, to rounding.
    TEST_F(BakeUnits, MillimetreInputBakesAsTheSameShapeInMetres)
    {
        BakeOptions options = cube_options();
        options.surface
            = write_text("cube_mm.obj", scale_v_lines(read_bytes(data_dir + "cube.obj"), 1000));
        options.medial
            = write_text("cube_mm.ma", scale_v_lines(read_bytes(data_dir + "cube.ma"), 1000));
        options.unit = "mm";
        BakeReport report;
        const BakeData mm = run_bake(options, report);
        const BakeData& m = cube_bake();
        ASSERT_EQ(mm.surface.num_vertices(), m.surface.num_vertices());
        EXPECT_LE((mm.surface.positions - m.surface.positions).cwiseAbs().maxCoeff(), 1e-12);
        EXPECT_LE((mm.medial.centers - m.medial.centers).cwiseAbs().maxCoeff(), 1e-12);
        EXPECT_LE((mm.medial.radii - m.medial.radii).cwiseAbs().maxCoeff(), 1e-12);
        ASSERT_EQ(mm.tet_mesh.num_vertices(), m.tet_mesh.num_vertices());
        ASSERT_EQ(mm.tet_mesh.num_tets(), m.tet_mesh.num_tets());
        const double node_difference
            = (mm.tet_mesh.positions - m.tet_mesh.positions).cwiseAbs().maxCoeff();
        EXPECT_LE(node_difference, 1e-12);
        EXPECT_NEAR(mm.rest_volumes.sum(), 1.0, 0.05); // about the unit cube, not 10^9 mm^3
        EXPECT_NEAR(mm.rest_volumes.sum(), m.rest_volumes.sum(), 1e-12);
        RecordProperty("max_node_difference_m", fmt::format("{:.3g}", node_difference));
        const nlohmann::json json = nlohmann::json::parse(mm.options_json);
        EXPECT_EQ(json.at("unit"), "mm");
        EXPECT_EQ(json.at("unit_scale"), 0.001);
        EXPECT_EQ(nlohmann::json::parse(m.options_json).at("unit"), "m");

        EXPECT_EQ(unit_scale("in"), 0.0254);
        EXPECT_EQ(unit_scale("cm"), 0.01);
        EXPECT_THROW(unit_scale("ft"), Error);
    }

    TEST(Bake, RejectsBadOptions)
    {
        BakeReport report;
        BakeOptions options = cube_options();
        options.tet_size = 0;
        EXPECT_THROW(run_bake(options, report), Error);
        options = cube_options();
        options.weights_per_node = 0;
        EXPECT_THROW(run_bake(options, report), Error);
        options = cube_options();
        options.unit = "yards";
        EXPECT_THROW(run_bake(options, report), Error);
    }

} // namespace
} // namespace mat
