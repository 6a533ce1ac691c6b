#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "formats/frame_io.hpp"
#include "formats/surface_io.hpp"
#include "tests/formats/frame_vtk_parser.hpp"
#include "tests/formats/surface_test_meshes.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    using FrameIo = test::SurfaceScratchTest;
    using test::expect_error_containing;
    using namespace test::vtk;

    /// A torus with coordinates that need all 17 significant digits (no float rounding).
    SurfaceMesh full_precision_torus()
    {
        SurfaceMesh mesh = test::torus(12, 7);
        std::mt19937 rng(7);
        std::uniform_real_distribution<double> noise(-1e-3, 1e-3);
        for (Index i = 0; i < mesh.positions.size(); ++i)
            mesh.positions.data()[i] += noise(rng) / 3.0;
        return mesh;
    }

    std::vector<double> flatten(const MatX& m)
    {
        std::vector<double> out;
        for (Index i = 0; i < m.rows(); ++i)
            for (Index k = 0; k < m.cols(); ++k)
                out.push_back(m(i, k));
        return out;
    }

    TEST(Base64Decoder, KnownVectors)
    {
        EXPECT_EQ(base64_decode("Zm9vYmFy"), "foobar");
        EXPECT_EQ(base64_decode("Zm9vYmE="), "fooba");
        EXPECT_EQ(base64_decode("Zm9vYg=="), "foob");
    }

    // ---- Surface frames ---------------------------------------------------------------------

    TEST_F(FrameIo, ObjIsExactAndReadBackBySurfaceReader)
    {
        const SurfaceMesh mesh = full_precision_torus();
        write_frame_surface(path("f.obj"), mesh.positions, mesh.faces, SurfaceFrameFormat::obj);
        test::expect_same_surface(mesh, read_surface(path("f.obj")), 1e-6); // assimp: floats
        // Every coordinate reads back to the same double.
        std::istringstream in(test::read_file_contents(path("f.obj")));
        Index vertex = 0, face = 0;
        for (std::string line; std::getline(in, line);) {
            std::istringstream fields(line);
            std::string kind, a, b, c;
            fields >> kind >> a >> b >> c;
            if (kind == "v") {
                ASSERT_LT(vertex, mesh.num_vertices());
                EXPECT_EQ(std::strtod(a.c_str(), nullptr), mesh.positions(vertex, 0));
                EXPECT_EQ(std::strtod(b.c_str(), nullptr), mesh.positions(vertex, 1));
                EXPECT_EQ(std::strtod(c.c_str(), nullptr), mesh.positions(vertex, 2));
                ++vertex;
            } else if (kind == "f") {
                ASSERT_LT(face, mesh.num_faces());
                EXPECT_EQ(std::stoi(a), mesh.faces(face, 0) + 1);
                EXPECT_EQ(std::stoi(c), mesh.faces(face, 2) + 1);
                ++face;
            }
        }
        EXPECT_EQ(vertex, mesh.num_vertices());
        EXPECT_EQ(face, mesh.num_faces());
    }

    TEST_F(FrameIo, PlyIsBinaryDoubleAndReadBackBySurfaceReader)
    {
        const SurfaceMesh mesh = full_precision_torus();
        // The format decides, not the extension.
        write_frame_surface(path("f.dat"), mesh.positions, mesh.faces, SurfaceFrameFormat::ply);
        write_frame_surface(path("f.ply"), mesh.positions, mesh.faces, SurfaceFrameFormat::ply);
        const std::string bytes = test::read_file_contents(path("f.ply"));
        EXPECT_EQ(bytes, test::read_file_contents(path("f.dat")));
        test::expect_same_surface(mesh, read_surface(path("f.ply")), 1e-6);
        const std::size_t body = bytes.find("end_header\n") + 11;
        ASSERT_EQ(bytes.size(), body + 24 * mesh.num_vertices() + 13 * mesh.num_faces());
        MatX3 back(mesh.num_vertices(), 3);
        std::memcpy(back.data(), bytes.data() + body, 24 * mesh.num_vertices());
        EXPECT_EQ(back, mesh.positions);
        const char* last_face = bytes.data() + bytes.size() - 13;
        EXPECT_EQ(last_face[0], 3);
        std::int32_t index;
        std::memcpy(&index, last_face + 9, 4);
        EXPECT_EQ(index, mesh.faces(mesh.num_faces() - 1, 2));
    }

    TEST_F(FrameIo, FormatNames)
    {
        EXPECT_EQ(parse_surface_frame_format("PLY"), SurfaceFrameFormat::ply);
        EXPECT_EQ(std::string(extension(parse_surface_frame_format("obj"))), "obj");
        expect_error_containing([] { parse_surface_frame_format("stl"); }, { "'stl'", "obj" });
    }

    TEST_F(FrameIo, FailedWritesLeaveNothingAndNameThePath)
    {
        const SurfaceMesh mesh = test::unit_cube();
        const std::string missing = path("no_such_dir/f.obj");
        expect_error_containing(
            [&] {
                write_frame_surface(missing, mesh.positions, mesh.faces, SurfaceFrameFormat::obj);
            },
            { missing, "does not exist" });
        expect_error_containing(
            [&] { write_vtu(path("no_such_dir/f.vtu"), mesh.positions, mesh.faces); },
            { "no_such_dir/f.vtu", "does not exist" });
        expect_error_containing([&] { write_pvd(path("no_such_dir/run.pvd"), {}); },
            { "no_such_dir/run.pvd", "does not exist" });
        EXPECT_EQ(num_entries(), 0u);

        // Bad input: the previous frame stays as it was, no temporary is left.
        write_frame_surface(path("f.ply"), mesh.positions, mesh.faces, SurfaceFrameFormat::ply);
        const std::string before = test::read_file_contents(path("f.ply"));
        MatX3i bad_faces = mesh.faces;
        bad_faces(4, 1) = 8;
        expect_error_containing(
            [&] {
                write_frame_surface(
                    path("f.ply"), mesh.positions, bad_faces, SurfaceFrameFormat::ply);
            },
            { path("f.ply"), "face 4 has vertex index 8, expected 0 to 7" });
        MatX3 bad_positions = mesh.positions;
        bad_positions(5, 2) = std::nan("");
        expect_error_containing(
            [&] {
                write_frame_surface(
                    path("f.ply"), bad_positions, mesh.faces, SurfaceFrameFormat::obj);
            },
            { path("f.ply"), "vertex 5 has a non-finite coordinate" });
        expect_error_containing(
            [&] { write_vtu(path("f.ply"), bad_positions, mesh.faces); }, { "vertex 5" });
        EXPECT_EQ(test::read_file_contents(path("f.ply")), before);
        EXPECT_EQ(num_entries(), 1u);
    }

    // ---- VTU --------------------------------------------------------------------------------

    class VtuRoundTrip : public FrameIo, public ::testing::WithParamInterface<VtuEncoding> { };

    TEST_P(VtuRoundTrip, ArraysDecodeToTheInput)
    {
        const SurfaceMesh mesh = full_precision_torus();
        const Index n = mesh.num_vertices();
        std::mt19937 rng(3);
        std::normal_distribution<double> normal;
        MatX velocity(n, 3), stretch(n, 1);
        for (Index i = 0; i < n; ++i) {
            velocity.row(i) << normal(rng), normal(rng), 1e-300 * normal(rng);
            stretch(i) = 1.0 + 0.01 * normal(rng);
        }
        const std::vector<PointField> fields { { "velocity", velocity }, { "stretch", stretch } };
        write_vtu(path("f.vtu"), mesh.positions, mesh.faces, fields, GetParam());
        const std::string xml = test::read_file_contents(path("f.vtu"));

        const std::vector<std::string> files = start_tags(xml, "VTKFile");
        ASSERT_EQ(files.size(), 1u);
        EXPECT_EQ(attribute(files[0], "type"), "UnstructuredGrid");
        EXPECT_EQ(attribute(files[0], "byte_order"), "LittleEndian");
        EXPECT_EQ(attribute(files[0], "header_type"), "UInt64");
        const std::vector<std::string> pieces = start_tags(xml, "Piece");
        ASSERT_EQ(pieces.size(), 1u);
        EXPECT_EQ(attribute(pieces[0], "NumberOfPoints"), std::to_string(n));
        EXPECT_EQ(attribute(pieces[0], "NumberOfCells"), std::to_string(mesh.num_faces()));
        const std::vector<std::string> point_data = start_tags(xml, "PointData");
        ASSERT_EQ(point_data.size(), 1u);
        EXPECT_EQ(attribute(point_data[0], "Scalars"), "stretch");
        EXPECT_EQ(attribute(point_data[0], "Vectors"), "velocity");

        const std::vector<ParsedArray> arrays = parse_data_arrays(xml);
        ASSERT_EQ(arrays.size(), 6u);
        const std::string format = GetParam() == VtuEncoding::binary ? "binary" : "ascii";
        for (const ParsedArray& a : arrays)
            EXPECT_EQ(a.format, format) << a.name;
        // Shortest round-trip text and raw bytes both give back the exact doubles.
        const ParsedArray& points = find_array(arrays, "Points");
        EXPECT_EQ(points.type, "Float64");
        EXPECT_EQ(points.components, 3);
        EXPECT_EQ(points.values, flatten(mesh.positions));
        const ParsedArray& v = find_array(arrays, "velocity");
        EXPECT_EQ(v.components, 3);
        EXPECT_EQ(v.values, flatten(velocity));
        const ParsedArray& s = find_array(arrays, "stretch");
        EXPECT_EQ(s.components, 1);
        EXPECT_EQ(s.values, flatten(stretch));

        const ParsedArray& connectivity = find_array(arrays, "connectivity");
        EXPECT_EQ(connectivity.type, "Int32");
        std::vector<double> expected_connectivity, expected_offsets;
        for (Index f = 0; f < mesh.num_faces(); ++f) {
            for (int k = 0; k < 3; ++k)
                expected_connectivity.push_back(mesh.faces(f, k));
            expected_offsets.push_back(double(3 * (f + 1)));
        }
        EXPECT_EQ(connectivity.values, expected_connectivity);
        const ParsedArray& offsets = find_array(arrays, "offsets");
        EXPECT_EQ(offsets.type, "Int32");
        EXPECT_EQ(offsets.values, expected_offsets);
        const ParsedArray& types = find_array(arrays, "types");
        EXPECT_EQ(types.type, "UInt8");
        EXPECT_EQ(types.values, std::vector<double>(std::size_t(mesh.num_faces()), 5.0));
    }

    INSTANTIATE_TEST_SUITE_P(Encodings, VtuRoundTrip,
        ::testing::Values(VtuEncoding::binary, VtuEncoding::ascii),
        [](const auto& info) { return info.param == VtuEncoding::binary ? "binary" : "ascii"; });

    TEST_F(FrameIo, VtuBase64CoversEveryPaddingAndEmptyMeshes)
    {
        // 0..3 triangles (and no vertex at all): data sizes of every remainder modulo 3.
        for (Index faces = 0; faces <= 3; ++faces) {
            const MatX3 positions = faces == 0 ? MatX3(0, 3) : MatX3(MatX3::Random(3 + faces, 3));
            MatX3i tris(faces, 3);
            for (Index f = 0; f < faces; ++f)
                tris.row(f) << 0, int(f + 1), int(f + 2);
            write_vtu(path("f.vtu"), positions, tris);
            const std::vector<ParsedArray> arrays
                = parse_data_arrays(test::read_file_contents(path("f.vtu")));
            ASSERT_EQ(arrays.size(), 4u) << faces;
            EXPECT_EQ(
                find_array(arrays, "Points").values.size(), std::size_t(3 * positions.rows()));
            EXPECT_EQ(find_array(arrays, "types").values.size(), std::size_t(faces));
            EXPECT_EQ(find_array(arrays, "offsets").values.size(), std::size_t(faces));
        }
    }

    TEST_F(FrameIo, VtuRejectsBadFields)
    {
        const SurfaceMesh mesh = test::unit_cube();
        const std::string file = path("f.vtu");
        expect_error_containing(
            [&] {
                write_vtu(file, mesh.positions, mesh.faces, { { "v", MatX::Zero(7, 3) } });
            },
            { file, "point field 'v' is 7 x 3", "8 x 1 or 8 x 3" });
        expect_error_containing(
            [&] {
                write_vtu(file, mesh.positions, mesh.faces,
                    { { "a", MatX::Zero(8, 1) }, { "a", MatX::Zero(8, 3) } });
            },
            { file, "two point fields are named 'a'" });
        MatX inf = MatX::Zero(8, 1);
        inf(6) = 1.0 / 0.0;
        expect_error_containing(
            [&] {
                write_vtu(file, mesh.positions, mesh.faces, { { "s", inf } });
            },
            { file, "'s' is not finite at vertex 6" });
        EXPECT_EQ(num_entries(), 0u);
    }

    // ---- PVD --------------------------------------------------------------------------------

    TEST_F(FrameIo, PvdListsEntriesAndIsReplacedWhole)
    {
        std::vector<PvdEntry> entries { { 0.0, 0, "frames/a_0000.vtu" },
            { 0.1, 1, "frames/b&c \"0\".vtu" }, { 1.0 / 3.0, 0, "frames/a_0001.vtu" } };
        write_pvd(path("run.pvd"), { entries[0] });
        write_pvd(path("run.pvd"), entries); // rewritten after each frame
        const std::string xml = test::read_file_contents(path("run.pvd"));
        const std::vector<std::string> files = start_tags(xml, "VTKFile");
        ASSERT_EQ(files.size(), 1u);
        EXPECT_EQ(attribute(files[0], "type"), "Collection");
        const std::vector<std::string> sets = start_tags(xml, "DataSet");
        ASSERT_EQ(sets.size(), entries.size());
        for (std::size_t i = 0; i < sets.size(); ++i) {
            EXPECT_EQ(
                std::strtod(attribute(sets[i], "timestep").c_str(), nullptr), entries[i].time);
            EXPECT_EQ(attribute(sets[i], "part"), std::to_string(entries[i].part));
            EXPECT_EQ(attribute(sets[i], "file"), entries[i].file);
        }
        EXPECT_EQ(num_entries(), 1u); // no temporary left

        entries[1].time = std::nan("");
        expect_error_containing(
            [&] { write_pvd(path("run.pvd"), entries); }, { path("run.pvd"), "entry 1" });
        EXPECT_EQ(test::read_file_contents(path("run.pvd")), xml);
    }

} // namespace
} // namespace mat
