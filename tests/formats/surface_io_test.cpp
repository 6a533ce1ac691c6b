#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "surface_test_meshes.hpp"

// assimp 5.2's STL loader leaks its half-built mesh when an ASCII file ends early (the garbage
// test feeds it such files): keep LeakSanitizer to leaks of our own code.
extern "C" const char* __lsan_default_suppressions()
{
    return "leak:libassimp.so\n";
}

namespace mat {
namespace {

    namespace fs = std::filesystem;

    /// A fresh scratch directory per test, removed afterwards.
    class SurfaceIo : public ::testing::Test {
    protected:
        void SetUp() override
        {
            const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
            m_dir = fs::path(MAT_BINARY_DIR) / "test_scratch" / "surface_io" / info->name();
            fs::remove_all(m_dir);
            fs::create_directories(m_dir);
        }
        void TearDown() override { fs::remove_all(m_dir); }

        std::string path(const std::string& name) const { return (m_dir / name).string(); }

        std::string write_text(const std::string& name, const std::string& text) const
        {
            std::ofstream(path(name), std::ios::binary) << text;
            return path(name);
        }

        std::string write_bytes(const std::string& name, const std::vector<char>& bytes) const
        {
            std::ofstream(path(name), std::ios::binary).write(bytes.data(), bytes.size());
            return path(name);
        }

        fs::path m_dir;
    };

    std::vector<char> read_bytes(const std::string& path)
    {
        std::ifstream in(path, std::ios::binary);
        return std::vector<char>(std::istreambuf_iterator<char>(in), {});
    }

    std::string read_text(const std::string& path)
    {
        const std::vector<char> bytes = read_bytes(path);
        return std::string(bytes.begin(), bytes.end());
    }

    /// Same triangles (positions and orientation) up to vertex numbering, within `tolerance`.
    void expect_same_surface(const SurfaceMesh& a, const SurfaceMesh& b, double tolerance)
    {
        ASSERT_EQ(a.num_vertices(), b.num_vertices());
        ASSERT_EQ(a.num_faces(), b.num_faces());
        const auto ta = test::canonical_triangles(a);
        const auto tb = test::canonical_triangles(b);
        for (std::size_t f = 0; f < ta.size(); ++f)
            for (int k = 0; k < 9; ++k)
                ASSERT_NEAR(ta[f][k], tb[f][k], tolerance) << "triangle " << f;
    }

    // ---- Round trips ----------------------------------------------------------------------

    class SurfaceRoundTrip : public SurfaceIo,
                             public ::testing::WithParamInterface<const char*> { };

    TEST_P(SurfaceRoundTrip, WriteThenReadGivesTheSameSurface)
    {
        const SurfaceMesh mesh = test::torus(16, 9, 1.0, 0.4, 0.1);
        const std::string file = path(std::string("torus") + GetParam());
        write_surface(file, mesh);
        const SurfaceMesh back = read_surface(file);
        expect_same_surface(mesh, back, 1e-6);
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
        EXPECT_NE(
            read_text(path("cube.obj")).find("v 0.10000000000000001 1 1\n"), std::string::npos);
        EXPECT_NE(
            read_text(path("cube.off")).find("\n0.10000000000000001 1 1\n"), std::string::npos);
        EXPECT_NE(read_text(path("cube.off")).find("\n3 0 2 1\n"), std::string::npos);
    }

    TEST_F(SurfaceIo, BinaryPlyIsLittleEndianDoubles)
    {
        const SurfaceMesh mesh = test::unit_cube();
        write_surface(path("cube.ply"), mesh);
        const std::string text = read_text(path("cube.ply"));
        const std::string end = "end_header\n";
        const std::size_t header = text.find(end);
        ASSERT_NE(header, std::string::npos);
        EXPECT_NE(text.find("format binary_little_endian 1.0"), std::string::npos);
        EXPECT_EQ(text.size(), header + end.size() + 8 * 3 * 8 + 12 * (1 + 3 * 4));
    }

    TEST_F(SurfaceIo, BinaryStlHasNoSolidHeaderAndRightSize)
    {
        write_surface(path("cube.stl"), test::unit_cube());
        const std::vector<char> bytes = read_bytes(path("cube.stl"));
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
        EXPECT_TRUE(fs::is_empty(m_dir)) << "no temporary file may remain";
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
        expect_same_surface(cube, mesh, 0.0);
    }

    const char* const k_cube_quads_ply = R"(ply
format ascii 1.0
element vertex 8
property float x
property float y
property float z
element face 6
property list uchar int vertex_indices
end_header
0 0 0
1 0 0
1 1 0
0 1 0
0 0 1
1 0 1
1 1 1
0 1 1
4 0 3 2 1
4 4 5 6 7
4 0 1 5 4
4 3 7 6 2
4 0 4 7 3
4 1 2 6 5
)";

    TEST_F(SurfaceIo, AsciiPlyQuadsAreTriangulated)
    {
        const SurfaceMesh mesh = read_surface(write_text("cube.ply", k_cube_quads_ply));
        EXPECT_EQ(mesh.num_vertices(), 8);
        EXPECT_EQ(mesh.num_faces(), 12);
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary("cube.ply");
        EXPECT_NEAR(report.signed_volume, 1.0, 1e-12);
    }

    TEST_F(SurfaceIo, OffQuadsAreTriangulated)
    {
        const std::string text = "OFF\n8 6 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n"
                                 "0 1 1\n4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 3 7 6 2\n4 0 4 7 3\n"
                                 "4 1 2 6 5\n";
        const SurfaceMesh mesh = read_surface(write_text("cube.off", text));
        EXPECT_EQ(mesh.num_vertices(), 8);
        EXPECT_EQ(mesh.num_faces(), 12);
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary("cube.off");
        EXPECT_NEAR(report.signed_volume, 1.0, 1e-12);
    }

    TEST_F(SurfaceIo, ObjObjectsAreMergedAndWeldedAndLinesDropped)
    {
        // Two objects sharing the cube's vertices, plus a line and a point to drop.
        const std::string text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\n"
                                 "v 1 1 1\nv 0 1 1\no bottom_and_top\nf 1 4 3 2\nf 5 6 7 8\n"
                                 "o sides\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n"
                                 "o wire\nl 1 7\np 2\n";
        const SurfaceMesh mesh = read_surface(write_text("cube.obj", text));
        EXPECT_EQ(mesh.num_vertices(), 8);
        EXPECT_EQ(mesh.num_faces(), 12);
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary("cube.obj");
        EXPECT_EQ(report.num_components, 1);
        EXPECT_NEAR(report.signed_volume, 1.0, 1e-12);
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

    // ---- glTF 2.0 -------------------------------------------------------------------------

    std::string base64(const std::vector<char>& bytes)
    {
        static const char* table
            = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        std::string out;
        for (std::size_t i = 0; i < bytes.size(); i += 3) {
            std::uint32_t chunk = 0;
            const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
            for (std::size_t k = 0; k < 3; ++k)
                chunk = (chunk << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
            for (std::size_t k = 0; k < 4; ++k)
                out += k <= n ? table[(chunk >> (18 - 6 * k)) & 63u] : '=';
        }
        return out;
    }

    template <typename T> void append(std::vector<char>& bytes, T value)
    {
        const char* p = reinterpret_cast<const char*>(&value);
        bytes.insert(bytes.end(), p, p + sizeof(T));
    }

    /// A regular tetrahedron's buffer: 4 float positions (48 bytes), 12 uint32 indices (48).
    const SurfaceMesh& tetrahedron()
    {
        static const SurfaceMesh mesh = [] {
            SurfaceMesh m;
            m.positions.resize(4, 3);
            m.positions << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
            m.faces.resize(4, 3);
            m.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
            return m;
        }();
        return mesh;
    }

    std::vector<char> tetrahedron_buffer()
    {
        std::vector<char> bytes;
        for (Index i = 0; i < 4; ++i)
            for (int d = 0; d < 3; ++d)
                append(bytes, static_cast<float>(tetrahedron().positions(i, d)));
        for (Index f = 0; f < 4; ++f)
            for (int k = 0; k < 3; ++k)
                append(bytes, static_cast<std::uint32_t>(tetrahedron().faces(f, k)));
        return bytes;
    }

    /// A scene instancing the tetrahedron twice: under a translated parent scaled by 2
    /// (x -> 2x + (10, 0, 0)) and mirrored (x -> (-x - 10, y, z)).
    std::string tetrahedron_gltf(const std::string& buffer_uri)
    {
        return R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 1]}],
  "nodes": [
    {"translation": [10, 0, 0], "children": [2]},
    {"mesh": 0, "translation": [-10, 0, 0], "scale": [-1, 1, 1]},
    {"mesh": 0, "scale": [2, 2, 2]}
  ],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
  "buffers": [{"byteLength": 96)"
            + buffer_uri + R"(}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 48, "target": 34962},
    {"buffer": 0, "byteOffset": 48, "byteLength": 48, "target": 34963}
  ],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
     "min": [0, 0, 0], "max": [1, 1, 1]},
    {"bufferView": 1, "componentType": 5125, "count": 12, "type": "SCALAR"}
  ]
})";
    }

    void expect_two_tetrahedra_in_world_space(const SurfaceMesh& mesh)
    {
        ASSERT_EQ(mesh.num_vertices(), 8);
        ASSERT_EQ(mesh.num_faces(), 8);
        SurfaceMesh scaled = test::transformed(tetrahedron(), 2.0, Vec3(10, 0, 0));
        SurfaceMesh mirrored = test::transformed(tetrahedron(), 1.0, Vec3(10, 0, 0));
        mirrored.positions.col(0) *= -1.0;
        // Mirroring reverses the winding; the reader must restore it to stay outward.
        expect_same_surface(test::concatenate(scaled, test::flipped(mirrored)), mesh, 1e-6);
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary("tetrahedra");
        EXPECT_EQ(report.num_components, 2);
        EXPECT_NEAR(report.signed_volume, (8.0 + 1.0) / 6.0, 1e-6);
    }

    TEST_F(SurfaceIo, GltfEmbeddedBufferNodeTransformsGiveWorldSpace)
    {
        const std::string uri = R"(, "uri": "data:application/octet-stream;base64,)"
            + base64(tetrahedron_buffer()) + "\"";
        expect_two_tetrahedra_in_world_space(
            read_surface(write_text("tetrahedra.gltf", tetrahedron_gltf(uri))));
    }

    TEST_F(SurfaceIo, GlbBinaryContainer)
    {
        std::string json = tetrahedron_gltf("");
        json.resize((json.size() + 3) / 4 * 4, ' ');
        const std::vector<char> bin = tetrahedron_buffer(); // 96 bytes, already 4-aligned
        std::vector<char> glb;
        append<std::uint32_t>(glb, 0x46546C67u); // "glTF"
        append<std::uint32_t>(glb, 2u);
        append<std::uint32_t>(
            glb, static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
        append<std::uint32_t>(glb, static_cast<std::uint32_t>(json.size()));
        append<std::uint32_t>(glb, 0x4E4F534Au); // "JSON"
        glb.insert(glb.end(), json.begin(), json.end());
        append<std::uint32_t>(glb, static_cast<std::uint32_t>(bin.size()));
        append<std::uint32_t>(glb, 0x004E4942u); // "BIN\0"
        glb.insert(glb.end(), bin.begin(), bin.end());
        expect_two_tetrahedra_in_world_space(read_surface(write_bytes("tetrahedra.glb", glb)));
    }

    // ---- Failures -------------------------------------------------------------------------

    std::string error_of(const std::string& file)
    {
        try {
            read_surface(file);
        } catch (const Error& e) {
            return e.what();
        }
        return "";
    }

    TEST_F(SurfaceIo, MissingUnreadableAndEmptyFilesNameTheFileAndReason)
    {
        const std::string missing = error_of(path("nothere.obj"));
        EXPECT_NE(missing.find("nothere.obj"), std::string::npos) << missing;
        EXPECT_NE(missing.find("no such file"), std::string::npos) << missing;

        const std::string unknown = error_of(write_text("mesh.unknownformat", "hello\n"));
        EXPECT_NE(unknown.find("mesh.unknownformat: cannot read surface: "), std::string::npos)
            << unknown;
        EXPECT_GT(unknown.size(),
            std::string("mesh.unknownformat: cannot read surface: ").size() + path("").size());

        const std::string no_faces = error_of(write_text("points.obj", "v 0 0 0\nv 1 0 0\n"));
        EXPECT_NE(no_faces.find("points.obj: cannot read surface"), std::string::npos) << no_faces;

        const std::string lines = error_of(write_text("lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n"));
        EXPECT_NE(lines.find("no triangle"), std::string::npos) << lines;

        const std::string dir = error_of(m_dir.string());
        EXPECT_NE(dir.find("directory"), std::string::npos) << dir;
        for (const std::string& message : { missing, unknown, no_faces, lines, dir })
            EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }

    /// Random bytes and truncations of valid files: a mesh with valid indices, or mat::Error.
    TEST_F(SurfaceIo, GarbageNeverCrashes)
    {
        const auto level = logger().level();
        logger().set_level(spdlog::level::off);
        const SurfaceMesh mesh = test::torus(6, 5, 1.0, 0.4, 0.1);
        std::vector<std::pair<std::string, std::vector<char>>> valid;
        for (const char* ext : { ".obj", ".off", ".ply", ".stl" }) {
            write_surface(path(std::string("valid") + ext), mesh);
            valid.emplace_back(ext, read_bytes(path(std::string("valid") + ext)));
        }
        valid.emplace_back(".ply",
            std::vector<char>(k_cube_quads_ply, k_cube_quads_ply + std::strlen(k_cube_quads_ply)));
        const std::string stl_ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                                      "vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        valid.emplace_back(".stl", std::vector<char>(stl_ascii.begin(), stl_ascii.end()));

        std::mt19937 rng(2024);
        int cases = 0, meshes = 0;
        const auto feed = [&](const std::string& ext, const std::vector<char>& bytes) {
            const std::string file = write_bytes("garbage" + ext, bytes);
            ++cases;
            try {
                const SurfaceMesh got = read_surface(file);
                ++meshes;
                ASSERT_GT(got.num_faces(), 0);
                ASSERT_TRUE(got.faces.minCoeff() >= 0 && got.faces.maxCoeff() < got.num_vertices())
                    << ext << " " << bytes.size() << " bytes";
                validate_surface(got);
            } catch (const Error&) {
            }
        };
        // Truncations at random lengths, some with random bytes flipped.
        for (const auto& [ext, bytes] : valid)
            for (int i = 0; i < 30; ++i) {
                std::vector<char> cut(bytes.begin(),
                    bytes.begin()
                        + std::uniform_int_distribution<std::size_t>(0, bytes.size() - 1)(rng));
                if (i % 3 == 0 && !cut.empty())
                    for (int k = 0; k < 4; ++k)
                        cut[std::uniform_int_distribution<std::size_t>(0, cut.size() - 1)(rng)]
                            = static_cast<char>(rng());
                feed(ext, cut);
            }
        // Random bytes, with and without a plausible header.
        const std::vector<std::pair<std::string, std::string>> headers { { ".obj", "" },
            { ".off", "OFF\n" }, { ".ply", "ply\nformat binary_little_endian 1.0\n" },
            { ".stl", "" }, { ".stl", "solid x\n" }, { ".gltf", "{" }, { ".glb", "glTF" },
            { ".bin", "" } };
        for (const auto& [ext, header] : headers)
            for (int i = 0; i < 20; ++i) {
                std::vector<char> bytes(header.begin(), header.end());
                const int n = std::uniform_int_distribution<int>(0, 600)(rng);
                for (int k = 0; k < n; ++k)
                    bytes.push_back(static_cast<char>(rng()));
                feed(ext, bytes);
            }
        logger().set_level(level);
        EXPECT_GE(cases, 300);
        EXPECT_GT(meshes, 0) << "long truncations of text files still hold triangles";
    }

} // namespace
} // namespace mat
