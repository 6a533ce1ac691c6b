#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "surface_test_meshes.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    namespace fs = std::filesystem;

    using SurfaceIo = test::SurfaceScratchTest;

    // ---- Round trips ----------------------------------------------------------------------

    class SurfaceRoundTrip : public SurfaceIo,
                             public ::testing::WithParamInterface<const char*> { };

    TEST_P(SurfaceRoundTrip, WriteThenReadGivesTheSameSurface)
    {
        const SurfaceMesh mesh = test::torus(16, 9, 1.0, 0.4, 0.1);
        const std::string file = path(std::string("torus") + GetParam());
        write_surface(file, mesh);
        const SurfaceMesh back = read_surface(file);
        test::expect_same_surface(mesh, back, 1e-6);
        const SurfaceReport report = validate_surface(back);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary(file);
        EXPECT_NEAR(report.signed_volume, validate_surface(mesh).signed_volume, 1e-5);
    }

    INSTANTIATE_TEST_SUITE_P(Formats, SurfaceRoundTrip,
        ::testing::Values(".obj", ".off", ".ply", ".stl", ".OBJ"), [](const auto& info) {
            return std::string(info.param + 1) + (info.index == 4 ? "_upper" : "");
        });

    TEST_F(SurfaceIo, TextFormatsKeepFullDoublePrecision)
    {
        SurfaceMesh mesh = test::unit_cube();
        mesh.positions(6, 0) = 0.1;
        write_surface(path("cube.obj"), mesh);
        write_surface(path("cube.off"), mesh);
        EXPECT_NE(test::read_file_contents(path("cube.obj")).find("v 0.10000000000000001 1 1\n"),
            std::string::npos);
        EXPECT_NE(test::read_file_contents(path("cube.off")).find("\n0.10000000000000001 1 1\n"),
            std::string::npos);
        EXPECT_NE(
            test::read_file_contents(path("cube.off")).find("\n3 0 2 1\n"), std::string::npos);
    }

    TEST_F(SurfaceIo, BinaryPlyIsLittleEndianDoubles)
    {
        const SurfaceMesh mesh = test::unit_cube();
        write_surface(path("cube.ply"), mesh);
        const std::string text = test::read_file_contents(path("cube.ply"));
        const std::string end = "end_header\n";
        const std::size_t header = text.find(end);
        ASSERT_NE(header, std::string::npos);
        EXPECT_NE(text.find("format binary_little_endian 1.0"), std::string::npos);
        EXPECT_EQ(text.size(), header + end.size() + 8 * 3 * 8 + 12 * (1 + 3 * 4));
    }

    TEST_F(SurfaceIo, BinaryStlHasNoSolidHeaderAndRightSize)
    {
        write_surface(path("cube.stl"), test::unit_cube());
        const std::string bytes = test::read_file_contents(path("cube.stl"));
        ASSERT_EQ(bytes.size(), 84u + 12u * 50u);
        EXPECT_NE(std::string(bytes.begin(), bytes.begin() + 5), "solid");
        EXPECT_EQ(static_cast<unsigned char>(bytes[80]), 12);
    }

    TEST_F(SurfaceIo, WriteRejectsUnknownExtensionAndBadIndicesWithoutOutput)
    {
        EXPECT_THROW(write_surface(path("cube.xyz"), test::unit_cube()), Error);
        EXPECT_THROW(write_surface(path("cube"), test::unit_cube()), Error);
        SurfaceMesh bad = test::unit_cube();
        bad.faces(5, 1) = 8;
        try {
            write_surface(path("bad.obj"), bad);
            FAIL() << "no throw";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("face 5 has vertex index 8"), std::string::npos)
                << e.what();
        }
        EXPECT_THROW(write_surface(path("missing_dir/cube.obj"), test::unit_cube()), Error);
        EXPECT_FALSE(fs::exists(path("bad.obj")));
        EXPECT_TRUE(fs::is_empty(dir())) << "no temporary file may remain";
    }

    TEST_F(SurfaceIo, WriteReplacesAnExistingFile)
    {
        write_text("cube.off", "old content");
        write_surface(path("cube.off"), test::unit_cube());
        EXPECT_EQ(read_surface(path("cube.off")).num_faces(), 12);
    }

    // ---- Reading specific formats ---------------------------------------------------------

    TEST_F(SurfaceIo, BinaryStlWeldsToEightVertices)
    {
        write_surface(path("cube.stl"), test::unit_cube());
        const SurfaceMesh mesh = read_surface(path("cube.stl"));
        EXPECT_EQ(mesh.num_vertices(), 8);
        EXPECT_EQ(mesh.num_faces(), 12);
        EXPECT_TRUE(validate_surface(mesh).is_closed_manifold());
    }

    TEST_F(SurfaceIo, AsciiStlWeldsToEightVertices)
    {
        const SurfaceMesh cube = test::unit_cube();
        std::ostringstream text;
        text << "solid cube\n";
        for (Index f = 0; f < cube.num_faces(); ++f) {
            text << "  facet normal 0 0 0\n    outer loop\n";
            for (int k = 0; k < 3; ++k)
                text << "      vertex " << cube.positions.row(cube.faces(f, k)) << "\n";
            text << "    endloop\n  endfacet\n";
        }
        text << "endsolid cube\n";
        const SurfaceMesh mesh = read_surface(write_text("cube.stl", text.str()));
        EXPECT_EQ(mesh.num_vertices(), 8);
        EXPECT_EQ(mesh.num_faces(), 12);
        test::expect_same_surface(cube, mesh, 0.0);
    }

    // Expects `mesh`, read from `name`, to be the closed unit cube split into 12 triangles.
    void expect_triangulated_unit_cube(const SurfaceMesh& mesh, const std::string& name)
    {
        EXPECT_EQ(mesh.num_vertices(), 8);
        EXPECT_EQ(mesh.num_faces(), 12);
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary(name);
        EXPECT_EQ(report.num_components, 1);
        EXPECT_NEAR(report.signed_volume, 1.0, 1e-12);
    }

    TEST_F(SurfaceIo, AsciiPlyQuadsAreTriangulated)
    {
        expect_triangulated_unit_cube(
            read_surface(write_text("cube.ply", test::k_cube_quads_ply)), "cube.ply");
    }

    TEST_F(SurfaceIo, OffQuadsAreTriangulated)
    {
        const std::string text = "OFF\n8 6 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n"
                                 "0 1 1\n4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 3 7 6 2\n4 0 4 7 3\n"
                                 "4 1 2 6 5\n";
        expect_triangulated_unit_cube(read_surface(write_text("cube.off", text)), "cube.off");
    }

    TEST_F(SurfaceIo, ObjObjectsAreMergedAndWeldedAndLinesDropped)
    {
        // Two objects sharing the cube's vertices, plus a line and a point to drop.
        const std::string text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\n"
                                 "v 1 1 1\nv 0 1 1\no bottom_and_top\nf 1 4 3 2\nf 5 6 7 8\n"
                                 "o sides\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n"
                                 "o wire\nl 1 7\np 2\n";
        expect_triangulated_unit_cube(read_surface(write_text("cube.obj", text)), "cube.obj");
    }

    TEST_F(SurfaceIo, PlyKeepsDoublePrecision)
    {
        SurfaceMesh mesh = test::torus(8, 6);
        mesh.positions.array() += 0.1; // not representable in float
        write_surface(path("torus.ply"), mesh);
        const SurfaceMesh back = read_surface(path("torus.ply"));
        EXPECT_EQ(back.positions, mesh.positions);
        EXPECT_EQ(back.faces, mesh.faces);
    }

    TEST_F(SurfaceIo, PlyBigEndianExtraPropertiesAndOtherElements)
    {
        // Big-endian, vertex with a normal list and a color, a face with a second list, an
        // extra element in between; read by content although the extension is not .ply.
        std::vector<char> bytes;
        const std::string header = "ply\r\nformat binary_big_endian 1.0\r\n"
                                   "element vertex 3\r\nproperty list uchar float junk\r\n"
                                   "property float z\r\nproperty double x\r\nproperty short y\r\n"
                                   "property uchar red\r\nelement edge 1\r\n"
                                   "property int a\r\nproperty int b\r\nelement face 1\r\n"
                                   "property list ushort uint vertex_index\r\n"
                                   "property list uchar uchar flags\r\nend_header\r\n";
        bytes.insert(bytes.end(), header.begin(), header.end());
        const auto big = [&](auto value) {
            const char* p = reinterpret_cast<const char*>(&value);
            for (std::size_t i = sizeof(value); i-- > 0;)
                bytes.push_back(p[i]);
        };
        const double xs[3] = { 0.5, 1.5, -2.25 };
        for (int v = 0; v < 3; ++v) {
            big(std::uint8_t(2));
            big(1.0f);
            big(2.0f);
            big(float(v)); // z
            big(xs[v]); // x
            big(std::int16_t(-v)); // y
            big(std::uint8_t(255));
        }
        big(std::int32_t(0));
        big(std::int32_t(1));
        big(std::uint16_t(3));
        big(std::uint32_t(0));
        big(std::uint32_t(1));
        big(std::uint32_t(2));
        big(std::uint8_t(1));
        big(std::uint8_t(7));
        const SurfaceMesh mesh = read_surface(write_bytes("triangle.dat", bytes));
        ASSERT_EQ(mesh.num_vertices(), 3);
        ASSERT_EQ(mesh.num_faces(), 1);
        EXPECT_EQ(mesh.positions.row(2), Eigen::RowVector3d(-2.25, -2.0, 2.0));
        EXPECT_EQ(mesh.faces.row(0), Eigen::RowVector3i(0, 1, 2));
    }

    TEST_F(SurfaceIo, PlyErrorsNameTheFileAndPlace)
    {
        const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                 "property float y\nproperty float z\n";
        const auto error = [&](const std::string& name, const std::string& text) {
            try {
                read_surface(write_text(name, text));
            } catch (const Error& e) {
                return std::string(e.what());
            }
            return std::string("no error");
        };
        // A truncated header: assimp 5.2 hangs on this one.
        EXPECT_EQ(error("a.ply", head.substr(0, 60)),
            path("a.ply") + ": line 5: PLY header ends without 'end_header'");
        EXPECT_EQ(error("b.ply", head),
            path("b.ply")
                + ": line 7: PLY header ends without "
                  "'end_header'");
        const std::string faces = "element face 1\nproperty list uchar int vertex_indices\n"
                                  "end_header\n";
        EXPECT_EQ(error("c.ply", head + faces + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
            path("c.ply")
                + ": element face 0: vertex index 3 out of range (there are 3 "
                  "vertices)");
        EXPECT_EQ(error("d.ply", head + faces + "0 0 0\n1 0 0\n0 1 0\n3 0 1\n"),
            path("d.ply") + ": element face 0: unexpected end of file");
        EXPECT_EQ(error("e.ply", head + faces + "0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"),
            path("e.ply") + ": element vertex 1: 'x' is not a number");
        EXPECT_EQ(error("f.ply", "solid\n"),
            path("f.ply")
                + ": line 1: not a PLY file (expected "
                  "'ply')");
        EXPECT_EQ(error("g.ply", head + "end_header\n0 0 0\n1 0 0\n0 1 0\n"),
            path("g.ply") + ": cannot read surface: the file holds no triangle");
    }

    TEST_F(SurfaceIo, OffHeaderCountsBeyondTheFileAreRejected)
    {
        // assimp would allocate the announced counts before noticing the file is short.
        try {
            read_surface(write_text("lie.off", "OFF\n# comment\n3 900000000 0\n0 0 0\n"));
            FAIL() << "no throw";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("announces 3 vertices and 900000000 faces"),
                std::string::npos)
                << e.what();
        }
        const SurfaceMesh mesh
            = read_surface(write_text("one.off", "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
        EXPECT_EQ(mesh.num_faces(), 1);
    }

} // namespace
} // namespace mat
