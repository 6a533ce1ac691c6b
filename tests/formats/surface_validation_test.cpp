#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "surface_test_meshes.hpp"

namespace mat {
namespace {

    std::string failure(const SurfaceReport& report, const std::string& file)
    {
        try {
            require_closed_manifold(report, file);
        } catch (const Error& e) {
            return e.what();
        }
        return "";
    }

    /// Counts of every class, to check that a broken input trips only the expected ones.
    std::map<std::string, Index> counts(const SurfaceReport& r)
    {
        return { { "invalid_indices", r.invalid_indices.count },
            { "non_finite", r.non_finite.count }, { "boundary_edges", r.boundary_edges.count },
            { "non_manifold_edges", r.non_manifold_edges.count },
            { "non_manifold_vertices", r.non_manifold_vertices.count },
            { "inconsistent_orientation", r.inconsistent_orientation.count },
            { "inward_orientation", r.inward_orientation.count },
            { "degenerate_faces", r.degenerate_faces.count }, { "components", r.components.count },
            { "unreferenced_vertices", r.unreferenced_vertices.count } };
    }

    /// All counts zero except the listed ones.
    void expect_counts(const SurfaceReport& report, std::map<std::string, Index> expected)
    {
        for (const auto& [name, count] : counts(report))
            EXPECT_EQ(count, expected.count(name) ? expected[name] : 0) << name;
    }

    TEST(SurfaceValidation, CubeIsClosedManifoldOutward)
    {
        const SurfaceReport report = validate_surface(test::unit_cube());
        expect_counts(report, {});
        EXPECT_TRUE(report.is_closed_manifold());
        EXPECT_NO_THROW(require_closed_manifold(report, "cube.obj"));
        EXPECT_EQ(report.num_vertices, 8);
        EXPECT_EQ(report.num_faces, 12);
        EXPECT_EQ(report.num_components, 1);
        EXPECT_DOUBLE_EQ(report.signed_volume, 1.0);
        EXPECT_EQ(report.bbox.min(), Vec3(0, 0, 0));
        EXPECT_EQ(report.bbox.max(), Vec3(1, 1, 1));
        const std::string summary = report.summary("cube.obj");
        EXPECT_EQ(summary.rfind("cube.obj: 8 vertices, 12 faces, 1 connected component\n", 0), 0u)
            << summary;
        EXPECT_NE(summary.find("boundary edges: 0"), std::string::npos) << summary;
        EXPECT_NE(summary.find("verdict: closed, manifold and outward-oriented"), std::string::npos)
            << summary;
    }

    TEST(SurfaceValidation, NotClosed)
    {
        SurfaceMesh mesh = test::unit_cube();
        mesh.faces = mesh.faces.bottomRows(11).eval(); // drop face (0, 2, 1)
        const SurfaceReport report = validate_surface(mesh);
        expect_counts(report, { { "boundary_edges", 3 } });
        EXPECT_EQ(report.boundary_edges.example, 3); // (0, 1, 5), now face 3
        EXPECT_EQ(report.boundary_edges.description, "edge (0, 1) of face 3");
        EXPECT_FALSE(report.is_closed_manifold());
        EXPECT_EQ(failure(report, "cube.obj"),
            "cube.obj: not closed: 3 boundary edges, e.g. edge (0, 1) of face 3");
        EXPECT_NE(report.summary("cube.obj").find("verdict: not usable as a solid: not closed"),
            std::string::npos);
    }

    TEST(SurfaceValidation, NonManifoldEdge)
    {
        SurfaceMesh mesh = test::unit_cube();
        // A fin on edge (0, 1): a third face there, itself closed off by a flat double cover.
        mesh.positions.conservativeResize(9, 3);
        mesh.positions.row(8) << 0.5, -1.0, 0.0;
        mesh.faces.conservativeResize(14, 3);
        mesh.faces.row(12) << 1, 0, 8;
        mesh.faces.row(13) << 0, 1, 8;
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_EQ(report.non_manifold_edges.count, 1);
        EXPECT_EQ(report.non_manifold_edges.example, 0);
        EXPECT_EQ(
            report.non_manifold_edges.description, "edge (0, 1) shared by 4 faces: 0, 4, 12, ...");
        EXPECT_EQ(report.boundary_edges.count, 0);
        EXPECT_EQ(report.inconsistent_orientation.count, 0);
        EXPECT_EQ(failure(report, "fin.off"),
            "fin.off: non-manifold edges: 1 edge with more than two faces, e.g. edge (0, 1) "
            "shared by 4 faces: 0, 4, 12, ...");
    }

    TEST(SurfaceValidation, NonManifoldVertex)
    {
        // Two cubes touching at one corner: vertex 6 of the first is vertex 0 of the second.
        SurfaceMesh second = test::transformed(test::unit_cube(), 1.0, Vec3(1, 1, 1));
        SurfaceMesh mesh = test::concatenate(test::unit_cube(), second);
        for (Index f = 12; f < 24; ++f)
            for (int k = 0; k < 3; ++k)
                if (mesh.faces(f, k) == 8)
                    mesh.faces(f, k) = 6;
        const SurfaceReport report = validate_surface(mesh);
        expect_counts(report,
            { { "non_manifold_vertices", 1 }, { "components", 2 },
                { "unreferenced_vertices", 1 } });
        EXPECT_EQ(report.non_manifold_vertices.example, 6);
        EXPECT_EQ(
            report.non_manifold_vertices.description.rfind("vertex 6 has 2 separate fans", 0), 0u)
            << report.non_manifold_vertices.description;
        EXPECT_EQ(report.unreferenced_vertices.example, 8);
        EXPECT_EQ(failure(report, "bowtie.stl")
                      .rfind("bowtie.stl: non-manifold vertices: 1 vertex "
                             "whose faces form several fans, e.g. vertex 6",
                          0),
            0u);
    }

    TEST(SurfaceValidation, InconsistentOrientation)
    {
        SurfaceMesh mesh = test::unit_cube();
        mesh.faces.row(0) << 0, 1, 2;
        const SurfaceReport report = validate_surface(mesh);
        expect_counts(report, { { "inconsistent_orientation", 3 } });
        EXPECT_EQ(report.inconsistent_orientation.example, 0);
        EXPECT_EQ(report.inconsistent_orientation.description,
            "edge (0, 1) used in the same direction by faces 0 and 4");
        EXPECT_EQ(failure(report, "cube.ply"),
            "cube.ply: inconsistent orientation: 3 edges used twice in the same direction, e.g. "
            "edge (0, 1) used in the same direction by faces 0 and 4");
    }

    TEST(SurfaceValidation, InwardOrientation)
    {
        const SurfaceReport report = validate_surface(test::flipped(test::unit_cube()));
        expect_counts(report, { { "inward_orientation", 1 } });
        EXPECT_EQ(report.inward_orientation.example, 0);
        EXPECT_DOUBLE_EQ(report.signed_volume, -1.0);
        EXPECT_EQ(failure(report, "cube.obj"),
            "cube.obj: inward orientation: 1 closed component facing inward, e.g. component 0 "
            "(12 faces, starting at face 0) has signed volume -1");
    }

    TEST(SurfaceValidation, CavityMustFaceInward)
    {
        const SurfaceMesh outer = test::transformed(test::unit_cube(), 4.0, Vec3(-2, -2, -2));
        const SurfaceMesh inner = test::unit_cube();
        // A hollow box: the cavity's faces point into the cavity, so its volume is negative.
        const SurfaceReport hollow
            = validate_surface(test::concatenate(outer, test::flipped(inner)));
        expect_counts(hollow, { { "components", 2 } });
        EXPECT_TRUE(hollow.is_closed_manifold());
        EXPECT_DOUBLE_EQ(hollow.signed_volume, 63.0);
        // The same cavity facing outward is wrong.
        const SurfaceReport wrong = validate_surface(test::concatenate(outer, inner));
        expect_counts(wrong, { { "components", 2 }, { "inward_orientation", 1 } });
        EXPECT_EQ(wrong.inward_orientation.example, 1);
        EXPECT_NE(wrong.inward_orientation.description.find("a cavity inside 1 others"),
            std::string::npos)
            << wrong.inward_orientation.description;
        // Two separate outward cubes are fine; a separate inward one is not.
        const SurfaceMesh apart = test::transformed(test::unit_cube(), 1.0, Vec3(3, 0, 0));
        EXPECT_TRUE(validate_surface(test::concatenate(inner, apart)).is_closed_manifold());
        const SurfaceReport one_inward
            = validate_surface(test::concatenate(inner, test::flipped(apart)));
        EXPECT_EQ(one_inward.inward_orientation.count, 1);
        EXPECT_EQ(one_inward.inward_orientation.example, 1);
    }

    TEST(SurfaceValidation, DegenerateFaces)
    {
        // A repeated index, then a zero-area face of three distinct collinear vertices.
        SurfaceMesh mesh = test::unit_cube();
        mesh.faces.conservativeResize(13, 3);
        mesh.faces.row(12) << 0, 0, 1;
        SurfaceReport report = validate_surface(mesh);
        expect_counts(report, { { "degenerate_faces", 1 } });
        EXPECT_EQ(report.degenerate_faces.example, 12);
        EXPECT_EQ(report.degenerate_faces.description, "face 12 (0, 0, 1) repeats a vertex");
        EXPECT_EQ(failure(report, "c.obj"),
            "c.obj: degenerate faces: 1 face with zero area or a repeated vertex, e.g. face 12 (0, "
            "0, 1) repeats a vertex");

        // Split the cube's edge (0, 1) at its midpoint 8 with a flat sliver (0, 8, 1): the two
        // faces on that edge now go through vertex 8, and the mesh stays closed.
        mesh = test::unit_cube();
        mesh.positions.conservativeResize(9, 3);
        mesh.positions.row(8) << 0.5, 0.0, 0.0;
        mesh.faces.conservativeResize(14, 3);
        mesh.faces.row(0) << 8, 2, 1; // (0, 2, 1) -> (8, 2, 1) + (0, 2, 8)
        mesh.faces.row(12) << 0, 2, 8;
        mesh.faces.row(4) << 8, 1, 5; // (0, 1, 5) -> (8, 1, 5) + (0, 8, 5)
        mesh.faces.row(13) << 0, 8, 5;
        report = validate_surface(mesh);
        expect_counts(report, {});
        EXPECT_TRUE(report.is_closed_manifold());
        mesh.faces.conservativeResize(16, 3);
        mesh.faces.row(14) << 0, 8, 1; // a zero-area face and its twin, to stay closed
        mesh.faces.row(15) << 0, 1, 8;
        report = validate_surface(mesh);
        EXPECT_EQ(report.degenerate_faces.count, 2);
        EXPECT_EQ(report.degenerate_faces.example, 14);
        EXPECT_EQ(report.degenerate_faces.description.rfind("face 14 (0, 8, 1) has area 0", 0), 0u)
            << report.degenerate_faces.description;

        // The tolerance is relative to the bbox diagonal: a sliver of relative area 1e-9 passes.
        SurfaceMesh sliver;
        sliver.positions.resize(3, 3);
        sliver.positions << 0, 0, 0, 1, 0, 0, 0.5, 2e-9, 0;
        sliver.faces.resize(1, 3);
        sliver.faces << 0, 1, 2;
        EXPECT_EQ(validate_surface(sliver).degenerate_faces.count, 0);
        EXPECT_EQ(validate_surface(sliver, 1e-6).degenerate_faces.count, 1);
        EXPECT_EQ(
            validate_surface(test::transformed(sliver, 1e6, Vec3::Zero())).degenerate_faces.count,
            0);
    }

    TEST(SurfaceValidation, NonFiniteCoordinates)
    {
        for (double bad : { std::nan(""), std::numeric_limits<double>::infinity() }) {
            SurfaceMesh mesh = test::unit_cube();
            mesh.positions(6, 1) = bad;
            const SurfaceReport report = validate_surface(mesh);
            expect_counts(report, { { "non_finite", 1 } });
            EXPECT_EQ(report.non_finite.example, 6);
            EXPECT_EQ(report.bbox.max(), Vec3(1, 1, 1)) << "bbox over finite vertices only";
            EXPECT_EQ(failure(report, "c.obj")
                          .rfind("c.obj: non-finite coordinates: 1 vertex with "
                                 "NaN or Inf coordinates, e.g. vertex 6 is (1, ",
                              0),
                0u)
                << failure(report, "c.obj");
        }
    }

    TEST(SurfaceValidation, InvalidIndices)
    {
        SurfaceMesh mesh = test::unit_cube();
        mesh.faces(7, 2) = 8;
        mesh.faces(9, 0) = -1;
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_EQ(report.invalid_indices.count, 2);
        EXPECT_EQ(report.invalid_indices.example, 7);
        EXPECT_EQ(
            report.invalid_indices.description, "face 7 is (3, 6, 8) but there are 8 vertices");
        EXPECT_EQ(failure(report, "c.obj").rfind("c.obj: invalid indices: 2 faces", 0), 0u);
    }

    TEST(SurfaceValidation, ComponentsAndUnreferencedVerticesDoNotBlock)
    {
        SurfaceMesh mesh = test::concatenate(
            test::unit_cube(), test::transformed(test::unit_cube(), 0.5, Vec3(5, 0, 0)));
        mesh.positions.conservativeResize(17, 3);
        mesh.positions.row(16) << 9, 9, 9;
        const SurfaceReport report = validate_surface(mesh);
        expect_counts(report, { { "components", 2 }, { "unreferenced_vertices", 1 } });
        EXPECT_EQ(report.num_components, 2);
        EXPECT_EQ(report.components.example, 1);
        EXPECT_EQ(report.unreferenced_vertices.example, 16);
        EXPECT_TRUE(report.is_closed_manifold());
        EXPECT_NO_THROW(require_closed_manifold(report, "two.obj"));
        EXPECT_NEAR(report.signed_volume, 1.125, 1e-12);
        EXPECT_NE(report.summary("two.obj").find("(warning) vertices used by no face: 1, e.g. "
                                                 "vertex 16 at (9, 9, 9)"),
            std::string::npos)
            << report.summary("two.obj");
    }

    TEST(SurfaceValidation, EmptyMeshIsRejected)
    {
        const SurfaceReport report = validate_surface(SurfaceMesh());
        EXPECT_FALSE(report.is_closed_manifold());
        EXPECT_EQ(failure(report, "e.obj"), "e.obj: empty surface: no faces");
        EXPECT_TRUE(report.bbox.isEmpty());
    }

    /// Brute force: per undirected edge, its faces; per vertex, its fans by flood fill.
    TEST(SurfaceValidation, EdgeAndVertexClassesMatchBruteForceOnRandomMeshes)
    {
        std::mt19937 rng(7);
        for (int trial = 0; trial < 200; ++trial) {
            const int nv = 3 + trial % 8;
            const int nf = 1 + int(rng() % 16);
            SurfaceMesh mesh;
            mesh.positions = MatX3::Random(nv, 3);
            mesh.faces.resize(nf, 3);
            for (int f = 0; f < nf; ++f) {
                int a = rng() % nv, b = rng() % nv, c = rng() % nv;
                while (b == a)
                    b = rng() % nv;
                while (c == a || c == b)
                    c = rng() % nv;
                mesh.faces.row(f) << a, b, c;
            }
            std::map<std::pair<int, int>, std::vector<std::pair<int, bool>>> edges;
            for (int f = 0; f < nf; ++f)
                for (int k = 0; k < 3; ++k) {
                    const int a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
                    edges[{ std::min(a, b), std::max(a, b) }].push_back({ f, a < b });
                }
            Index boundary = 0, non_manifold = 0, inconsistent = 0;
            for (const auto& [key, uses] : edges) {
                boundary += uses.size() == 1;
                non_manifold += uses.size() > 2;
                inconsistent += uses.size() == 2 && uses[0].second == uses[1].second;
            }
            Index bad_vertices = 0;
            for (int v = 0; v < nv; ++v) {
                std::vector<int> around;
                for (int f = 0; f < nf; ++f)
                    if ((mesh.faces.row(f).array() == v).any())
                        around.push_back(f);
                if (around.empty())
                    continue;
                std::set<int> reached { around[0] };
                for (bool grew = true; grew;) {
                    grew = false;
                    for (int f : around)
                        for (int g : std::set<int>(reached))
                            if (!reached.count(f)) {
                                int shared = 0; // vertices shared besides v
                                for (int i = 0; i < 3; ++i)
                                    for (int j = 0; j < 3; ++j)
                                        shared += mesh.faces(f, i) == mesh.faces(g, j)
                                            && mesh.faces(f, i) != v;
                                if (shared > 0) {
                                    reached.insert(f);
                                    grew = true;
                                }
                            }
                }
                bad_vertices += reached.size() < around.size();
            }
            const SurfaceReport report = validate_surface(mesh);
            ASSERT_EQ(report.boundary_edges.count, boundary) << "trial " << trial;
            ASSERT_EQ(report.non_manifold_edges.count, non_manifold) << "trial " << trial;
            ASSERT_EQ(report.inconsistent_orientation.count, inconsistent) << "trial " << trial;
            ASSERT_EQ(report.non_manifold_vertices.count, bad_vertices) << "trial " << trial;
        }
    }

    TEST(SurfaceValidation, LargeTorusIsClosedWithTheRightVolume)
    {
        const double R = 1.0, r = 0.4, pi = 3.14159265358979323846;
        const SurfaceMesh mesh = test::torus(400, 160, R, r); // 128k faces
        const auto start = std::chrono::steady_clock::now();
        const SurfaceReport report = validate_surface(mesh);
        const double seconds
            = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        logger().info("validate_surface: {} faces in {:.3f} s", mesh.num_faces(), seconds);
        expect_counts(report, {});
        EXPECT_TRUE(report.is_closed_manifold());
        EXPECT_NEAR(report.signed_volume, 2.0 * pi * pi * R * r * r, 1e-3);
    }

    // ---- The sample meshes ----------------------------------------------------------------

    class SampleMesh : public ::testing::TestWithParam<const char*> { };

    TEST_P(SampleMesh, IsClosedManifoldOutward)
    {
        const std::string file = std::string(MAT_SAMPLES_DIR) + "/meshes/" + GetParam();
        const SurfaceMesh mesh = read_surface(file);
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary(file);
        EXPECT_NO_THROW(require_closed_manifold(report, file));
        EXPECT_EQ(report.num_components, 1);
        EXPECT_EQ(report.unreferenced_vertices.count, 0);
        EXPECT_GT(report.signed_volume, 0.0);
        // Euler characteristic V - E + F with E = 3F/2: 2 for a sphere.
        EXPECT_EQ(2 * mesh.num_vertices() - mesh.num_faces(), 4) << "genus 0";
    }

    INSTANTIATE_TEST_SUITE_P(Samples, SampleMesh, ::testing::Values("armadillo.off", "bunny00.off"),
        [](const auto& info) {
            std::string name = info.param;
            return name.substr(0, name.find('.'));
        });

} // namespace
} // namespace mat
