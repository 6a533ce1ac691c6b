// Surface reading failures: one clear mat::Error naming the file, and never a crash on garbage.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "surface_test_meshes.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/temp_files.hpp"

// assimp 5.2's STL loader leaks its half-built mesh when an ASCII file ends early (the garbage
// test feeds it such files): keep LeakSanitizer to leaks of our own code.
extern "C" const char* __lsan_default_suppressions()
{
    return "leak:libassimp.so\n";
}

namespace mat {
namespace {

    using SurfaceIoErrors = test::SurfaceScratchTest;

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

    TEST_F(SurfaceIoErrors, MissingUnreadableAndEmptyFilesNameTheFileAndReason)
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

        const std::string directory = error_of(dir().string());
        EXPECT_NE(directory.find("directory"), std::string::npos) << directory;
        for (const std::string& message : { missing, unknown, no_faces, lines, directory })
            EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }

    // A closed tetrahedron in OFF, with `header` in place of its "4 4 6" counts line and
    // `faces` in place of its face lines.
    std::string tetrahedron_off(const std::string& header = "4 4 6",
        const std::string& faces = "3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n")
    {
        return "OFF\n" + header + "\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n" + faces;
    }

    /// assimp 5.2 reads these with its own words ("Validation failed: aiMesh::mFaces[4].mIndices
    /// is nullptr") or clamps the index: our message names the line, the element and the problem.
    TEST_F(SurfaceIoErrors, MalformedOffNamesTheLineAndTheElement)
    {
        ASSERT_EQ(read_surface(write_text("tet.off", tetrahedron_off())).num_faces(), 4);
        const std::string file = path("bad.off");
        const auto expect = [&](const std::string& text, int line, const std::string& what) {
            write_text("bad.off", text);
            SCOPED_TRACE(text);
            test::expect_line_error([&] { read_surface(file); }, file, line, what);
        };
        expect(tetrahedron_off("4 5 6"), 2,
            "the header announces 4 vertices and 5 faces, but the file has only 4 face lines "
            "after its 4 vertex lines");
        expect("OFF\n9 1 0\n0 0 0\n1 0 0\n", 2,
            "the header announces 9 vertices and 1 faces, but the file has only 2 lines after it");
        expect(tetrahedron_off("4 4 6", "3 0 2 1\n3 0 1 3\n3 1 2 7\n3 0 3 2\n"), 9,
            "face 2: vertex index 7 out of range: the file has 4 vertices (valid 0..3)");
        expect(tetrahedron_off("4 4 6", "3 0 2 1\n3 0 -1 3\n3 1 2 3\n3 0 3 2\n"), 8,
            "face 1: vertex index -1 out of range");
        expect(tetrahedron_off("4 4 6", "3 0 2 1\n3 0 1\n3 1 2 3\n3 0 3 2\n"), 8,
            "face 1 announces 3 vertices but lists 2");
        expect(tetrahedron_off("4 4 6", "3 0 2 1\n3 0 1 3\n3 1 x 3\n3 0 3 2\n"), 9,
            "face 2: vertex index 'x' is not an integer");
        expect(
            tetrahedron_off("4 4 6", "3 0 2 1\n0\n3 1 2 3\n3 0 3 2\n"), 8, "face 1 has 0 vertices");
        expect(tetrahedron_off("4 4 6", "3 0 2 1\n12 0 1 2 3 0 1 2 3 0 1 2 3\n"), 8,
            "face 1 has 12 vertices, more than the 9 the OFF reader takes");
        expect("OFF\n4 4 6\n0 0 0\n1 0\n", 4, "vertex 1 has 2 coordinate(s), expected 3");
        expect("OFF\n4 4 6\n0 0 0\n1 y 0\n", 4, "vertex 1: coordinate 'y' is not a number");
        expect(tetrahedron_off("4 4"), 2,
            "header: expected the 3 counts 'vertices faces edges', found 2 values");
        expect(tetrahedron_off("4 -4 6"), 2, "header: count '-4' is not a non-negative integer");
        expect(tetrahedron_off("4 0 0"), 2, "the header announces no faces");
        expect(tetrahedron_off("4 4 6 7"), 2, "found 4 values");
        expect("OFF\n", 2, "header: expected the 3 counts 'vertices faces edges', found none");
        // A count far beyond what the file holds costs nothing before the message.
        expect(tetrahedron_off("4000000000 4000000000 0"), 2,
            "the header announces 4000000000 vertices and 4000000000 faces, but the file has only "
            "8 lines after it");
        // The counts may share the keyword's line; a file without the keyword is checked too;
        // an OFF file under another extension is checked like one named .off.
        expect("OFF 4 5 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n", 1,
            "the header announces 4 vertices and 5 faces, but the file has only 1 face lines");
        expect("4 5 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n", 1, "only 1 face lines");
        const std::string renamed = write_text("tet.txt", tetrahedron_off("4 5 6"));
        test::expect_line_error([&] { read_surface(renamed); }, renamed, 2, "only 4 face lines");
    }

    /// assimp 5.2 says "OBJ: vertex index out of range" or "OBJ: Invalid face index." without a
    /// line: ours names the line and the face.
    TEST_F(SurfaceIoErrors, BadObjIndicesNameTheLineAndTheFace)
    {
        const std::string vertices = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
        ASSERT_EQ(
            read_surface(write_text("tet.obj",
                             vertices + "f 1 3 2\nf 1/1 2/2 4/4\nf -3//1 -2//1 -1//1\nf 1 4 3\n"))
                .num_faces(),
            4);
        const std::string file = path("bad.obj");
        const auto expect = [&](const std::string& text, int line, const std::string& what) {
            write_text("bad.obj", text);
            SCOPED_TRACE(text);
            test::expect_line_error([&] { read_surface(file); }, file, line, what);
        };
        expect(vertices + "f 1 3 2\nf 1 2 9\n", 6,
            "face 1: vertex index 9 out of range: the file has 4 vertices (valid 1..4)");
        expect(vertices + "f 1 3 2\n# c\nf 1 0/1 4\n", 7,
            "face 1: vertex index 0: OBJ indices start at 1");
        expect("v 0 0 0\nf 1 -2 1\nv 1 0 0\n", 2,
            "face 0: vertex index -2 out of range: it counts back from the 1 vertices before "
            "this line");
        expect(vertices + "l 1 2\nl 2 x\n", 6, "polyline 1: vertex index 'x' is not an integer");
    }

    // What assimp reports without a place ("Invalid number of vertices", "No suitable reader
    // found") gets our own line: a truncated or malformed ASCII STL, a .gltf that is not JSON.
    TEST_F(SurfaceIoErrors, BrokenAsciiStlAndGltfNameTheLineAndTheProblem)
    {
        const std::string facet = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                  "vertex 0 1 0\nendloop\nendfacet\n";
        // A whole file reads (a single triangle: no error from the reader).
        EXPECT_EQ(error_of(write_text("ok.stl", "solid t\n" + facet + "endsolid t\n")), "");
        const std::string truncated = write_text("cut.stl",
            "solid t\n" + facet + "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n");
        EXPECT_EQ(error_of(truncated),
            truncated
                + ": the file ends after line 12, inside facet 1 after 2 of its 3 vertices: it is "
                  "truncated");
        const std::string two = path("two.stl");
        write_text("two.stl",
            "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n"
            "endfacet\nendsolid t\n");
        test::expect_line_error(
            [&] { read_surface(two); }, two, 6, "facet 0: 2 vertices, an STL facet has 3");
        const std::string nan = path("nan.stl");
        write_text("nan.stl",
            "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 x 0\n"
            "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n");
        test::expect_line_error([&] { read_surface(nan); }, nan, 5,
            "facet 0: vertex 1: coordinate 'x' is not a number");
        const std::string gltf = write_text(
            "broken.gltf", R"({"asset": {"version": "2.0"}, "meshes": [ {"primitives": [)");
        const std::string message = error_of(gltf);
        EXPECT_EQ(message.rfind(gltf + ": the glTF is not valid JSON: at line 1, column ", 0), 0u)
            << message;
    }

    /// Random bytes and truncations of valid files: a mesh with valid indices, or mat::Error.
    TEST_F(SurfaceIoErrors, GlbChunkLongerThanTheFileIsRefusedBeforeAssimp)
    {
        // Found by fuzzing: assimp allocated the 4 GB a GLB's JSON chunk header claimed.
        const std::string json = R"({"asset": {"version": "2.0"}})";
        const auto glb = [&](std::uint32_t chunk_length) {
            std::string bytes = "glTF";
            const auto u32 = [&](std::uint32_t v) {
                for (int k = 0; k < 4; ++k)
                    bytes += char((v >> (8 * k)) & 0xff);
            };
            u32(2);
            u32(std::uint32_t(20 + json.size()));
            u32(chunk_length);
            bytes += "JSON" + json;
            return bytes;
        };
        const std::string lying = write_text("lying.glb", glb(0xF0000000u));
        EXPECT_EQ(error_of(lying),
            lying + ": GLB chunk 0 claims 4026531840 bytes but " + std::to_string(json.size())
                + " follow its header");
        // A chunk that fits passes the check (assimp then finds no mesh in it).
        const std::string fits = write_text("fits.glb", glb(std::uint32_t(json.size())));
        EXPECT_EQ(error_of(fits).find("GLB chunk"), std::string::npos);
    }

    TEST_F(SurfaceIoErrors, GarbageNeverCrashes)
    {
        const auto level = logger().level();
        logger().set_level(spdlog::level::off);
        const SurfaceMesh mesh = test::torus(6, 5, 1.0, 0.4, 0.1);
        std::vector<std::pair<std::string, std::vector<char>>> valid;
        for (const char* ext : { ".obj", ".off", ".ply", ".stl" }) {
            write_surface(path(std::string("valid") + ext), mesh);
            const std::string bytes = test::read_file_contents(path(std::string("valid") + ext));
            valid.emplace_back(ext, std::vector<char>(bytes.begin(), bytes.end()));
        }
        valid.emplace_back(".ply",
            std::vector<char>(test::k_cube_quads_ply,
                test::k_cube_quads_ply + std::strlen(test::k_cube_quads_ply)));
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
